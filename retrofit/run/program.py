"""Run a part program, top to bottom: program → plan → execute → outputs → report.

:func:`run_program` is the one run of ``retrofit run`` for every machine and program: the G-code
is compiled with the machine's tool table and the tool in the spindle; the host's commands are
replaced (:mod:`retrofit.atc.front`: the changer's sequences, or pauses for manual changes);
the commands are planned and executed by the fast path (or by the tick-by-tick 002 controller
for threads and homing); the port frames go to the outputs; the report joins what the controller
did with what the simulated machine did, every violation with its time and program line.
A run on ``sim://`` and ``vcd://`` that can is read ahead instead, a window at a time from the
first line (:mod:`retrofit.run.stream`).
"""

from __future__ import annotations

import sys
from dataclasses import dataclass, field
from pathlib import Path

from ..errors import GcodeError, MotionError, OutputError
from ..machine.config import Machine
from ..runlog import RunLog

#: share of the whole work each stage takes (measured with the CLI on a 200 000-segment program;
#: within compile the bar follows the lines run, within outputs the machine time delivered)
STAGE_WEIGHTS = {"compile": 0.70, "plan": 0.10, "execute": 0.08, "outputs": 0.12}


@dataclass
class Run:
    """What one run did: the program, its host events, the log, the machine, the report."""

    machine: Machine
    name: str
    program: object = None
    expanded: object = None
    plan: object = None
    log: RunLog | None = None
    sim: object = None
    report: dict = field(default_factory=dict)
    how: str = ""
    command_count: int = 0
    io: dict | None = None          # DOUT changes and WAITs (retrofit.run.digital.io_report)
    line_of: object = None          # tick -> program line, for a run read ahead or on the controller
    pause_ticks: dict | None = None  # command index -> tick of a pause, for a run on the controller
    kept: object = None             # what a streamed run kept for its HTML report (opts.report_store)


def read_program(name: str, stdin=None) -> tuple[str, str]:
    """(text, name) of a program: ``-`` is standard input, else a file or a shipped example."""
    if name == "-":
        stream = stdin or sys.stdin
        data = stream.buffer.read() if hasattr(stream, "buffer") else stream.read()
        if isinstance(data, bytes):
            try:
                data = data.decode("utf-8")
            except UnicodeDecodeError as exc:
                raise GcodeError(f"not UTF-8 text (byte {exc.start})", "<stdin>") from None
        return data, "<stdin>"
    path = resolve_program(name)
    try:
        return path.read_text(encoding="utf-8"), path.name
    except UnicodeDecodeError as exc:
        raise GcodeError(f"not a UTF-8 text file (byte {exc.start})", path.name) from None
    except OSError as exc:
        raise GcodeError(f"cannot read the program ({exc.strerror})", str(path)) from None


def resolve_program(name: str | Path) -> Path:
    """A program by path, or by the name of a shipped example (``lathe-profile.ngc``)."""
    from importlib import resources
    path = Path(name)
    if path.is_file():
        return path
    shipped = resources.files("retrofit") / "examples" / path.name
    if not path.parent.parts and shipped.is_file():
        return Path(str(shipped))
    examples = sorted(p.name for p in (resources.files("retrofit") / "examples").iterdir()
                      if p.name.endswith(".ngc"))
    raise GcodeError(f"no such program; shipped examples: {', '.join(examples)}; "
                     "'-' reads standard input", str(name))


def run_program(text: str, name: str, machine: Machine, opts, progress, wait=None,
                tool_table=None, spindle_tool: int = 0) -> Run:
    """The whole run of program ``text`` (see the module doc); ``opts`` holds the command line's
    choices (backlash_comp, reference, controller, urls; ``before_outputs(run)``, called when the
    machine is about to move, e.g. to mark a tool change under way in the spindle record)."""
    from ..atc.front import expand_host_commands
    from ..gcode import compile_program
    run, warned = Run(machine, name), 0          # messages already printed by a read-ahead try
    from .stream import ReadWhole, reads_ahead, run_read_ahead
    if reads_ahead(machine, opts, opts.urls):
        try:         # 1-4 a window at a time, from the first line (retrofit.run.stream)
            run_read_ahead(run, text, opts, progress, tool_table, spindle_tool)   # warns as it reads
            from .summary import run_report
            run.report = run_report(run)
            return run
        except ReadWhole as exc:
            run, warned = Run(machine, name), exc.warned
    # 1. program: G-code -> commands (G38 probing moves made as the program is read: on the
    #    controller at the far end of the link when the run drives one, else on the simulated
    #    machine); TOOL and PAUS -> the changer's sequences and pauses
    prober = link_prober(machine, spindle_tool, opts.urls) or sim_prober(machine, spindle_tool)
    try:
        run.program = compile_program(text, machine, file=name, tool_table=tool_table,
                                      spindle_tool=spindle_tool, probe=prober,
                                      dialect=getattr(opts, "dialect", None),
                                      on_progress=lambda done: progress.fraction("compile", done))
        print_warnings(run.program.messages[warned:])
        opened = prober.handoff() if hasattr(prober, "handoff") and prober.moves else None
        if prober is not None and prober.moves and opened is None:
            refuse_real_probing(opts.urls, name)
        run.expanded = expand_host_commands(run.program, machine, spindle_tool)
        from ..firmware.limits import for_run
        clamped = for_run(run.expanded, machine, opts.urls)     # a controller on the link: its rates
        run.command_count = len(run.program.commands)
        progress.done("compile")
        # 2. plan and 3. execute: by the planner and the fast path, or through the 002 controller
        reason = "--controller" if opts.controller else controller_reason(run.expanded.commands, machine)
        streamed = False
        if reason:
            refuse_io_on_controller(run.expanded, reason)
            run.log = run_on_controller(run.expanded, machine, opts.backlash_comp, opts.reference, reason, run)
            run.how = f"002 controller ({reason})"
            progress.done("plan")
        else:
            run.plan = plan_expanded(run.expanded, machine, opts.backlash_comp, progress)
            streamed = can_stream(run, opts)
            if streamed and not getattr(opts, "keep_commands", True):
                run.program.commands = run.expanded.commands = []     # planned: let the objects go
            run.log = None if streamed else execute(run.plan, opts.reference)
            run.how = "reference path" if opts.reference else "fast path"
            run.io = digital_outputs(run)
        progress.done("execute")
        # 4. outputs: frames to every output, stopping at pauses on a real machine; a clock-timed
        #    run to sim:// and vcd:// only is made and delivered a window at a time (bounded memory)
        if getattr(opts, "before_outputs", None):
            opts.before_outputs(run)
        if streamed:
            if getattr(opts, "report_store", None):
                run.kept = opts.report_store(run)
            run.sim = stream_outputs(run, opts.urls, progress, taps=[run.kept.feed] if run.kept else [])
        else:
            run.sim = deliver_outputs(run, opts.urls, wait, progress, opened)
    except BaseException:
        from ..failsafe import stop_all
        link = getattr(getattr(prober, "cell", None), "output", None)
        stop_all([link] if link is not None and link.is_open else [])    # the link's machine first
        raise
    finally:
        if hasattr(prober, "close"):
            prober.close()          # (the link's port, when probing opened it)
    # 5. report: the log joined with what the machine did
    from .summary import run_report
    run.report = run_report(run)
    for part in run.report.get("remote") or []:
        part["clamped"] = clamped
    return run


def print_warnings(messages) -> None:
    """The program's WARNING messages (e.g. a feed lowered to the machine's fastest) on stderr."""
    for file, number, kind, text in messages:
        if kind == "WARNING":
            print(f"{file}:{number}: warning: {text}", file=sys.stderr)


def refuse_io_on_controller(expanded, reason: str) -> None:
    """DOUT and WAIT are timed by the planner's run; the controller's run does not make them."""
    from ..commands import Dout, Wait
    for cmd, line in zip(expanded.commands, expanded.lines):
        if isinstance(cmd, (Dout, Wait)):
            raise GcodeError(f"{cmd}: digital outputs and input waits (M62-M66) run on the "
                             f"planner's path; this program runs through the controller ({reason}), "
                             f"which does not make them", expanded.file, line)


def refuse_io_on_link(url: str, device) -> None:
    """The link and the firmware do not carry DOUT and WAIT: refused before anything is sent."""
    found = next((c for c in device if not c.linked), None)
    if found is not None:
        raise OutputError(f"{url}: {found}: the serial link does not carry digital outputs and "
                          f"input waits (M62-M66); run the program on sim:// (or a port-frame "
                          f"output such as parport://)")


def digital_outputs(run: Run) -> dict | None:
    """The run's DOUT changes written in its port frames; the report's ``io`` part (None when
    the program has no DOUT or WAIT)."""
    from ..commands import Dout, Wait
    from .digital import io_report, output_changes, with_outputs
    commands = run.expanded.commands
    if not any(isinstance(c, (Dout, Wait)) for c in commands):
        return None
    changes = output_changes(run.plan, commands)
    if run.log is not None:
        run.log.frames = with_outputs(run.log.frames, changes, run.machine)
    return io_report(run.plan, commands, run.expanded.lines, changes)


def sim_prober(machine: Machine, spindle_tool: int = 0):
    """The prober of G38 moves on the simulated machine (one with a tool setter and a changer),
    or None: probing is then refused with its line."""
    if "setter" not in machine.parts or "atc" not in machine.parts:
        return None
    from ..atc.prober import SimProber
    return SimProber(machine, spindle_tool)


def link_prober(machine: Machine, spindle_tool: int, urls):
    """The prober of G38 moves on the controller at the far end of the link, when the run drives
    one (a single serial output) and the machine has a probe input (a tool setter); else None."""
    from ..outputs import OutputURL, open_output, output_class
    linked = [u for u in urls
              if getattr(output_class(OutputURL.parse(u).scheme), "takes_commands", False)]
    if len(linked) != 1 or "setter" not in machine.parts:
        return None
    from ..atc.linkcell import LinkProber
    return LinkProber(open_output(linked[0], machine), machine, spindle_tool)


def refuse_real_probing(urls, name: str) -> None:
    """A program whose probing moves were made on the simulated machine must not drive a real one."""
    from .runner import is_real
    real = [u for u in urls if is_real(u)]
    if real:
        raise OutputError(f"{real[0]}: {name} probes (G38) and its probe results come from the "
                          "simulated machine; a machine's own probe input is read through one "
                          "controller on the serial link (a single serial:// output, on a machine "
                          "with a tool setter), or run it on sim://")


def plan_expanded(expanded, machine: Machine, backlash_comp: bool, progress):
    """The plan of an expanded program; a GcodeError naming file:line when it cannot be planned."""
    from ..motion.planner import plan_program
    try:
        return plan_program(progress.counting("plan", expanded.commands), machine, backlash_comp)
    except MotionError as exc:
        index = getattr(exc, "command_index", None)
        line = expanded.lines[index] if index is not None and index < len(expanded.lines) else None
        raise GcodeError(str(exc), expanded.file, line) from None


def plan_compiled(program, machine: Machine, backlash_comp: bool = True):
    """(program, plan) of a compiled program that holds no host command (TOOL, PAUS): the
    planner's part of a run, for labs, tests and the console; errors as :func:`plan_expanded`."""
    from .progress import silent
    return program, plan_expanded(program, machine, backlash_comp, silent(STAGE_WEIGHTS))


def controller_reason(commands, machine: Machine) -> str | None:
    """Why a program must run through the controller rather than the planner, or None.

    Moves timed by the spindle (ISTP: G33, G76) and homing against switches (ZMOV on a machine
    with ``[homing]``) depend on inputs read while the program runs.
    """
    from ..commands import IStp, ZMov
    if any(isinstance(c, IStp) for c in commands):
        return "threads under the spindle's indexer"
    if "homing" in machine.parts and any(isinstance(c, ZMov) for c in commands):
        return "homing against switches"
    return None


def run_on_controller(expanded, machine: Machine, backlash_comp: bool = True, reference: bool = False,
                      reason: str = "", run: Run | None = None) -> RunLog:
    """Run the commands through the tick-by-tick controller driving a simulated machine (its
    switches and spindle are the controller's inputs), standing still at each pause as the
    console does (:mod:`retrofit.run.controlled`); ``run`` gets the program line of each tick and
    the tick of each pause. A GcodeError naming file:line when the controller refuses a command
    or halts with an error."""
    from .controlled import run_controlled
    if reference:
        raise GcodeError(f"--reference steps the planner's per-tick reference path; this program "
                         f"runs through the controller ({reason}), which is per tick already",
                         expanded.file)
    done = run_controlled(expanded, machine, backlash_comp)
    if run is not None:
        run.line_of, run.pause_ticks = done.line_of, done.pause_ticks
    return done.log


def execute(plan, reference: bool = False) -> RunLog:
    """Step schedule and port frames of a plan, by the fast path unless ``reference``."""
    if reference:
        from ..motion.execute import execute_reference
        return execute_reference(plan)
    from ..motion.fast import execute_fast
    return execute_fast(plan)


def deliver_outputs(run: Run, urls: list[str], wait, progress, opened=None):
    """Frames to the frame outputs, commands to the command outputs; the simulated machine.
    ``opened``: (URL, open output, device commands already run) of a link that probing used."""
    from .runner import deliver, is_real
    exp = run.expanded
    pauses = [(pause_tick(run, e.index), e.index, f"line {e.line}: {e.says}") for e in exp.pauses]
    real = [u for u in urls if is_real(u)]
    if pauses and real and wait is None:
        raise OutputError(f"{real[0]}: the program pauses ({pauses[0][2]}) and this output drives a "
                          "machine: run it from a terminal, where Enter resumes after each pause")
    frame_urls, remote = command_outputs(urls, run.machine, exp.commands,
                                         [(i, says) for _, i, says in pauses], wait, opened,
                                         exp.lines, exp.file)
    run.report["remote"] = remote
    total = max(int(run.log.ticks), 1)
    return deliver(run.log, frame_urls, [(t, says) for t, _, says in pauses], wait,
                   lambda tick: progress.fraction("outputs", tick / total), plan=run.plan)


#: outputs a streamed run can feed window by window
STREAM_SCHEMES = ("sim", "vcd")
#: steps per streamed window: small enough that the progress bar moves often, large enough that
#: the compiled kernels dominate the per-window cost
STREAM_WINDOW_STEPS = 1 << 17


def can_stream(run: Run, opts) -> bool:
    """Whether the run's frames can be made and delivered a window at a time, never held whole:
    the fast path, no tool changer (its magazine check replays the whole run), no ``--html``
    (which keeps every frame for its pulse view), only ``sim://`` and ``vcd://``. A pause is a
    point in the stream: these outputs drive no machine, so nothing waits there."""
    from ..commands import Dout
    from ..outputs import OutputURL
    return (not opts.reference and "atc" not in run.machine.parts
            and not any(isinstance(c, Dout) for c in run.expanded.commands)
            and not getattr(opts, "keep_frames", False)
            and all(OutputURL.parse(u).scheme in STREAM_SCHEMES for u in opts.urls))


def stream_outputs(run: Run, urls: list[str], progress, blocks=None, on_index=None, taps=()):
    """The plan's frames to every output as they are made (each file complete or absent); the
    simulated machine. ``run.log`` becomes the streamed log: waypoints and steps, no frames.
    ``blocks``: (machine, iterator of plan blocks) for a run read ahead, in place of ``run.plan``,
    and ``on_index`` then gets the index of the command after the last one stepped; ``taps`` get
    each window of frames too."""
    from contextlib import ExitStack

    from ..outputs.deliver import deliver_plan
    from .runner import staged_url
    with ExitStack() as files:
        staged = [staged_url(url, files) for url in urls]
        moved = on_index if blocks is not None else (lambda done: progress.fraction("outputs", done))
        run.log, sim = deliver_plan(run.plan, staged, moved,
                                    window_steps=STREAM_WINDOW_STEPS, blocks=blocks, taps=taps)
    run.report["remote"] = []
    return sim


def pause_tick(run: Run, index: int) -> int:
    """The tick at which the moves before command ``index`` have ended."""
    if run.plan is None:
        return (run.pause_ticks or {}).get(index, 0 if index == 0 else int(run.log.ticks))
    ends = [m.t0_s + m.duration_s for m in run.plan.moves if m.index < index]
    return round(max(ends, default=0.0) / run.machine.tick_s)


def command_outputs(urls: list[str], machine: Machine, commands, pauses=(), wait=None,
                    opened=None, lines=None, file: str = "") -> tuple[list[str], list[dict]]:
    """Run ``commands`` on the command-level outputs among ``urls`` (``serial://``, ...).

    Such outputs (``takes_commands``) get the program's commands, not its port frames, and
    report what the controller at the far end did; at each pause (command index, words) the
    commands before it are run to their end and ``wait(words)`` is called. Returns the URLs left
    for the port frames and one report part per command-level output (``remote`` in
    docs/report.md).
    """
    from ..firmware.limits import send_naming_line
    from ..outputs import OutputURL, open_output, output_class
    frame_urls, remote = [], []
    for url in urls:
        if not getattr(output_class(OutputURL.parse(url).scheme), "takes_commands", False):
            frame_urls.append(url)
            continue
        if commands is None:
            raise OutputError(f"{url}: this output runs a program's commands; this run has only "
                              "port frames (use it with retrofit run)")
        device = [c for c in commands if not c.host]
        device_lines = [n for c, n in zip(commands, lines or [None] * len(commands)) if not c.host]
        refuse_io_on_link(url, device)
        resumed = opened is not None and opened[0] == url
        with (opened[1] if resumed else open_output(url, machine)) as out:
            done, part, sent = (opened[2], None, opened[2]) if resumed else (0, None, 0)
            for index, says in [p for p in pauses if p[0] >= done] + [(len(device), None)]:
                if index > done or says is None:
                    part = send_naming_line(out, device, device_lines, file, done, index)
                    sent += part["commands"]
                    part["commands"] = sent
                    out.opts["init"] = False          # INIT once, at the start of the program
                    done = index
                if says is not None:
                    wait(says)
            remote.append(part)
    return frame_urls, remote
