"""``retrofit console``: the operator's console in the browser (preview, run, watch, steer)."""

from __future__ import annotations

import os

from ..errors import RetrofitError
from . import default_machine_line, machine_option

#: how much a console that drives only sim:// lowers its own priority
CONSOLE_NICENESS = 10
#: how long the server waits for open requests when it ends (s); the outputs are safe before
SHUTDOWN_S = 5


def add_commands(sub) -> None:
    c = sub.add_parser("console", help="serve the operator's console: open a program, run it on sim:// "
                                       "or a real output, watch and steer it in a browser")
    machine_option(c, "chivu-lathe")
    c.add_argument("--output", action="append", metavar="URL",
                   help="where the port frames go besides sim:// (repeatable); see 'retrofit outputs'")
    c.add_argument("--programs", metavar="DIR", help="folder whose programs the page may open (besides "
                                                     "the shipped examples)")
    c.add_argument("--listen", default="127.0.0.1:8080", metavar="HOST:PORT",
                   help="address the page is served on (default 127.0.0.1:8080)")
    c.add_argument("--allow-remote", action="store_true",
                   help="allow a --listen address other computers reach (anyone with the printed "
                        "address, token included, can then move the machine)")
    c.add_argument("--no-backlash-comp", action="store_true", help="turn backlash compensation off")
    c.set_defaults(func=cmd_console)


def listen_address(text: str) -> tuple[str, int]:
    """``host:port`` as (host, port); a port alone means 127.0.0.1."""
    host, _, port = text.rpartition(":")
    try:
        number = int(port)
    except ValueError:
        number = -1
    if not 0 <= number <= 65535:
        raise RetrofitError(f"--listen {text!r}: expected HOST:PORT with a port 0..65535, e.g. 127.0.0.1:8080")
    return host or "127.0.0.1", number


def cmd_console(args) -> int:
    import secrets
    import sys

    import uvicorn

    from ..console.api import create_app
    from ..console.guard import is_loopback
    from ..console.server import Console
    from ..machine.config import load_machine
    host, port = listen_address(args.listen)
    remote = not is_loopback(host)
    if remote and not args.allow_remote:
        raise RetrofitError(f"--listen {args.listen}: not a loopback address; other computers could move the "
                            "machine. Add --allow-remote if that is meant (read docs/console.md first)")
    machine = load_machine(args.machine)
    console = Console(machine, args.output, backlash_comp=not args.no_backlash_comp, programs=args.programs,
                      machine_arg=args.machine)
    if not console.output_urls and hasattr(os, "nice"):
        os.nice(CONSOLE_NICENESS)     # only sim://: a paced port loop on this computer goes first
    token = secrets.token_urlsafe(24)
    if remote:
        print(f"retrofit console: WARNING: serving on {host}:{port}, reachable from other computers; whoever "
              "has the address below can move the machine", file=sys.stderr, flush=True)
    shown = "127.0.0.1" if host in ("0.0.0.0", "::", "[::]") else host
    print(f"retrofit console for {machine.name}: http://{shown}:{port}/?token={token}  (Ctrl-C ends it)", flush=True)
    for line in default_machine_line(args.machine):
        print(line.strip(), flush=True)
    app = create_app(console, token=token, remote=remote, listen_host=host)
    server = safe_server(uvicorn.Config(app, host=host.strip("[]"), port=port, log_level="warning",
                                        timeout_graceful_shutdown=SHUTDOWN_S), console)
    try:
        server.run()
    finally:
        console.make_safe()
    return 0


def safe_server(config, console):
    """uvicorn's server, whose exit on SIGINT, SIGTERM and SIGHUP first puts the outputs safe."""
    import signal

    import uvicorn

    class SafeServer(uvicorn.Server):
        def handle_exit(self, sig, frame):
            console.make_safe()                           # STOP, drivers off, pins at rest: first
            if sig == signal.SIGHUP:                      # a second SIGHUP (re-raised on exit) ends us
                signal.signal(signal.SIGHUP, signal.SIG_DFL)
            super().handle_exit(sig, frame)
    server = SafeServer(config)
    signal.signal(signal.SIGHUP, server.handle_exit)
    return server
