"""Checks of lab 04 (backlash): run with `retrofit lab check 04`, or pytest on this file.

Besides the chivu lathe, the checks draw machines at random (seeded: RETROFIT_CHECK_SEED draws them
again): shipped lathes and mills with other screws, play and clearances, experiments that start
away from 0 and go back by several steps between readings. The expected readings come from the
checks' own run of the simulated machine, the expected dead band from the readings.
"""

from dataclasses import replace

import pytest

from retrofit.machine.config import load_machine
from retrofit.lab.check import cases, seed_note
from retrofit.lab.core import expect, load_target
from retrofit.motion.errorloop import PositionErrorLoop
from retrofit.sim import SimMachine

SHIPPED = ["chivu-lathe", "mitic-lathe", "tul-mill", "grenoble-mill"]


@pytest.fixture(scope="module")
def lab():
    """The file under check: student.py, or what RETROFIT_LAB_TARGET names."""
    return load_target(__file__)


@pytest.fixture(scope="module")
def lathe():
    return load_machine("chivu-lathe")


def random_machine(rng, name=None):
    """A shipped machine with random screws (steps/mm with decimals), play and clearances."""
    base = load_machine(name or rng.choice(SHIPPED))
    axes = tuple(replace(a, steps_per_mm=round(rng.uniform(20.0, 200.0), rng.choice([0, 2])),
                         backlash_mm=round(rng.uniform(0.0, 0.2), 3)) for a in base.axes)
    band = {a.name: round(rng.uniform(1.5, 10.5) / a.steps_per_mm, 4) for a in axes}   # 1.5 to 10.5 steps of play
    return replace(base, name=f"{base.name} with screws {', '.join(f'{a.name} {a.steps_per_mm:g}' for a in axes)} "
                              f"steps/mm and play {band}", axes=axes, sim=replace(base.sim, dead_band_mm=band))


def experiment(rng, machine, axis):
    """Targets of a dial experiment that starts away from 0 and goes back by 1 to 4 steps a reading, past the
    play or (2 times in 5) not as far."""
    i = machine.axis_names.index(axis)
    band_steps = int(machine.sim.dead_band_mm.get(axis, 0.0) * machine.axis(axis).steps_per_mm) + 1
    start = rng.randint(-40, 40)
    approach = start + rng.randint(10, 30)
    others = [rng.randint(-20, 20) for _ in machine.axes]
    point = lambda s: tuple(s if j == i else others[j] for j in range(len(machine.axes)))   # noqa: E731
    targets, at = [point(start), point(approach)], approach
    back = band_steps + 6 if rng.random() < 0.6 else rng.randint(1, max(band_steps - 1, 1))   # or inside the play
    while approach - at < back:
        at -= rng.randint(1, 4)
        targets.append(point(at))
    return targets


def reference_readings(machine, axis, targets):
    """The experiment run by the checks themselves: (motor steps, carriage mm) at every target."""
    log = PositionErrorLoop(machine, backlash_comp=False).run(targets)
    sim = SimMachine(machine, log.start_steps)
    sim.feed(log.frames)
    return [sim.state_at(w.reached_tick)[axis] for w in log.waypoints]


def test_dial_targets(lab):
    """TODO 1: out to +approach on one axis, then back one step at a time, on lathes and mills"""
    rng = cases("04 dial targets")
    for _ in range(12):
        machine = load_machine(rng.choice(SHIPPED))
        axis, approach, reverse = rng.choice(machine.axis_names), rng.randint(2, 60), rng.randint(1, 40)
        want = [tuple(approach - k if name == axis else 0 for name in machine.axis_names) for k in range(reverse + 1)]
        got = [tuple(t) for t in lab.dial_targets(machine, axis, approach, reverse)]
        expect(got == want, f"dial_targets({machine.name}, {axis!r}, approach={approach}, reverse={reverse}); "
                            f"{seed_note()}", expected=want[:8], got=got[:8],
               hint=f"{reverse + 1} targets: the approach point, then one step less each time; 0 on the "
                    f"other axes; in the machine's axis order {machine.axis_names}")


FAMILIES = {"lathes": ["chivu-lathe", "mitic-lathe"], "mills": ["tul-mill", "grenoble-mill"]}


@pytest.mark.parametrize("family", list(FAMILIES))
def test_dial_readings(lab, family):
    """TODO 2: one (motor steps, carriage mm) reading at every reached target, compensation off"""
    rng = cases(f"04 dial readings {family}")
    first = load_machine(FAMILIES[family][0])
    for machine in [first] + [random_machine(rng, rng.choice(FAMILIES[family])) for _ in range(3)]:
        axis = rng.choice(machine.axis_names)
        targets = experiment(rng, machine, axis)
        want = reference_readings(machine, axis, targets)
        got = [(int(m), float(c)) for m, c in lab.dial_readings(machine, axis, targets)]
        ok = len(got) == len(want) and all(m == wm and abs(c - wc) < 1e-9 for (m, c), (wm, wc) in zip(got, want))
        expect(ok, f"dial_readings({machine.name}, {axis!r}, targets {targets[:4]} ...) (clearance "
                   f"{machine.axis(axis).backlash_mm} mm); {seed_note()}",
               expected=[(m, round(c, 4)) for m, c in want], got=[(m, round(c, 4)) for m, c in got],
               hint="for each waypoint of the log: sim.state_at(waypoint.reached_tick)[axis]; "
                    "drive with backlash_comp=False so the controller adds no steps")


@pytest.mark.parametrize("family", list(FAMILIES))
def test_dead_band_from_readings(lab, family):
    """TODO 3: the dead band from the readings: motor travel minus carriage travel, in mm"""
    rng = cases(f"04 dead band {family}")
    first = load_machine(FAMILIES[family][0])
    for machine in [first] + [random_machine(rng, rng.choice(FAMILIES[family])) for _ in range(3)]:
        for axis in machine.axis_names[:2]:
            readings = reference_readings(machine, axis, experiment(rng, machine, axis))[1:]
            step = machine.axis(axis).step_mm
            (m0, c0), (m1, c1) = readings[0], readings[-1]
            want = abs(m1 - m0) * step - abs(c1 - c0)
            got = float(lab.dead_band_mm(machine, axis, readings))
            expect(abs(got - want) <= 1e-9, f"dead_band_mm({machine.name}, {axis!r}, readings) with "
                   f"{len(readings)} readings: motor {m0} -> {m1} steps, carriage {c0:.4f} -> {c1:.4f} mm; {seed_note()}",
                   expected=f"{want:.4f} mm = {abs(m1 - m0)} steps x {step:g} mm - {abs(c1 - c0):.4f} mm",
                   got=f"{got:.4f} mm" + (f" ({(want - got) / step:+.2f} steps off)" if step else ""),
                   hint="from the first reading (at the reversal) to the last, whatever the steps between "
                        "readings; in mm, not steps: motor steps times this axis's step_mm, minus the carriage's "
                        "travel (already mm)")


def test_measured_dead_band_within_a_step(lab):
    """TODOs 1-3: your whole experiment finds the simulator's dead band within one step"""
    rng = cases("04 whole experiment")
    for machine in [load_machine("chivu-lathe")] + [random_machine(rng, "chivu-lathe") for _ in range(3)]:
        for axis in machine.axis_names:
            readings = lab.dial_readings(machine, axis, lab.dial_targets(machine, axis))
            got = float(lab.dead_band_mm(machine, axis, readings))
            want, step = machine.sim.dead_band_mm[axis], machine.axis(axis).step_mm
            expect(abs(got - want) <= step + 1e-9, f"the dead band of {axis} your experiment measures on {machine.name}; "
                   f"{seed_note()}",
                   expected=f"{want:.3f} mm (the machine file's [sim] dead_band_mm) within one step, {step:g} mm",
                   got=f"{got:.4f} mm", hint="reverse more steps than the play, so the carriage has moved by the end")


def test_with_clearance_on_random_machines(lab):
    """TODO 4: with_clearance replaces the backlash_mm of the axes named, on lathes and mills"""
    rng = cases("04 clearances")
    for _ in range(8):
        machine = random_machine(rng)
        named = rng.sample(machine.axis_names, rng.randint(1, len(machine.axis_names)))
        clearances = {name: round(rng.uniform(0.0, 0.3), 4) for name in named}
        new = lab.with_clearance(machine, clearances)
        want = tuple(replace(a, backlash_mm=clearances.get(a.name, a.backlash_mm)) for a in machine.axes)
        expect(tuple(new.axes) == want and new.sim == machine.sim and new.name == machine.name,
               f"with_clearance({machine.name}, {clearances}); {seed_note()}",
               expected=[a.backlash_mm for a in want], got=[a.backlash_mm for a in new.axes],
               hint="replace backlash_mm of the axes named in clearances, in mm; the others unchanged")


def test_with_clearance_makes_a_new_machine(lab, lathe):
    """TODO 4: with_clearance replaces backlash_mm and leaves everything else alone"""
    new = lab.with_clearance(lathe, {"X": 0.125})
    expect(new.axis("X").backlash_mm == 0.125 and new.axis("X").backlash_steps == 5,
           "with_clearance(lathe, {'X': 0.125}).axis('X')", expected="backlash_mm 0.125 (5 steps)",
           got=f"backlash_mm {new.axis('X').backlash_mm}")
    expect(new.axis("Z") == lathe.axis("Z") and new.sim == lathe.sim and new.name == lathe.name,
           "the other axis and the rest of the machine", expected="unchanged", got="changed",
           hint="only replace the axes named in clearances")
    expect(lathe.axis("X").backlash_mm == 0.10, "the machine you were given", expected="unchanged (0.10 mm on X)",
           got=f"{lathe.axis('X').backlash_mm} mm", hint="use dataclasses.replace to make a new machine")


def test_compensated_error_within_a_step(lab, lathe):
    """Compensated with what you measured, the zigzag's carriage error is at most one step"""
    bare = lab.with_clearance(lathe, {"X": 0.0, "Z": 0.0})
    measured = {a: float(lab.dead_band_mm(bare, a, lab.dial_readings(bare, a, lab.dial_targets(bare, a))))
                for a in ("X", "Z")}
    compensated = lab.with_clearance(bare, measured)
    log, sim = lab.drive(compensated, lab.zigzag(compensated), True)
    errors = lab.carriage_errors(compensated, log, sim)
    for axis in compensated.axes:
        worst = max(errors[axis.name])
        expect(worst <= axis.step_mm + 1e-9, f"the {axis.name} carriage on the zigzag, compensated with "
               f"{measured[axis.name]:.3f} mm", expected=f"at most one step ({axis.step_mm:g} mm) off",
               got=f"{worst:.3f} mm", hint="the clearance goes into backlash_mm in mm")
