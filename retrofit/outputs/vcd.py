"""vcd://FILE.vcd — the step and direction signals as a Value Change Dump for GTKWave and PulseView.

URL grammar: ``vcd://FILE.vcd`` (relative path) or ``vcd:///abs/FILE.vcd``; no options.

One 1-bit wire per used port bit, named after the machine's pins (``X.step``, ``X.dir``,
``Z.step``, ...), and ``out0``.. for the spare outputs on a parallel port's data pins
(``[io]``), in a scope named after the machine; the level written is the level on the pin
(inversions included). Values change at the frame ticks and the file ends at the run's end
tick. The timescale is the tick itself when VCD can state it (1, 10 or 100 of a unit: a 100 us
tick gives ``100 us`` and VCD time = tick number); otherwise the largest such unit that divides
the tick (a 50 us tick gives ``10 us``, 5 units a tick).
pyvcd is imported when the file is opened; it writes the header and the first frames (the
``$dumpvars`` block), then a compiled loop writes the value changes in the same text, a chunk at
a time, so a long run streams to the file at a fraction of a microsecond per change.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from ..errors import OutputError
from ..frames import PortFrames
from ..motion._jit import compiled, kernel
from .base import Output

#: frames written per call of the compiled writer (bounds its text buffer)
_SUB_CHUNK = 1 << 16

_UNITS = (("s", 10**15), ("ms", 10**12), ("us", 10**9), ("ns", 10**6), ("ps", 10**3), ("fs", 1))


def tick_timescale(tick_us: float) -> tuple[str, int]:
    """The VCD timescale for a tick and how many of its units make one tick.

    VCD allows only 1, 10 or 100 of s, ms, us, ns, ps, fs (GTKWave drops any other multiplier),
    so a tick of 100 us is its own timescale, ("100 us", 1), and a 50 us tick is ("10 us", 5).
    """
    tick_fs = round(tick_us * 10**9)
    if tick_fs <= 0:
        raise OutputError(f"tick of {tick_us:g} us cannot be a VCD timescale")
    for unit, fs in _UNITS:
        for magnitude in (100, 10, 1):
            if tick_fs % (magnitude * fs) == 0:
                return f"{magnitude} {unit}", tick_fs // (magnitude * fs)
    raise AssertionError("unreachable: 1 fs divides every whole number of fs")


def signal_bits(machine) -> list[tuple[str, int, int | None]]:
    """(signal name, port bit, connector pin) for every used bit, in axis order."""
    out = []
    for axis in machine.axes:
        out.append((f"{axis.name}.step", axis.step_bit, axis.step_pin))
        out.append((f"{axis.name}.dir", axis.dir_bit, axis.dir_pin))
    io = machine.parts.get("io")
    if io is not None and machine.port == "db25":       # spare outputs on the port's data pins
        out.extend((f"out{k}", pin - 2, pin) for k, pin in enumerate(io.outputs))
    return out


class VcdOutput(Output):
    """vcd://FILE.vcd — step / direction wires named after the machine's pins, one VCD time unit per tick."""

    scheme = "vcd"
    grammar = "vcd://FILE.vcd"
    summary = "Value Change Dump of every step/dir pin (X.step, X.dir, ...), changes at the ticks; GTKWave, PulseView"
    options = {}

    def open(self) -> None:
        if self.is_open:
            return
        if not self.url.target:
            raise OutputError(f"{self.url.text}: a file is needed; expected {self.grammar}")
        from vcd import VCDWriter  # lazily: only a VCD output needs pyvcd
        self.path = Path(self.url.target)
        try:
            self._fh = open(self.path, "w", encoding="ascii")
        except OSError as exc:
            raise OutputError(f"{self.url.text}: cannot write {self.path}: {exc.strerror or exc}") from None
        timescale, self.units_per_tick = tick_timescale(self.machine.tick_us)
        self.writer = VCDWriter(self._fh, timescale=timescale, date="",
                                version="retrofit", comment=self._comment())
        scope = re.sub(r"[^A-Za-z0-9_]", "_", self.machine.name) or "machine"
        self.vars = [(self.writer.register_var(scope, name, "wire", size=1, init=0), 1 << bit)
                     for name, bit, _ in signal_bits(self.machine)]
        self.prev: int | None = None
        self.end_tick = 0
        self._raw = False
        self._masks = np.array([mask for _, mask in self.vars], np.int64)
        idents = [str(var.ident).encode("ascii") for var, _ in self.vars]
        width = max((len(i) for i in idents), default=1)
        self._ids = np.zeros((len(idents), width), np.uint8)
        for k, ident in enumerate(idents):
            self._ids[k, :len(ident)] = list(ident)
        self._id_len = np.array([len(i) for i in idents], np.int64)
        self._per_frame = 24 + len(idents) * (width + 2)
        super().open()

    def _comment(self) -> str:
        pins = ", ".join(f"{name} = bit {bit}" + (f" pin {pin}" if pin is not None else "")
                         for name, bit, pin in signal_bits(self.machine))
        per = "one tick" if self.units_per_tick == 1 else f"1/{self.units_per_tick} tick"
        return f"{self.machine.name}: one time unit = {per} (tick {self.machine.tick_us:g} us); {pins}"

    def write(self, frames: PortFrames) -> None:
        if len(frames.ticks) and int(frames.ticks[0]) < self.end_tick:
            raise OutputError(f"{self.url.text}: frame at tick {int(frames.ticks[0])} before tick "
                              f"{self.end_tick}; frames must come in tick order")
        ticks, values = frames.ticks, frames.values
        fast = compiled(len(ticks))
        start = 0
        while start < len(ticks) and not (self._raw and fast):   # pyvcd until it wrote past time 0
            self._write_pyvcd(int(ticks[start]), int(values[start]))
            start += 1
        for lo in range(start, len(ticks), _SUB_CHUNK):
            hi = min(lo + _SUB_CHUNK, len(ticks))
            buf = np.empty((hi - lo) * self._per_frame, np.uint8)
            n, self.prev = _vcd_changes(ticks[lo:hi], values[lo:hi], self.prev, self.units_per_tick,
                                        self._masks, self._ids, self._id_len, buf)
            self._fh.write(buf[:n].tobytes().decode("ascii"))
        self.end_tick = max(self.end_tick, int(frames.end_tick))

    def _write_pyvcd(self, tick: int, value: int) -> None:
        diff = 0xFF if self.prev is None else value ^ self.prev
        for var, mask in self.vars:
            if diff & mask:
                self.writer.change(var, tick * self.units_per_tick, 1 if value & mask else 0)
        self.prev = value
        self._raw = tick > 0
        if self._raw:
            self.writer.flush()

    def close(self) -> None:
        if not self.is_open:
            return
        try:
            self.writer.close(self.end_tick * self.units_per_tick if self.end_tick > 0 else None)
        finally:
            self._fh.close()
            super().close()


@kernel
def _vcd_changes(ticks, values, prev, scale, masks, ids, id_len, out):
    """VCD text of the frames' changes (``#time`` then ``0<id>`` / ``1<id>`` per changed wire)."""
    n = 0
    digits = np.empty(24, np.uint8)
    for i in range(ticks.shape[0]):
        value = np.int64(values[i])
        diff = value ^ prev
        prev = value
        changed = False
        for k in range(masks.shape[0]):
            if diff & masks[k]:
                changed = True
        if not changed:
            continue
        out[n] = 35                                     # '#'
        n += 1
        t = ticks[i] * scale
        nd = 0
        while True:
            digits[nd] = 48 + t % 10
            nd += 1
            t //= 10
            if t == 0:
                break
        for d in range(nd - 1, -1, -1):
            out[n] = digits[d]
            n += 1
        out[n] = 10
        n += 1
        for k in range(masks.shape[0]):
            if diff & masks[k]:
                out[n] = 49 if value & masks[k] else 48
                n += 1
                for c in range(id_len[k]):
                    out[n] = ids[k, c]
                    n += 1
                out[n] = 10
                n += 1
    return n, prev
