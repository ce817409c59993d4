"""The console's web server: a Starlette app serving the page and a small JSON API.

The page (``static/``) and its one library (plotly.js, from the ``plotly`` Python package) are
served from the installed packages, so the console works offline with no build step. Every
``/api/`` call carries the console's token (``X-Retrofit-Token``); the calls that act carry the
control id of the browser that holds control (``X-Retrofit-Control``); see :mod:`.guard`. Bodies
are JSON, checked by the schemas of :mod:`.schema`.

=========================  ==================================================================
``GET  /api/machine``      the machine: axes, soft limits, lathe or not; examples and programs
``POST /api/control``      ``{"take": false}``: control if no one holds it; ``{"take": true}``:
                           take it over. Answers ``{"control": id, "holder": {...}}`` (409 if held)
``POST /api/open``         ``{"name": ...}`` (a listed program) or ``{"name": ..., "text": ...}``
``GET  /api/program``      the program open (what /api/open answered; ``{}`` before one is)
``POST /api/run``          ``{"speed": 0}`` as fast as possible, ``{"speed": f}`` paced at f x machine time
``POST /api/action``       ``{"kind": "stop" | "hold" | "resume" | "feed" | "rapid" | "answer" |
                           "speed" | "jog" | "home" | "mdi", ...}``
``GET  /api/state``        DRO, line, flags, dialog, fault, control; ``?since=n``: the backplot from n on
``GET  /api/report``       the run's report (docs/report.md, plus ``events`` and ``moves``)
``GET  /api/timeline``     ``?t0=&t1=`` (ticks): position, velocity, acceleration, carriage error
``GET  /api/pulses``       ``?t0=&t1=`` (ticks): the step and direction lines
=========================  ==================================================================
"""

from __future__ import annotations

from importlib import resources
from pathlib import Path

from ..errors import RetrofitError
from ..machine.config import Machine
from .guard import CONTROL_HEADER
from .schema import PROGRAM_BYTES

STATIC = resources.files("retrofit.console") / "static"


def plotly_js() -> Path:
    """plotly.min.js as the ``plotly`` package ships it."""
    import plotly
    return Path(plotly.__file__).parent / "package_data" / "plotly.min.js"


def create_app(console, *, token: str, remote: bool = False, listen_host: str = "127.0.0.1"):
    """The Starlette application of ``console``, guarded by ``token`` (see :mod:`.guard`); ``remote``:
    also serve the listening address ``listen_host`` when it is not a loopback address."""
    from contextlib import asynccontextmanager

    from starlette.applications import Starlette
    from starlette.middleware import Middleware
    from starlette.responses import FileResponse
    from starlette.routing import Mount, Route
    from starlette.staticfiles import StaticFiles

    from .guard import Control, Guard, host_names
    from .schema import ControlBody, OpenBody, RunBody, action_schema
    control, actions = Control(), action_schema(console.machine)

    def claim(r, body):
        ident, holder = control.claim(r.headers.get(CONTROL_HEADER), body.take, (r.client or ("?",))[0])
        return {"control": ident, "holder": holder}

    def state(r, body):
        return dict(console.state(query_int(r, "since")), control=control.view(r.headers.get(CONTROL_HEADER)))
    q = query_int
    routes = [
        Route("/", lambda r: FileResponse(str(STATIC / "index.html"))),
        Route("/plotly.min.js", lambda r: FileResponse(str(plotly_js()))),
        Route("/api/machine", endpoint(lambda r, b: machine_info(console.machine, console.folder.programs()))),
        Route("/api/program", endpoint(lambda r, b: console.listing)),
        Route("/api/control", endpoint(claim, ControlBody, control=None), methods=["POST"]),
        Route("/api/open", endpoint(lambda r, b: console.open(b.path, b.name, b.text), OpenBody, control,
                                    limit=PROGRAM_BYTES), methods=["POST"]),
        Route("/api/run", endpoint(lambda r, b: console.start(b.speed), RunBody, control), methods=["POST"]),
        Route("/api/action", endpoint(lambda r, b: console.act(**b.model_dump()), actions, control),
              methods=["POST"]),
        Route("/api/state", endpoint(state)),
        Route("/api/report", endpoint(lambda r, b: console.report())),
        Route("/api/timeline", endpoint(lambda r, b: console.timeline(q(r, "t0"), q(r, "t1")))),
        Route("/api/pulses", endpoint(lambda r, b: console.pulses(q(r, "t0"), q(r, "t1")))),
        Mount("/static", StaticFiles(directory=str(STATIC))),
    ]

    @asynccontextmanager
    async def lifespan(app):
        yield
        console.close()                  # the server ends: finish the run's outputs
    guard = Middleware(Guard, token=token, names=host_names(listen_host, remote))
    return Starlette(routes=routes, lifespan=lifespan, middleware=[guard])


def endpoint(fn, schema=None, control=None, limit: int = 0):
    """An API route: the body read (at most ``limit`` bytes) and checked against ``schema``, the
    caller's control checked, then ``fn(request, body)`` in a worker thread; errors as one line."""
    from starlette.concurrency import run_in_threadpool
    from starlette.responses import JSONResponse

    from .guard import Held
    from .schema import ACTION_BYTES, BadRequest, parse

    async def route(request):
        try:
            body = None
            if request.method == "POST":
                raw = await read_body(request, limit or ACTION_BYTES)
                if control is not None:
                    control.check(request.headers.get(CONTROL_HEADER))
                body = parse(schema, raw, request.url.path)
            return JSONResponse(await run_in_threadpool(fn, request, body))
        except Held as exc:
            return JSONResponse({"error": str(exc), "holder": exc.holder}, status_code=exc.status)
        except BadRequest as exc:
            return JSONResponse({"error": str(exc)}, status_code=exc.status)
        except (RetrofitError, KeyError, ValueError) as exc:
            return JSONResponse({"error": one_line(exc)}, status_code=getattr(exc, "status", 400))
    return route


async def read_body(request, limit: int) -> bytes:
    """The request's body; BadRequest (413) past ``limit`` bytes, before reading more."""
    from .schema import BadRequest
    declared = request.headers.get("content-length", "")
    too_long = BadRequest(f"{request.url.path}: body over {limit} bytes, the most this call takes", status=413)
    if declared.isdigit() and int(declared) > limit:
        raise too_long
    body = bytearray()
    async for chunk in request.stream():
        body += chunk
        if len(body) > limit:
            raise too_long
    return bytes(body)


def one_line(exc: BaseException) -> str:
    return (str(exc) if not isinstance(exc, KeyError) else f"missing {exc}").replace("\n", " ")


def query_int(request, key: str, default: int = 0) -> int:
    """A whole number from the query string (ticks, a trail index); ValueError names it."""
    raw = request.query_params.get(key, str(default))
    try:
        return int(raw)
    except ValueError:
        raise ValueError(f"?{key}={raw!r}: expected a whole number") from None


def machine_info(machine: Machine, programs: list[str] = ()) -> dict:
    from importlib import resources as res

    from ..run.plot import is_lathe
    examples = sorted(p.name for p in (res.files("retrofit") / "examples").iterdir() if p.name.endswith(".ngc"))
    return {"name": machine.name, "description": machine.description, "tick_us": machine.tick_us,
            "lathe": is_lathe(machine), "examples": examples, "programs": list(programs),
            "axes": [{"name": a.name, "label": a.label, "min": a.min_mm, "max": a.max_mm} for a in machine.axes]}
