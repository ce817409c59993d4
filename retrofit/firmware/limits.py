"""The rates the firmware keeps (firmware/limits.toml, measured in simavr), and a firmware run
planned within them: feeds clamped, over-rate encoders and threads refused up front.

``firmware/limits.toml`` is written by ``bench/firmware_limits.py`` and names the build it was
measured on (:func:`build_identity`: a hash of the firmware's sources); a test holds the two
equal, so a change to the firmware's step engine asks for the table to be measured again.

A run whose outputs include a command-level output (``serial://``: the firmware on the link) goes
through :func:`plan_within_limits` before it is planned: every move's feed is lowered so that its
base axis (the axis with the most steps) steps no faster than the table's rate for its number of
moving axes (steps all equal, or Bresenham ratios), as LinuxCNC clamps a move to the machine's
maximum velocity; the run's summary names the lines clamped. The fast feed (FFDR) acts on every
queued move at once on the firmware, so rapids take one fast feed, the lowest any of them needs.
"""

from __future__ import annotations

import dataclasses
import hashlib
import math
import tomllib
from pathlib import Path

from ..commands import CStp, FFdr, FMov, Init, IStp, PFdr, PMov, Prob, Pstn, Spin, ZMov
from ..errors import ConfigError, GcodeError
from ..machine.config import Machine

ROOT = Path(__file__).resolve().parents[2]
FIRMWARE = ROOT / "firmware"
TABLE = FIRMWARE / "limits.toml"
WRITER = "bench/firmware_limits.py"


def build_identity(source: Path = FIRMWARE) -> str:
    """sha256 of the firmware's sources (``*.c`` and ``*.h`` of ``firmware/``, not the machine
    headers nor the harness): what the step engine is made of."""
    digest = hashlib.sha256()
    for path in sorted([*source.glob("*.c"), *source.glob("*.h")]):
        digest.update(path.name.encode() + b"\0" + path.read_bytes() + b"\0")
    return digest.hexdigest()


def _limit(rate: float, margin: float) -> float:
    return math.floor(rate * margin / 500.0) * 500.0


def table_text(measured: dict[str, float], encoder_counts_s: float, margin: float) -> str:
    """The text of firmware/limits.toml for these measurements (steps/s of the base axis)."""
    lines = [f"# firmware/limits.toml - the rates the firmware keeps, measured in simavr by {WRITER}.",
             f"# Written by {WRITER}: never edit it; measure again after any change to firmware/.",
             "[build]", f'identity = "{build_identity()}"   # sha256 of firmware/*.c and *.h',
             f"margin = {margin:g}   # the share of the measured rate the host plans with", "",
             "[measured]   # highest clean rate: steps/s of the base axis; counts/s of the encoder"]
    lines += [f'"{case}" = {rate:.1f}' for case, rate in measured.items()]
    lines += [f"encoder_counts_s = {encoder_counts_s:.1f}", "",
              "[limit]   # what the host plans with: measured x margin, rounded down to 500"]
    lines += [f'"{case}" = {_limit(rate, margin):.1f}' for case, rate in measured.items()]
    lines += [f"encoder_counts_s = {_limit(encoder_counts_s, margin):.1f}", ""]
    return "\n".join(lines)


@dataclasses.dataclass(frozen=True)
class Limits:
    """The planned rates of one build: ``steps`` by case ("3", "3:bresenham", ...)."""

    identity: str
    margin: float
    steps: dict[str, float]
    encoder_counts_s: float
    measured: dict[str, float]

    def step_rate(self, moving: int, equal: bool, long_pulse: bool = False) -> tuple[float, str]:
        """(steps/s of the base axis, in words) for a move of ``moving`` axes; ``long_pulse``: a
        machine whose pulse is over 3 us (compare B's interrupt ends it): the long-pulse cap too."""
        short = {k: r for k, r in self.steps.items() if not k.endswith(":long-pulse")}
        if equal and str(moving) in short:
            rate, words = short[str(moving)], f"on {moving} axis" + ("es" if moving > 1 else "")
        else:
            cases = [r for k, r in short.items() if k.split(":")[0] == str(moving) and ":" in k]
            rate, words = min(cases) if cases else min(short.values()), f"on {moving} axes in Bresenham ratios"
        capped = [r for k, r in self.steps.items() if k.endswith(":long-pulse")]
        if long_pulse and capped and min(capped) < rate:
            return min(capped), words + " with pulses over 3 us"
        return rate, words


def load(path: Path = TABLE) -> Limits:
    """The recorded table; ConfigError when it is missing or not the table the bench writes."""
    try:
        data = tomllib.loads(path.read_text())
        steps = {k: float(v) for k, v in data["limit"].items() if k != "encoder_counts_s"}
        return Limits(data["build"]["identity"], float(data["build"]["margin"]), steps,
                      float(data["limit"]["encoder_counts_s"]),
                      {k: float(v) for k, v in data["measured"].items()})
    except (OSError, KeyError, ValueError, tomllib.TOMLDecodeError) as exc:
        raise ConfigError(f"{path}: not a limits table written by {WRITER} ({exc}); "
                          f"run python3 {WRITER}") from None


def check_encoder(machine: Machine, limits: Limits | None = None) -> None:
    """ConfigError when the machine's encoder at its top speed counts faster than the firmware follows."""
    spindle = machine.parts.get("spindle")
    if spindle is None:
        return
    limits = limits or load()
    rpm = spindle.max_rpm * (1.0 + spindle.speed_tolerance)
    rate = spindle.encoder_counts_per_rev * rpm / 60.0
    if rate > limits.encoder_counts_s:
        top = limits.encoder_counts_s * 60.0 / spindle.encoder_counts_per_rev / (1.0 + spindle.speed_tolerance)
        raise ConfigError(
            f"{machine.source} [spindle]: encoder_counts_per_rev = {spindle.encoder_counts_per_rev} at "
            f"max_rpm = {spindle.max_rpm:g} (+{spindle.speed_tolerance:.0%}) is {rate:.0f} counts/s; the "
            f"firmware follows at most {limits.encoder_counts_s:.0f} counts/s ({TABLE.name}): lower "
            f"max_rpm to {math.floor(top):d} or use an encoder with fewer counts")


@dataclasses.dataclass
class Clamp:
    """The moves of one case whose feed was lowered."""

    rate: float
    words: str
    lines: list = dataclasses.field(default_factory=list)
    feeds: list = dataclasses.field(default_factory=list)

    def note(self) -> str:
        lo, hi = min(self.feeds), max(self.feeds)
        feeds = f"{lo:.1f}" if math.isclose(lo, hi) else f"{lo:.1f}-{hi:.1f}"
        numbers = sorted(set(n for n in self.lines if n is not None))
        lines = ("line " if len(numbers) == 1 else "lines ") + (", ".join(map(str, numbers)) or "-")
        return (f"feed clamped to {feeds} mm/min on {lines}: the firmware keeps "
                f"{self.rate / 1000:g} kHz {self.words}")


class _Walk:
    """Where the program's moves go, in steps, as the firmware plans them."""

    def __init__(self, machine: Machine, limits: Limits):
        from ..controller.settings import home_positions_mm
        self.m, self.limits = machine, limits
        self.pos = {a.name: 0 for a in machine.axes}
        self.home = {n: machine.axis(n).to_steps(mm) for n, mm in home_positions_mm(machine).items()}
        self.clamps: dict[str, Clamp] = {}
        self.long_pulse = any(a.pulse_high_ticks * machine.tick_us > 3.0 for a in machine.axes)

    def allowed_mm_min(self, cmd, line) -> float | None:
        """The highest feed at which ``cmd``'s move stays within the limit (None: no motion)."""
        target = dict(self.pos)
        for name, mm in cmd.axes:
            target[self.m.axis(name).name] = self.m.axis(name).to_steps(mm)
        delta = {n: abs(target[n] - self.pos[n]) for n in target if target[n] != self.pos[n]}
        self.pos = target
        if not delta:
            return None
        base = max(delta.values())
        length = math.sqrt(sum((d / self.m.axis(n).steps_per_mm) ** 2 for n, d in delta.items()))
        rate, words = self.limits.step_rate(len(delta), len(set(delta.values())) == 1, self.long_pulse)
        self.case = (f"{len(delta)}" + ("" if len(set(delta.values())) == 1 else ":b"), rate, words)
        return rate * length / base * 60.0

    def clamped(self, line, feed: float) -> None:
        key, rate, words = self.case
        c = self.clamps.setdefault(key, Clamp(rate, words))
        c.lines.append(line)
        c.feeds.append(feed)


def _floor_feed(feed: float) -> float:
    return math.floor(feed * 10.0) / 10.0


def plan_within_limits(expanded, machine: Machine, limits: Limits | None = None) -> list[str]:
    """Lower the feeds of ``expanded`` (commands, lines, events: changed in place) so that no move
    of a firmware run steps faster than the recorded limits; refuse a thread whose encoder rate
    the firmware cannot follow, and a rigid tap. Returns the summary's lines (none when nothing
    was clamped)."""
    from ..outputs.serial import RIGID_TAP_REASON, reverses_in_chain
    limits = limits or load()
    check_encoder(machine, limits)
    walk = _Walk(machine, limits)
    fast = machine.motion.rapid_feed_mm_min
    out, lines, where = [], [], []
    program_feed = sent = machine.motion.default_feed_mm_min
    indexer, rpm, turning, fast_need, fast_lines = False, 0.0, 0, math.inf, []
    for cmd, line in zip(expanded.commands, expanded.lines):
        if isinstance(cmd, Init):
            walk.pos = dict.fromkeys(walk.pos, 0)
        elif isinstance(cmd, Pstn):
            walk.pos.update({machine.axis(n).name: machine.axis(n).to_steps(mm) for n, mm in cmd.axes})
        elif isinstance(cmd, ZMov):                    # seeks, one axis at the fast feed
            walk.pos.update({n: walk.home[n] for n in (cmd.names or walk.pos)})
            walk.case = ("1",) + limits.step_rate(1, True, walk.long_pulse)
            allowed = walk.case[1] / max(a.steps_per_mm for a in machine.axes) * 60.0
            if allowed < fast:
                fast_need = min(fast_need, allowed)
                walk.clamped(line, _floor_feed(allowed))
                fast_lines.append(line)
        elif isinstance(cmd, (IStp, CStp)):
            indexer = isinstance(cmd, IStp)
        elif isinstance(cmd, Spin):
            if reverses_in_chain(cmd, indexer, turning):
                raise GcodeError(f"{cmd} {RIGID_TAP_REASON}", expanded.file, line)
            rpm, turning = (cmd.rpm if cmd.direction else 0.0), cmd.direction
        elif isinstance(cmd, FFdr):
            fast = cmd.feed
        elif isinstance(cmd, PFdr):
            program_feed = sent = cmd.feed
        elif isinstance(cmd, FMov):
            allowed = walk.allowed_mm_min(cmd, line)
            if allowed is not None and allowed < fast:
                fast_need = min(fast_need, allowed)
                walk.clamped(line, _floor_feed(allowed))
                fast_lines.append(line)
        elif isinstance(cmd, (PMov, Prob)) and indexer:
            walk.allowed_mm_min(cmd, line)
            _check_thread(machine, limits, rpm, expanded.file, line)
        elif isinstance(cmd, (PMov, Prob)):
            allowed = walk.allowed_mm_min(cmd, line)
            want = program_feed if allowed is None else min(program_feed, _floor_feed(allowed))
            if want < program_feed:
                walk.clamped(line, want)
            if not math.isclose(want, sent) and out and isinstance(out[-1], PFdr):
                out[-1] = PFdr(feed=want)              # the program's PFDR for this move, lowered
            elif not math.isclose(want, sent):
                out.append(PFdr(feed=want))
                lines.append(line)
            sent = want
        where.append(len(out))
        out.append(cmd)
        lines.append(line)
    if fast_need < math.inf:                            # only ever lowered
        feed = _floor_feed(fast_need)
        out = [FFdr(feed=feed) if isinstance(c, FFdr) and c.feed > feed else c for c in out]
        where = [k + 1 for k in where]
        out.insert(0, FFdr(feed=feed))
        lines.insert(0, fast_lines[0] if fast_lines else None)
        for c in walk.clamps.values():
            c.feeds = [feed if n in fast_lines else f for n, f in zip(c.lines, c.feeds)]
    where.append(len(out))
    expanded.events[:] = [dataclasses.replace(e, index=where[e.index])   # each pause and tool
                          for e in expanded.events]                       # change stays in place
    expanded.commands, expanded.lines = out, lines
    return [c.note() for c in walk.clamps.values()]


def _check_thread(machine: Machine, limits: Limits, rpm: float, file: str, line) -> None:
    spindle = machine.parts.get("spindle")
    if spindle is None:
        return
    top = rpm * (1.0 + spindle.speed_tolerance)
    rate = spindle.encoder_counts_per_rev * top / 60.0
    if rate > limits.encoder_counts_s:
        most = limits.encoder_counts_s * 60.0 / spindle.encoder_counts_per_rev / (1.0 + spindle.speed_tolerance)
        raise GcodeError(f"thread at S{rpm:g}: the encoder's {spindle.encoder_counts_per_rev} counts a turn at "
                         f"up to {top:.0f} rpm are {rate:.0f} counts/s; the firmware follows at most "
                         f"{limits.encoder_counts_s:.0f} counts/s: S{math.floor(most)} at most", file, line)


def takes_firmware(urls) -> bool:
    """Whether one of ``urls`` is a command-level output (``serial://``: a controller on the link)."""
    from ..outputs import OutputURL, output_class
    return any(getattr(output_class(OutputURL.parse(u).scheme), "takes_commands", False) for u in urls)


def for_run(expanded, machine: Machine, urls) -> list[str]:
    """:func:`plan_within_limits` when the run drives a controller on the link, else nothing."""
    return plan_within_limits(expanded, machine) if takes_firmware(urls) else []


def machine_lines(machine: Machine, limits: Limits) -> list[str]:
    """How the machine file's own top rates stand against the limits, one line each."""
    out = []
    long_pulse = any(a.pulse_high_ticks * machine.tick_us > 3.0 for a in machine.axes)
    most, words = limits.step_rate(1, True, long_pulse)
    for a in machine.axes:
        rate = a.max_velocity_mm_s * a.steps_per_mm
        out.append(f"  {machine.name} {a.name}: max {rate:.0f} steps/s "
                   + ("within" if rate <= most else "ABOVE") + f" the limit {most:.0f} {words}")
    spindle = machine.parts.get("spindle")
    if spindle is not None:
        try:
            check_encoder(machine, limits)
            rate = spindle.encoder_counts_per_rev * spindle.max_rpm * (1 + spindle.speed_tolerance) / 60
            out.append(f"  {machine.name} encoder: {rate:.0f} counts/s at max_rpm, within "
                       f"{limits.encoder_counts_s:.0f}")
        except ConfigError as exc:
            out.append(f"  {machine.name} encoder: REFUSED: {exc}")
    return out


def send_naming_line(out, device, lines, file: str, start: int, end: int) -> dict:
    """``out.send_program(device[start:end])``; when the controller stopped because a thread pass
    saw no spindle index pulse (ERROR and SPINDLE_ON without INDEX_SEEN: protocol.md), the
    OutputError names the program line of the pass that starts where the axes stand."""
    from ..errors import OutputError
    try:
        return out.send_program(device[start:end])
    except OutputError as exc:
        line = _index_timeout_line(out, device, lines, end)
        if line is None:
            raise
        from ..controller.indexrun import INDEX_TIMEOUT_S
        raise OutputError(f"{file}:{line}: the thread pass saw no spindle index pulse within "
                          f"{INDEX_TIMEOUT_S:g} s (the spindle is not turning); the controller "
                          f"stopped with an error ({exc})") from None


def _index_timeout_line(out, device, lines, end: int):
    """The line of the ISTP pass the controller stands on (at its start, or part-way along it,
    but not at its end), if it stopped for want of an index pulse."""
    from ..commands import Rdps, Rdst
    from ..errors import LinkError
    from ..link.replies import flag_names
    try:
        names = flag_names(out.link.request(Rdst()).flags)
        position = dict(out.link.request(Rdps()).steps)
    except (LinkError, AttributeError):
        return None
    if not {"ERROR", "SPINDLE_ON"} <= set(names) or "INDEX_SEEN" in names:
        return None
    m = out.machine
    pos = {a.name: 0 for a in m.axes}            # INIT, then the program's moves
    here = {**pos, **position}
    indexer = False
    for k, cmd in enumerate(device[:end]):
        if isinstance(cmd, (IStp, CStp)):
            indexer = isinstance(cmd, IStp)
        elif isinstance(cmd, Init):
            pos = dict.fromkeys(pos, 0)
        if not isinstance(cmd, (FMov, PMov, Prob, Pstn)):
            continue
        to = {**pos, **{m.axis(n).name: m.axis(n).to_steps(mm) for n, mm in cmd.axes}}
        if isinstance(cmd, PMov) and indexer and here != to and _on_line(here, pos, to):
            return lines[k] if k < len(lines) else None
        pos = to
    return None


def _on_line(p: dict, a: dict, b: dict) -> bool:
    """Whether ``p`` lies on the line from ``a`` to ``b`` (steps, within a step of it)."""
    d = {n: b[n] - a[n] for n in a}
    length2 = sum(v * v for v in d.values())
    if length2 == 0:
        return p == a
    t = sum((p[n] - a[n]) * d[n] for n in a) / length2
    return -1e-9 <= t <= 1 and all(abs(a[n] + t * d[n] - p[n]) <= 1.0 for n in a)
