"""Machine descriptions: TOML files read strictly into plain frozen dataclasses.

Machines ship inside the package (``retrofit/machines/*.toml``) and load by name
(``load_machine("chivu-lathe")``) or by path. Inside the toolkit every time is an integer tick
and every position an integer step; mm and seconds exist only here and at the other edges.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from importlib import import_module, resources
from pathlib import Path
from typing import Any

from ..errors import ConfigError
from .tomlreader import Section, load_toml, shown_key

#: DB25 data pins 2..9 drive data register bits 0..7 (003, Table 1).
DB25_DATA_PINS = tuple(range(2, 10))
#: what the step / direction pins of a machine are wired to
PORT_KINDS = ("db25", "ramps", "none")
#: the axis letters of RS274 (LinuxCNC's XYZABCUVW): an axis is named by one of them ...
AXIS_NAMES = "XYZABCUVW"
#: ... of which A, B and C turn (degrees: retrofit.machine.rotary)
ROTARY_NAMES = "ABC"
#: ... or by E, the drive of a tool carousel (an axis no G-code word moves; [atc] axis = "E")
AUX_AXIS_NAMES = "E"
#: the largest step count a position may have: a signed 32-bit count, as the firmware keeps it
STEPS_MAX = 2**31 - 1


@dataclass(frozen=True)
class Axis:
    """One axis: how steps become millimetres, its limits, its pulse timing and its pins."""

    name: str                   # "X", "Z", ...
    label: str                  # "transversal", "longitudinal", ...
    steps_per_mm: float         # the lathe paper's KT / KL
    min_mm: float               # soft limits
    max_mm: float
    pulse_high_ticks: int       # 'dunu' in the lathe paper: ticks at logic 1
    pulse_low_ticks: int        # ticks at logic 0 before the next step; period = high + low ('perioada')
    dir_setup_ticks: int        # direction stable this long before a rising step edge
    dir_hold_ticks: int         # direction unchanged this long after a rising step edge
    backlash_mm: float          # compensation clearance ('JocT' / 'JocL')
    max_velocity_mm_s: float
    max_accel_mm_s2: float
    step_bit: int               # bit of the step signal in the port frame byte
    dir_bit: int                # bit of the direction signal in the port frame byte
    step_pin: int | None        # the connector pin (DB25 pin on a parallel port, board pin on RAMPS)
    dir_pin: int | None
    invert_step: bool = False
    invert_dir: bool = False
    rotary: bool = False        # A, B, C: every "mm" of this axis is a degree
    wrap: bool = False          # a rotary axis without limits: G90 moves take the shorter way round

    @property
    def backlash_steps(self) -> int:
        """The compensation clearance rounded to whole steps."""
        return round(self.backlash_mm * self.steps_per_mm)

    @property
    def min_steps(self) -> int:
        return math.ceil(self.min_mm * self.steps_per_mm - 1e-9)

    @property
    def max_steps(self) -> int:
        return math.floor(self.max_mm * self.steps_per_mm + 1e-9)

    @property
    def step_mm(self) -> float:
        return 1.0 / self.steps_per_mm

    def to_steps(self, mm: float) -> int:
        """Nearest whole step to a position in mm."""
        return round(mm * self.steps_per_mm)

    def to_mm(self, steps: float) -> float:
        return steps / self.steps_per_mm


@dataclass(frozen=True)
class SimModel:
    """The physical machine the simulator models (may differ from what the controller assumes)."""

    dead_band_mm: dict[str, float]
    motors: dict[str, object] = field(default_factory=dict)   # [sim.motor.<axis>]: motors.MotorModel


@dataclass(frozen=True)
class MotionSettings:
    """How the planner moves the axes ([motion] section; every key has a default)."""

    arc_tolerance_mm: float = 0.002      # allowed radius error of an arc's chords (004's e)
    rapid_feed_mm_min: float = 3000.0    # FMOV / ZMOV feed (FFDR) unless a command sets another
    default_feed_mm_min: float = 300.0   # PMOV feed (PFDR) before any F word
    lookahead: int = 16                  # moves the planner looks ahead (1 = stop at every junction)
    profile: str = "trapezoid"           # or "exponential" (the engraver paper's ramp)
    junction_deviation_mm: float = 0.01  # how much a junction may round a corner when taken at speed
    interpolator: str = "dda"            # 004 digital integration (evenly spaced pulses), or "bresenham" (002)


@dataclass(frozen=True)
class Machine:
    """A whole machine: its axes in order, the tick, the simulator's physics and optional parts."""

    name: str
    description: str
    source: str                     # file it was read from
    tick_us: float
    port: str                       # "db25" (parallel port), "ramps" (Arduino board pins), "none"
    axes: tuple[Axis, ...]
    sim: SimModel
    motion: MotionSettings = MotionSettings()
    parts: dict[str, Any] = field(default_factory=dict)      # optional sections, see SECTION_PARSERS
    dialect: str = "rs274"          # how its programs are read: "rs274" (LinuxCNC) or "fanuc" (lathe)

    @property
    def tick_s(self) -> float:
        return self.tick_us * 1e-6

    @property
    def axis_names(self) -> tuple[str, ...]:
        return tuple(a.name for a in self.axes)

    def axis(self, name: str) -> Axis:
        for a in self.axes:
            if a.name == name.upper():
                return a
        raise ConfigError(f"{self.name}: no axis {name!r}; axes are {', '.join(self.axis_names)}")

    def ticks(self, seconds: float) -> int:
        """Nearest whole tick to a time in seconds."""
        return round(seconds / self.tick_s)


#: Optional top-level sections other parts of retrofit read: name -> "module:function", imported
#: when a machine file has that section. The function takes (Section, axes) and returns a frozen
#: object stored in ``Machine.parts[name]``; it must read every key and call ``section.finish()``.
SECTION_PARSERS: dict[str, str] = {
    "servo": "retrofit.camlink.servo:read_servo_section",
    "parport": "retrofit.outputs.parport:read_parport_section",
    "switches": "retrofit.controller.settings:read_switches_section",
    "spindle": "retrofit.controller.settings:read_spindle_section",
    "homing": "retrofit.controller.settings:read_homing_section",
    "atc": "retrofit.atc.settings:read_atc_section",
    "tools": "retrofit.atc.settings:read_tools_section",
    "setter": "retrofit.atc.setter:read_setter_section",
    "ramps": "retrofit.atc.board:read_ramps_section",
    "io": "retrofit.machine.iopins:read_io_section",
    "fanuc": "retrofit.gcode.fanuc_settings:read_fanuc_section",
}


def machines_dir():
    return resources.files("retrofit") / "machines"


def list_machines() -> list[str]:
    """Names of the machine files shipped with retrofit."""
    return sorted(p.name[:-5] for p in machines_dir().iterdir() if p.name.endswith(".toml"))


def resolve_machine_path(name_or_path: str | Path) -> Path:
    text = str(name_or_path)
    if text.endswith(".toml") or "/" in text or "\\" in text:
        return Path(text)
    candidate = machines_dir() / f"{text}.toml"
    if not candidate.is_file():
        raise ConfigError(f"unknown machine {text!r}; shipped machines: {', '.join(list_machines())}"
                          " (or give a path to a .toml file)")
    return Path(str(candidate))


def load_machine(name_or_path: str | Path) -> Machine:
    """Load a machine by shipped name (``"chivu-lathe"``) or by path to a TOML file.

    Raises ConfigError naming file, section and key for a typo key, a wrong type or a value
    out of range.
    """
    path = resolve_machine_path(name_or_path)
    root = Section(path.name, "", load_toml(path))
    head = root.section("machine")
    name = head.get_str("name")
    description = head.get_str("description", "")
    tick_us = head.get_float("tick_us", above=0.0, maxval=1e6)
    port = head.get_str("port", "db25", choices=PORT_KINDS)
    dialect = head.get_str("dialect", "rs274", choices=("rs274", "fanuc"))
    head.finish()
    axes_section = root.section("axis")
    _check_axis_names(path.name, axes_section)
    axes = tuple(_read_axis(key, sec, port, i) for i, (key, sec) in enumerate(axes_section.subsections()))
    axes_section.finish()
    if not axes:
        raise ConfigError(f"{path.name} [axis]: a machine needs at least one axis ([axis.x] ...)")
    if len(axes) > 4:
        raise ConfigError(f"{path.name} [axis]: at most 4 axes fit a port frame byte (step + dir each)")
    _check_pins(path.name, axes)
    sim = _read_sim(root.section("sim", required=False), axes, path.name)
    motion = _read_motion(root.section("motion", required=False))
    parts = {}
    for key in list(root._data):
        if key in SECTION_PARSERS:
            module, _, func = SECTION_PARSERS[key].partition(":")
            parts[key] = getattr(import_module(module), func)(root.section(key), axes)
    root.finish()
    from .iopins import check_io_pins
    check_io_pins(path.name, port, axes, parts)
    return Machine(name=name, description=description, source=str(path), tick_us=tick_us, port=port,
                   axes=axes, sim=sim, motion=motion, parts=parts, dialect=dialect)


def _check_axis_name(file: str, key: str) -> None:
    """An [axis.*] key is one RS274 axis letter (either case)."""
    if len(key) != 1 or key.upper() not in AXIS_NAMES + AUX_AXIS_NAMES:
        raise ConfigError(f"{file} [axis.{shown_key(key)}]: {key!r} is not an axis name; an axis "
                          f"is named by one letter of {AXIS_NAMES} (either case; E for a tool "
                          "carousel), e.g. [axis.x]")


def _check_axis_names(file: str, axes_section: Section) -> None:
    """Each axis once: [axis.x] and [axis.X] name the same axis."""
    seen: dict[str, str] = {}
    for key, _ in axes_section.subsections():
        _check_axis_name(file, key)
        if key.upper() in seen:
            raise ConfigError(f"{file} [axis.{key}]: axis {key.upper()} is already defined by "
                              f"[axis.{seen[key.upper()]}]; each axis is defined once")
        seen[key.upper()] = key


def _read_axis(key: str, sec: Section, port: str, index: int) -> Axis:
    """One [axis.*] table. On a DB25 port the pins choose the data bits (pin 2 = bit 0);
    elsewhere axis i uses bits 2i (step) and 2i + 1 (direction) of the frame byte."""
    _check_axis_name(sec.file, key)
    why = (f'{{}} is needed on port "{port}" ([machine] port, "db25" unless set); use '
           'port = "none" for a simulation-only machine')
    if port == "db25":
        step_pin = sec.get_int("step_pin", minval=2, maxval=9, why=why.format("step_pin"))
        dir_pin = sec.get_int("dir_pin", minval=2, maxval=9, why=why.format("dir_pin"))
        step_bit, dir_bit = step_pin - 2, dir_pin - 2
    else:
        required = port == "ramps"
        step_pin = sec.get_int("step_pin", minval=0, maxval=255, why=why.format("step_pin")) if required else None
        dir_pin = sec.get_int("dir_pin", minval=0, maxval=255, why=why.format("dir_pin")) if required else None
        step_bit, dir_bit = 2 * index, 2 * index + 1
    if key.upper() in ROTARY_NAMES:
        from .rotary import read_rotary
        return read_rotary(key, sec, step_pin, dir_pin, step_bit, dir_bit)
    steps_per_mm = sec.get_float("steps_per_mm", above=0.0, maxval=1e6)
    reach = STEPS_MAX / steps_per_mm            # the travel a signed 32-bit step count covers
    min_mm = sec.get_float("min_mm", minval=-reach, maxval=reach)
    max_mm = sec.get_float("max_mm", minval=-reach, maxval=reach)
    if not max_mm > min_mm:
        raise sec.error("max_mm", f"must be > min_mm ({min_mm:g})")
    axis = Axis(
        name=key.upper(),
        label=sec.get_str("label", key.upper()),
        steps_per_mm=steps_per_mm,
        min_mm=min_mm,
        max_mm=max_mm,
        pulse_high_ticks=sec.get_int("pulse_high_ticks", 1, minval=1, maxval=10_000),
        pulse_low_ticks=sec.get_int("pulse_low_ticks", 1, minval=1, maxval=10_000),
        dir_setup_ticks=sec.get_int("dir_setup_ticks", 1, minval=0, maxval=10_000),
        dir_hold_ticks=sec.get_int("dir_hold_ticks", 1, minval=0, maxval=10_000),
        backlash_mm=sec.get_float("backlash_mm", 0.0, minval=0.0, maxval=10.0),
        max_velocity_mm_s=sec.get_float("max_velocity_mm_s", 50.0, above=0.0, maxval=10_000.0),
        max_accel_mm_s2=sec.get_float("max_accel_mm_s2", 500.0, above=0.0, maxval=1e6),
        step_bit=step_bit,
        dir_bit=dir_bit,
        step_pin=step_pin,
        dir_pin=dir_pin,
        invert_step=sec.get_bool("invert_step", False),
        invert_dir=sec.get_bool("invert_dir", False),
    )
    sec.finish()
    return axis


def _check_pins(file: str, axes: tuple[Axis, ...]) -> None:
    used: dict[int, str] = {}
    for axis in axes:
        for what, pin in (("step_pin", axis.step_pin), ("dir_pin", axis.dir_pin)):
            if pin is None:
                continue
            if pin in used:
                raise ConfigError(f"{file} [axis.{axis.name.lower()}] {what} = {pin}: "
                                  f"already used by {used[pin]}; each pin drives one signal")
            used[pin] = f"{axis.name}.{what}"


def _read_sim(sec: Section | None, axes: tuple[Axis, ...], file: str) -> SimModel:
    if sec is None:
        return SimModel(dead_band_mm={a.name: 0.0 for a in axes})
    bands = sec.section("dead_band_mm", required=False)
    dead: dict[str, float] = {a.name: 0.0 for a in axes}
    if bands is not None:
        for axis in axes:
            dead[axis.name] = bands.get_float(axis.name.lower(), 0.0, minval=0.0, maxval=10.0)
        bands.finish()
    motor_tables = sec.section("motor", required=False)
    motors = {}
    if motor_tables is not None:
        from .motors import read_motor_tables
        motors = read_motor_tables(motor_tables, axes)
    sec.finish()
    return SimModel(dead_band_mm=dead, motors=motors)


def _read_motion(sec: Section | None) -> MotionSettings:
    if sec is None:
        return MotionSettings()
    d = MotionSettings()
    settings = MotionSettings(
        arc_tolerance_mm=sec.get_float("arc_tolerance_mm", d.arc_tolerance_mm, above=0.0, maxval=1.0),
        rapid_feed_mm_min=sec.get_float("rapid_feed_mm_min", d.rapid_feed_mm_min, above=0.0),
        default_feed_mm_min=sec.get_float("default_feed_mm_min", d.default_feed_mm_min, above=0.0),
        lookahead=sec.get_int("lookahead", d.lookahead, minval=1, maxval=1024),
        profile=sec.get_str("profile", d.profile, choices=("trapezoid", "exponential")),
        junction_deviation_mm=sec.get_float("junction_deviation_mm", d.junction_deviation_mm, minval=0.0),
        interpolator=sec.get_str("interpolator", d.interpolator, choices=("bresenham", "dda")),
    )
    sec.finish()
    return settings
