"""The machine-file sections the controller reads: [switches], [spindle] and [homing].

Each reader takes a strict :class:`~retrofit.machine.tomlreader.Section` and the machine's axes and
returns a frozen object stored in ``Machine.parts`` (see ``config.SECTION_PARSERS``). Names that
refer to other sections (a homing switch, say) are checked by :func:`machine_io` once the whole
file is read, with an error naming file, section and key.
"""

from __future__ import annotations

from dataclasses import dataclass

from ..errors import ConfigError
from ..machine.config import Axis, Machine
from ..machine.tomlreader import Section

SWITCH_KINDS = ("limit", "home", "precise")
SIDES = {"positive": 1, "negative": -1}


@dataclass(frozen=True)
class SwitchSpec:
    """One switch on an axis: closed while the carriage is at or beyond ``trip_mm`` on ``side``.

    ``kind`` is ``limit`` (motion towards it stops when it closes), ``home`` (found by homing,
    nothing else) or ``precise`` (002's precise-position switch, the fine reference of homing).
    It opens again only once the carriage is back ``hysteresis_mm`` inside the trip point.
    """

    name: str                 # 'nlsx', 'plsx', 'plsz', 'ppsx', 'ppsz', or any other
    axis: str                 # 'X', 'Z', ...
    kind: str
    trip_mm: float
    side: int                 # +1: closed at or above trip_mm; -1: at or below
    hysteresis_mm: float
    overtravel_mm: float      # how far past the trip point the carriage may go before a hard stop


@dataclass(frozen=True)
class Switches:
    """Every switch of a machine, by name in file order."""

    specs: tuple[SwitchSpec, ...]

    def named(self, name: str) -> SwitchSpec | None:
        for spec in self.specs:
            if spec.name == name.lower():
                return spec
        return None

    def on_axis(self, axis: str) -> tuple[SwitchSpec, ...]:
        return tuple(s for s in self.specs if s.axis == axis.upper())


@dataclass(frozen=True)
class SpindleSim:
    """How the simulated spindle behaves (``[spindle.sim]``)."""

    accel_rpm_s: float = 3000.0       # how fast the drive changes speed
    load_noise: float = 0.0           # speed varies within ±load_noise (fraction) with the load
    noise_interval_ms: float = 200.0  # the load changes smoothly over this time
    seed: int = 1
    stalled: bool = False             # jammed: it never turns, whatever the drive is told


@dataclass(frozen=True)
class SpindleSettings:
    """The spindle and its indexer: an encoder giving ICLK pulses and one SIND pulse a revolution."""

    encoder_counts_per_rev: int       # ICLK pulses per revolution (C)
    max_rpm: float
    speed_tolerance: float            # the controller plans for a spindle up to this fraction fast
    sync_accel_share: float           # share of an axis's acceleration a thread lead-in may use
    sim: SpindleSim = SpindleSim()
    #: the drive reverses on command at this rate (rpm/s) and the encoder counts both ways
    #: (quadrature): rigid tapping (G33.1) needs it; None: a one-way encoder
    reverse_rpm_s: float | None = None


@dataclass(frozen=True)
class AxisHoming:
    """How one axis finds machine zero: seek ``switch`` fast, back off, find ``precise`` slowly."""

    axis: str
    switch: str               # sought at the fast feed (FFDR)
    precise: str | None       # found slowly after backing off; None: the seek switch itself
    home_mm: float            # the position the axis has when the reference switch closes
    backoff_mm: float         # extra distance backed off after the seek switch opened
    latch_mm_min: float       # the slow feed towards the reference switch


@dataclass(frozen=True)
class Homing:
    """Homing order and per-axis settings (``[homing]``)."""

    order: tuple[str, ...]
    axes: dict[str, AxisHoming]

    def home_mm(self, axis: str) -> float:
        found = self.axes.get(axis.upper())
        return found.home_mm if found else 0.0


def read_switches_section(sec: Section, axes: tuple[Axis, ...]) -> Switches:
    """``[switches.<name>]`` tables: axis, kind, trip_mm, side, hysteresis_mm, overtravel_mm."""
    names = {a.name for a in axes}
    specs = []
    for key, sub in sec.subsections():
        axis = sub.get_str("axis").upper()
        if axis not in names:
            raise sub.error("axis", f"no such axis; axes are {', '.join(sorted(names))}")
        side = sub.get_str("side", choices=tuple(SIDES))
        specs.append(SwitchSpec(
            name=key.lower(), axis=axis, kind=sub.get_str("kind", choices=SWITCH_KINDS),
            trip_mm=sub.get_float("trip_mm"), side=SIDES[side],
            hysteresis_mm=sub.get_float("hysteresis_mm", 0.05, minval=0.0, maxval=10.0),
            overtravel_mm=sub.get_float("overtravel_mm", 1.0, minval=0.0, maxval=100.0)))
        sub.finish()
    sec.finish()
    if not specs:
        raise ConfigError(f"{sec.file} [switches]: no switch given; add e.g. [switches.plsz]")
    return Switches(tuple(specs))


def read_spindle_section(sec: Section, axes: tuple[Axis, ...]) -> SpindleSettings:
    """``[spindle]``: the encoder and the indexer's planning margins; ``[spindle.sim]`` its physics."""
    settings = SpindleSettings(
        encoder_counts_per_rev=sec.get_int("encoder_counts_per_rev", minval=1, maxval=1_000_000),
        max_rpm=sec.get_float("max_rpm", above=0.0, maxval=100_000.0),
        speed_tolerance=sec.get_float("speed_tolerance", 0.15, minval=0.0, maxval=1.0),
        sync_accel_share=sec.get_float("sync_accel_share", 0.8, above=0.0, maxval=1.0),
        reverse_rpm_s=sec.get_float("reverse_rpm_s", None, above=0.0, maxval=1_000_000.0)
        if sec.has("reverse_rpm_s") else None,
        sim=_read_spindle_sim(sec.section("sim", required=False)))
    sec.finish()
    return settings


def _read_spindle_sim(sec: Section | None) -> SpindleSim:
    if sec is None:
        return SpindleSim()
    d = SpindleSim()
    sim = SpindleSim(
        accel_rpm_s=sec.get_float("accel_rpm_s", d.accel_rpm_s, above=0.0),
        load_noise=sec.get_float("load_noise", d.load_noise, minval=0.0, maxval=0.5),
        noise_interval_ms=sec.get_float("noise_interval_ms", d.noise_interval_ms, above=0.0),
        seed=sec.get_int("seed", d.seed), stalled=sec.get_bool("stalled", d.stalled))
    sec.finish()
    return sim


def read_homing_section(sec: Section, axes: tuple[Axis, ...]) -> Homing:
    """``[homing]``: ``order`` (axis letters) and one ``[homing.<axis>]`` table per homed axis."""
    names = [a.name for a in axes]
    order = tuple(str(v).upper() for v in sec.get_list("order"))
    for name in order:
        if name not in names:
            raise sec.error("order", f"axis {name} is not on the machine (axes: {', '.join(names)})")
    if len(set(order)) != len(order):
        raise sec.error("order", "names an axis twice")
    per_axis = {}
    for key in [k for k in sec._data if k != "order"]:
        sub = sec.section(key)
        assert sub is not None          # a required section is there or refused
        axis = key.upper()
        if axis not in order:
            raise ConfigError(f"{sec.file} [homing.{key}]: axis {axis} is not in [homing] order "
                              f"({', '.join(order) or 'empty'})")
        precise = sub.get_str("precise", "")
        per_axis[axis] = AxisHoming(
            axis=axis, switch=sub.get_str("switch").lower(), precise=precise.lower() or None,
            home_mm=sub.get_float("home_mm", 0.0),
            backoff_mm=sub.get_float("backoff_mm", 1.0, minval=0.0, maxval=1000.0),
            latch_mm_min=sub.get_float("latch_mm_min", 30.0, above=0.0))
        sub.finish()
    sec.finish()
    missing = [a for a in order if a not in per_axis]
    if missing:
        raise ConfigError(f"{sec.file} [homing]: order names {missing[0]} but there is no "
                          f"[homing.{missing[0].lower()}] table")
    return Homing(order, per_axis)


@dataclass(frozen=True)
class MachineIO:
    """What a machine has around its axes: switches, spindle, homing (each may be absent)."""

    switches: Switches
    spindle: SpindleSettings | None
    homing: Homing | None


def machine_io(machine: Machine) -> MachineIO:
    """The machine's switches, spindle and homing, with the homing switches checked to exist.

    Raises ConfigError naming the machine file and the ``[homing.<axis>]`` key at fault.
    """
    switches = machine.parts.get("switches") or Switches(())
    homing = machine.parts.get("homing")
    file = machine.source.rsplit("/", 1)[-1]
    if homing is not None:
        for axis, how in homing.axes.items():
            for key in ("switch", "precise"):
                name = getattr(how, key)
                if name is None:
                    continue
                spec = switches.named(name)
                known = ", ".join(s.name for s in switches.specs) or "none"
                if spec is None:
                    raise ConfigError(f"{file} [homing.{axis.lower()}] {key} = {name!r}: no such "
                                      f"switch in [switches] (switches: {known})")
                if spec.axis != axis:
                    raise ConfigError(f"{file} [homing.{axis.lower()}] {key} = {name!r}: that switch "
                                      f"is on axis {spec.axis}, not {axis}")
    return MachineIO(switches, machine.parts.get("spindle"), homing)


def home_positions_mm(machine: Machine) -> dict[str, float]:
    """Where ZMOV leaves every axis: its ``home_mm`` when it is homed against switches, else 0."""
    homing = machine.parts.get("homing")
    return {name: (homing.home_mm(name) if homing else 0.0) for name in machine.axis_names}
