"""Small helpers shared by tests: machines with chosen physics, runs through the simulator."""

from dataclasses import replace

from retrofit.machine.config import SimModel, load_machine
from retrofit.motion.errorloop import PositionErrorLoop
from retrofit.sim import SimMachine


def lathe(dead_band_equals_comp: bool = False, **sim_bands):
    """chivu-lathe, optionally with a simulated dead band equal to the compensation clearance."""
    m = load_machine("chivu-lathe")
    if dead_band_equals_comp:
        sim_bands = {a.name: a.backlash_steps / a.steps_per_mm for a in m.axes}
    if sim_bands:
        bands = dict(m.sim.dead_band_mm)
        bands.update(sim_bands)
        m = replace(m, sim=SimModel(dead_band_mm=bands))
    return m


def run_targets(machine, targets, backlash_comp=True):
    """Run the 003 error loop over targets; return (log, sim) after the sim saw every frame."""
    log = PositionErrorLoop(machine, backlash_comp=backlash_comp).run(targets)
    sim = SimMachine(machine, log.start_steps)
    sim.feed(log.frames)
    return log, sim


def step_times(machine, frames):
    """Per axis: (rise ticks, directions) of the step pulses on the wire, as a driver decodes them."""
    from retrofit.sim.drivers import DriverInput
    out = {}
    for axis in machine.axes:
        rises, dirs = DriverInput(axis).edges(frames.ticks, frames.values)
        out[axis.name] = (rises.astype(float), dirs.astype(float))
    return out


def limit_breaches(machine, frames, slack=1e-9):
    """Velocity / acceleration breaches seen in the step times, allowing one tick of quantisation.

    Each step time is within half a tick of its ideal time, so an interval of D ticks stands for
    an ideal interval in [D - 1, D + 1]. A speed breaches when even D + 1 is too fast; an
    acceleration breaches when even the most favourable reading of two adjacent intervals
    needs more than the axis may give.
    """
    import numpy as np
    tick_s = machine.tick_s
    breaches = []
    for axis in machine.axes:
        rises, dirs = step_times(machine, frames)[axis.name]
        if len(rises) < 2:
            continue
        step = axis.step_mm
        gaps = np.diff(rises)
        v_slow = step / ((gaps + 1) * tick_s)                  # slowest reading of each interval
        v_fast = step / (np.maximum(gaps - 1, 1e-9) * tick_s)  # fastest reading
        for k in np.flatnonzero(v_slow > axis.max_velocity_mm_s * (1 + slack)):
            breaches.append((axis.name, "velocity", int(rises[k + 1]), float(v_slow[k])))
        same = dirs[1:-1] == dirs[2:]                           # the two intervals around step k+1
        lo1, hi1, lo2, hi2 = v_slow[:-1], v_fast[:-1], v_slow[1:], v_fast[1:]
        dv = np.where(same, np.maximum(0.0, np.maximum(lo2 - hi1, lo1 - hi2)), lo1 + lo2)
        dt = (gaps[:-1] + gaps[1:] + 2) / 2 * tick_s
        accel = dv / dt
        for k in np.flatnonzero(accel > axis.max_accel_mm_s2 * (1 + slack)):
            breaches.append((axis.name, "acceleration", int(rises[k + 1]), float(accel[k])))
    return breaches
