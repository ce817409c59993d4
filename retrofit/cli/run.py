"""``retrofit run`` (any program on any machine), ``retrofit demo circle``, ``retrofit machines``."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from types import SimpleNamespace

from ..errors import RetrofitError
from . import default_machine_line, machine_option


def add_commands(sub) -> None:
    """Add ``machines``, ``demo`` and ``run`` to the ``retrofit`` command line."""
    m = sub.add_parser("machines", help="list the machine files that ship with retrofit")
    m.set_defaults(func=cmd_machines)

    d = sub.add_parser("demo", help="run a demo from the source papers")
    d.add_argument("which", choices=["circle"], help="circle: the lathe paper's 100-point circle")
    motion_options(d)
    d.add_argument("--radius", type=float, default=15.0, help="circle radius in mm (default 15)")
    d.add_argument("--points", type=int, default=100, help="points on the circle (default 100)")
    d.set_defaults(func=cmd_demo)

    r = sub.add_parser("run", help="run a G-code part program on a machine",
                       description="Run PROGRAM on the machine: tool changes (the changer's sequences, "
                                   "or a pause for a manual change), homing, threads, pauses. Any "
                                   "error or stop puts the outputs in a safe state first (enable off, "
                                   "step bits low). Exit 0: clean; 1: the simulated machine reported "
                                   "violations; 2: refused input or an unusable output; 130: "
                                   "interrupted (Ctrl-C); 128+N: stopped by signal N (129 SIGHUP, "
                                   "143 SIGTERM).")
    r.add_argument("program", help="G-code file (.ngc), a shipped example (lathe-profile.ngc, "
                                   "engraving.ngc), or - for standard input")
    motion_options(r)
    r.add_argument("--tool-table", metavar="FILE.tbl",
                   help="LinuxCNC tool table (default: in the machine's state folder, see "
                        "docs/atc.md); the spindle record stays in the state folder")
    r.add_argument("--reference", action="store_true",
                   help="step by the readable per-tick reference path instead of the compiled fast path")
    r.add_argument("--controller", action="store_true",
                   help="run through the tick-by-tick 002 controller (automatic for threads and homing)")
    r.add_argument("--progress", choices=["auto", "on", "off"], default="auto",
                   help="progress bar on standard error (auto: only on a terminal)")
    r.add_argument("--dialect", choices=["rs274", "fanuc"], default=None,
                   help="how the program is written: rs274 (LinuxCNC) or fanuc (Fanuc/Haas lathe, "
                        "docs/fanuc.md); default: the machine file's dialect, else rs274")
    r.set_defaults(func=cmd_run)


def motion_options(p: argparse.ArgumentParser) -> None:
    """Options every command that moves axes takes."""
    machine_option(p, "chivu-lathe")
    p.add_argument("--output", action="append", metavar="URL",
                   help="where the port frames go (repeatable; default sim://); see 'retrofit outputs'")
    p.add_argument("--no-backlash-comp", action="store_true", help="turn backlash compensation off")
    p.add_argument("--plot", metavar="FILE.png", help="save commanded vs carriage path as PNG "
                                                      "(.png is added to a name without extension)")
    p.add_argument("--report", metavar="FILE.json", help="write the run report (docs/report.md)")
    p.add_argument("--html", metavar="FILE.html", help="write the run as an interactive page that opens offline")
    p.add_argument("--allow-violations", action="store_true",
                   help="exit 0 even when the simulated machine reported violations")


def cmd_machines(args) -> int:
    from ..machine.config import list_machines, load_machine
    for name in list_machines():
        m = load_machine(name)
        axes = ", ".join(f"{a.name} {a.steps_per_mm:g} steps/mm" for a in m.axes)
        print(f"{name:16s} {m.description}  [{axes}; tick {m.tick_us:g} us]")
    return 0


def cmd_demo(args) -> int:
    from ..failsafe import signals_raise
    with signals_raise():              # SIGHUP, SIGTERM: the outputs go safe, as on Ctrl-C
        return _demo(args)


def _demo(args) -> int:
    from ..demo import circle_targets
    from ..machine.config import load_machine
    from ..motion.errorloop import PositionErrorLoop
    from ..run.report import build_report
    from ..run.runner import deliver
    from ..run.summary import fit, summary_lines
    machine = load_machine(args.machine)
    if args.points < 1 or not args.radius > 0:
        raise RetrofitError(f"--points must be >= 1 and --radius > 0 (got {args.points}, {args.radius:g})")
    files = output_files(args)
    log = PositionErrorLoop(machine, backlash_comp=not args.no_backlash_comp).run(
        circle_targets(machine, args.radius, args.points))
    from ..run.program import command_outputs
    urls, _ = command_outputs(args.output or ["sim://"], machine, None)     # refuses serial://
    sim = deliver(log, urls)
    report = build_report(log, sim)
    for v in report["violations"]:
        v.update(tick=int(v["tick"]), time_s=round(int(v["tick"]) * machine.tick_s, 6), line=None)
    comp = "off" if args.no_backlash_comp else "on"
    title = f"{machine.name}: circle r={args.radius:g} mm, {args.points} points, backlash comp {comp}"
    lines = summary_lines(report, title) + default_machine_line(args.machine)
    lines = fit(lines) + write_files(files, args, log, sim, report)
    print("\n".join(lines))
    return exit_code(report, args)


def cmd_run(args) -> int:
    import gc

    # A run makes hundreds of thousands of objects (a command per arc chord, a planned move per
    # command) and almost no reference cycles: refcounting frees them, and the cyclic collector
    # would only walk them again and again (a tenth of a long run's CPU). This process ends with
    # the run, so the collector stays off for it.
    from ..failsafe import signals_raise
    gc.disable()
    try:
        with signals_raise():              # SIGHUP, SIGTERM: the outputs go safe, as on Ctrl-C
            return _run(args)
    finally:
        gc.enable()


def _run(args) -> int:
    from ..atc.state import spindle_store
    from ..machine.config import load_machine
    from ..machine.tooltable import ToolTable
    from ..run.program import STAGE_WEIGHTS, read_program, run_program
    from ..run.progress import Progress
    from ..run.summary import fit, summary_lines
    machine = load_machine(args.machine)
    text, name = read_program(args.program)
    files = output_files(args)
    urls = args.output or ["sim://"]
    table_path, store = spindle_store(machine, args.machine, urls, args.tool_table)
    table, start_tool = ToolTable.load(table_path), store.load()

    def mark(run) -> None:                 # the machine's record says "changing" until the run has ended
        if store.real and changes_tools(run.expanded):
            store.begin(start_tool, run.expanded.end_tool)
    opts = SimpleNamespace(backlash_comp=not args.no_backlash_comp, reference=args.reference,
                           controller=args.controller, urls=urls,
                           keep_commands=bool(getattr(args, "plot", None) or getattr(args, "html", None)),
                           report_store=html_store if getattr(args, "html", None) else None,
                           before_outputs=mark, dialect=args.dialect)
    progress = Progress(STAGE_WEIGHTS, None if args.progress == "auto" else args.progress == "on")
    try:
        run = run_program(text, name, machine, opts, progress, operator_wait(), table, start_tool)
    finally:
        progress.close()
    exp = run.expanded
    if changes_tools(exp):
        store.save(exp.end_tool)
    title = f"{machine.name}: {name}, {run.command_count} commands, {run.how}"
    lines = summary_lines(run.report, title) + default_machine_line(args.machine)
    lines += [f"  tool table: {table_path}; {store.describe()} (T{exp.end_tool} in the spindle)"
              ] if exp.events or "atc" in machine.parts else []
    lines += remote_lines(run.report.get("remote") or [])
    notes = [(line, text) for _, line, kind, text in run.program.messages if kind == "NOTE"]
    lines += [f"  line {line}: note: {text}" for line, text in notes[:10]]
    lines += [f"  ... and {len(notes) - 10} more notes"] if len(notes) > 10 else []
    files_lines = write_files(files, args, run.log, run.sim, run.report,     # a path is not wrapped
                              run.program.commands, (name, text), run.program, run.kept)
    print("\n".join(fit(lines) + files_lines))
    return exit_code(run.report, args)


def html_store(run):
    """What ``--html`` keeps of a streamed run: bounded, whatever the run's length."""
    from ..console.reportstore import store_for
    return store_for(run)


def changes_tools(expanded) -> bool:
    """Whether the run changes the tool in the spindle (by the changer or by hand)."""
    return expanded.changes_the_tool


def exit_code(report: dict, args) -> int:
    """1 when the machine reported violations (0 with --allow-violations), else 0."""
    return 1 if report["violations"] and not args.allow_violations else 0


def operator_wait():
    """How a pause on a real machine waits: a prompt on a terminal; None without one."""
    if not sys.stdin.isatty():
        return None

    def wait(says: str) -> None:
        print(f"paused: {says}; press Enter to go on", file=sys.stderr, flush=True)
        sys.stdin.readline()
    return wait


def output_files(args) -> dict:
    """The files ``--plot`` and ``--report`` will write, checked before any work is done."""
    from ..atomic import check_target
    files = {}
    if args.plot:
        plot = Path(args.plot)
        files["plot"] = plot if plot.suffix else plot.with_name(plot.name + ".png")
    if args.report:
        files["report"] = Path(args.report)
    if getattr(args, "html", None):
        files["html"] = Path(args.html)
    for path in files.values():
        check_target(path)
    from ..atomic import plan
    from ..outputs import OutputURL
    from ..run.runner import FILE_SCHEMES
    targets = [OutputURL.parse(u) for u in (getattr(args, "output", None) or [])]
    plan([Path(u.target) for u in targets if u.scheme in FILE_SCHEMES and u.target] + list(files.values()))
    return files


def write_files(files: dict, args, log, sim, report: dict, commands=None, program=None,
                compiled=None, kept=None) -> list[str]:
    """Write the plot, the page and the report (each complete or absent); their summary lines.

    ``program`` is the run's (name, G-code text), ``compiled`` its Program (None for a demo),
    ``kept`` what a streamed run kept for the page.
    """
    from ..atomic import write_json_atomic
    lines = []
    if "plot" in files:
        from ..run.plot import plot_run
        lines.append(f"  plot: {plot_run(args, log, sim, commands, files['plot'], program)}")
    if "html" in files:
        from ..console.report_html import write_html_report
        path = write_html_report(args, log, sim, report, commands, files["html"], program, compiled, kept)
        lines.append(f"  html: {path}")
    if "report" in files:
        write_json_atomic(files["report"], report)
        lines.append(f"  report: {files['report']}")
    return lines


def remote_lines(remote: list[dict]) -> list[str]:
    """One summary line per remote controller: its final position (RDPS) and status."""
    lines = []
    for part in remote:
        pos = ", ".join(f"{name} {mm:.3f}" for name, mm in part["position_mm"].items())
        lines.append(f"  remote {part['url']}: RDPS {pos} mm; status {' '.join(part['status']) or '-'}"
                     f"; {part['commands']} commands in {part['wall_s']:.2f} s")
        lines += [f"  {note}" for note in part.get("clamped", [])]
    return lines

