"""The instruction set in the middle: the 14 motion commands of 002, plus spindle, coolant, probing.

Every front end (G-code, CAM link, tool changer) compiles to these objects and every output or
link consumes them. Each is a frozen dataclass whose ``str()`` is its text form and
:func:`parse_command` gives the same object back::

    >>> parse_command("PMOV X12.5 Z-3")
    PMov(axes=(('X', 12.5), ('Z', -3.0)))
    >>> str(parse_command("PMOV X12.5 Z-3"))
    'PMOV X12.5 Z-3'

Units in the text form and the objects: positions mm, feeds mm/min (mm per spindle revolution
while ISTP is the step source), dwell seconds, spindle rpm. Inside the controller: steps, ticks.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from typing import ClassVar

from .errors import RetrofitError


class CommandError(RetrofitError, ValueError):
    """A command's text form is malformed or its values are out of range."""


def _num(value: float) -> str:
    """Shortest text that reads back to the same float ('12.5', '-3', '0.1')."""
    if float(value).is_integer() and abs(value) < 1e15:
        return str(int(value))
    return repr(float(value))


@dataclass(frozen=True)
class Command:
    mnemonic: ClassVar[str] = ""
    immediate: ClassVar[bool] = False      # STOP, RDPS, RDST: run at once, ahead of the queue
    motion: ClassVar[bool] = False         # goes through prepare/execute
    host: ClassVar[bool] = False           # TOOL, PAUS: handled by the run on the host, never sent to a device
    linked: ClassVar[bool] = True          # the serial link carries it (DOUT, WAIT: not yet)

    def __str__(self) -> str:
        return self.mnemonic


@dataclass(frozen=True)
class _AxesCommand(Command):
    """A command with axis words: ``axes`` is ((name, mm), ...) in the order given."""

    axes: tuple[tuple[str, float], ...] = ()

    def __str__(self) -> str:
        return " ".join([self.mnemonic] + [f"{n}{_num(v)}" for n, v in self.axes])

    def position(self) -> dict[str, float]:
        return dict(self.axes)


@dataclass(frozen=True)
class _FeedCommand(Command):
    feed: float = 0.0      # mm/min (mm/rev under ISTP)

    def __str__(self) -> str:
        return f"{self.mnemonic} F{_num(self.feed)}"


@dataclass(frozen=True)
class Init(Command):
    """Defaults for position and feedrates, clear all queues, state ready."""
    mnemonic: ClassVar[str] = "INIT"


@dataclass(frozen=True)
class FMov(_AxesCommand):
    """Fast move to a position at the fast feedrate (G00)."""
    mnemonic: ClassVar[str] = "FMOV"
    motion: ClassVar[bool] = True


@dataclass(frozen=True)
class PMov(_AxesCommand):
    """Programmed move at the machining feedrate (G01, arc chords)."""
    mnemonic: ClassVar[str] = "PMOV"
    motion: ClassVar[bool] = True


@dataclass(frozen=True)
class ZMov(Command):
    """Home the named axes (all, in the machine's homing order, when none is named)."""
    mnemonic: ClassVar[str] = "ZMOV"
    motion: ClassVar[bool] = True
    names: tuple[str, ...] = ()

    def __str__(self) -> str:
        return " ".join((self.mnemonic,) + self.names)


@dataclass(frozen=True)
class Stop(Command):
    """Abrupt stop (operator)."""
    mnemonic: ClassVar[str] = "STOP"
    immediate: ClassVar[bool] = True


@dataclass(frozen=True)
class FFdr(_FeedCommand):
    """Fast feedrate for FMOV / ZMOV; takes effect at once, even mid-move."""
    mnemonic: ClassVar[str] = "FFDR"


@dataclass(frozen=True)
class MFdr(_FeedCommand):
    """Machining feedrate for PMOV; takes effect at once (operator override)."""
    mnemonic: ClassVar[str] = "MFDR"


@dataclass(frozen=True)
class PFdr(_FeedCommand):
    """Program feedrate; takes effect when the next motion command is fetched."""
    mnemonic: ClassVar[str] = "PFDR"


@dataclass(frozen=True)
class Dely(Command):
    """Dwell for ``seconds`` (G04)."""
    mnemonic: ClassVar[str] = "DELY"
    motion: ClassVar[bool] = True
    seconds: float = 0.0

    def __str__(self) -> str:
        return f"{self.mnemonic} P{_num(self.seconds)}"


@dataclass(frozen=True)
class CStp(Command):
    """The tick clock is the step source (feed in mm/min)."""
    mnemonic: ClassVar[str] = "CSTP"


@dataclass(frozen=True)
class IStp(Command):
    """The spindle indexer is the step source (feed in mm per revolution: threads)."""
    mnemonic: ClassVar[str] = "ISTP"


@dataclass(frozen=True)
class Pstn(_AxesCommand):
    """Set the actual position of the named axes (coordinate set-up, G92)."""
    mnemonic: ClassVar[str] = "PSTN"


@dataclass(frozen=True)
class Rdps(Command):
    """Read the actual position."""
    mnemonic: ClassVar[str] = "RDPS"
    immediate: ClassVar[bool] = True


@dataclass(frozen=True)
class Rdst(Command):
    """Read the status flags."""
    mnemonic: ClassVar[str] = "RDST"
    immediate: ClassVar[bool] = True


@dataclass(frozen=True)
class Spin(Command):
    """Spindle: ``rpm`` and direction +1 (M3), -1 (M4) or 0 (M5, stopped). Not one of 002's 14."""
    mnemonic: ClassVar[str] = "SPIN"
    rpm: float = 0.0
    direction: int = 0

    def __str__(self) -> str:
        return f"{self.mnemonic} S{_num(self.rpm)} D{self.direction}"


@dataclass(frozen=True)
class Cool(Command):
    """Coolant: 0 off (M9), 7 mist (M7), 8 flood (M8). Not one of 002's 14."""
    mnemonic: ClassVar[str] = "COOL"
    mode: int = 0

    def __str__(self) -> str:
        return f"{self.mnemonic} M{self.mode}"


@dataclass(frozen=True)
class Prob(_AxesCommand):
    """Probing move (G38.2-G38.5): a line to ``axes`` at the machining feed (as PMOV) that stops
    at the first step after which the probe input closes (``away``, text ``PROB AWAY X1 Z-40``:
    opens); RDST's PROBED says it stopped on the probe (docs/protocol.md). Not one of 002's 14."""
    mnemonic: ClassVar[str] = "PROB"
    motion: ClassVar[bool] = True
    away: bool = False

    def __str__(self) -> str:
        words = [self.mnemonic] + (["AWAY"] if self.away else [])
        return " ".join(words + [f"{n}{_num(v)}" for n, v in self.axes])

    @classmethod
    def from_words(cls, words: list[str]) -> Prob:
        """``["AWAY", "X1", "Z-40"]`` -> Prob; AWAY may come once, first."""
        away = words[:1] == ["AWAY"]
        rest = words[1:] if away else words
        if "AWAY" in rest:
            raise CommandError("PROB: AWAY comes once, before the axis words, e.g. PROB AWAY X1 Z-40")
        return cls(tuple(_axis_words(cls.mnemonic, rest)), away)


@dataclass(frozen=True)
class Tool(Command):
    """Put tool ``number`` in the spindle (T<n> M6; T0 empties it). Not one of 002's 14.

    Front ends emit it; the run hands it to the machine's tool changer, whose sequence of
    commands takes its place, or, on a machine without one, pauses for a manual change.
    """
    mnemonic: ClassVar[str] = "TOOL"
    host: ClassVar[bool] = True
    number: int = 0

    def __str__(self) -> str:
        return f"{self.mnemonic} T{self.number}"


#: why a program pauses: PAUS M0 (program pause), M1 (optional stop), M60 (pallet shuttle), M6 (manual
#: tool change), M19 (G87: the operator orients the stopped spindle)
PAUSE_REASONS = {0: "program pause (M0)", 1: "optional stop (M1)", 60: "pallet change pause (M60)",
                 19: "orient the spindle by hand (G87 back boring)",
                 6: "manual tool change (M6)"}


@dataclass(frozen=True)
class Paus(Command):
    """Stop after the moves before it and wait for the operator to resume. Not one of 002's 14.

    ``reason`` is the M code that asked for it (:data:`PAUSE_REASONS`); on ``sim://`` the pause
    is recorded in the report and the run goes on.
    """
    mnemonic: ClassVar[str] = "PAUS"
    host: ClassVar[bool] = True
    reason: int = 0

    def __str__(self) -> str:
        return f"{self.mnemonic} M{self.reason}"


#: DOUT's M codes: (level, synchronised with the next move) as LinuxCNC's M62-M65
DOUT_CODES = {62: (1, True), 63: (0, True), 64: (1, False), 65: (0, False)}


@dataclass(frozen=True)
class Dout(Command):
    """Digital output ``output`` (``[io]`` out<n>) on or off: ``code`` 62/63 as the next move
    starts, 64/65 at once (LinuxCNC's M62-M65). Not one of 002's 14; the link does not carry it."""
    mnemonic: ClassVar[str] = "DOUT"
    linked: ClassVar[bool] = False
    code: int = 64
    output: int = 0

    def __str__(self) -> str:
        return f"{self.mnemonic} M{self.code} P{self.output}"

    @property
    def level(self) -> int:
        return DOUT_CODES[self.code][0]

    @property
    def synced(self) -> bool:
        return DOUT_CODES[self.code][1]

    @classmethod
    def from_values(cls, values: dict) -> Dout:
        code, output = values["M"], values["P"]
        if code not in DOUT_CODES:
            raise CommandError(f"DOUT M{_num(code)}: the code is 62, 63, 64 or 65")
        if not output.is_integer() or not 0 <= output < 64:
            raise CommandError(f"DOUT P{_num(output)}: the output is a whole number from 0 to 63")
        return cls(int(code), int(output))


@dataclass(frozen=True)
class Wait(Command):
    """Wait on digital input ``input`` (``[io]`` in<n>), LinuxCNC's M66 P L Q: ``mode`` 0 reads
    it at once, 1/2 wait for a rising/falling edge, 3/4 for high/low, at most ``timeout`` s.
    The moves before it end first. Not one of 002's 14; the link does not carry it."""
    mnemonic: ClassVar[str] = "WAIT"
    linked: ClassVar[bool] = False
    motion: ClassVar[bool] = True
    input: int = 0
    mode: int = 0
    timeout: float = 0.0

    def __str__(self) -> str:
        return f"{self.mnemonic} P{self.input} L{self.mode} Q{_num(self.timeout)}"

    @classmethod
    def from_values(cls, values: dict) -> Wait:
        number, mode, timeout = values["P"], values["L"], values["Q"]
        if not number.is_integer() or not 0 <= number < 64:
            raise CommandError(f"WAIT P{_num(number)}: the input is a whole number from 0 to 63")
        if mode not in (0.0, 1.0, 2.0, 3.0, 4.0):
            raise CommandError(f"WAIT L{_num(mode)}: the mode is 0, 1, 2, 3 or 4")
        if not 0.0 <= timeout <= 86400.0 or (mode and not timeout > 0.0):
            raise CommandError(f"WAIT Q{_num(timeout)}: the timeout is from 0 to 86400 s, above 0 "
                               f"when L is 1-4")
        return cls(int(number), int(mode), timeout)


#: every command class by mnemonic
COMMANDS: dict[str, type[Command]] = {c.mnemonic: c for c in (
    Init, FMov, ZMov, PMov, Stop, FFdr, MFdr, PFdr, Dely, CStp, IStp, Pstn, Rdps, Rdst, Spin, Cool,
    Prob, Tool, Paus, Dout, Wait)}
#: the commands a device executes (what the serial link carries): all but the host's own and
#: those the link does not carry yet
DEVICE_COMMANDS: dict[str, type[Command]] = {m: c for m, c in COMMANDS.items()
                                             if not c.host and c.linked}

_WORD = re.compile(r"([A-Z])([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)$")


def parse_command(text: str) -> Command:
    """The command object of a text form such as ``"PMOV X12.5 Z-3"`` (case-insensitive)."""
    parts = text.strip().upper().split()
    if not parts:
        raise CommandError("empty command; expected a mnemonic such as PMOV X12.5 Z-3")
    head, words = parts[0], parts[1:]
    cls = COMMANDS.get(head)
    if cls is None:
        raise CommandError(f"unknown command {head!r}; known: {', '.join(COMMANDS)}")
    if cls is Prob:
        return Prob.from_words(words)
    if issubclass(cls, _AxesCommand):
        return cls(tuple(_axis_words(head, words)))
    if cls is ZMov:
        bad = [w for w in words if not re.fullmatch(r"[A-Z]", w)]
        if bad:
            raise CommandError(f"ZMOV {bad[0]!r}: expected axis letters only, e.g. ZMOV X Z")
        return ZMov(tuple(words))
    values = dict(_words(head, words))
    expected = {FFdr: "F", MFdr: "F", PFdr: "F", Dely: "P", Spin: "SD", Cool: "M", Tool: "T",
                Paus: "M", Dout: "MP", Wait: "PLQ"}.get(cls, "")
    extra = set(values) - set(expected)
    missing = set(expected) - set(values)
    if extra or missing:
        form = " ".join(f"{c}<number>" for c in expected) or "no arguments"
        raise CommandError(f"{text.strip()!r}: expected {head} {form}".rstrip())
    if hasattr(cls, "from_values"):
        return cls.from_values(values)
    if cls in (FFdr, MFdr, PFdr):
        return cls(_check(head, "F", values["F"], minval=0.0))
    if cls is Dely:
        return Dely(_check(head, "P", values["P"], minval=0.0))
    if cls is Spin:
        direction = values["D"]
        if direction not in (-1.0, 0.0, 1.0):
            raise CommandError(f"SPIN D{_num(direction)}: direction must be -1, 0 or 1")
        return Spin(_check(head, "S", values["S"], minval=0.0), int(direction))
    if cls is Cool:
        if values["M"] not in (0.0, 7.0, 8.0):
            raise CommandError(f"COOL M{_num(values['M'])}: mode must be 0, 7 or 8")
        return Cool(int(values["M"]))
    if cls is Tool:
        number = values["T"]
        if not number.is_integer() or not 0 <= number <= 99999:
            raise CommandError(f"TOOL T{_num(number)}: tool number must be a whole number from 0 to 99999")
        return Tool(int(number))
    if cls is Paus:
        if values["M"] not in PAUSE_REASONS:
            raise CommandError(f"PAUS M{_num(values['M'])}: reason must be one of "
                               f"{', '.join(str(k) for k in PAUSE_REASONS)}")
        return Paus(int(values["M"]))
    return cls()


def _words(head: str, words: list[str]):
    for word in words:
        m = _WORD.match(word)
        if not m:
            raise CommandError(f"{head}: bad word {word!r}; expected a letter and a number, e.g. X12.5")
        yield m.group(1), float(m.group(2))


def _axis_words(head: str, words: list[str]):
    seen = set()
    for name, value in _words(head, words):
        if name in seen:
            raise CommandError(f"{head}: axis {name} given twice")
        seen.add(name)
        yield name, _check(head, name, value)


def _check(head: str, letter: str, value: float, minval: float | None = None) -> float:
    if not math.isfinite(value):
        raise CommandError(f"{head} {letter}: {value} is not a finite number")
    if minval is not None and value < minval:
        raise CommandError(f"{head} {letter}{_num(value)}: must be >= {_num(minval)}")
    return value
