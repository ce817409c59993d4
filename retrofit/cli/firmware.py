"""Sub-command ``retrofit firmware``: the compiled firmware in simavr (``sim``), its size (``size``),
the rates it keeps (``limits``)."""

from __future__ import annotations

import json
import subprocess
import sys

from . import machine_option


def add_commands(sub) -> None:
    """Add ``firmware sim`` and ``firmware size`` to the ``retrofit`` command line."""
    fw = sub.add_parser("firmware", help="the ATmega2560 firmware: run it in simavr wired to a "
                                         "simulated machine, or print its flash and RAM use")
    fsub = fw.add_subparsers(dest="firmware_command", required=True)
    s = fsub.add_parser("sim", help="run firmware/ in simavr, its USART on a TCP port, its pins "
                                    "wired to the simulated machine",
                        description="Build the firmware for the machine and run it on simavr's "
                                    "cycle-exact ATmega2560: step/dir pins decoded by the driver "
                                    "model of sim://, switches and the spindle encoder fed back. "
                                    "Serves until interrupted (or until the client hangs up with "
                                    "--once), then prints a report like sim://'s.")
    machine_option(s, "mitic-lathe")
    s.add_argument("--listen", metavar="HOST:PORT", required=True,
                   help="serve the USART on a TCP port (port 0 picks a free one; it is printed)")
    s.add_argument("--vcd", metavar="FILE", help="write the output ports as VCD")
    s.add_argument("--spindle-rpm", type=float, default=0.0,
                   help="turn the spindle encoder at this fixed speed (ICLK on D21, SIND on D20); "
                        "default: the firmware's own spindle outputs (M3/M4/M5, S) drive the "
                        "spindle of sim:// (ramp, load noise of [spindle.sim]), whose encoder "
                        "feeds it back")
    s.add_argument("--spindle-stalled", action="store_true",
                   help="the spindle is jammed and never turns (as [spindle.sim] stalled = true)")
    s.add_argument("--tool", metavar="Tn|LENGTH,DIAMETER",
                   help="the tool in the spindle for the tool setter's beam (a machine with "
                        "[setter]): Tn, a tool of [tools.sim], with the magazine moving the tools "
                        "as the carousel changes them (T0: empty); or a fixed tool, LENGTH,DIAMETER "
                        "in mm; without it nothing breaks the beam")
    s.add_argument("--start", metavar="AXIS=STEPS", action="append", default=[],
                   help="where a carriage starts, in steps (repeatable); default 0")
    s.add_argument("--speed", type=float, default=1.0,
                   help="AVR time per wall time at most (0: as fast as simavr goes); default 1")
    s.add_argument("--once", action="store_true", help="stop when the first client hangs up")
    s.add_argument("--boot-ms", type=float, default=0.0,
                   help="start the firmware N ms late, dropping the bytes sent meanwhile, as the "
                        "Mega's bootloader does after the port opens (DTR reset); default 0")
    s.add_argument("--json", action="store_true", help="print the report as JSON")
    s.set_defaults(func=_cmd_sim)
    z = fsub.add_parser("size", help="flash and RAM of the firmware built for a machine")
    z.add_argument("--machine", action="append", default=[],
                   help="machine name (repeatable); default: every machine the firmware supports")
    z.set_defaults(func=_cmd_size)
    lim = fsub.add_parser("limits", help="the step and encoder rates this firmware build keeps "
                                         "(firmware/limits.toml, measured by bench/firmware_limits.py)")
    lim.add_argument("--machine", action="append", default=[],
                     help="also check a machine file's top rates (repeatable); default: the shipped ones")
    lim.set_defaults(func=_cmd_limits)


def _start_steps(specs: list[str], machine) -> dict[str, int]:
    from ..errors import ConfigError
    out = {}
    for spec in specs:
        name, _, value = spec.partition("=")
        try:
            out[machine.axis(name).name] = int(value)
        except ValueError:
            raise ConfigError(f"--start {spec}: expected AXIS=STEPS with whole steps, e.g. X=-1200") from None
    return out


def _tool(spec: str | None, machine) -> tuple[float, float] | int | None:
    from ..errors import ConfigError
    if spec is None:
        return None
    if "setter" not in machine.parts:
        raise ConfigError(f"--tool {spec}: machine {machine.name} has no tool setter ([setter] "
                          "section); --tool is for a machine with one")
    if spec[:1] in "Tt":
        from ..atc.settings import tools_of
        if "atc" not in machine.parts:
            raise ConfigError(f"--tool {spec}: machine {machine.name} has no tool changer ([atc]); "
                              "give the tool as LENGTH,DIAMETER in mm")
        known = sorted(tools_of(machine).sim)
        number = spec[1:]
        if not (number.isascii() and number.isdigit()) or (int(number) and int(number) not in known):
            raise ConfigError(f"--tool {spec}: expected T0 (empty) or a tool of [tools.sim] of "
                              f"{machine.name}: {', '.join(f'T{t}' for t in known) or 'none'}")
        return int(number)
    try:
        length, diameter = (float(v) for v in spec.split(","))
    except ValueError:
        raise ConfigError(f"--tool {spec}: expected LENGTH,DIAMETER in mm, e.g. 20,3") from None
    if not (length > 0 and diameter > 0):
        raise ConfigError(f"--tool {spec}: length and diameter must be above 0 mm")
    return length, diameter


def _cmd_sim(args) -> int:
    from ..firmware.limits import check_encoder
    from ..firmware.sim import Harness, build, report
    from ..machine.config import load_machine
    machine = load_machine(args.machine)
    check_encoder(machine)                       # an encoder faster than the firmware follows
    start = _start_steps(args.start, machine)
    tool = _tool(args.tool, machine)
    elf = build(machine.name)
    harness = Harness(elf, machine, listen=args.listen, start_steps=start, vcd=args.vcd,
                      spindle_rpm=args.spindle_rpm, speed=args.speed, stats=True,
                      boot_ms=args.boot_ms, tool=tool, spindle_stalled=args.spindle_stalled)
    if args.once:
        harness.args.append("--once")
    harness.start()
    print(f"{machine.name}: firmware in simavr listening on {harness.address} "
          f"(host: --output serial+socket://{harness.address})", flush=True)
    try:
        harness.proc.wait()
    except KeyboardInterrupt:
        pass
    log = harness.stop(0.0)
    result = report(log, machine, start)
    result["interrupts"] = log.stats
    if log.spindle_tool is not None:
        result["spindle_tool"] = log.spindle_tool              # the magazine's, at the end
    if args.json:
        print(json.dumps(result, indent=2))
    else:
        _print_report(result)
    return 0


def _print_report(r: dict) -> None:
    print(f"{r['machine']}: {r['cycles']} cycles ({r['duration_s']:.3f} s of AVR time), "
          f"{r['bytes_sent']} bytes sent")
    print("  carriage mm: " + ", ".join(f"{a} {v:.3f}" for a, v in r["carriage_mm"].items()))
    print("  motor steps: " + ", ".join(f"{a} {v}" for a, v in r["motor_steps"].items()))
    if "spindle_tool" in r:
        print(f"  spindle: {'T%d' % r['spindle_tool'] if r['spindle_tool'] else 'empty'}")
    print(f"  violations: {len(r['violations'])}")
    for v in r["violations"][:10]:
        print(f"    cycle {v['cycle']} {v['axis']} {v['kind']}: {v['detail']}")


def firmware_size(machine_name: str) -> dict[str, int]:
    """Flash (text + data) and RAM (data + bss) bytes of the firmware for ``machine_name``."""
    from ..firmware.sim import build
    elf = build(machine_name)
    out = subprocess.run(["avr-size", "-A", str(elf)], capture_output=True, text=True, check=True).stdout
    sizes = {}
    for line in out.splitlines():
        words = line.split()
        if len(words) >= 2 and words[0].startswith(".") and words[1].isdigit():
            sizes[words[0]] = int(words[1])
    text, data, bss = sizes.get(".text", 0), sizes.get(".data", 0), sizes.get(".bss", 0)
    return {"flash": text + data, "ram": data + bss, "flash_of": 262144 - 8192, "ram_of": 8192}


def _cmd_size(args) -> int:
    from ..firmware.sim import supported_machines
    names = args.machine or supported_machines()
    for name in names:
        s = firmware_size(name)
        print(f"{name}: flash {s['flash']} of {s['flash_of']} bytes ({100 * s['flash'] / s['flash_of']:.1f} %), "
              f"RAM {s['ram']} of {s['ram_of']} bytes ({100 * s['ram'] / s['ram_of']:.1f} %)")
    sys.stdout.flush()
    return 0


def _cmd_limits(args) -> int:
    from ..firmware import limits as fl
    from ..firmware.sim import supported_machines
    from ..machine.config import load_machine
    limits = fl.load()
    current = limits.identity == fl.build_identity()
    print(f"{fl.TABLE}: build {limits.identity[:16]} "
          + ("(this tree's firmware)" if current else
             f"(STALE: this tree's firmware is {fl.build_identity()[:16]}; run python3 {fl.WRITER})"))
    print(f"  {'case':<24}{'measured':>10}{'planned':>10}   (steps/s of the base axis; margin {limits.margin:g})")
    for case, rate in limits.steps.items():
        print(f"  {case:<24}{limits.measured[case]:>10.0f}{rate:>10.0f}")
    print(f"  {'encoder':<24}{limits.measured['encoder_counts_s']:>10.0f}{limits.encoder_counts_s:>10.0f}"
          "   (counts/s)")
    for name in args.machine or supported_machines():
        print("\n".join(fl.machine_lines(load_machine(name), limits)))
    return 0 if current else 1
