"""The optical tool setter's probing moves on the firmware: ``retrofit setter`` through the
serial link against the firmware in simavr (``retrofit firmware sim``), its beam fed back from the
tool the harness is told the spindle holds.

Oracles: the tool's true length and diameter in the machine file (``[tools.sim]``), and the same
measurement on the simulated mill (sim://), which cuts its probing moves at the step that breaks
the beam. The firmware reads the beam debounced (three 1 ms samples), so it stops up to 3 ms
late: at the setter's probe feed (60 mm/min) 3 um, 1.2 steps of Z.
"""

from __future__ import annotations

import json
import re
import shutil

import pytest

from retrofit.atc.settings import tools_of
from retrofit.atc.state import SpindleStore, state_paths
from retrofit.atc.tooltable import ToolTableStore
from retrofit.cli import main
from retrofit.machine.config import load_machine

pytestmark = pytest.mark.skipif(
    shutil.which("avr-gcc") is None or shutil.which("make") is None,
    reason="the firmware needs avr-gcc and make: apt-get install gcc-avr avr-libc make libsimavr-dev")

fs = pytest.importorskip("retrofit.firmware.sim")


def spindle_holds(machine, table, tool: int) -> None:
    """The spindle records (the machine's and the simulated one) say ``tool`` is in the spindle."""
    for simulated in (False, True):
        _, record = state_paths(machine, table, simulated)
        record.parent.mkdir(parents=True, exist_ok=True)
        SpindleStore(machine.name, record, machine.parts["atc"].pockets).save(tool)


def setter(machine, table, output: str, *words: str) -> None:
    assert main(["setter", *words, "--machine", machine.name, "--tool-table", str(table),
                 "--output", output]) == 0


def measured(machine, table, tool: int):
    tbl, _ = state_paths(machine, table)
    t = ToolTableStore(machine.name, tbl.with_name(f"{tbl.stem}.setter.json"), tbl).load()
    return t.reference, t.tools[tool]


@pytest.mark.slow          # the setter's whole cycle on the firmware in simavr: a long run
def test_the_setter_measures_the_tool_on_the_firmware_as_on_the_simulated_mill(tmp_path, capsys):
    """T1 (20 mm x 3 mm) in the spindle: the reference run, then its length and diameter, on the
    firmware through the link and on sim://. Every probing move is a PROB that stops on the
    beam; the results agree with the tool's true size and with sim:// to within the debounce."""
    machine = load_machine("tul-mill")
    t1 = tools_of(machine).sim[1]                             # [tools.sim] t1 of tul-mill.toml
    length_true, diameter_true = t1.length_mm, t1.diameter_mm
    assert (length_true, diameter_true) == (20.0, 3.0)
    sim_tbl, fw_tbl = tmp_path / "sim" / "tul.tbl", tmp_path / "fw" / "tul.tbl"
    for table in (sim_tbl, fw_tbl):
        table.parent.mkdir()
        spindle_holds(machine, table, 1)
    setter(machine, sim_tbl, "sim://", "reference")
    setter(machine, sim_tbl, "sim://", "measure", "T1")

    harness = fs.Harness(fs.build(machine.name), machine, listen="127.0.0.1:0", speed=0,
                         tool=(length_true, diameter_true)).start()
    try:
        url = f"serial+socket://{harness.address}?wait_s=600"
        setter(machine, fw_tbl, url, "reference")
        setter(machine, fw_tbl, url + "&init=0", "measure", "T1")   # the same session goes on
    finally:
        harness.stop()
    out = capsys.readouterr().out
    assert len(re.findall(r"(\d+) probing moves", out)) == 2
    assert [int(n) for n in re.findall(r"(\d+) probing moves", out)] == [1, 3]

    sim_ref, sim_t1 = measured(machine, sim_tbl, 1)
    fw_ref, fw_t1 = measured(machine, fw_tbl, 1)
    z_step = 1 / machine.axis("Z").steps_per_mm
    y_step = 1 / machine.axis("Y").steps_per_mm
    late = 0.003 * machine.parts["setter"].probe_feed_mm_min / 60       # 3 ms at the probe feed
    # the beam met up to the debounce later (lower) on the firmware, never earlier
    assert -(late + z_step) <= fw_ref.z_break_mm - sim_ref.z_break_mm <= z_step
    # the length is measured against the reference: the late stop cancels
    assert abs(fw_t1.length_mm - length_true) <= z_step
    assert abs(fw_t1.length_mm - sim_t1.length_mm) <= z_step
    # each side stops late by the same amount: the diameter comes out smaller by up to twice
    assert -2 * (late + y_step) <= fw_t1.diameter_mm - diameter_true <= y_step
    assert abs(fw_t1.diameter_mm - sim_t1.diameter_mm) <= 2 * (late + y_step)


G38_PROGRAM = """G21 G90 G54
G0 Z-18
G0 X8 Y8
G38.2 Z-45 F60 (down onto the setter's beam)
G10 L20 P1 Z0 (where it met the beam is Z0 of G54)
G0 Z5
G0 X20 Y20
M2
"""


def test_a_g38_program_probes_on_the_firmware_and_goes_on_from_where_the_machine_stopped(
        tmp_path, monkeypatch):
    """G38.2 in a part program run through the link: the probing move is made on the machine as
    the program is read (a PROB), and the program goes on from where it stopped. The harness's
    spindle holds a 25 mm tool while the record says T1 (20 mm): the beam top is at Z -52, so the
    machine meets it at Z -27 and ends 5 mm above, at Z -22; on sim:// (the record's 20 mm tool)
    it meets it at -32 and ends at -27. The result is the machine's, not the simulator's."""
    monkeypatch.chdir(tmp_path)
    machine = load_machine("tul-mill")
    (tmp_path / "probe.ngc").write_text(G38_PROGRAM)
    table = tmp_path / "tul.tbl"
    spindle_holds(machine, table, 1)
    top = machine.parts["setter"].beam_top_z_mm

    def run(output: str, name: str) -> dict:
        assert main(["run", "probe.ngc", "--machine", machine.name, "--tool-table", str(table),
                     "--output", output, "--progress", "off", "--report", f"{name}.json"]) == 0
        return json.loads((tmp_path / f"{name}.json").read_text())

    sim = run("sim://", "sim")
    harness = fs.Harness(fs.build(machine.name), machine, listen="127.0.0.1:0", speed=0,
                         tool=(25.0, 3.0)).start()
    try:
        remote = run(f"serial+socket://{harness.address}?wait_s=600", "fw")["remote"][0]
    finally:
        log = harness.stop()
    z_step = 1 / machine.axis("Z").steps_per_mm
    assert sim["axes"]["Z"]["carriage_mm"] == pytest.approx(top + 20 + 5, abs=z_step)
    assert remote["position_mm"]["Z"] == pytest.approx(top + 25 + 5, abs=z_step)
    assert "PROBED" in remote["status"]
    carriage = fs.report(log, machine)["carriage_mm"]                 # counted on the pins
    assert carriage == pytest.approx({"X": 20.0, "Y": 20.0, "Z": top + 30, "E": 0.0}, abs=z_step)


def test_a_g38_program_on_two_links_is_refused_before_anything_moves(tmp_path, monkeypatch,
                                                                       capsys):
    """Two controllers on the link: whose probe would the program read? Refused, as any probing
    program to a real output the run cannot probe on."""
    monkeypatch.chdir(tmp_path)
    machine = load_machine("tul-mill")
    (tmp_path / "probe.ngc").write_text(G38_PROGRAM)
    table = tmp_path / "tul.tbl"
    spindle_holds(machine, table, 1)
    code = main(["run", "probe.ngc", "--machine", machine.name, "--tool-table", str(table),
                 "--output", "serial+socket://127.0.0.1:9", "--output", "serial+socket://127.0.0.1:10",
                 "--progress", "off"])
    assert code == 2
    assert "probes (G38)" in capsys.readouterr().err        # (nothing listens on either port)


@pytest.mark.slow
def test_tools_the_changer_brings_are_measured_on_the_firmware_as_on_the_simulated_mill(tmp_path):
    """T1 in the spindle, the others in their pockets; the harness moves the tools as the
    carousel changes them and the beam sees the tool really in the spindle. `setter reference`,
    then `setter measure T3 T5` through the link: each change made by the firmware (T1 back to
    its pocket, T3 picked, ...), each tool's length and diameter as its true size and as sim://
    measures it, and T5 in the spindle at the end."""
    machine = load_machine("tul-mill")
    sim_tbl, fw_tbl = tmp_path / "sim" / "tul.tbl", tmp_path / "fw" / "tul.tbl"
    for table in (sim_tbl, fw_tbl):
        table.parent.mkdir()
        spindle_holds(machine, table, 1)
    setter(machine, sim_tbl, "sim://", "reference")
    setter(machine, sim_tbl, "sim://", "measure", "T3", "T5")
    harness = fs.Harness(fs.build(machine.name), machine, listen="127.0.0.1:0", speed=0,
                         tool=1).start()
    try:
        url = f"serial+socket://{harness.address}?wait_s=600"
        setter(machine, fw_tbl, url, "reference")
        setter(machine, fw_tbl, url + "&init=0", "measure", "T3", "T5")
    finally:
        log = harness.stop()
    assert log.spindle_tool == 5                                     # what the magazine holds
    true = tools_of(machine).sim
    z_step, y_step = (1 / machine.axis(a).steps_per_mm for a in "ZY")
    late = 0.003 * machine.parts["setter"].probe_feed_mm_min / 60
    for tool in (3, 5):
        _, sim = measured(machine, sim_tbl, tool)
        _, fw = measured(machine, fw_tbl, tool)
        assert abs(fw.length_mm - true[tool].length_mm) <= z_step, tool
        assert abs(fw.length_mm - sim.length_mm) <= z_step, tool
        assert -2 * (late + y_step) <= fw.diameter_mm - true[tool].diameter_mm <= y_step, tool
        assert abs(fw.diameter_mm - sim.diameter_mm) <= 2 * (late + y_step), tool


@pytest.mark.parametrize("spec, says", [
    ("T99", "expected T0 (empty) or a tool of [tools.sim] of tul-mill: T1, T2,"),
    ("20", "expected LENGTH,DIAMETER in mm"),
    ("20,0", "length and diameter must be above 0 mm"),
])
def test_firmware_sim_names_what_its_tool_option_accepts(spec, says, capsys):
    assert main(["firmware", "sim", "--machine", "tul-mill", "--listen", "127.0.0.1:0",
                 "--tool", spec]) == 2
    assert says in capsys.readouterr().err
