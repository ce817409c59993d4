"""The optical tool setter: lengths and diameters within one step of the simulated tools' truth."""

import tempfile
from dataclasses import replace
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from retrofit.atc import setter as st_
from retrofit.atc.cell import SimCell
from retrofit.atc.changer import ToolChanger
from retrofit.atc.magazine import MagazineState
from retrofit.atc.measure import ToolSetter
from retrofit.atc.settings import SimTool, tools_of
from retrofit.atc.state import SpindleStore
from retrofit.atc.tooltable import ToolTable, ToolTableStore
from retrofit.errors import ProbeError, ToolChangeError, ToolStateError
from retrofit.gcode import compile_program
from retrofit.machine.config import load_machine

MILL = load_machine("tul-mill")
SETTER = MILL.parts["setter"]
STEP = MILL.axis("Z").step_mm
SLACK = 1e-9


def measured(machine, tools, tmp_path):
    """Calibrate with the reference tool, then measure ``tools``; (table, cell, changer)."""
    changer = ToolChanger(machine, SpindleStore(machine.name, tmp_path / "spindle.json"))
    cell, table = SimCell(machine), ToolTable(machine.name)
    setter = ToolSetter(machine, table)
    changer.change(SETTER.reference_tool, cell)
    setter.calibrate(cell, changer.spindle_tool)
    for tool in tools:
        changer.change(tool, cell)
        setter.measure(cell, changer.spindle_tool)
    return table, cell, changer


def test_lengths_and_diameters_within_one_step(tmp_path):
    tools = [2, 3, 4, 6, 8, 12]
    table, cell, _ = measured(MILL, tools, tmp_path)
    truth = tools_of(MILL).sim
    for tool in tools:
        got = table.tools[tool]
        assert abs(got.length_mm - truth[tool].length_mm) <= STEP + SLACK, tool
        assert abs(got.diameter_mm - truth[tool].diameter_mm) <= STEP + SLACK, tool
        assert table.length_offset(tool) == pytest.approx(got.length_mm - 20.0)
    assert cell.violations == []


@settings(max_examples=6)
@given(st.lists(st.tuples(st.floats(8.0, 29.0), st.floats(0.3, 7.5)), min_size=3, max_size=3))
def test_any_tool_geometry_within_one_step(geometry):
    tools = {1: SimTool(1, 20.0, 3.0)}
    tools.update({n: SimTool(n, round(l, 4), round(d, 4)) for n, (l, d) in enumerate(geometry, 2)})
    machine = replace(MILL, parts={**MILL.parts, "tools": replace(tools_of(MILL), sim=tools)})
    with tempfile.TemporaryDirectory() as folder:
        table, _, _ = measured(machine, [2, 3, 4], Path(folder))
    for n in (2, 3, 4):
        assert abs(table.tools[n].length_mm - tools[n].length_mm) <= STEP + SLACK
        assert abs(table.tools[n].diameter_mm - tools[n].diameter_mm) <= STEP + SLACK


def test_all_axes_stop_at_the_step_that_breaks_the_beam():
    cell = SimCell(MILL, MagazineState.loaded(MILL, 3))
    length = tools_of(MILL).sim[3].length_mm
    cell.run(st_.length_approach(SETTER))
    hit = cell.probe(st_.length_probe(SETTER))
    z = cell.carriage_mm()["Z"]
    edge = SETTER.beam_top_z_mm + length                   # Z+ up: the tip, Z - length, meets the top
    assert 0.0 <= edge - z < STEP + SLACK                  # stopped within the step that broke it
    assert hit.position_mm["Z"] == pytest.approx(z)        # the controller counted the same steps
    assert cell.sim.traces["Z"].ticks[-1] == hit.tick      # not one step after
    assert (cell.carriage_mm()["X"], cell.carriage_mm()["Y"]) == (SETTER.beam_x_mm, SETTER.beam_y_mm)
    assert cell.violations == []
    cell.run(st_.retract(SETTER))                          # and it moves on from there
    assert cell.carriage_mm()["Z"] == SETTER.approach_z_mm


def test_without_a_reference_nothing_is_measured():
    cell = SimCell(MILL, MagazineState.loaded(MILL, 3))
    with pytest.raises(ToolChangeError, match="no reference in the tool table of tul-mill"):
        ToolSetter(MILL, ToolTable("tul-mill")).measure(cell, 3)
    assert cell.runs == []


def test_the_reference_run_needs_the_reference_tool():
    with pytest.raises(ToolChangeError, match="needs the reference tool T1 in the spindle, not T4"):
        ToolSetter(MILL, ToolTable("tul-mill")).calibrate(SimCell(MILL), 4)


def test_an_empty_spindle_never_breaks_the_beam():
    cell = SimCell(MILL)                                   # the record says T1, the spindle is empty
    with pytest.raises(ProbeError, match="the beam did not break while Z went from -18 to -45 mm"):
        ToolSetter(MILL, ToolTable("tul-mill")).calibrate(cell, 1)
    assert cell.carriage_mm()["Z"] == SETTER.lowest_z_mm


def test_the_tool_table_survives_on_disk(tmp_path):
    table, _, _ = measured(MILL, [3], tmp_path)
    store = ToolTableStore("tul-mill", tmp_path / "table.json")
    store.save(table)
    again = store.load()
    assert again.reference == table.reference and again.tools == table.tools
    (tmp_path / "table.json").write_text("{\"tools\": {\"3\": 5}}")
    with pytest.raises(ToolStateError, match="the setter's record is unreadable"):
        store.load()


@pytest.mark.parametrize("tool", [3, 8])
def test_g43_puts_the_tip_where_the_reference_tool_would_be(tmp_path, tool):
    table, cell, changer = measured(MILL, [tool], tmp_path)
    store = ToolTableStore("tul-mill", tmp_path / "setter.json", tmp_path / "tul-mill.tbl")
    store.save(table)                                      # the measurements go to tool.tbl
    from retrofit.machine.tooltable import ToolTable as Tbl
    program = compile_program("G43\nG0 X20 Y20 Z-20\nG49\nG0 Z-10", MILL, start_mm=cell.commanded_mm(),
                              tool_table=Tbl.load(tmp_path / "tul-mill.tbl"),
                              spindle_tool=changer.spindle_tool)
    cell.run(program.commands[:-1])                        # up to the move under G43
    tip = cell.carriage_mm()["Z"] - tools_of(MILL).sim[tool].length_mm     # Z+ up: the tool hangs below
    assert abs(tip - (-20.0 - SETTER.reference_length_mm)) <= STEP + SLACK
    cell.run(program.commands[-1:])                        # after G49 Z is the gauge line again
    assert cell.carriage_mm()["Z"] == -10.0
