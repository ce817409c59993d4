"""The console's web server: a Starlette app serving the page and a small JSON API.

The page (``static/``) and its one library (plotly.js, from the ``plotly`` Python package) are
served from the installed packages, so the console works offline with no build step. The API:

=======================  ====================================================================
``GET  /api/machine``    the machine: axes, soft limits, lathe or not; the shipped programs
``POST /api/open``       ``{"path": ...}`` or ``{"name": ..., "text": ...}``: listing + preview
``POST /api/run``        ``{"speed": 0}`` as fast as possible, ``{"speed": f}`` paced at f x machine time
``POST /api/action``     ``{"kind": "stop" | "hold" | "resume" | "feed" | "rapid" | "answer" |
                         "speed" | "jog" | "home" | "mdi", ...}``
``GET  /api/state``      DRO, line, flags, dialog; ``?since=n``: the backplot points from n on
``GET  /api/report``     the run's report (docs/report.md, plus ``events`` and ``moves``)
``GET  /api/timeline``   ``?t0=&t1=`` (ticks): position, velocity, acceleration, carriage error
``GET  /api/pulses``     ``?t0=&t1=`` (ticks): the step and direction lines
=======================  ====================================================================
"""

from __future__ import annotations

from importlib import resources
from pathlib import Path

from ..config import Machine
from ..errors import RetrofitError

STATIC = resources.files("retrofit.console") / "static"


def plotly_js() -> Path:
    """plotly.min.js as the ``plotly`` package ships it."""
    import plotly
    return Path(plotly.__file__).parent / "package_data" / "plotly.min.js"


class Console:
    """The state behind the page: the machine, the program opened, the run and its views."""

    def __init__(self, machine: Machine, outputs: list[str] | None = None, backlash_comp: bool = True):
        self.machine = machine
        self.output_urls = [u for u in (outputs or []) if not u.startswith("sim://")]
        self.backlash_comp = backlash_comp
        self.program = None
        self.source = ""
        self.run = None
        self._report = None
        self._steps = self._frames = self._pulses = None
        self._recorded = None                  # (frames, sim or None) of a run made elsewhere
        self.run_id = 0                        # which run the page's state belongs to

    # -- program ------------------------------------------------------------------------------------
    def open(self, path: str | None = None, name: str | None = None, text: str | None = None) -> dict:
        """Compile a program (a path, a shipped name, or the text of a picked file); its listing
        and preview. A ``.cmds`` file is a command list: one command a line in the text form
        (``FMOV X5 Z1``, ``TOOL T2``, ``PAUS M0``), ``#`` starting a comment."""
        from ..gcode.program import compile_program
        from ..runprogram import resolve_program
        from .views import preview
        if text is None:
            file = resolve_program(path or name or "")
            text, name = file.read_text(errors="replace"), file.name
        name = name or "program.ngc"
        if name.endswith(".cmds"):
            self.program = command_list(text, name)
        else:
            self.program = compile_program(text, self.machine, name)
        self.source = text
        return {"name": self.program.file, "listing": text.splitlines(),
                "preview": preview(self.program, self.machine, text)}

    # -- run ------------------------------------------------------------------------------------------
    def start(self, speed: float = 0.0) -> dict:
        """Run the opened program from the machine's zero on sim:// (and the real outputs)."""
        from .engine import SteeredRun
        if self.program is None:
            raise RetrofitError("no program open; open one first (a path or a shipped example)")
        if self.run is not None and not self.run.finished:
            raise RetrofitError("a run is under way; STOP it or wait for its end")
        self.close()
        self._report = self._steps = self._frames = self._pulses = self._recorded = None
        self.run = SteeredRun(self.machine, self.program.commands, self.program.lines,
                              backlash_comp=self.backlash_comp, paced=speed > 0, speed=speed or 1.0,
                              outputs=self._open_outputs())
        self.run_id += 1
        self.run.start()
        return self.state()

    def close(self) -> None:
        """End the run shown (its real outputs finished); the console closes with this too."""
        if self.run is not None:
            self.run.close()

    def _open_outputs(self) -> list:
        from ..outputs import open_output
        outs = [open_output(u, self.machine) for u in self.output_urls]
        for out in outs:
            out.open()
        return outs

    def act(self, kind: str, **args) -> dict:
        """An operator's action on the run (or, for jog / home / MDI, on a stopped machine)."""
        from .engine import jog_command
        if kind in ("jog", "home", "mdi"):
            run = self._manual_run()
            if kind == "jog":
                cmds = [jog_command(self.machine, run.snapshot()["commanded_mm"], args["axis"], float(args["step"]))]
                lines = [0]
            elif kind == "home":
                from ..commands import FMov
                cmds, lines = [FMov(axes=tuple((a.name, 0.0) for a in self.machine.axes))], [0]
            else:
                cmds, lines = self._mdi(run, str(args.get("text", "")))
            run.extend(cmds, lines)
            return self.state()
        if self.run is None:
            raise RetrofitError(f"{kind}: nothing is running")
        self.run.act(kind, **args)
        return self.state()

    def _manual_run(self):
        from .engine import SteeredRun
        if self.run is not None and not self.run.finished and self.run.state != "done":
            if self.run.state == "running":
                raise RetrofitError("jog, home and MDI wait until the program has ended")
        if self.run is None or self.run.state in ("stopped", "error"):
            self.close()
            self.run_id += 1
            self.run = SteeredRun(self.machine, [], [], backlash_comp=self.backlash_comp,
                                  outputs=self._open_outputs())
        self._report = self._steps = self._frames = self._pulses = None
        return self.run

    def _mdi(self, run, text: str):
        from ..gcode.program import compile_program
        here = run.snapshot()["commanded_mm"]
        prog = compile_program(text, self.machine, "MDI", start_mm=here)
        return prog.commands, [0] * len(prog.commands)

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
                    "run_id": self.run_id}
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
        sim = self._recorded[1] if self._recorded is not None else self.run.sim
        machine = self.machine
        steps = self.steps()

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


def create_app(console: Console):
    """The Starlette application of ``console``."""
    from contextlib import asynccontextmanager

    from starlette.applications import Starlette
    from starlette.responses import FileResponse, JSONResponse
    from starlette.routing import Mount, Route
    from starlette.staticfiles import StaticFiles

    def guarded(fn):
        async def endpoint(request):
            try:
                body = await request.json() if request.method == "POST" else {}
                return JSONResponse(await _call(fn, request, body))
            except (RetrofitError, KeyError, ValueError) as exc:
                return JSONResponse({"error": str(exc)}, status_code=400)
        return endpoint

    q = lambda r, k, d=0: int(float(r.query_params.get(k, d)))                 # noqa: E731
    routes = [
        Route("/", lambda r: FileResponse(str(STATIC / "index.html"))),
        Route("/plotly.min.js", lambda r: FileResponse(str(plotly_js()))),
        Route("/api/machine", guarded(lambda r, b: machine_info(console.machine))),
        Route("/api/open", guarded(lambda r, b: console.open(b.get("path"), b.get("name"), b.get("text"))),
              methods=["POST"]),
        Route("/api/run", guarded(lambda r, b: console.start(float(b.get("speed", 0)))), methods=["POST"]),
        Route("/api/action", guarded(lambda r, b: console.act(**b)), methods=["POST"]),
        Route("/api/state", guarded(lambda r, b: console.state(q(r, "since")))),
        Route("/api/report", guarded(lambda r, b: console.report())),
        Route("/api/timeline", guarded(lambda r, b: console.timeline(q(r, "t0"), q(r, "t1")))),
        Route("/api/pulses", guarded(lambda r, b: console.pulses(q(r, "t0"), q(r, "t1")))),
        Mount("/static", StaticFiles(directory=str(STATIC))),
    ]
    @asynccontextmanager
    async def lifespan(app):
        yield
        console.close()                  # the server ends: finish the run's outputs
    return Starlette(routes=routes, lifespan=lifespan)


async def _call(fn, request, body):
    """Run ``fn`` in a worker thread, so a long computation never blocks the server's loop."""
    from starlette.concurrency import run_in_threadpool
    return await run_in_threadpool(fn, request, body)


def machine_info(machine: Machine) -> dict:
    from importlib import resources as res
    from ..plot import is_lathe
    examples = sorted(p.name for p in (res.files("retrofit") / "examples").iterdir() if p.name.endswith(".ngc"))
    return {"name": machine.name, "description": machine.description, "tick_us": machine.tick_us,
            "lathe": is_lathe(machine), "examples": examples,
            "axes": [{"name": a.name, "label": a.label, "min": a.min_mm, "max": a.max_mm} for a in machine.axes]}
