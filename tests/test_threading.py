"""Threads under the spindle's indexer: G33 and G76 on mitic-lathe, measured on the simulator.

The spindle's speed changes between passes (300, 600, 1200 rpm) and wanders by +-10 % within each
pass (a seeded load). Positions come from what the simulated machine did -- the Z carriage after
every step and the spindle's angle at that tick -- never from the controller's own counters.

For a perfect thread the carriage position in steps plus ``S`` (steps per revolution) times the
spindle's angle in revolutions is a constant ``phi`` along the whole helix; the tests look at
``phi`` pass by pass.
"""

import math
from dataclasses import replace

import numpy as np
import pytest

from retrofit.commands import FMov, IStp, PMov, Rdst, Spin
from retrofit.controller import Controller
from retrofit.controller.program import ProgramError, run_commands
from retrofit.errors import GcodeError
from retrofit.gcode import compile_program
from retrofit.gcode.threading import pass_depths
from retrofit.link.replies import StatusFlags as F
from retrofit.machine.config import load_machine
from retrofit.motion.indexer import lead_in_counts
from retrofit.sim import SimMachine

BASE = load_machine("mitic-lathe")
SPM = BASE.axis("Z").steps_per_mm                    # 80 steps/mm
PITCH = 1.5
S = PITCH * SPM                                      # 120 steps a revolution
SPEEDS = (300.0, 600.0, 1200.0)


def noisy(machine=BASE, noise=0.10, seed=7):
    spindle = machine.parts["spindle"]
    return replace(machine, parts={**machine.parts, "spindle": replace(
        spindle, sim=replace(spindle.sim, load_noise=noise, seed=seed))})


def with_speeds(commands, speeds):
    """A SPIN before each pass (the rapid back to the pass's start, before the rapid in), cycling
    through ``speeds``."""
    out, k = [], 0
    for i, cmd in enumerate(commands):
        nxt = commands[i + 1] if i + 1 < len(commands) else None
        if (isinstance(cmd, FMov) and isinstance(nxt, FMov)
                and dict(nxt.axes)["Z"] == dict(cmd.axes)["Z"]
                and dict(nxt.axes)["X"] < dict(cmd.axes)["X"]):
            out.append(Spin(speeds[k % len(speeds)], 1))
            k += 1
        out.append(cmd)
    return out, k


def cut_passes(sim, machine, skip_mm=0.0, start_z=None):
    """Per pass: (rise ticks, carriage steps, spindle revolutions) of its Z steps towards -Z,
    without its backlash take-up and the first ``skip_mm`` after the pass's start ``start_z``."""
    trace = sim.traces["Z"]
    ticks = np.asarray(trace.ticks)
    motor = np.asarray(trace.motor_steps)
    carriage = np.asarray(trace.carriage_mm) * SPM
    down = np.flatnonzero(np.diff(motor, prepend=sim._initial[1][0]) < 0)
    groups = np.split(down, np.flatnonzero(np.diff(down) > 1) + 1)
    takeup = machine.axis("Z").backlash_steps
    out = []
    for g in groups:
        g = g[takeup:]
        if start_z is not None:
            g = g[carriage[g] < (start_z - skip_mm) * SPM]
        out.append((ticks[g], carriage[g], sim.spindle.revolutions_at(ticks[g])))
    return out


def wrap(values, ref):
    """``values`` brought within half a revolution's steps of ``ref`` (phi is defined modulo S)."""
    return (values - ref + S / 2) % S - S / 2 + ref


@pytest.fixture(scope="module")
def g76_run():
    machine = noisy()
    prog = compile_program("G18 G21 G90\nG0 X12 Z3\nS300 M3\n"
                           "G76 P1.5 Z-12 I-0.5 J0.25 K0.92 R1.5 Q0 H2\nG0 X20\n", machine, "m16.ngc")
    commands, passes = with_speeds(list(prog.commands), SPEEDS)
    sim = SimMachine(machine)
    ctl = run_commands(commands, machine, sim=sim)
    return machine, sim, ctl, passes


def test_every_pass_cuts_the_same_helix_at_300_600_and_1200_rpm(g76_run):
    machine, sim, ctl, passes = g76_run
    assert passes >= 10 and ctl.fault is None
    cuts = cut_passes(sim, machine, skip_mm=2.5, start_z=3.0)     # past every lead-in (< 1.9 mm)
    assert len(cuts) == passes
    ref = np.median(cuts[0][1] + S * cuts[0][2])
    phis = [wrap(steps + S * revs, ref) for _, steps, revs in cuts]
    allphi = np.concatenate(phis)
    assert allphi.max() - allphi.min() <= 1.0                 # one helix, within one step, all passes
    rpms = [sim.spindle.rpm_between(int(t[0]), int(t[-1])) for t, _, _ in cuts]
    for k, rpm in enumerate(rpms):
        assert rpm == pytest.approx(SPEEDS[k % 3], rel=0.1)    # the speed really changed
    t, _, _ = cuts[2]                                          # a 1200 rpm pass: the load varies it
    per_rev = [sim.spindle.rpm_between(int(a), int(b)) for a, b in zip(t[:-120:120], t[120::120])]
    assert max(per_rev) / min(per_rev) > 1.05


def test_each_pass_advances_one_pitch_a_revolution(g76_run):
    machine, sim, _, _ = g76_run
    for ticks, steps, revs in cut_passes(sim, machine, skip_mm=2.5, start_z=3.0):
        slope = np.polyfit(revs, steps / SPM, 1)[0]
        assert slope == pytest.approx(-PITCH, abs=2e-4)


def test_the_lead_in_starts_early_and_stays_within_the_acceleration(g76_run):
    """Each pass starts moving before the helix passes its start point (by more at a faster
    spindle), so that it is on the helix when the lead-in ends; the lead-in's fitted acceleration
    is within the axis's limit."""
    machine, sim, _, passes = g76_run
    spindle, z = machine.parts["spindle"], machine.axis("Z")
    accel = z.max_accel_mm_s2 * spindle.sync_accel_share * SPM
    counts = spindle.encoder_counts_per_rev
    early = []
    for k, (ticks, steps, revs) in enumerate(cut_passes(sim, machine)):
        rpm = SPEEDS[k % 3] * (1 + spindle.speed_tolerance)
        lead = lead_in_counts(S, counts, rpm, accel)           # counts on each side of the index
        ramp = int(S * lead / counts)                          # steps until the helix is reached
        phi = np.median((steps + S * revs)[ramp + 10:])        # the helix: steps + S revs = phi
        helix_at_start = (phi - steps[0]) / S                  # angle at which it passes the start
        assert helix_at_start - round(helix_at_start) == pytest.approx(0.0, abs=0.02)  # an index
        early.append(helix_at_start - revs[0])                 # the axis set off this much before
        assert 0.5 * lead / counts < early[-1] <= lead / counts + 0.01
        t = ticks[:ramp] * machine.tick_s
        fit = np.polyfit(t - t[0], steps[:ramp] - steps[0], 2)
        assert 0.0 < -2 * fit[0] / SPM <= z.max_accel_mm_s2   # mm/s^2, fitted over the lead-in
    assert np.mean(early[0::3]) < np.mean(early[1::3]) < np.mean(early[2::3])


def test_no_drift_over_a_hundred_revolutions():
    machine = noisy(seed=3)
    prog = compile_program("G0 X10 Z15\nS1200 M3\nG33 Z-95 K1\nG0 X12\n", machine, "long.ngc")
    sim = SimMachine(machine)
    run_commands(prog.commands, machine, sim=sim)
    (ticks, steps, revs), = cut_passes(sim, machine, skip_mm=3.0, start_z=15.0)
    assert revs[-1] - revs[0] > 100
    phi = steps + SPM * revs                                   # 1 mm a revolution: 80 steps
    assert phi.max() - phi.min() <= 1.0                        # the start and the end agree
    whole = np.arange(math.ceil(revs[0]), math.floor(revs[-1]) + 1)
    at = np.interp(whole, revs, steps)                         # the carriage at each whole turn
    advance = np.diff(at) / SPM
    assert np.all(np.abs(advance + 1.0) <= 1.0 / SPM)          # each turn: the pitch, within a step
    assert abs((at[-1] - at[0]) / SPM + (len(whole) - 1)) <= 1.0 / SPM


def test_tapered_ends_keep_the_helix():
    machine = noisy(seed=11)
    prog = compile_program("G0 X12 Z4\nS400 M3\nG76 P1.5 Z-14 I-0.5 J0.3 K0.92 R2 Q0 H1 E3 L3\n",
                           machine, "tapered.ngc")
    commands, passes = with_speeds(list(prog.commands), (400.0, 800.0))
    sim = SimMachine(machine)
    run_commands(commands, machine, sim=sim)
    cuts = cut_passes(sim, machine, skip_mm=4.0, start_z=4.0)  # the straight part and the exit taper
    ref = np.median(cuts[0][1] + S * cuts[0][2])
    allphi = np.concatenate([wrap(steps + S * revs, ref) for _, steps, revs in cuts])
    assert allphi.max() - allphi.min() <= 1.0


def test_a_pass_too_short_for_its_lead_in_is_refused_before_motion():
    with pytest.raises(GcodeError, match=r"short.ngc:3: G76: at S1800 the lead-in to thread speed "
                                         r"takes 1\.86 mm, more than the 1\.50 mm"):
        compile_program("G0 X12 Z1\nS1800 M3\nG76 P1 Z-0.5 I-0.5 J0.2 K1\n", BASE, "short.ngc")


@pytest.mark.parametrize("text, message", [
    ("S2000 M3\nG33 Z-20 K2", r"G33: 2 mm/rev at up to 2300 rpm .* is 76\.67 mm/s; the axes allow 40\.00"),
    ("G33 Z-20 K1", "G33 with the spindle stopped"),
    ("S300 M3\nG33 Z-20 K6", "480 steps a revolution exceed the encoder's 400 counts"),
    ("S300 M3\nG33 Z-20", "G33 needs K"),
    ("S300 M3\nG76 P1.5 Z-10 I-1 K1", "missing: J"),
    ("S300 M3\nG76 P1.5 Z-10 I-1 J0.1 K1 R0.5", "R0.5: the depth degression must be >= 1.0"),
    ("S300 M3\nG76 P1.5 Z-10 I0 J0.1 K1", "I0: the peak must be off the drive line"),
    ("S300 M3\nG76 P1.5 Z-10 I-1 J0.1 K1 E7 L1", "E7: the taper must be >= 0 and at most half the drive line"),
    ("S300 M3\nG76 X3 P1.5 Z-10 I-1 J0.1 K1", "G76 takes Z as its only axis word"),
    ("S300 M3\nG17 G76 P1.5 Z-10 I-1 J0.1 K1", r"G76 needs the ZX plane \(G18\)"),
    ("G0 X1 Q5", "Q5: Q word with no G code that uses it"),
], ids=["too-fast", "spindle-stopped", "too-coarse", "no-k", "missing-j", "degression",
        "no-peak", "long-taper", "x-word", "plane", "q-without-g76"])
def test_thread_rules_name_the_line_and_the_figures(text, message):
    with pytest.raises(GcodeError, match=message):
        compile_program(text, BASE, "t.ngc")


def test_threads_need_a_spindle_encoder():
    with pytest.raises(GcodeError, match="G33 needs a spindle encoder with an index pulse"):
        compile_program("S300 M3\nG33 Z-20 K1", load_machine("chivu-lathe"))


def test_the_controller_refuses_a_pass_the_operator_made_too_fast():
    machine = noisy()
    prog = compile_program("G0 X12 Z1\nS300 M3\nG33 Z0 K1\n", machine, "op.ngc")   # fine at S300
    commands = list(prog.commands)
    commands.insert(commands.index(IStp()), Spin(1800.0, 1))   # the operator turns it up
    sim = SimMachine(machine)
    with pytest.raises(ProgramError, match=r"lead-in to thread speed takes 1\.86 mm .* longer than the "
                                           r"1\.00 mm move"):
        run_commands(commands, machine, sim=sim)
    z_before = sim.traces["Z"].motor_steps[-1]
    assert z_before == 80                                     # Z reached the start, and no further


def test_rdst_shows_the_spindle_the_index_and_the_indexer():
    machine = noisy()
    prog = compile_program("G0 X12 Z3\nS600 M3\nG33 Z-3 K1\nG0 X14\n", machine, "flags.ngc")
    ctl = Controller(machine, sim=SimMachine(machine))
    ctl.stream(prog.commands)
    seen = []
    while not ctl.idle:
        for _ in range(50):
            ctl.tick()
        seen.append(ctl.submit(Rdst()).flags)
    assert any(f & F.SPINDLE_ON and not f & F.INDEX_SEEN for f in seen)     # spinning up
    assert any(f & F.INDEXER and f & F.MOVING and f & F.INDEX_SEEN for f in seen)
    assert seen[-1] & F.SPINDLE_ON and not seen[-1] & (F.INDEXER | F.MOVING)


def test_g76_makes_linuxcnc_passes():
    """rs274's passes (tests/test_gcode_g76.py checks every move against its recorded output):
    the infeed follows the flank at Q from the thread's start, the deepest pass ends at Z, and
    each pass goes out to the drive line plus the depth still to cut."""
    prog = compile_program("G0 X12 Z3\nS300 M3\nG76 P1.5 Z-12 I-0.5 J0.25 K0.92 R1.5 Q29.5 H2\n",
                           BASE, "q.ngc")
    cmds = prog.commands
    cuts = [c for c, prev in zip(cmds[1:], cmds) if isinstance(c, PMov) and prev != IStp()]
    starts = [cmds[i - 3] for i, c in enumerate(cmds) if isinstance(c, PMov)]
    outs = [cmds[i + 2] for i, c in enumerate(cmds) if isinstance(c, PMov)]
    depths = pass_depths(0.25, 0.92, 1.5, 2)
    assert len(depths) == 10 and depths[-3:] == [0.92] * 3
    assert [dict(c.axes)["X"] for c in cuts] == pytest.approx([12 - 0.5 - d for d in depths])
    tan_q = math.tan(math.radians(29.5))                      # deeper passes start further on
    assert [dict(c.axes)["Z"] for c in starts] == pytest.approx([3 - d * tan_q for d in depths])
    assert [dict(c.axes)["Z"] for c in cuts] == pytest.approx([-12 + (0.92 - d) * tan_q for d in depths])
    assert [dict(c.axes)["X"] for c in outs] == pytest.approx([12 + 0.92 - d for d in depths])
    assert str(cmds[-1]) == "FMOV X12 Z-12"                   # the end of the drive line


def test_g76_under_g7_reads_i_j_k_as_diameters():
    """Diameter mode: the same thread written with diameters cuts where the radius program cuts
    (a factor two off would cut twice too deep)."""
    radius = compile_program("G8 G0 X12 Z3\nS300 M3\nG76 P1.5 Z-12 I-0.5 J0.25 K0.92 Q29.5\n",
                             BASE, "r.ngc")
    diameter = compile_program("G7 G0 X24 Z3\nS300 M3\nG76 P1.5 Z-12 I-1 J0.5 K1.84 Q29.5\n",
                               BASE, "d.ngc")
    assert [str(c) for c in diameter.commands] == [str(c) for c in radius.commands]
    deepest = min(dict(c.axes)["X"] for c in radius.commands if isinstance(c, PMov))
    assert deepest == pytest.approx(12 - 0.5 - 0.92)


def test_the_simulated_spindle_counts_and_indexes():
    machine = noisy(noise=0.1, seed=5)
    sim = SimMachine(machine)
    spindle = sim.spindle
    spindle.command(0, 600.0, 1)
    first = spindle.read(20_000)                              # 2 s: ramped up (0.2 s), turning
    assert first.at_speed and first.index_count % 400 == 0 and first.index_count > 0
    rpm = [spindle.rpm_between(t, t + 1000) for t in range(3000, 40_000, 1000)]
    assert 540 <= min(rpm) < 590 and 610 < max(rpm) <= 660     # +-10 % load, seen by the encoder
    again = SimMachine(machine).spindle
    again.command(0, 600.0, 1)
    assert again.read(20_000) == first                         # seeded: the same every run
