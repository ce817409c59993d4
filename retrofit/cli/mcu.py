"""Sub-command ``retrofit mcu``: the Python motion controller behind the serial link (pty or TCP)."""

from __future__ import annotations

from . import machine_option


def add_commands(sub) -> None:
    """Add ``mcu`` to the ``retrofit`` command line."""
    m = sub.add_parser("mcu", help="run the motion controller behind the serial link, like 002's "
                                   "microcontroller (on a pty or a TCP port)",
                       description="Serve the wire protocol of docs/protocol.md with the Python "
                                   "motion controller behind it. Prints where it serves, then runs "
                                   "until interrupted. Its ticks run in simulated time, as fast as "
                                   "the work allows.")
    machine_option(m, "mitic-lathe")
    where = m.add_mutually_exclusive_group(required=True)
    where.add_argument("--pty", action="store_true",
                       help="serve on a new pseudo terminal; prints its path (/dev/pts/N)")
    where.add_argument("--listen", metavar="HOST:PORT",
                       help="serve on a TCP port (port 0 picks a free one; the real one is printed)")
    m.add_argument("--sim", action="store_true",
                   help="drive a simulated machine behind the controller: its switches close (ZMOV) "
                        "and its spindle's encoder runs (ISTP); without, nothing is wired")
    m.add_argument("--no-backlash-comp", action="store_true", help="turn backlash compensation off")
    m.add_argument("--heartbeat-ms", type=_heartbeat_ms, default=None, metavar="MS",
                   help="brake a moving machine whose host has sent nothing for MS milliseconds "
                        "(default 500, as the firmware; 50 to 60000)")
    m.set_defaults(func=_cmd_mcu)


def _heartbeat_ms(text: str) -> float:
    import argparse
    import math
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not 50 <= value <= 60000:
        raise argparse.ArgumentTypeError(f"{text!r}: give milliseconds from 50 to 60000")
    return value


def _cmd_mcu(args) -> int:
    from ..firmware.mcu import McuLoop, PtyPort, TcpServerPort, make_controller, parse_listen
    from ..machine.config import load_machine
    machine = load_machine(args.machine)
    controller = make_controller(machine, backlash_comp=not args.no_backlash_comp, simulate=args.sim)
    if args.pty:
        port = PtyPort()
        where = f"on {port.name} (host: --output serial://{port.name})"
    else:
        port = TcpServerPort(*parse_listen(args.listen))
        host, number = port.address
        where = (f"listening on {host}:{number} (host: --output serial+socket://{host}:{number})")
    print(f"{machine.name}: motion controller {where}", flush=True)
    try:
        from ..link.codec import HEARTBEAT_MS
        McuLoop(port, machine, controller, name=where,
                heartbeat_ms=args.heartbeat_ms or HEARTBEAT_MS).serve_forever()
    finally:
        port.close()
    return 0
