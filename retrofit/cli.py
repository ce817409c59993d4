"""The ``retrofit`` command line."""

from __future__ import annotations

import argparse
import sys

from importlib import import_module

from .errors import RetrofitError


def command_modules() -> list[str]:
    """Modules ``retrofit/cli_*.py`` that add sub-commands.

    Each has ``add_commands(subparsers)`` and imports heavy libraries only inside its command
    functions, so building the parser stays cheap.
    """
    import pkgutil
    import retrofit
    return sorted(f"retrofit.{m.name}" for m in pkgutil.iter_modules(retrofit.__path__)
                  if m.name.startswith("cli_"))


def main(argv: list[str] | None = None) -> int:
    parser = _parser()
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help()
        return 2
    try:
        return args.func(args) or 0
    except RetrofitError as exc:
        print(f"retrofit: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("retrofit: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:                # output piped into `head` and the reader went away
        import os
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 141


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="retrofit", description="CNC retrofit toolkit: controller, simulator, outputs.")
    sub = p.add_subparsers(metavar="COMMAND")

    m = sub.add_parser("machines", help="list the machine files that ship with retrofit")
    m.set_defaults(func=_cmd_machines)

    d = sub.add_parser("demo", help="run a demo from the source papers")
    d.add_argument("which", choices=["circle"], help="circle: the lathe paper's 100-point circle")
    motion_options(d)
    d.add_argument("--radius", type=float, default=15.0, help="circle radius in mm (default 15)")
    d.add_argument("--points", type=int, default=100, help="points on the circle (default 100)")
    d.set_defaults(func=_cmd_demo)

    r = sub.add_parser("run", help="run a G-code part program on a machine")
    r.add_argument("program", help="G-code file (.ngc); the shipped examples: lathe-profile.ngc, engraving.ngc")
    motion_options(r)
    r.add_argument("--reference", action="store_true",
                   help="step by the readable per-tick reference path instead of the compiled fast path")
    r.add_argument("--controller", action="store_true",
                   help="run through the tick-by-tick 002 controller (automatic for threads and homing)")
    r.add_argument("--progress", choices=["auto", "on", "off"], default="auto",
                   help="progress bar (auto: only on a terminal)")
    r.set_defaults(func=_cmd_run)
    for module in command_modules():
        import_module(module).add_commands(sub)
    return p


def motion_options(p: argparse.ArgumentParser) -> None:
    p.add_argument("--machine", default="chivu-lathe", help="shipped machine name or path to a .toml file")
    p.add_argument("--output", action="append", metavar="URL",
                   help="where the port frames go (repeatable; default sim://); see 'retrofit outputs'")
    p.add_argument("--no-backlash-comp", action="store_true", help="turn backlash compensation off")
    p.add_argument("--plot", metavar="FILE.png", help="save commanded vs carriage path as PNG")
    p.add_argument("--report", metavar="FILE.json", help="write the run report (docs/report.md)")


def _cmd_machines(args) -> int:
    from .config import list_machines, load_machine
    for name in list_machines():
        m = load_machine(name)
        axes = ", ".join(f"{a.name} {a.steps_per_mm:g} steps/mm" for a in m.axes)
        print(f"{name:16s} {m.description}  [{axes}; tick {m.tick_us:g} us]")
    return 0


def _cmd_demo(args) -> int:
    from .config import load_machine
    from .demo import circle_targets
    from .motion.errorloop import PositionErrorLoop
    machine = load_machine(args.machine)
    if args.points < 1 or not args.radius > 0:
        raise RetrofitError(f"--points must be >= 1 and --radius > 0 (got {args.points}, {args.radius:g})")
    loop = PositionErrorLoop(machine, backlash_comp=not args.no_backlash_comp)
    log = loop.run(circle_targets(machine, args.radius, args.points))
    comp = "off" if args.no_backlash_comp else "on"
    finish_run(args, log, f"{machine.name}: circle r={args.radius:g} mm, {args.points} points, backlash comp {comp}")
    return 0


def _cmd_run(args) -> int:
    from .config import load_machine
    from .gcode import load_program
    from .runprogram import Progress, controller_reason, execute, plan_compiled, resolve_program
    machine = load_machine(args.machine)
    path = resolve_program(args.program)
    progress = Progress(["compiling and planning", "stepping", "simulating"],
                        None if args.progress == "auto" else args.progress == "on")
    try:
        program = load_program(path, machine)
        reason = "--controller" if args.controller else controller_reason(program.commands, machine)
        if reason:
            return _run_controller(args, machine, path, program, reason, progress)
        program, plan = plan_compiled(program, machine, backlash_comp=not args.no_backlash_comp)
        progress.next()
        log = execute(plan, reference=True) if args.reference else None   # else streamed to the outputs
        progress.next()
        comp = "off" if args.no_backlash_comp else "on"
        path_name = "reference" if args.reference else "fast"
        finish_run(args, log, f"{machine.name}: {path.name}, {len(program.commands)} commands, "
                              f"{len(plan.moves)} moves, backlash comp {comp}, {path_name} path",
                   program.commands, plan=None if args.reference else plan)
        progress.next()
    finally:
        progress.close()
    return 0


def _run_controller(args, machine, path, program, reason: str, progress) -> int:
    """``retrofit run`` through the 002 controller: its frames, from a simulated machine's inputs."""
    from .runprogram import run_on_controller
    if args.reference:
        raise RetrofitError(f"--reference steps the planner's per-tick reference path; {path.name} runs "
                            f"through the controller ({reason}), which is per tick already")
    progress.next()
    log = run_on_controller(program, machine, backlash_comp=not args.no_backlash_comp)
    progress.next()
    comp = "off" if args.no_backlash_comp else "on"
    finish_run(args, log, f"{machine.name}: {path.name}, {len(program.commands)} commands, backlash comp "
                          f"{comp}, 002 controller ({reason})", program.commands)
    progress.next()
    return 0


def finish_run(args, log, title: str, commands=None, plan=None) -> dict:
    """Deliver frames (or, to command-level outputs, ``commands``), print the summary, write plot and report.

    With a ``plan`` (and no ``log``) the frames are made and delivered window by window."""
    from .report import build_report, summary_lines, write_json_atomic
    from .runner import deliver
    from .runprogram import command_outputs, remote_lines
    machine = plan.machine if plan is not None else log.machine
    urls, remote = command_outputs(args.output or ["sim://"], machine, commands)
    if plan is not None:
        from .outputs.deliver import deliver_plan
        log, sim = deliver_plan(plan, urls)
    else:
        sim = deliver(log, urls)
    report = build_report(log, sim)
    if remote:
        report["remote"] = remote
    lines = [title] + summary_lines(report) + remote_lines(remote)
    if args.plot:                        # files first: a closed terminal must not lose them
        from .plot import plot_path
        lines.append(f"  plot: {plot_path(log, sim, args.plot, title)}")
    if args.report:
        write_json_atomic(args.report, report)
        lines.append(f"  report: {args.report}")
    print("\n".join(lines))
    return report


if __name__ == "__main__":
    sys.exit(main())
