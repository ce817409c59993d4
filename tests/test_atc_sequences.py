"""Tool changes on tul-mill: the document's three conditions, move by move, and what the sim holds after."""

import pytest

from retrofit.atc.cell import SimCell
from retrofit.atc.magazine import MagazineState
from retrofit.atc.sequences import change_sequence, homing_steps
from retrofit.atc.settings import atc_of
from retrofit.errors import ToolChangeError
from retrofit.machine.config import load_machine

MILL = load_machine("tul-mill")
ATC = atc_of(MILL)

# The document's sequences (figures 23-25 and their G-code), with tul-mill's constants:
# X1 23, Y_POINT_A 28, Y_POINT_B 44, Z_POINT_1 -40.5, Z_POINT_2 -45 (the document's 40.5 and 45
# down from the top, Z+ up), ATC_OFFSET 3.2, ATC_HOME 0.
# Each step ends with DELY P0, the document's M400.
PUT_BACK_3 = ["FMOV X23 Y28 Z-45", "DELY P0",          # X1, Y_POINT_A, Z_POINT_2, rapid
              "ZMOV E", "FMOV E6.2", "DELY P0",        # home the carousel, CCW to pocket 3
              "PFDR F800", "PMOV Y44", "DELY P0",      # Y_POINT_B at 800: T3 into its fork
              "PFDR F1000", "PMOV Z-40.5", "DELY P0"]  # Z_POINT_1 at 1000: lift off, T3 released
PICK_5_INSIDE = ["ZMOV E", "FMOV E8.2", "DELY P0",     # home, CCW to pocket 5 (spindle above the tools)
                 "PFDR F200", "PMOV Z-45", "DELY P0",  # Z_POINT_2 at 200: onto T5, it clamps
                 "PFDR F1000", "PMOV Y28", "DELY P0",  # Y_POINT_A at 1000: out with T5
                 "ZMOV E", "DELY P0"]                  # the door closes: CW home
CONDITIONS = {
    1: (0, 3, ["FMOV X23 Y28 Z-40.5", "DELY P0", "ZMOV E", "FMOV E6.2", "DELY P0",
               "PFDR F800", "PMOV Y44", "DELY P0", "PFDR F200", "PMOV Z-45", "DELY P0",
               "PFDR F1000", "PMOV Y28", "DELY P0", "ZMOV E", "DELY P0"]),
    2: (3, 5, PUT_BACK_3 + PICK_5_INSIDE),
    3: (3, 0, PUT_BACK_3 + ["PFDR F1000", "PMOV Y28", "DELY P0", "ZMOV E", "DELY P0"]),
}
# (X, Y, Z, E) at the end of every move that moved, and the feed of the feed moves (mm/min)
PATHS = {
    1: [((23, 28, -40.5, 0), None), ((23, 28, -40.5, 6.2), None), ((23, 44, -40.5, 6.2), 800),
        ((23, 44, -45, 6.2), 200), ((23, 28, -45, 6.2), 1000), ((23, 28, -45, 0), None)],
    2: [((23, 28, -45, 0), None), ((23, 28, -45, 6.2), None), ((23, 44, -45, 6.2), 800),
        ((23, 44, -40.5, 6.2), 1000), ((23, 44, -40.5, 0), None), ((23, 44, -40.5, 8.2), None),
        ((23, 44, -45, 8.2), 200), ((23, 28, -45, 8.2), 1000), ((23, 28, -45, 0), None)],
    3: [((23, 28, -45, 0), None), ((23, 28, -45, 6.2), None), ((23, 44, -45, 6.2), 800),
        ((23, 44, -40.5, 6.2), 1000), ((23, 28, -40.5, 6.2), 1000), ((23, 28, -40.5, 0), None)],
}


def run_condition(condition):
    current, new, _ = CONDITIONS[condition]
    cell = SimCell(MILL, MagazineState.loaded(MILL, current), start_mm={"X": 5.0, "Y": 5.0, "Z": -5.0})
    seq = change_sequence(ATC, current, new, MILL.name)
    cell.run(seq.commands())
    return seq, cell


def visited(cell):
    """(end point, feed-axis peak speed) of every move that moved, judged from the sim's traces."""
    out, last = [], None
    for move in cell.moves():
        point = tuple(round(move.reached_mm[n], 6) for n in "XYZE")
        if point != last:
            out.append((point, move.peak_mm_s))
            last = point
    return out


@pytest.mark.parametrize("condition", [1, 2, 3], ids=["1-pick", "2-put-back-then-pick", "3-T0"])
def test_commands_follow_the_documents_sequence(condition):
    current, new, expected = CONDITIONS[condition]
    seq = change_sequence(ATC, current, new, MILL.name)
    assert seq.condition == condition
    assert [str(c) for c in seq.commands()] == expected


@pytest.mark.parametrize("condition", [1, 2, 3], ids=["1-pick", "2-put-back-then-pick", "3-T0"])
def test_the_machine_moves_through_the_documents_points_at_its_feeds(condition):
    _, cell = run_condition(condition)
    moves = visited(cell)                       # from X5 Y5 Z-5: the first move is the approach
    assert [p for p, _ in moves] == [tuple(float(v) for v in p) for p, _ in PATHS[condition]]
    for (point, peak), (_, feed) in zip(moves, PATHS[condition]):
        if feed is not None:
            fastest = max(peak.values())
            assert fastest == pytest.approx(feed / 60.0, rel=0.03), (point, peak)
    assert cell.violations == []


@pytest.mark.parametrize("condition, spindle, empty_pocket", [(1, 3, 3), (2, 5, 5), (3, None, None)],
                         ids=["1-pick", "2-put-back-then-pick", "3-T0"])
def test_afterwards_the_sim_has_the_right_tool_everywhere(condition, spindle, empty_pocket):
    _, cell = run_condition(condition)
    state = cell.magazine.state
    assert state.spindle == spindle
    assert state.pockets == {p: (None if p == empty_pocket else p) for p in range(1, 13)}


def test_the_carousel_approaches_pockets_ccw_and_closes_cw():
    _, cell = run_condition(2)
    e = cell.sim.traces["E"]
    runs, direction = [], 0
    for before, after in zip([0] + e.motor_steps[:-1], e.motor_steps):
        d = 1 if after > before else -1
        if d != direction:
            runs.append(d)
            direction = d
    # + (CCW) to pocket 3, - (CW) home, + to pocket 5, - home: the door closes
    assert runs == [1, -1, 1, -1]


def test_selecting_the_tool_in_the_spindle_does_nothing():
    seq = change_sequence(ATC, 7, 7)
    assert (seq.condition, seq.commands()) == (0, [])
    assert change_sequence(ATC, 0, 0).commands() == []


@pytest.mark.parametrize("tool", [13, -1, 99, 2.5, "3", True], ids=str)
def test_a_tool_outside_0_to_12_is_refused_before_any_motion(tool):
    cell = SimCell(MILL)
    with pytest.raises(ToolChangeError, match=r"0\.\.12|pockets 1\.\.12"):
        cell.run(change_sequence(ATC, 0, tool, MILL.name).commands())
    assert cell.tick == 0 and cell.runs == []


def test_the_refusal_names_the_machine_the_rule_and_what_is_accepted():
    with pytest.raises(ToolChangeError) as err:
        change_sequence(ATC, 0, 13, "tul-mill")
    assert str(err.value) == ("T13: no such tool on tul-mill; the carousel has pockets 1..12 (tool n "
                              "lives in pocket n) and T0 puts the tool back, leaving the spindle empty")


def test_homing_goes_z_y_x_then_the_carousel():
    order = MILL.parts["homing"].order
    steps = homing_steps(ATC, order)
    assert [str(c) for s in steps for c in s.commands] == ["ZMOV Z", "ZMOV Y", "ZMOV X", "ZMOV E"]
    cell = SimCell(MILL, start_mm={"X": 20.0, "Y": 30.0, "Z": -40.0, "E": 6.2})
    cell.run([c for s in steps for c in s.commands])
    assert cell.carriage_mm() == {"X": 0.0, "Y": 0.0, "Z": 0.0, "E": 0.0}
    z = list(cell.sim.traces["Z"].carriage_mm)
    assert z == sorted(z) and z[0] > -40.0              # Z goes up, to its home at the top
    ends = {n: cell.sim.traces[n].ticks[-1] for n in "ZYXE"}
    assert ends["Z"] < ends["Y"] < ends["X"] < ends["E"]
