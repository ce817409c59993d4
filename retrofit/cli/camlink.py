"""Sub-commands of the CAM link (001): ``serve``, ``send`` and ``loop-model``."""

from __future__ import annotations

from . import machine_option


def add_commands(sub) -> None:
    """Add ``serve``, ``send`` and ``loop-model`` to the ``retrofit`` command line."""
    s = sub.add_parser("serve", help="run the simulated servo mill behind the CAM link (TCP, '@' lines)")
    machine_option(s, "grenoble-mill", "machine with a [servo] section")
    s.add_argument("--listen", default="127.0.0.1:5000", metavar="HOST:PORT",
                   help="address to listen on (default 127.0.0.1:5000; port 0 picks a free one)")
    s.add_argument("--idle-timeout", type=float, default=30.0, metavar="SECONDS",
                   help="drop a client that sends nothing for this long (default 30)")
    s.set_defaults(func=_cmd_serve)

    c = sub.add_parser("send", help="stream a G-code program to a CAM link server as 1 ms rows")
    c.add_argument("program", metavar="PROGRAM.ngc", help="part program in machine coordinates (mm)")
    c.add_argument("--to", required=True, metavar="HOST:PORT", help="the server (retrofit serve)")
    machine_option(c, "grenoble-mill", "the machine the server runs")
    c.set_defaults(func=_cmd_send)

    m = sub.add_parser("loop-model", help="position loop: python-control model vs simulation")
    machine_option(m, "grenoble-mill", "machine with a [servo] section")
    m.add_argument("--axis", default="X", help="axis to model (default X)")
    m.add_argument("--step-mm", type=float, default=0.2, help="step size (default 0.2 mm)")
    m.add_argument("--speed", type=float, default=10.0, help="ramp speed in mm/s (default 10)")
    m.add_argument("--plot", metavar="FILE.png", help="save the step response, model vs simulation")
    m.set_defaults(func=_cmd_loop_model)


def _cmd_serve(args) -> int:
    from ..camlink.machine import CamMill
    from ..camlink.server import CamLinkServer, parse_listen
    from ..machine.config import load_machine
    machine = load_machine(args.machine)
    host, port = parse_listen(args.listen)
    server = CamLinkServer(CamMill(machine), host, port, log=lambda text: print(text, flush=True),
                           idle_timeout_s=args.idle_timeout)
    print(f"{machine.name}: CAM link listening on {server.address[0]}:{server.address[1]}", flush=True)
    try:
        server.serve_forever()
    finally:
        server.shutdown()
    return 0


def _cmd_send(args) -> int:
    import time
    from pathlib import Path

    from ..camlink.client import CamClient, stream_job
    from ..camlink.job import program_job
    from ..camlink.server import parse_listen
    from ..errors import LinkError
    from ..gcode import compile_program
    from ..machine.config import load_machine
    machine = load_machine(args.machine)
    path = Path(args.program)
    try:
        text = path.read_text()
    except OSError as exc:
        raise LinkError(f"{path}: cannot read the program: {exc.strerror or exc}") from None
    program = compile_program(text, machine, path.name)
    host, port = parse_listen(args.to)
    started = time.monotonic()
    with CamClient(host, port) as client:
        result = stream_job(client, program_job(machine, program.commands))
    took = time.monotonic() - started
    print(f"{path.name}: {len(program)} commands, {result.rows} rows "
          f"({result.rows * machine.tick_s:.3f} s of machine time) sent in {took:.2f} s")
    for i, pos in enumerate(result.positions, 1):
        mm = ", ".join(f"{a.name}{a.to_mm(p):.3f}" for a, p in zip(machine.axes, pos))
        print(f"  operation {i} ended at {mm} mm ({' '.join(map(str, pos))} pulses)")
    return 0


def _cmd_loop_model(args) -> int:
    from ..camlink.model import plot_comparison, ramp_comparison, step_comparison
    from ..machine.config import load_machine
    machine = load_machine(args.machine)
    axis = machine.axis(args.axis).name
    step = step_comparison(machine, axis, args.step_mm)
    print(f"{machine.name} axis {axis}: step of {args.step_mm:g} mm")
    print(f"  overshoot: model {100 * step.overshoot('model'):.1f} %, "
          f"simulation {100 * step.overshoot('sim'):.1f} %")
    for ff in (False, True):
        ramp = ramp_comparison(machine, axis, args.speed, feedforward=ff)
        em, es = ramp.following_error("model"), ramp.following_error("sim")
        label = "with feed-forward" if ff else "without feed-forward"
        print(f"  ramp {args.speed:g} mm/s {label}: peak following error model {abs(em).max():.1f}, "
              f"simulation {abs(es).max():.1f} pulses; final model {em[-1]:.1f}, simulation {es[-1]:.1f}")
    if args.plot:
        print(f"  plot: {plot_comparison(step, args.plot, f'{machine.name} {axis}: step response')}")
    return 0
