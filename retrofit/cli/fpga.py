"""``retrofit fpga build``: 004's FPGA pulse engine synthesised, placed and routed for an iCE40 board."""

from __future__ import annotations

from pathlib import Path

from . import machine_option


def add_commands(sub) -> None:
    f = sub.add_parser("fpga", help="the engraver's FPGA pulse engine (Amaranth HDL): build it for a board",
                       description="The pulse engine of the engraver's FPGA (docs/fpga.md). 'build' runs "
                                   "Yosys and nextpnr-ice40 (the YoWASP builds from PyPI) and prints the "
                                   "resources used and the maximum clock; the bitstream is written to the "
                                   "build folder, outside the source tree.")
    fsub = f.add_subparsers(dest="fpga_command", required=True)
    b = fsub.add_parser("build", help="synthesise, place and route; print LUTs, flip-flops, RAM blocks, fmax")
    b.add_argument("--board", default="icebreaker", help="board from amaranth-boards (known: icebreaker)")
    machine_option(b, "engraver", "machine whose axes and driver timing the engine gets")
    b.add_argument("--variant", choices=("pulse", "di"), default="pulse",
                   help="pulse: a record per pulse from the processor; di: line records, the digital "
                        "integration in the gateware (docs/fpga.md)")
    b.add_argument("--build-dir", type=Path, default=None,
                   help="where the build files and bitstream go (default: the user's cache folder)")
    b.set_defaults(func=cmd_build)


def cmd_build(args) -> int:
    from ..fpga.board import build
    from ..machine.config import load_machine
    from ..outputs.pacer_build import cache_dir
    machine = load_machine(args.machine)
    where = args.build_dir or cache_dir() / "fpga" / f"{args.board}-{machine.name}-{args.variant}"
    report = build(machine, args.board, where, args.variant)
    print("\n".join(report.lines()))
    return 0
