"""Checks of lab 12 (the position-error loop): `retrofit lab check 12`, or pytest on this file.

The checks draw seeded random cases (a failure names the seed): start positions, targets that
reverse every axis, shipped machines and random valid ones (other steps/mm, pulse timing, pin
inversions, dead bands), compensation on and off. The loop they compare yours with is written
here, from the paper, with its own step counters: nothing in it comes from retrofit, so your file
cannot reach it (tests/test_lab_12.py holds it equal to ``retrofit.motion.errorloop``). The
carriage is read from retrofit's simulated machine, whose lead screws have a real dead band.
"""

import random
from dataclasses import replace

import pytest

from retrofit.machine.config import load_machine
from retrofit.frames import PortFrames
from retrofit.lab.core import expect, load_target
from retrofit.sim import SimMachine


class Counters:
    """One axis's step generator: 'dunu' and 'perioada', and the direction's set-up and hold."""

    def __init__(self, axis):
        self.on, self.off, self.setup, self.hold = (axis.pulse_high_ticks, axis.pulse_low_ticks,
                                                     axis.dir_setup_ticks, axis.dir_hold_ticks)
        self.dunu = self.perioada = 0
        self.sense, self.now, self.rose, self.turned = -1, -1, -(1 << 40), -(1 << 40)

    def bit(self):
        self.now += 1
        if self.dunu:
            self.dunu, self.perioada = self.dunu - 1, self.perioada - 1
            return 1
        self.perioada = max(self.perioada - 1, 0)
        return 0


def reference(machine, targets, comp, start):
    """003's loop, tick by tick: the same dict as run_loop."""
    axes, out = machine.axes, {"ticks": [], "values": [], "reached": [], "readout": []}
    gens = [Counters(a) for a in axes]
    joc = [round(a.backlash_mm * a.steps_per_mm) if comp else 0 for a in axes]
    poz, queue = list(start), [list(t) for t in targets]
    dorita, tick = (queue.pop(0) if queue else None), 0
    while True:
        byte = 0
        for a, g in zip(axes, gens):
            byte |= ((g.bit() ^ a.invert_step) << a.step_bit) | (((g.sense > 0) ^ a.invert_dir) << a.dir_bit)
        if not out["values"] or out["values"][-1] != byte:
            out["ticks"].append(tick)
            out["values"].append(byte)
        if dorita is None and not any(g.perioada for g in gens):
            break
        if dorita is not None:
            eroare = [d - p for d, p in zip(dorita, poz)]
            for i, (a, g, e) in enumerate(zip(axes, gens, eroare)):
                sense = (e > 0) - (e < 0)
                if sense and sense != g.sense:
                    if g.now + 1 - g.rose < g.hold:
                        continue
                    g.sense, g.turned = sense, g.now + 1
                    if joc[i]:
                        poz[i] -= joc[i] * sense
                        out["readout"].append([tick, a.name, poz[i]])
                if sense and g.perioada == 0 and g.now + 1 - g.turned >= g.setup:
                    g.dunu, g.perioada, g.rose = g.on, g.on + g.off, g.now + 1
                    poz[i] += sense
                    out["readout"].append([tick, a.name, poz[i]])
            if not any(eroare):
                out["reached"].append(tick)
                dorita = queue.pop(0) if queue else None
        tick += 1
    out["end_tick"] = tick + 1
    return out


def frames_of(run):
    """A run's port bytes as frames: a byte from tick 0 (0 if none was written there), then each change."""
    ticks, values = [0], [0]
    for tick, value in zip(run["ticks"], run["values"]):
        tick, value = int(tick), int(value)
        if tick == ticks[-1]:
            values[-1] = value
        elif value != values[-1]:
            ticks.append(tick)
            values.append(value)
    return PortFrames(ticks, values, int(run["end_tick"]))


def carriage_at(machine, run, start):
    """The simulated carriages (mm) at every reached tick, fed the run's port bytes."""
    sim = SimMachine(machine, tuple(start))
    sim.watch(run["reached"])
    sim.feed_reference(frames_of(run))
    return [[sim.state_at(t)[a.name][1] for a in machine.axes] for t in run["reached"]], sim.violations


# -- machines and cases --------------------------------------------------------------------------
def _random_machine(seed):
    """A valid lathe nobody ships: odd steps/mm, pulse timing and dead bands; the clearance set to
    the dead band (rounded to a step by the controller), or a step more on some axes."""
    rng = random.Random(seed)
    base = load_machine("chivu-lathe")
    axes, play = [], {}
    for a in base.axes:
        spm = round(rng.uniform(20, 130), 3)
        play[a.name] = round(rng.uniform(0.0, 0.2), 3)
        clearance = play[a.name] + rng.choice([0, 0, 0, 1]) / spm       # as measured in lab 04, or a step more
        axes.append(replace(a, steps_per_mm=spm, backlash_mm=clearance, pulse_high_ticks=rng.randint(1, 3),
                            pulse_low_ticks=rng.randint(1, 3), dir_setup_ticks=rng.randint(0, 2),
                            dir_hold_ticks=rng.randint(0, 2), invert_step=rng.random() < 0.3,
                            invert_dir=rng.random() < 0.3))
    return replace(base, name=f"random-{seed}", axes=tuple(axes), sim=replace(base.sim, dead_band_mm=play))


MACHINES = {"chivu-lathe": lambda: load_machine("chivu-lathe"), "mitic-lathe": lambda: load_machine("mitic-lathe"),
            "engraver": lambda: load_machine("engraver"), "random-3": lambda: _random_machine(3),
            "random-18": lambda: _random_machine(18), "random-40": lambda: _random_machine(40)}


def case(seed, machine, legs=10):
    """A random start and targets that reverse every axis again and again (steps, inside the limits)."""
    rng = random.Random(seed)
    room = [(max(a.min_steps, -150), min(a.max_steps, 150)) for a in machine.axes]
    start = [rng.randint(max(lo, -30), min(hi, 30)) for lo, hi in room]
    here, sense, targets = list(start), [rng.choice((1, -1)) for _ in machine.axes], []
    for _ in range(legs):
        for i, (lo, hi) in enumerate(room):
            if rng.random() < 0.8:
                sense[i] = -sense[i]
                step = sense[i] * rng.choice([1, 2, rng.randint(3, 40)])
                if not lo <= here[i] + step <= hi:
                    sense[i], step = -sense[i], -step
                here[i] += step
        targets.append(list(here))
    if rng.random() < 0.3:
        targets.insert(rng.randrange(len(targets)), list(targets[rng.randrange(len(targets))]))
    return start, targets


@pytest.fixture(scope="module")
def lab():
    """The file under check: student.py, or what RETROFIT_LAB_TARGET names."""
    return load_target(__file__)


def _ints(values):
    return [int(v) for v in values]


# -- TODO 1 -------------------------------------------------------------------------------------------------
def test_turn(lab):
    """TODO 1: turn shifts the instantaneous position by the clearance on a reversal, and only then"""
    rng = random.Random(12)
    cases = [(10, -1, 1, 4), (10, 1, -1, 4), (10, 1, 1, 4), (-7, -1, -1, 3), (0, 1, -1, 0)]
    cases += [(rng.randint(-500, 500), rng.choice((1, -1)), rng.choice((1, -1)), rng.randint(0, 9)) for _ in range(200)]
    for position, direction, new, clearance in cases:
        want = [position - clearance * new if new != direction else position, new]
        got = lab.turn(position, direction, new, clearance)
        expect(_ints(got) == want, f"turn(position={position}, direction={direction}, new_direction={new}, "
               f"clearance={clearance})", expected=tuple(want), got=got,
               hint="turning to + (AvansDreapta) subtracts the clearance, turning to - adds it; no reversal, "
                    "no shift" if new != direction else "the direction did not change: nothing moves")


# -- TODO 2 -------------------------------------------------------------------------------------------------
def test_evaluate_axis(lab):
    """TODO 2: evaluate_axis turns when the error's sign asks for it and asks for a step while there is an error"""
    rng = random.Random(22)
    cases = [(5, 5, 1, 3, True), (9, 10, 1, 3, True), (9, 10, 1, 3, False), (12, 10, -1, 2, True),
             (11, 10, 1, 2, False)]
    cases += [(rng.randint(-40, 40), rng.randint(-40, 40), rng.choice((1, -1)), rng.randint(0, 6), rng.random() < 0.7)
              for _ in range(400)]
    for desired, position, direction, clearance, can_turn in cases:
        sense = (desired > position) - (desired < position)
        if sense == 0:
            want = [position, direction, False]
        elif sense != direction and not can_turn:
            want = [position, direction, False]
        elif sense != direction:
            want = [position - clearance * sense, sense, True]
        else:
            want = [position, direction, True]
        got = lab.evaluate_axis(desired, position, direction, clearance, can_turn)
        ok = len(got) == 3 and _ints(got[:2]) == want[:2] and bool(got[2]) == want[2]
        expect(ok, f"evaluate_axis(desired={desired}, position={position}, direction={direction}, "
               f"clearance={clearance}, can_turn={can_turn})", expected=tuple(want), got=got,
               hint="no error: nothing; the error's sign against the direction: turn (with the clearance) if the "
                    "generator may, else wait; then ask for a step (the generator counts it, not you)")


# -- TODO 3 -------------------------------------------------------------------------------------------------
def _runs(lab, name, seeds):
    machine = MACHINES[name]()
    for seed in seeds:
        start, targets = case(seed, machine)
        for comp in (True, False):
            want = reference(machine, targets, comp, start)
            got = lab.run_loop(machine, [list(t) for t in targets], comp, list(start))
            yield machine, seed, comp, start, targets, want, got


def _where(machine, seed, comp):
    return f"{machine.name} (seed {seed}, compensation {'on' if comp else 'off'})"


@pytest.mark.parametrize("name", list(MACHINES))
def test_carriage_on_the_screw(lab, name):
    """TODO 3: on the simulated screw with its dead band, the carriage stands where 003's loop puts it"""
    for machine, seed, comp, start, targets, want, got in _runs(lab, name, (3, 4)):
        expected, _ = carriage_at(machine, want, start)
        got_at, _ = carriage_at(machine, {k: got[k] for k in ("ticks", "values", "end_tick", "reached")}, start)
        for k, (t, w, g) in enumerate(zip(targets, expected, got_at)):
            mm = [a.to_mm(s) for a, s in zip(machine.axes, t)]
            off = [round(c - m, 4) for c, m in zip(g, mm)]
            expect(all(abs(a - b) < 1e-9 for a, b in zip(w, g)),
                   f"carriage at target {k} {t} steps = {[round(m, 4) for m in mm]} mm on "
                   f"{_where(machine, seed, comp)}",
                   expected=f"{[round(c, 4) for c in w]} mm "
                            f"({[round(c - m, 4) for c, m in zip(w, mm)]} from the target)",
                   got=f"{[round(c, 4) for c in g]} mm ({off} from the target)",
                   hint="with compensation each reversal must add the clearance's steps; without, none")
            if comp and all(round(machine.sim.dead_band_mm[a.name] * a.steps_per_mm) == a.backlash_steps
                            for a in machine.axes):
                expect(all(abs(o) <= a.step_mm + 1e-9 for o, a in zip(off, machine.axes)),
                       f"carriage at target {k} on {_where(machine, seed, comp)}",
                       expected="within one step of the target", got=f"{off} mm off")


@pytest.mark.parametrize("name", list(MACHINES))
def test_readout_tick_by_tick(lab, name):
    """TODO 3: the loop's instantaneous positions, tick by tick, and the tick each target is reached"""
    for machine, seed, comp, start, targets, want, got in _runs(lab, name, (1, 2)):
        readout = [[int(t), str(n), int(p)] for t, n, p in got["readout"]]
        for k, (w, g) in enumerate(zip(want["readout"], readout + [None] * len(want["readout"]))):
            expect(w == g, f"run_loop on {_where(machine, seed, comp)}: readout line {k} (tick, axis, PozInst)",
                   expected=w, got=g, hint="one line each time the instantaneous position changes: the shift of a "
                   "reversal, then each step the generator starts; each tick: frame first, then evaluate every axis")
        expect(len(readout) == len(want["readout"]), f"run_loop on {_where(machine, seed, comp)}: readout lines",
               expected=len(want["readout"]), got=len(readout), hint="nothing more once the last target is reached")
        expect(_ints(got["reached"]) == want["reached"], f"run_loop on {_where(machine, seed, comp)}: reached ticks "
               f"of the {len(targets)} targets", expected=want["reached"], got=got["reached"],
               hint="a target is reached on the tick its errors are all zero; the next one is evaluated from the "
                    "next tick")


@pytest.mark.parametrize("name", list(MACHINES))
def test_port_bytes_and_timing(lab, name):
    """TODO 3: the port byte of every tick, the pulses' and direction's timing, and the end of the run"""
    for machine, seed, comp, start, targets, want, got in _runs(lab, name, (5,)):
        frames, expected = frames_of(got), frames_of(want)
        if frames != expected:
            bytes_want, bytes_got = expected.per_tick(), frames.per_tick()
            k = next((i for i, (a, b) in enumerate(zip(bytes_want, bytes_got)) if a != b), min(len(bytes_want),
                                                                                            len(bytes_got)))
            expect(False, f"run_loop on {_where(machine, seed, comp)}: the port byte at tick {k}",
                   expected=f"{int(bytes_want[k]):08b} (run ends at tick {expected.end_tick})" if k < len(bytes_want)
                   else f"the run over (end_tick {expected.end_tick})",
                   got=f"{int(bytes_got[k]):08b} (run ends at tick {frames.end_tick})" if k < len(bytes_got)
                   else f"the run over (end_tick {frames.end_tick})",
                   hint="write the byte once a tick before evaluating; end on the first tick after the last target "
                        "with no pulse under way; end_tick is one past that frame")
        _, violations = carriage_at(machine, got, start)
        expect(not violations, f"the simulated drivers on {_where(machine, seed, comp)}", expected="no violations",
               got=[str(v) for v in violations[:3]], hint="turn the direction only through the step generator")
