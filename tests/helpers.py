"""Small helpers shared by tests: machines with chosen physics, runs through the simulator."""

from dataclasses import replace

from retrofit.config import SimModel, load_machine
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
