"""The simulator's tool-changer checks: each one reported from what the machine really did."""

from dataclasses import replace

import pytest

from retrofit.atc.cell import SimCell
from retrofit.atc.magazine import MagazineState
from retrofit.atc.sequences import change_sequence
from retrofit.atc.settings import atc_of
from retrofit.commands import FMov, PFdr, PMov, ZMov
from retrofit.machine.config import load_machine
from retrofit.motion.fast import execute_fast
from retrofit.motion.planner import plan_program

MILL = load_machine("tul-mill")
ATC = atc_of(MILL)


def kinds(cell):
    return [v.kind for v in cell.violations]


def full_magazine_except(*empty):
    return {p: (None if p in empty else p) for p in range(1, 13)}


def test_turning_the_carousel_with_the_spindle_down_in_the_magazine():
    cell = SimCell(MILL)
    cell.run([FMov((("X", 23.0), ("Y", 28.0), ("Z", -40.5))), FMov((("E", 6.2),)),
              PFdr(800.0), PMov((("Y", 44.0),)), PMov((("Z", -45.0),))])       # T3 clamped
    assert kinds(cell) == [] and cell.magazine.state.spindle == 3
    cell.run([FMov((("E", 8.2),))])                                           # turn, spindle still down
    assert kinds(cell) == ["carousel_turn"]
    assert "below Z_POINT_1 -40.5" in cell.violations[0].detail


def test_turning_at_z_point_1_inside_the_magazine_is_allowed():
    cell = SimCell(MILL)
    cell.run([FMov((("X", 23.0), ("Y", 28.0), ("Z", -40.5))), PFdr(800.0), PMov((("Y", 44.0),)),
              FMov((("E", 6.2),)), ZMov(("E",))])
    assert kinds(cell) == []


def test_entering_the_magazine_where_no_pocket_is_at_the_spindle():
    cell = SimCell(MILL)                                      # carousel at home: 0 deg, no pocket there
    cell.run([FMov((("X", 23.0), ("Y", 28.0), ("Z", -45.0))), PFdr(800.0), PMov((("Y", 44.0),))])
    assert kinds(cell) == ["pocket_misaligned"]
    assert cell.magazine.state.spindle is None                # nothing clamped


def test_entering_off_the_station_x1():
    cell = SimCell(MILL)
    cell.run([FMov((("X", 21.0), ("Y", 28.0), ("Z", -45.0))), FMov((("E", 6.2),)),
              PFdr(800.0), PMov((("Y", 44.0),))])
    assert kinds(cell) == ["pocket_misaligned"]


def test_a_controller_with_the_wrong_atc_offset_enters_between_pockets():
    wrong = replace(MILL, parts={**MILL.parts, "atc": replace(ATC, atc_offset=3.0)})
    cell = SimCell(wrong)
    cell.run(change_sequence(atc_of(wrong), 0, 3).commands())
    assert "pocket_misaligned" in kinds(cell)
    assert cell.magazine.state.spindle is None


def test_a_pocket_receiving_a_second_tool():
    # the spindle holds T3 but goes to pocket 5, which holds T5
    cell = SimCell(MILL, MagazineState(3, full_magazine_except(3)))
    cell.run([FMov((("X", 23.0), ("Y", 28.0), ("Z", -45.0))), ZMov(("E",)), FMov((("E", 8.2),)),
              PFdr(800.0), PMov((("Y", 44.0),)), PFdr(1000.0), PMov((("Z", -40.5),))])
    assert kinds(cell) == ["pocket_occupied"]
    assert cell.magazine.state.spindle == 3 and cell.magazine.state.pockets[5] == 5


def test_a_tool_put_into_a_pocket_that_is_not_its_own():
    cell = SimCell(MILL, MagazineState(3, full_magazine_except(3, 5)))
    cell.run([FMov((("X", 23.0), ("Y", 28.0), ("Z", -45.0))), FMov((("E", 8.2),)),
              PFdr(800.0), PMov((("Y", 44.0),)), PFdr(1000.0), PMov((("Z", -40.5),))])
    assert kinds(cell) == ["wrong_pocket"]
    assert cell.magazine.state.pockets[5] == 3                # it is there now, in the wrong place


def test_a_move_leaving_the_work_volume():
    # frames planned for a machine that believes Y reaches 60 mm, fed to tul-mill (45 mm)
    y = MILL.axis("Y")
    believer = replace(MILL, axes=tuple(replace(a, max_mm=60.0) if a is y else a for a in MILL.axes))
    frames = execute_fast(plan_program([FMov((("Y", 50.0),))], believer)).frames
    cell = SimCell(MILL)
    cell.sim.feed(frames)
    assert kinds(cell) == ["travel"]
    assert cell.violations[0].axis == "Y"


@pytest.mark.parametrize("tool", range(1, 13))
def test_every_pocket_is_at_the_spindle_at_its_document_position(tool):
    cell = SimCell(MILL)
    assert cell.magazine.pocket_at(ATC.atc_offset + tool) == tool
    assert cell.magazine.pocket_at(ATC.atc_offset + tool + 0.1) is None      # 2 deg off: no pocket
    assert ATC.sim.pocket_angle_deg(tool) == 80 + 20 * (tool - 1) + 4       # pocket 1 at 80 deg, then 20
