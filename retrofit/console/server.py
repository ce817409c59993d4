"""The state behind the console's page: the machine, the program opened, the run and its views.

One run at a time, started under a lock; STOP in every state; the programs it may open come from
:mod:`.programs`; the web app in front of it is :mod:`.api` (``create_app``).
"""

from __future__ import annotations

import threading
from contextlib import contextmanager
from pathlib import Path

from ..errors import GcodeError, RetrofitError
from ..machine.config import Machine

#: how long the console waits for a stopped run's thread to end before it puts the outputs safe
STOP_JOIN_S = 5.0


class Console:
    """The state behind the page: the machine, the program opened, the run and its views.

    ``outputs``: frame outputs besides sim:// (a command-level output, such as serial://, is
    refused here); ``programs``: the folder whose programs may be opened besides the examples.
    """

    def __init__(self, machine: Machine, outputs: list[str] | None = None, backlash_comp: bool = True,
                 programs: str | Path | None = None, machine_arg: str | None = None):
        from .programs import ProgramFolder
        from .tools import SpindleTools
        self.machine = machine
        self.output_urls = [u for u in (outputs or []) if not u.startswith("sim://")]
        for url in self.output_urls:
            check_output(url)
        self.folder = ProgramFolder(programs)
        self.tools = SpindleTools(machine, self.output_urls, machine_arg)
        self._opened_tool = self._recorded_tool()  # the tool in the spindle the program was compiled for
        self.backlash_comp = backlash_comp
        self.program = None
        self.source = ""
        self.listing: dict = {}                # what open() answered: the page shows it again after a reload
        self.run = None
        self._report = None
        self._steps = self._frames = self._pulses = None
        self._recorded = None                  # (frames, sim or None) of a run made elsewhere
        self.run_id = 0                        # which run the page's state belongs to
        self._run_lock = threading.Lock()      # one start (or jog, home, MDI) at a time
        self._stops = 0                        # STOPs so far: one during a start stops the new run

    def _recorded_tool(self) -> int | None:
        """The tool the spindle record says, None when it cannot be trusted (opening a program
        then says why and how to recover)."""
        from ..errors import ToolStateError
        try:
            return self.tools.tool()
        except ToolStateError:
            return None

    # -- program ------------------------------------------------------------------------------------
    def open(self, path: str | None = None, name: str | None = None, text: str | None = None) -> dict:
        """Compile a program (one the console lists, by ``name`` or ``path``, or the ``text`` of a
        picked file); its listing and preview. A ``.cmds`` file is a command list: one command a
        line in the text form (``FMOV X5 Z1``, ``TOOL T2``, ``PAUS M0``), ``#`` starting a comment."""
        from .views import preview
        if text is None:
            text, name = self.folder.read(path if path is not None else name or "")
        name = Path(name or "program.ngc").name
        tool = self.tools.tool()
        program = self.tools.compile(text, name, tool)
        self._opened_tool = tool
        from .tools import clamped_feeds
        said = [f"{file or program.file}:{number}: {words}"             # as retrofit run warns
                for file, number, kind, words in getattr(program, "messages", ()) if kind == "WARNING"]
        listing = {"name": program.file, "listing": text.splitlines(),
                   "preview": preview(program, self.machine, text),
                   "warnings": said + clamped_feeds(program, self.machine, self._default_feed())}
        self.program, self.source, self.listing = program, text, listing
        return listing

    def _default_feed(self) -> float:
        """The feed (mm/min) a program runs at before its first F: the controller's."""
        from ..controller import Controller
        return Controller(self.machine).processor.walker.feed

    # -- run ------------------------------------------------------------------------------------------
    def start(self, speed: float = 0.0) -> dict:
        """Run the opened program from the machine's zero on sim:// (and the real outputs); one
        start at a time: Busy (409) while another starts or a run is under way."""
        from .engine import SteeredRun
        with self._exclusive():
            if self.program is None:
                raise RetrofitError("no program open; open one first (a program the console lists, or an uploaded file)")
            if self.run is not None and not self.run.finished:
                raise Busy("a run is under way; STOP it or wait for its end")
            stops = self._stops
            tool, program = self.tools.tool(), self.program
            if tool != self._opened_tool:          # the spindle changed since: G43 and T need the tool
                program = self.tools.compile(self.source, program.file, tool)
            self.close()
            self._report = self._steps = self._frames = self._pulses = self._recorded = None
            run = self.tools.expand(program, tool)
            outputs = self._open_outputs()
            self.tools.begin(run)
            self.run = SteeredRun(self.machine, run.commands, run.lines, backlash_comp=self.backlash_comp,
                                  paced=speed > 0, speed=speed or 1.0, outputs=outputs, tool=tool,
                                  changes=run.changes, on_done=lambda done: self.tools.finish(done.tool))
            self.run_id += 1
            self.run.start()
            if self._stops != stops:           # STOP came while the run was being set up
                self.run.stop()
            return self.state()

    @contextmanager
    def _exclusive(self):
        """The run lock, taken at once or Busy (409)."""
        if not self._run_lock.acquire(blocking=False):
            raise Busy("another start, jog, home or MDI is under way")
        try:
            yield
        finally:
            self._run_lock.release()

    def stop(self) -> dict:
        """STOP, in every state: the run stops (or its outputs go safe if its thread is gone)."""
        self._stops += 1
        run = self.run
        if run is not None:
            run.stop()
        return self.state()

    def make_safe(self) -> None:
        """The console ends (a signal): STOP, then every output safe (drivers off, pins at rest)."""
        run = self.run
        if run is not None:
            run.stop()
            run.join(STOP_JOIN_S)
            run.make_outputs_safe()

    def close(self) -> None:
        """End the run shown (its real outputs finished); the console closes with this too."""
        if self.run is not None:
            self.run.close()

    def _open_outputs(self) -> list:
        from ..outputs import open_output
        outs = []
        try:
            for url in self.output_urls:
                outs.append(open_output(url, self.machine))
                outs[-1].open()
        except BaseException:
            for out in outs:
                out.abort()
            raise
        return outs

    def act(self, kind: str, **args) -> dict:
        """An operator's action on the run (or, for jog / home / MDI, on a stopped machine)."""
        if kind == "stop":
            return self.stop()
        if kind in ("jog", "home", "mdi"):
            with self._exclusive():
                fresh = self._fresh_run_needed()
                here = ({a.name: 0.0 for a in self.machine.axes} if fresh
                        else self.run.snapshot()["commanded_mm"])
                tool = self.tools.tool() if fresh else self.run.tool
                moves = self._manual(here, kind, args, tool)   # a refusal here changes nothing
                run = self._manual_run(fresh, tool)
                self.tools.begin(moves)
                run.extend(moves.commands, [0] * len(moves.commands), moves.changes)
                return self.state()
        if self.run is None:
            raise RetrofitError(f"{kind}: nothing is running")
        self.run.act(kind, **args)
        return self.state()

    def _manual(self, here: dict, kind: str, args: dict, tool: int):
        """The commands of a jog (within the soft limits), a home or an MDI line, from ``here``
        (mm) with ``tool`` in the spindle (an MDI tool change by the changer), expanded."""
        from ..commands import FMov
        from ..gcode.program import Program
        if kind == "mdi":
            try:
                program = self.tools.compile(args["text"], "MDI", tool, start_mm=here)
            except GcodeError as exc:              # the line itself, then the rule it breaks
                raise GcodeError(exc.rule, f'MDI "{args["text"].strip()}"') from None
            return self.tools.expand(program, tool)
        if kind == "jog":
            axis = self.machine.axis(args["axis"])
            target = here[axis.name] + args["step"]
            if not axis.min_mm <= target <= axis.max_mm:
                raise RetrofitError(f"jog {axis.name} {args['step']:+g} mm from {here[axis.name]:g} mm to "
                                    f"{target:g} mm: beyond the soft limits {axis.min_mm:g}..{axis.max_mm:g} mm")
            moves = [FMov(axes=((axis.name, round(target, 6)),))]
        else:
            moves = [FMov(axes=tuple((a.name, 0.0) for a in self.machine.axes))]
        return self.tools.expand(Program(moves, [0] * len(moves), kind), tool)

    def _fresh_run_needed(self) -> bool:
        """True when a jog, home or MDI starts a fresh controller (none yet, or after STOP or an
        error); RetrofitError while a program runs."""
        if self.run is not None and self.run.state == "running":
            raise RetrofitError("jog, home and MDI wait until the program has ended")
        return self.run is None or self.run.state in ("stopped", "error")

    def _manual_run(self, fresh: bool, tool: int):
        from .engine import SteeredRun
        if fresh:
            self.close()
            self.run_id += 1
            self.run = SteeredRun(self.machine, [], [], backlash_comp=self.backlash_comp,
                                  outputs=self._open_outputs(), tool=tool,
                                  on_done=lambda done: self.tools.finish(done.tool))
        self._report = self._steps = self._frames = self._pulses = None
        return self.run

    def show_run(self, log, sim=None, report: dict | None = None) -> None:
        """Show a run made elsewhere (``retrofit run``'s fast path, a recording) in the after-run
        views: its port frames, and the carriage error when ``sim`` saw them."""
        self.run = self._steps = self._frames = self._pulses = None
        self.run_id += 1
        self._recorded = (log.frames, sim)
        self._report = report or {"machine": self.machine.name, "tick_us": self.machine.tick_us,
                                  "ticks": int(log.frames.end_tick), "violations": [], "events": [], "moves": []}

    def state(self, since: int = 0) -> dict:
        """The run's snapshot, its id, and the backplot points from ``since`` on."""
        if self.run is None:
            return {"state": "done" if self._recorded else "ready", "trail": [], "trail_len": 0,
                    "run_id": self.run_id, "tool": self._opened_tool}
        snap = dict(self.run.snapshot(), run_id=self.run_id)
        trail = self.run.trail
        snap["trail"], snap["trail_len"] = trail[since:], len(trail)
        return snap

    # -- after the run -----------------------------------------------------------------------------------
    def report(self) -> dict:
        from .runreport import console_report
        if self._recorded is not None:
            return self._report
        if self.run is None or not self.run.finished:
            raise RetrofitError("the report is there once the run has ended")
        if self._report is None:
            self._report = console_report(self.run)
        return self._report

    def steps(self):
        from .views import axis_steps
        if self._steps is None:
            self.report()
            self._steps = axis_steps(self.frames(), self.machine)
        return self._steps

    def frames(self):
        """The port frames of the run the views show."""
        if self._recorded is not None:
            return self._recorded[0]
        if self._frames is None:
            self._frames = self.run.ctl.frames()
        return self._frames

    def timeline(self, t0: int, t1: int) -> dict:
        from .views import timeline
        steps = self.steps()                   # first: refused until a run has ended
        sim = self._recorded[1] if self._recorded is not None else self.run.sim
        machine = self.machine

        def carriage(i, ticks):
            import numpy as np
            trace = sim.traces[machine.axes[i].name]
            values = np.concatenate(([0.0], np.asarray(trace.carriage_mm, float)))
            return values[np.searchsorted(np.asarray(trace.ticks, np.int64), ticks, side="right")]
        return timeline(steps, machine, t0, t1, carriage if sim is not None else None)

    def pulses(self, t0: int, t1: int) -> dict:
        from .views import PulseIndex
        if self._pulses is None:
            self.steps()
            self._pulses = PulseIndex(self.frames(), self.machine)
        return self._pulses.window(t0, t1)


def command_list(text: str, file: str):
    """A program from a command list; a CommandError naming ``file:line`` for a line that is not one."""
    from ..commands import CommandError, parse_command
    from ..gcode.program import Program
    commands, lines = [], []
    for number, raw in enumerate(text.splitlines(), 1):
        body = raw.split("#", 1)[0].strip()
        if not body:
            continue
        try:
            commands.append(parse_command(body))
        except CommandError as exc:
            raise CommandError(f"{file}:{number}: {exc}") from None
        lines.append(number)
    return Program(commands, lines, file)


class Busy(RetrofitError):
    """The console is starting or running another run (status 409)."""

    status = 409


def check_output(url: str) -> None:
    """An output the console can drive (it hands outputs port frames); OutputError if not."""
    from ..errors import OutputError
    from ..outputs import OutputURL, output_class
    cls = output_class(OutputURL.parse(url).scheme)
    if getattr(cls, "takes_commands", False):
        raise OutputError(f"{url}: the console drives outputs that take port frames (sim, parport, "
                          "parport+record, vcd); a command-level output is driven by 'retrofit run'")

