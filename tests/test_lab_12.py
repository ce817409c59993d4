"""Lab 12's checks are held to retrofit's loop: the position-error loop written in
labs/12_error_loop/checks.py with its own counters (so a student's file cannot reach it) gives the
port bytes and reached ticks of ``retrofit.motion.errorloop.PositionErrorLoop``, tick for tick, on
shipped and random machines, with compensation on and off."""

from pathlib import Path

import pytest

from retrofit.lab.core import load_module
from retrofit.motion.errorloop import PositionErrorLoop

CHECKS = load_module(Path(__file__).resolve().parent.parent / "labs" / "12_error_loop" / "checks.py")
MACHINES = {**CHECKS.MACHINES, **{f"random-{s}": (lambda s=s: CHECKS._random_machine(s)) for s in range(100, 106)}}


@pytest.mark.parametrize("name", list(MACHINES))
def test_the_checks_loop_is_retrofits(name):
    machine = MACHINES[name]()
    for seed in range(4):
        start, targets = CHECKS.case(seed, machine)
        for comp in (True, False):
            mine = CHECKS.reference(machine, targets, comp, start)
            log = PositionErrorLoop(machine, backlash_comp=comp, start_steps=start).run(targets)
            where = f"{name} seed {seed} compensation {comp}"
            assert mine["reached"] == [w.reached_tick for w in log.waypoints], where
            assert (mine["ticks"], mine["values"], mine["end_tick"]) == \
                (log.frames.ticks.tolist(), log.frames.values.tolist(), log.frames.end_tick), where
            assert len(mine["readout"]) >= sum(log.steps_emitted.values()), where    # a line per step at least


def test_the_checks_reach_no_module_a_student_file_can_import_for_their_loop():
    """The checks import retrofit for machines, frames, messages and the simulated machine only."""
    text = Path(CHECKS.__file__).read_text(encoding="utf-8")
    imports = {line.split()[1] for line in text.splitlines() if line.startswith(("import ", "from "))}
    assert imports <= {"random", "dataclasses", "pytest", "retrofit.machine.config", "retrofit.frames", "retrofit.lab.core",
                       "retrofit.sim"}, imports
