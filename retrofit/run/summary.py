"""The report of a ``retrofit run`` and its summary: plain lines that fit 80 columns.

The report (docs/report.md) is :func:`retrofit.run.report.build_report` plus what only a run of a
program knows: the program, how it ran, the tool changes and pauses, and for every violation its
machine time and the program line whose move was under way.
"""

from __future__ import annotations

import textwrap

import numpy as np

#: what a violation's kind means, in words
KIND_WORDS = {
    "lost_steps": "lost steps",
    "travel": "left its travel",
    "pulse_high": "step pulse too short (high)",
    "pulse_low": "step pulse too short (low)",
    "dir_setup": "direction changed too close before a step",
    "dir_hold": "direction changed too soon after a step",
}
WIDTH = 80


def run_report(run) -> dict:
    """The report of ``run`` (a :class:`retrofit.run.program.Run`)."""
    from .report import build_report
    remote = run.report.get("remote") or []
    report = build_report(run.log, run.sim)
    found = list(run.sim.violations) + magazine_violations(run)
    found.sort(key=lambda v: (v.tick, v.axis, v.kind))
    lines = _line_finder(run)
    report["violations"] = [{"tick": int(v.tick), "axis": v.axis, "kind": v.kind, "detail": v.detail,
                             "time_s": round(int(v.tick) * run.machine.tick_s, 6),
                             "line": lines(int(v.tick))} for v in found]
    report["program"] = run.name
    report["how"] = run.how
    exp = run.expanded
    report["tool"] = {"start": exp.start_tool, "end": exp.end_tool,
                      "changes": [{"line": e.line, "says": e.says} for e in exp.changes]}
    report["pauses"] = [{"line": e.line, "says": e.says} for e in exp.pauses]
    if remote:
        report["remote"] = remote
    if getattr(run, "io", None):
        report["io"] = run.io
    return report


def magazine_violations(run) -> list:
    """What the magazine model saw the machine do wrong (collisions, a tool dropped...)."""
    return magazine_check(run.machine, run.log.start_steps, run.expanded.start_tool, run.sim)


def magazine_check(machine, start_steps, start_tool: int, sim) -> list:
    """The magazine model's violations of a run on ``machine`` (none without a changer): the one
    check of ``retrofit run`` and the console, replayed on what the simulated machine did."""
    if "atc" not in machine.parts:
        return []
    from ..atc.magazine import MagazineModel, MagazineState
    start = {a.name: a.to_mm(s) for a, s in zip(machine.axes, start_steps or [0] * len(machine.axes))}
    model = MagazineModel(machine, MagazineState.loaded(machine, start_tool), start)
    model.replay(sim, 0)
    return list(model.violations)


def _line_finder(run):
    """tick -> the program line of the move under way then (None when not known)."""
    if getattr(run, "line_of", None) is not None:         # a run read ahead keeps its own
        return run.line_of
    plan, lines = run.plan, run.expanded.lines
    if plan is None or not len(plan.arrays()):
        return lambda tick: None
    starts, indices = plan.arrays().t0s, plan.arrays().index
    tick_s = run.machine.tick_s

    def line(tick: int):
        k = max(int(np.searchsorted(starts, tick * tick_s + 1e-12, side="right")) - 1, 0)
        index = int(indices[k])
        return lines[index] if 0 <= index < len(lines) else None
    return line


def violation_words(v: dict) -> str:
    """One violation in words: when, where in the program, which axis, what."""
    where = f"line {v['line']}" if v.get("line") else "no program line"
    what = KIND_WORDS.get(v["kind"], v["kind"].replace("_", " "))
    return f"at {v['time_s']:.3f} s ({where}): {v['axis']} {what}: {v['detail']}"


def summary_lines(report: dict, title: str) -> list[str]:
    """What ran, how long in machine time, per-axis end and error, each violation in words."""
    out = _wrap(f"{title}; {report['duration_s']:.3f} s of machine time "
                f"({report['ticks']} ticks of {report['tick_us']:g} us)")
    for name, ax in report["axes"].items():
        out += _wrap(f"  {name}: end {ax['carriage_mm']:.3f} mm (target {ax['target_mm']:.3f}), "
                     f"worst error {ax['max_carriage_error_mm']:.3f} mm, {ax['steps']} steps")
    tool = report.get("tool") or {}
    events = [(c["line"] or 0, c["says"]) for c in tool.get("changes", [])]
    events += [(p["line"] or 0, f"paused: {p['says']}") for p in report.get("pauses", [])]
    for line, says in sorted(events, key=lambda e: e[0]):
        out += _wrap(f"  line {line}: {says}")
    found = report["violations"]
    out.append(f"  violations: {len(found)}")
    shown = found[:10]
    for v in shown:
        out += _wrap("    " + violation_words(v))
    if len(found) > len(shown):
        out.append(f"    ... and {len(found) - len(shown)} more (all in the report)")
    return out


def fit(lines: list[str]) -> list[str]:
    """``lines`` wrapped to 80 columns, continuation lines indented under their start."""
    return [part for line in lines for part in _wrap(line)]


def _wrap(text: str) -> list[str]:
    indent = " " * (len(text) - len(text.lstrip()) + 2)
    return textwrap.wrap(text, WIDTH, subsequent_indent=indent, break_on_hyphens=False,
                         break_long_words=False) or [""]
