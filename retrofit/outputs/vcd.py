"""vcd://FILE.vcd — the step and direction signals as a Value Change Dump for GTKWave and PulseView.

URL grammar: ``vcd://FILE.vcd`` (relative path) or ``vcd:///abs/FILE.vcd``; no options.

One 1-bit wire per used port bit, named after the machine's pins (``X.step``, ``X.dir``,
``Z.step``, ...) in a scope named after the machine; the level written is the level on the pin
(inversions included). Values change at the frame ticks and the file ends at the run's end
tick. The timescale is the tick itself when VCD can state it (1, 10 or 100 of a unit: a 100 us
tick gives ``100 us`` and VCD time = tick number); otherwise the largest such unit that divides
the tick (a 50 us tick gives ``10 us``, 5 units a tick).
pyvcd is imported when the file is opened.
"""

from __future__ import annotations

import re
from pathlib import Path

from ..errors import OutputError
from ..frames import PortFrames
from .base import Output

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
        from vcd import VCDWriter              # lazily: only a VCD output needs pyvcd
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
        super().open()

    def _comment(self) -> str:
        pins = ", ".join(f"{name} = bit {bit}" + (f" pin {pin}" if pin is not None else "")
                         for name, bit, pin in signal_bits(self.machine))
        per = "one tick" if self.units_per_tick == 1 else f"1/{self.units_per_tick} tick"
        return f"{self.machine.name}: one time unit = {per} (tick {self.machine.tick_us:g} us); {pins}"

    def write(self, frames: PortFrames) -> None:
        change, prev, scale = self.writer.change, self.prev, self.units_per_tick
        for tick, value in zip(frames.ticks.tolist(), frames.values.tolist()):
            if tick < self.end_tick:
                raise OutputError(f"{self.url.text}: frame at tick {tick} before tick {self.end_tick}; "
                                  "frames must come in tick order")
            diff = 0xFF if prev is None else value ^ prev
            for var, mask in self.vars:
                if diff & mask:
                    change(var, tick * scale, 1 if value & mask else 0)
            prev = value
        self.prev = prev
        self.end_tick = max(self.end_tick, int(frames.end_tick))

    def close(self) -> None:
        if not self.is_open:
            return
        try:
            self.writer.close(self.end_tick * self.units_per_tick if self.end_tick > 0 else None)
        finally:
            self._fh.close()
            super().close()
