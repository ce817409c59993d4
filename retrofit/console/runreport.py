"""The report of a console run: the run report of docs/report.md (with the changer's magazine
checked as ``retrofit run`` checks it), plus what the operator did and the feed each move really
ran at (measured from the step pulses, split where the operator acted)."""

from __future__ import annotations

import numpy as np

from ..commands import FMov, PMov
from .views import axis_steps

#: the window (s of machine time) over which the speed of a move is measured
SPEED_WINDOW_S = 0.05
#: operator actions that change a move's speed
SPEED_EVENTS = ("feed", "rapid", "hold", "resume", "stop")


def console_report(run) -> dict:
    """``build_report`` of a :class:`~retrofit.console.engine.SteeredRun`, with ``events`` and ``moves``."""
    from ..run.report import build_report
    log = run.ctl.run_log()
    from ..run.summary import magazine_check
    report = build_report(log, run.sim)
    found = [v.as_dict() for v in magazine_check(run.machine, log.start_steps, run.start_tool, run.sim)]
    report["violations"] = sorted(report["violations"] + found, key=lambda v: (v["tick"], v["axis"], v["kind"]))
    report["events"] = list(run.events)
    report["moves"] = moves(run, log.frames)
    for v in report["violations"]:
        v["line"] = line_at(report["moves"], v["tick"])
    last_rise = [int(s.ticks[-1]) for s in axis_steps(log.frames, run.machine) if len(s.ticks)]
    report["last_step_tick"] = max(last_rise, default=None)
    return report


def line_at(moves: list[dict], tick: int) -> int | None:
    """The program line of the move running at ``tick`` (None outside every move)."""
    for mv in moves:
        if mv["start_tick"] <= tick < mv["end_tick"]:
            return mv["line"]
    return None


def moves(run, frames) -> list[dict]:
    """One entry per move the controller began: its program line, kind, ticks, the programmed feed
    and the measured feed (mm/min) of each stretch between the operator's speed changes."""
    machine = run.machine
    steps = axis_steps(frames, machine)
    cuts = [t for t in (e["tick"] for e in run.events if e["kind"] in SPEED_EVENTS)]
    out = []
    starts = run.starts + [(frames.end_tick, None)]
    for (t0, serial), (t1, _) in zip(starts, starts[1:]):
        index = run.serial_index[serial - 1] if 0 < serial <= len(run.serial_index) else -1
        cmd = run.commands[index] if index >= 0 else None
        if not isinstance(cmd, (FMov, PMov)):
            continue
        bounds = [t0] + [t for t in cuts if t0 < t < t1] + [t1]
        out.append({"line": run.lines[index], "kind": "rapid" if isinstance(cmd, FMov) else "cut",
                    "command": str(cmd), "start_tick": int(t0), "end_tick": int(t1),
                    "programmed_feed_mm_min": None if isinstance(cmd, FMov) else run.feeds[index],
                    "feed_mm_min": [{"from_tick": int(a), "to_tick": int(b),
                                     "measured": measured_feed(steps, machine, a, b)}
                                    for a, b in zip(bounds, bounds[1:])]})
    return out


def measured_feed(steps, machine, t0: int, t1: int) -> float | None:
    """The path speed (mm/min) the axes held over [t0, t1): measured from the first to the last
    window (SPEED_WINDOW_S each) whose speed reaches 9/10 of the median window's, so that
    acceleration at either end does not count (a straight move: the distance between the
    plateau's ends over its time); None when the stretch is shorter than three
    windows or nothing moved."""
    w = max(int(SPEED_WINDOW_S / machine.tick_s), 1)
    ticks = np.arange(t0, t1, w, dtype=np.int64)
    if len(ticks) < 3:
        return None
    pos = np.column_stack([s.at(ticks) / a.steps_per_mm for s, a in zip(steps, machine.axes)])
    speed = np.linalg.norm(np.diff(pos, axis=0), axis=1) / (w * machine.tick_s) * 60.0
    moving = speed[speed > 0]
    if not len(moving):
        return None
    fast = np.flatnonzero(speed >= 0.9 * np.median(moving))
    a, b = int(fast[0]), int(fast[-1]) + 1             # the plateau: first to last fast window
    dist = np.linalg.norm(pos[b] - pos[a])
    return round(float(dist / ((ticks[b] - ticks[a]) * machine.tick_s) * 60.0), 3)
