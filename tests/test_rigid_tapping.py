"""G33.1 rigid tapping: against rs274's canonical calls, and on the simulated reversible spindle.

The golden programs (``tests/gcode/tapping``) run on a mill whose spindle reverses with a two-way
encoder; rs274's RIGID_TAP(x, y, z) is a tap to (x, y, z) and back to where it started, so each
stands for two moves. On the simulator the Z carriage's steps and the spindle's angle come from
what the simulated machine did; along one helix ``steps + S revs`` is a constant (``S`` steps a
revolution), going in, while the spindle slows, stops and reverses, and coming out.
"""

import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from retrofit import machines
from retrofit.commands import CStp, FMov, IStp, PFdr, PMov, Spin
from retrofit.controller.program import run_commands
from retrofit.errors import ConfigError, GcodeError, OutputError
from retrofit.gcode import compile_program, load_program
from retrofit.machine.config import load_machine
from retrofit.outputs import open_output
from retrofit.outputs.serial import refuse_rigid_tap
from retrofit.sim import SimMachine
from retrofit.sim.spindle import SimSpindle

from tests.test_gcode_rs274 import _CALL, canon_events, compare, golden, retrofit_points

HERE = Path(__file__).resolve().parent / "gcode"
TAP_MILL = load_machine(HERE / "rs274-tap.toml")
TAPS = sorted((HERE / "tapping").glob("*.ngc"))
MOVES = ("STRAIGHT_TRAVERSE", "STRAIGHT_FEED", "ARC_FEED", "NURBS_FEED", "RIGID_TAP")
#: rs274's refusals and the line retrofit must name (counted by hand in the programs)
REFUSED_AT = {   # program: (line, retrofit's words, rs274's)
    "err-tap-no-k": (5, "G33.1 needs K", "K word missing with g33/g33.1"),
    "err-tap-spindle-stopped": (3, "G33.1 with the spindle stopped", "Spindle not turning in G33.1"),
    "err-tap-cutter-comp": (6, r"G33.1 with cutter radius compensation on \(G41.1\)", "Bug code not g0 or g1"),
}

BASE = load_machine("mitic-lathe")
SPM = BASE.axis("Z").steps_per_mm                               # 80 steps/mm


def rs274_moves(text: str) -> list[tuple]:
    """rs274's moves (machine mm); each RIGID_TAP as a move to its end and one back to its start."""
    names = [m.group(1) for m in map(_CALL.match, text.splitlines()) if m and m.group(1) in MOVES]
    events = canon_events(text.replace("RIGID_TAP(", "STRAIGHT_FEED("))
    assert len(names) == len(events)
    out, here = [], (0.0, 0.0, 0.0)
    for name, event in zip(names, events):
        out.append(event)
        if name == "RIGID_TAP":
            out.append(("line", here, event[-1]))
        else:
            here = event[1]
    return out


@pytest.mark.parametrize("program", TAPS, ids=lambda p: p.stem)
def test_taps_agree_with_rs274(program):
    accepted, status, body = golden(program)
    if program.stem in REFUSED_AT:
        line, words, theirs = REFUSED_AT[program.stem]
        assert not accepted and status == theirs
        with pytest.raises(GcodeError, match=rf"{program.name}:{line}: {words}"):
            load_program(program, TAP_MILL)
        return
    assert accepted, status
    taps = body.count("RIGID_TAP(")
    assert taps >= 1
    compiled = load_program(program, TAP_MILL)
    compare(rs274_moves(body), retrofit_points(compiled))
    cmds = list(compiled.commands)
    starts = [i for i, c in enumerate(cmds) if isinstance(c, IStp)]
    assert len(starts) == taps                                   # one synchronised chain a tap
    for i in starts:
        pfdr, down, turn, up, back, end = cmds[i + 1:i + 7]
        assert isinstance(pfdr, PFdr) and isinstance(down, PMov) and isinstance(up, PMov)
        assert end == CStp()
        assert turn.direction == -back.direction != 0            # reversed at the bottom, then restored
        before = next(c for c in reversed(cmds[:i]) if isinstance(c, (FMov, PMov)))
        assert up.axes == before.axes                            # out to where the tap started


def test_the_golden_set_has_taps_in_inch_incremental_m4_and_subroutines():
    bodies = {p.stem: golden(p)[2] for p in TAPS}
    assert sum(b.count("RIGID_TAP(") for b in bodies.values()) >= 12
    assert "CANON_UNITS_INCHES" in bodies["tap-inch-offsets"]
    assert "START_SPINDLE_COUNTERCLOCKWISE" in bodies["tap-m4-left"]


@pytest.mark.skipif(not Path("/usr/bin/rs274").exists(), reason="LinuxCNC's rs274 is not installed")
@pytest.mark.parametrize("program", TAPS, ids=lambda p: p.stem)
def test_the_tap_golden_files_are_what_rs274_prints_today(program):
    from tests.gcode.regenerate import run_rs274
    recorded = (HERE / "golden" / "tapping" / f"{program.stem}.canon").read_text()
    assert run_rs274(program) == recorded


# -- on the simulated spindle ---------------------------------------------------------------------
def reversible(drive_rpm_s=3000.0, file_rpm_s=3000.0, noise=0.05, seed=3):
    """mitic-lathe with a spindle that reverses: the drive's real ramp and the machine file's."""
    spindle = BASE.parts["spindle"]
    sim = replace(spindle.sim, accel_rpm_s=drive_rpm_s, load_noise=noise, seed=seed)
    return replace(BASE, parts={**BASE.parts, "spindle": replace(spindle, reverse_rpm_s=file_rpm_s, sim=sim)})


def tap_run(machine, text):
    prog = compile_program(text, machine, "tap.ngc")
    sim = SimMachine(machine)
    ctl = run_commands(prog.commands, machine, sim=sim)
    trace = sim.traces["Z"]
    ticks = np.asarray(trace.ticks)
    steps = np.asarray(trace.carriage_mm) * SPM
    return ctl, sim, ticks, steps, sim.spindle.revolutions_at(ticks)


CASES = {   # id: (program, steps a revolution, start Z, depth Z, spindle direction going in)
    "m3-300rpm": ("G18 G21 G90\nG0 X0 Z5\nS300 M3\nG33.1 Z-10 K1.5\nG0 X5\n", 1.5 * SPM, 5.0, -10.0, 1),
    "m4-700rpm-i1.5": ("G18 G21 G90\nG0 X0 Z4\nS700 M4\nG33.1 Z-12 K1 I1.5\nG0 X5\n", 1.0 * SPM, 4.0, -12.0, -1),
}


@pytest.fixture(scope="module", params=list(CASES))
def tapped(request):
    text, s, z0, depth, sign = CASES[request.param]
    ctl, sim, ticks, steps, revs = tap_run(reversible(), text)
    assert ctl.fault is None
    return s * sign, z0, depth, sim, ticks, steps, revs


def test_the_carriage_follows_the_spindle_angle_in_through_the_reversal_and_out(tapped):
    s, z0, _, _, ticks, steps, revs = tapped                # s < 0: M4, the count falls going in
    sign, s = np.sign(s), abs(s)
    phi = steps + sign * s * revs
    tap = np.arange(len(steps)) >= np.flatnonzero(np.diff(steps) < 0)[0]   # from the tap's first step
    below = tap & (steps < (z0 - 1.0) * SPM)             # past the lead-in, both ways
    helix = np.median(phi[below])
    assert np.all(np.abs(phi[below] - helix) <= 1.0)     # one helix, within a step
    deepest = int(np.argmin(steps))
    turn_revs = (sign * revs).max()                      # where the spindle turned round
    assert (turn_revs - sign * revs[deepest]) * s <= 2.0   # it turned within two steps of the bottom
    rpm = np.abs(np.gradient(revs, ticks * BASE.tick_s)) * 60.0
    slow = below & (rpm < 0.5 * rpm[below].max())
    assert slow.sum() >= 10                              # steps made while the spindle was slow
    assert np.all(np.abs(phi[slow] - helix) <= 1.0)      # and they kept the pitch too


def test_the_tap_reaches_the_programmed_depth_and_ends_where_it_started(tapped):
    _, z0, depth, _, _, steps, _ = tapped
    assert steps.min() == pytest.approx(depth * SPM, abs=1.0)     # the deepest point, within a step
    assert steps.min() >= depth * SPM - 1.0                      # never past it
    first_down = int(np.flatnonzero(np.diff(steps) < 0)[0])
    assert steps[-1] == pytest.approx(steps[first_down], abs=0.5)  # back at the start Z
    assert steps[first_down] == pytest.approx(z0 * SPM, abs=1.0)


def test_the_spindle_turns_its_programmed_way_again_after_the_tap(tapped):
    *_, sim, ticks, steps, revs = tapped
    later = sim.spindle.revolutions_at([int(ticks[-1]), int(ticks[-1]) + 2000])
    before = revs[np.argmin(steps)] - revs[0]                     # the way it turned going in
    assert np.sign(later[1] - later[0]) == np.sign(before) == np.sign(sim.spindle.target_rpm)


@pytest.mark.parametrize("drive_rpm_s", [12000.0, 2000.0], ids=["drive-faster-than-file", "drive-slower"])
def test_the_tap_never_passes_its_depth_whatever_the_drive(drive_rpm_s):
    """The approach is closed on the encoder: a drive quicker than the machine file says still
    stops at the depth; a slower one overruns it with the spindle, never with the tap."""
    machine = reversible(drive_rpm_s=drive_rpm_s, file_rpm_s=3000.0, noise=0.0)
    ctl, _, _, steps, revs = tap_run(machine, "G18 G21 G90\nG0 X0 Z5\nS600 M3\nG33.1 Z-10 K1\nG0 X5\n")
    assert ctl.fault is None
    assert steps.min() == pytest.approx(-10 * SPM, abs=1.0)
    assert steps[-1] == pytest.approx(5 * SPM, abs=1.0)
    overrun = (revs.max() - revs[np.argmin(steps)]) * SPM      # steps' worth the spindle went on
    assert overrun <= (2.0 if drive_rpm_s > 3000.0 else 200.0)


@pytest.mark.parametrize("machine, reason", [
    (BASE, (r"tap.ngc:4: G33.1: the spindle of machine mitic-lathe does not reverse on command with a "
            r"two-way encoder; .*\[spindle\] reverse_rpm_s")),
    (load_machine("chivu-lathe"), r"tap.ngc:4: G33.1: machine chivu-lathe has no spindle encoder"),
    (load_machine(HERE / "rs274-mill.toml"), r"tap.ngc:4: G33.1: machine rs274-mill has no spindle encoder"),
], ids=["one-way-encoder", "no-encoder", "mill-without-spindle"])
def test_a_machine_without_a_reversible_spindle_refuses_with_the_reason(machine, reason):
    with pytest.raises(GcodeError, match=reason):
        compile_program("G21 G90\nG0 X0 Z5\nS300 M3\nG33.1 Z-10 K1.5\n", machine, "tap.ngc")


@pytest.mark.parametrize("text, message", [
    ("S300 M3\nG33.1 Z-10 K1.5 I0", "I0: G33.1's I scales the spindle speed"),
    ("S300 M3\nG33.1 Z-10 K0", "K0: G33.1's K must be > 0"),
    ("S1000 M3\nG33.1 Z0 K1", (r"G33.1: at up to 1150 rpm the spindle turns 4\.59 mm of the tap while it "
                               r"stops \(in, planned at 80% of reverse_rpm_s 3000\), more than the 4\.\d\d mm "
                               r"left of the 5\.00 mm tap")),
    ("S600 M3\nG33.1 Z-1 K1 I2", r"\(out, .* more than the 6\.00 mm left of the 6\.00 mm tap"),
    ("S300 M3\nG95\nG33.1 Z-10 K1", "G33.1 under G96/G95"),
    ("S300 M3\nG1 Z-10 I2 F100", "I2: I word with no G code that uses it"),
], ids=["i-zero", "k-zero", "no-room-to-stop-in", "no-room-to-stop-out", "per-rev", "i-elsewhere"])
def test_tap_words_are_checked_with_the_line(text, message):
    with pytest.raises(GcodeError, match=message):
        compile_program("G18 G21 G90\nG0 X0 Z5\n" + text, reversible(), "t.ngc")


def test_the_serial_link_refuses_a_rigid_tap_before_sending_anything():
    """Nothing listens on the port: the refusal comes before the link is opened."""
    machine = reversible()
    prog = compile_program("G18 G21 G90\nG0 X0 Z5\nS300 M3\nG33.1 Z-10 K1.5\n", machine, "t.ngc")
    out = open_output("serial+socket://127.0.0.1:9", machine)
    with pytest.raises(OutputError, match=r"127\.0\.0\.1:9: command 7 \(SPIN S300 D-1\) reverses the "
                                          r"spindle inside a synchronised \(ISTP\) chain.*encoder one way"):
        out.send_program(prog.commands)
    refuse_rigid_tap("serial://x", [Spin(300.0, 1), IStp(), PFdr(1.0), PMov((("Z", -3.0),)), CStp(),
                                   Spin(300.0, -1)])                    # after the chain: fine


def test_retrofit_run_to_the_firmware_refuses_a_rigid_tap_naming_its_line(tmp_path):
    """The run's firmware check names the program's line; nothing is sent (nothing listens)."""
    machine_file = tmp_path / "tap-lathe.toml"
    text = (Path(machines.__file__).parent / "mitic-lathe.toml").read_text()
    machine_file.write_text(text.replace("[spindle]\n", "[spindle]\nreverse_rpm_s = 3000.0\n", 1))
    program = tmp_path / "tap.ngc"
    program.write_text("G18 G21 G90\nG0 X0 Z5\nS300 M3\nG33.1 Z-10 K1.5\nM2\n")
    proc = subprocess.run([sys.executable, "-m", "retrofit.cli", "run", str(program), "--machine",
                           str(machine_file), "--output", "serial+socket://127.0.0.1:9", "--progress", "off"],
                          capture_output=True, text=True, timeout=120, check=False)
    assert proc.returncode == 2
    assert "tap.ngc:4: SPIN S300 D-1 reverses the spindle inside a synchronised (ISTP) chain, a rigid " \
           "tap (G33.1); the firmware's indexer counts its encoder one way" in proc.stderr


def test_the_two_way_encoder_counts_down_backwards_and_indexes_both_ways():
    machine = reversible(noise=0.0)
    spindle = SimSpindle(machine.parts["spindle"], machine.tick_us)
    spindle.command(0, 600.0, -1)
    a = spindle.read(10_000)                                   # 1 s at up to 600 rpm backwards
    assert a.count < -3000 and a.index_count % 400 == 0 and a.index_count <= a.count + 400
    spindle.command(10_001, 600.0, 1)
    b = spindle.read(30_000)
    assert b.count > a.count + 3000 and b.index_count % 400 == 0
    stepped = SimSpindle(machine.parts["spindle"], machine.tick_us)   # tick by tick: the same
    stepped.command(0, 600.0, -1)
    for t in range(0, 10_001, 1000):
        stepped.read(t)
    stepped.command(10_001, 600.0, 1)
    for t in range(10_001, 30_001, 1000):
        stepped.read(t)
    assert stepped.read(30_000) == b
    assert np.array_equal(np.asarray(stepped.history), np.asarray(spindle.history))


def test_a_spindle_that_turns_back_before_the_end_halts_the_move():
    """The safety net of the approach: the count falls back while the carriage is short of the end."""
    from retrofit.controller.turnaround import Turnaround
    from retrofit.errors import MotionError
    said = []
    turn = Turnaround(300.0, -1, (300.0, 1), 3000.0, 400, lambda *a: said.append(a))
    for tick, count in enumerate([0, 10, 20, 30, 40, 36]):  # within a step (5 counts): a wobble
        turn.watch(tick, count, 0.0, 1000.0, 5.0)
        turn.check(count, 5.0, "PMOV Z-10")
    turn.watch(6, 30, 0.0, 1000.0, 5.0)
    with pytest.raises(MotionError, match="PMOV Z-10: the spindle turned back 10 counts before the carriage"):
        turn.check(30, 5.0, "PMOV Z-10")
    assert said == []                                        # far from the end: nothing asked yet


def test_the_readable_tick_loop_makes_the_same_tap():
    """kernels=False (every tick in readable Python) gives the same port bytes and carriage."""
    machine = reversible(seed=9)
    prog = compile_program("G18 G21 G90\nG0 X0 Z3\nS600 M4\nG33.1 Z-3 K1 I1.5\nG0 X4\n", machine, "ref.ngc")
    runs = []
    for kernels in (True, False):
        sim = SimMachine(machine)
        ctl = run_commands(prog.commands, machine, sim=sim, kernels=kernels)
        runs.append((ctl.frames(), list(sim.traces["Z"].carriage_mm)))
    (fast, z_fast), (ref, z_ref) = runs
    assert np.array_equal(fast.ticks, ref.ticks) and np.array_equal(fast.values, ref.values)
    assert z_fast == z_ref and min(z_ref) == pytest.approx(-3.0, abs=1 / SPM)


@pytest.mark.parametrize("value, message", [
    ("-5", r"bad\.toml \[spindle\] reverse_rpm_s = -5: must be > 0"),
    ('"fast"', r"bad\.toml \[spindle\] reverse_rpm_s.*must be a number"),
], ids=["negative", "text"])
def test_a_wrong_reverse_rate_names_the_file_section_and_key(tmp_path, value, message):
    text = (Path(machines.__file__).parent / "mitic-lathe.toml").read_text()
    bad = tmp_path / "bad.toml"
    bad.write_text(text.replace("[spindle]\n", f"[spindle]\nreverse_rpm_s = {value}\n", 1))
    with pytest.raises(ConfigError, match=message):
        load_machine(bad)
