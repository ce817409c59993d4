"""parport://[DEVICE][?tick_us=US&every_tick=1&force=1&paced=0&engine=E] — PC parallel port, a byte a tick.

URL grammar: ``parport://`` (``/dev/parport0``) or ``parport:///dev/parportN``, with options
``tick_us`` (pace at this tick instead of the machine's ``tick_us``), ``every_tick`` (write every
tick's byte, not only changes), ``force`` (run even when the calibration says this computer
cannot hold the tick), ``paced`` (``paced=0``: the same loop as fast as possible) and ``engine``
(``auto``, ``compiled`` or ``python``: which paced loop writes, see :mod:`retrofit.outputs.pacer`;
the compiled one writes to the port's file descriptor with ioctl PPWDATA).

The data register (DB25 pins 2..9 = bits 0..7) gets the port-frame byte through pyparallel's
``setData`` (Linux ppdev), paced by :mod:`retrofit.outputs.pacer`. pyparallel is imported only
when the port is opened. The optional ``[parport]`` section of a machine file names a driver
enable on a control pin (1, 14, 16, 17) and switches on the status pins (10, 11, 12, 13, 15);
the hardware inversions of the paper's Table 1 (pins 1, 14, 17 and 11) are undone here, so
users always speak of the level on the pin.
"""

from __future__ import annotations

import sys
from dataclasses import dataclass, field

from ..errors import OutputError
from ..frames import PinMap, PortFrames
from ..machine.tomlreader import Section
from .base import Output
from .pacer import ENGINES, Calibration, Lateness, Pacer, RealtimeMode, calibrate


@dataclass(frozen=True)
class Db25Pin:
    """One DB25 pin of a PC parallel port (the lathe paper's Table 1)."""

    pin: int
    signal: str
    direction: str      # "out", "in", "in/out"
    register: str       # "data", "status", "control"
    bit: int
    inverted: bool      # the register bit is the opposite of the pin level


DB25: dict[int, Db25Pin] = {p.pin: p for p in (
    Db25Pin(1, "Strobe", "in/out", "control", 0, True),
    *(Db25Pin(n, f"Data{n - 2}", "out", "data", n - 2, False) for n in range(2, 10)),
    Db25Pin(10, "Ack", "in", "status", 6, False),
    Db25Pin(11, "Busy", "in", "status", 7, True),
    Db25Pin(12, "Paper-Out", "in", "status", 5, False),
    Db25Pin(13, "Select", "in", "status", 4, False),
    Db25Pin(14, "Linefeed", "in/out", "control", 1, True),
    Db25Pin(15, "Error", "in", "status", 3, False),
    Db25Pin(16, "Reset", "in/out", "control", 2, False),
    Db25Pin(17, "Select-Printer", "in/out", "control", 3, True),
)}
STATUS_PINS = (10, 11, 12, 13, 15)
CONTROL_PINS = (1, 14, 16, 17)
GROUND_PINS = tuple(range(18, 26))


def control_bits(pin: int, level: bool) -> tuple[int, int]:
    """(mask, register bits) that put ``level`` (True = 5 V) on a control pin."""
    p = DB25[pin]
    return 1 << p.bit, (int(level) ^ int(p.inverted)) << p.bit


def status_levels(register: int) -> dict[int, bool]:
    """Pin levels (True = 5 V) of the status pins from a raw status register."""
    return {pin: bool(register >> DB25[pin].bit & 1) ^ DB25[pin].inverted for pin in STATUS_PINS}


@dataclass(frozen=True)
class ParportSettings:
    """The ``[parport]`` section: a driver enable on a control pin and switch names on status pins."""

    enable_pin: int | None = None
    enable_level: bool = True                 # level that enables the drivers (True = 5 V)
    switches: dict[int, str] = field(default_factory=dict)   # status pin -> switch name


def read_parport_section(sec: Section, axes) -> ParportSettings:
    """Read ``[parport]``: ``enable_pin``, ``enable_level``, ``pin10`` .. ``pin15`` (switch names)."""
    enable = sec.get_int("enable_pin", 0)
    if enable and enable not in CONTROL_PINS:
        raise sec.error("enable_pin", f"must be a control pin: one of {', '.join(map(str, CONTROL_PINS))} "
                                      "(or 0 for none)")
    level = sec.get_str("enable_level", "high", choices=("high", "low"))
    switches = {}
    for pin in STATUS_PINS:
        name = sec.get_str(f"pin{pin}", "")
        if name:
            switches[pin] = name
    if len(set(switches.values())) != len(switches):
        raise sec.error(f"pin{next(iter(switches))}", "each switch needs its own name")
    sec.finish()
    return ParportSettings(enable or None, level == "high", switches)


class PpdevPort:
    """The real port through pyparallel (Linux ppdev): data writes, control frobs, status reads."""

    def __init__(self, device: str):
        import parallel  # lazily: only a real port needs pyparallel
        self._port = parallel.Parallel(port=device)
        self._set_data = self._port.setData

    @property
    def fd(self) -> int | None:
        """The open ppdev file descriptor, for the compiled writer (None if pyparallel hides it)."""
        fd = getattr(self._port, "_fd", None)
        return fd if isinstance(fd, int) else None

    def write(self, tick: int, value: int) -> None:
        self._set_data(value)

    def frob_control(self, mask: int, bits: int) -> None:
        self._port.PPFCONTROL(mask, bits)

    def read_status(self) -> int:
        return self._port.PPRSTATUS()

    def hold_until(self, end_tick: int) -> None:
        """The port's latch holds the last byte by itself."""

    def close(self) -> None:
        del self._set_data
        self._port = None                     # pyparallel releases the port and closes it

    discard = close                           # a port that failed to start: just let it go


def open_error(url: str, device: str, exc: BaseException) -> OutputError:
    """The one-line message for a port that will not open, with what to check."""
    reason = getattr(exc, "strerror", None) or str(exc)
    if isinstance(exc, ImportError):
        return OutputError(f"{url}: pyparallel is not installed ({reason}); pip install pyparallel")
    return OutputError(
        f"{url}: cannot open {device} ({reason}); check: the ppdev module is loaded (sudo modprobe ppdev), "
        f"the lp module is not holding the port (sudo rmmod lp), and you may use {device} "
        "(permission: group lp, sudo usermod -aG lp $USER, then log in again)")


class ParportOutput(Output):
    """parport://[DEVICE][?tick_us=US&every_tick=1&force=1&paced=0] — one byte a tick on a DB25 port."""

    scheme = "parport"
    grammar = "parport://[/dev/parportN][?tick_us=US&every_tick=1&force=1&paced=0&engine=auto|compiled|python]"
    summary = "PC parallel port (DB25, Linux ppdev via pyparallel), paced in real time; default /dev/parport0"
    options = {"tick_us": (float, 0.0), "every_tick": (bool, False), "force": (bool, False),
               "paced": (bool, True), "engine": (str, "auto")}
    default_device = "/dev/parport0"

    def __init__(self, url, machine):
        super().__init__(url, machine)
        if machine.port != "db25":
            raise OutputError(f"{url.text}: the machine {machine.name} is wired to port = {machine.port!r}; "
                              "a parallel port output needs [machine] port = \"db25\"")
        tick_us = self.opts["tick_us"] or machine.tick_us
        if not tick_us > 0:
            raise OutputError(f"{url.text}: tick_us must be > 0; expected {self.grammar}")
        self.tick_ns = round(tick_us * 1000)
        if self.opts["engine"] not in ENGINES:
            raise OutputError(f"{url.text}: engine={self.opts['engine']!r}: expected one of "
                              f"{', '.join(ENGINES)}; expected {self.grammar}")
        self.settings: ParportSettings = machine.parts.get("parport") or ParportSettings()
        self.calibration: Calibration | None = None
        self.timing: Lateness | None = None
        self.realtime = RealtimeMode()
        self.quiet = False                     # True: do not print the timing lines on close
        self.stopped = False                   # safe_stop() ran: the run ended early

    @property
    def device(self) -> str:
        return self.url.target or self.default_device

    def _open_port(self):
        try:
            return PpdevPort(self.device)
        except (OSError, ImportError) as exc:
            raise open_error(self.url.text, self.device, exc) from None

    def open(self) -> None:
        if self.is_open:
            return
        self.port = self._open_port()
        try:
            self._set_enable(True)
            self.pacer = self._make_pacer()
        except BaseException:
            self.realtime.leave()
            self.port.discard()
            raise
        super().open()

    def _engine(self) -> str:
        """The engine asked for; Python when the port offers the compiled writer no target."""
        memory = getattr(self.port, "memory", False)
        if self.opts["engine"] != "python" and not memory and getattr(self.port, "fd", None) is None:
            if self.opts["engine"] == "compiled":
                raise OutputError(f"{self.url.text}: engine=compiled needs the port's file descriptor, "
                                  "which this pyparallel does not expose; use engine=python")
            return "python"
        return self.opts["engine"]

    def _make_pacer(self) -> Pacer:
        """Pacer for the run; calibrates first and refuses a tick this computer cannot hold."""
        engine = self._engine()
        if not self.opts["paced"]:
            return Pacer(self.tick_ns, every_tick=self.opts["every_tick"], paced=False, engine=engine)
        self.realtime.enter()
        self.calibration = calibrate(self.tick_ns, self.realtime, 1 if self.opts["every_tick"] else 2, engine)
        if not self.calibration.holds and not self.opts["force"]:
            raise OutputError(self.calibration.refusal(self.url.text))
        return Pacer(self.tick_ns, every_tick=self.opts["every_tick"], spin_ns=self.calibration.spin_ns,
                     engine=engine)

    def write(self, frames: PortFrames) -> None:
        self.pacer.play(frames, self.port.write, getattr(self.port, "fd", None))

    def safe_stop(self) -> None:
        """Stop now: the drivers' enable off, then every data pin at rest (step lines inactive,
        directions and spare outputs low) at once; ``close()`` then finishes nothing scheduled."""
        if not self.is_open or self.stopped:
            return
        self.stopped = True
        try:
            self._set_enable(False)
        finally:
            self.port.write(getattr(self.port, "next_tick", 0), PinMap(self.machine).invert)

    def close(self) -> None:
        if not self.is_open:
            return
        try:
            self.timing = self.pacer.lateness() if self.stopped else self.pacer.finish()
            if not self.stopped:
                self.port.hold_until(self.pacer.end_tick)
            self._set_enable(False)
        finally:
            self.realtime.leave()
            self.port.close()
            super().close()
        if not self.quiet and self.timing.writes:
            for line in self.report_lines():
                print(f"{self.url.text}: {line}", file=sys.stderr)

    def abort(self) -> None:
        """:meth:`safe_stop`, then close at once: the port's latch holds the byte at rest."""
        if not self.is_open:
            return
        try:
            self.safe_stop()
        finally:
            self.realtime.leave()
            self.port.close()
            Output.close(self)

    def report_lines(self) -> list[str]:
        """Calibration, real-time mode and lateness, one line each (what was measured)."""
        lines = [self.calibration.line()] if self.calibration else []
        if self.opts["paced"]:
            lines.append(self.realtime.line())
            if getattr(self, "pacer", None) is not None:
                lines.append(self.pacer.engine_note)
        if self.timing:
            lines.append(self.timing.line())
        return lines

    def _set_enable(self, on: bool) -> None:
        pin = self.settings.enable_pin
        if pin:
            self.port.frob_control(*control_bits(pin, self.settings.enable_level if on
                                                 else not self.settings.enable_level))

    def read_inputs(self) -> dict[int, bool]:
        """Levels of the status pins 10, 11, 12, 13, 15 (True = 5 V), Busy's inversion undone."""
        if not self.is_open:
            raise OutputError(f"{self.url.text}: open the port before reading its inputs")
        return status_levels(self.port.read_status())

    def read_switches(self) -> dict[str, bool]:
        """The named switches of the machine's ``[parport]`` section: name -> pin level high."""
        levels = self.read_inputs()
        return {name: levels[pin] for pin, name in self.settings.switches.items()}

    def observe(self) -> dict:
        return {"timing": self.timing, "calibration": self.calibration, "realtime": list(self.realtime.notes)}
