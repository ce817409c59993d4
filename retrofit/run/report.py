"""The run report: a stable JSON contract (docs/report.md) shared by every command that moves axes."""

from __future__ import annotations

import numpy as np

from ..atomic import write_json_atomic  # noqa: F401  (callers import it from here)
from ..runlog import RunLog, WaypointTable
from ..sim import SimMachine


def build_report(log: RunLog, sim: SimMachine) -> dict:
    """The report of one run: the controller's log joined with what the machine really did."""
    machine = log.machine
    final = log.final_target
    errors = _waypoint_errors(log, sim)
    axes = {}
    for i, axis in enumerate(machine.axes):
        motor_steps = sim.motor_steps[i]
        axes[axis.name] = {
            "steps": int(log.steps_emitted.get(axis.name, 0)),
            "target_mm": round(axis.to_mm(final[i]), 6),
            "motor_mm": round(axis.to_mm(motor_steps), 6),
            "carriage_mm": round(sim.carriage_mm(axis.name), 6),
            "reversals": int(sim.reversals[i]),
            "max_carriage_error_mm": round(float(errors[i]), 6),
        }
    return {
        "machine": machine.name,
        "tick_us": float(machine.tick_us),
        "ticks": int(log.ticks),
        "duration_s": round(log.ticks * machine.tick_s, 6),
        "axes": axes,
        "violations": [v.as_dict() for v in sim.violations],
        "max_following_error_steps": int(log.max_following_error_steps),
    }


def _waypoint_errors(log: RunLog, sim: SimMachine) -> np.ndarray:
    """Per axis, the largest |carriage - target| (mm) at the ticks the waypoints were reached."""
    machine = log.machine
    if isinstance(log.waypoints, WaypointTable):
        if log.waypoints.worst_mm is not None:           # settled while the run was streamed
            return log.waypoints.worst_mm
        steps, _, reached = log.waypoints.columns()
        steps, reached = steps[reached >= 0], reached[reached >= 0]
    else:
        kept = [w for w in log.waypoints if w.reached_tick is not None]
        steps = np.array([w.steps for w in kept], np.int64).reshape(len(kept), len(machine.axes))
        reached = np.array([w.reached_tick for w in kept], np.int64)
    if not len(reached):
        return np.zeros(len(machine.axes))
    carriage = sim.states_at(reached)[:, :, 1]
    spm = np.array([a.steps_per_mm for a in machine.axes])
    return np.abs(carriage - steps / spm).max(axis=0)


def summary_lines(report: dict) -> list[str]:
    """A short human summary of a report."""
    lines = [f"{report['machine']}: {report['ticks']} ticks of {report['tick_us']:g} us "
             f"= {report['duration_s']:.3f} s of machine time"]
    for name, ax in report["axes"].items():
        lines.append(f"  {name}: {ax['steps']} steps, target {ax['target_mm']:.3f} mm, carriage "
                     f"{ax['carriage_mm']:.3f} mm, {ax['reversals']} reversals, worst carriage error "
                     f"at a reached point {ax['max_carriage_error_mm']:.3f} mm")
    n = len(report["violations"])
    lines.append(f"  violations: {n}" + (f" (first: {report['violations'][0]})" if n else ""))
    return lines
