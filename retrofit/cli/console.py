"""``retrofit console``: the operator's console in the browser (preview, run, watch, steer)."""

from __future__ import annotations

import os

from ..errors import RetrofitError

#: how much a console that drives only sim:// lowers its own priority
CONSOLE_NICENESS = 10


def add_commands(sub) -> None:
    c = sub.add_parser("console", help="serve the operator's console: open a program, run it on sim:// "
                                       "or a real output, watch and steer it in a browser")
    c.add_argument("--machine", default="chivu-lathe", help="shipped machine name or path to a .toml file")
    c.add_argument("--output", action="append", metavar="URL",
                   help="where the port frames go besides sim:// (repeatable); see 'retrofit outputs'")
    c.add_argument("--listen", default="127.0.0.1:8080", metavar="HOST:PORT",
                   help="address the page is served on (default 127.0.0.1:8080)")
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
    import uvicorn
    from ..config import load_machine
    from ..console.server import Console, create_app
    from ..outputs import OutputURL, output_class
    host, port = listen_address(args.listen)
    machine = load_machine(args.machine)
    for url in args.output or []:
        output_class(OutputURL.parse(url).scheme)          # an unknown output fails here, not mid-run
    console = Console(machine, args.output, backlash_comp=not args.no_backlash_comp)
    if not console.output_urls and hasattr(os, "nice"):
        os.nice(CONSOLE_NICENESS)     # only sim://: a paced port loop on this computer goes first
    print(f"retrofit console for {machine.name}: http://{host}:{port}/  (Ctrl-C ends it)", flush=True)
    uvicorn.run(create_app(console), host=host, port=port, log_level="warning")
    return 0
