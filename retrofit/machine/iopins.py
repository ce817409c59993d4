"""Spare digital outputs and inputs (``[io]`` in the machine file), for M62-M66.

A machine file names its spare pins by number, in the terms of its port::

    [io]
    out0 = 6          # DB25 data pin 6 (bit 4 of the port byte): M62-M65 P0
    out1 = 7
    in0 = 10          # DB25 status pin 10 (Ack): M66 P0
    [io.sim]
    in0 = [0.5, 2.0]  # the simulated input toggles at 0.5 s and 2.0 s of the run (starts low)

On a parallel port (``port = "db25"``) an output is a data pin 2-9 the axes leave free, and it
is written in the port byte with the step and direction bits, so it shows in every port-frame
output (``sim://``, ``vcd://``, ``parport://``); an input is a status pin 10, 11, 12, 13 or 15.
On RAMPS (``port = "ramps"``) a pin is an Arduino Mega pin D0-D69 no other signal uses, and on
``port = "none"`` a pin number 0-255 of the board; there the port byte has no room for it, and
the outputs' changes are in the run's report only.

The simulated inputs start low and toggle at the times listed in ``[io.sim]`` (seconds from the
start of the run); an input without a list stays low. :func:`wait_outcome` is M66's rule on them.
"""

from __future__ import annotations

import bisect
import math
from dataclasses import dataclass, field

from ..errors import ConfigError
from .tomlreader import Section

#: at most this many outputs and inputs (LinuxCNC's default number of motion digital I/O)
MAX_PINS = 64
#: DB25 pins an output or an input may use (the data and status registers)
DB25_OUT, DB25_IN = tuple(range(2, 10)), (10, 11, 12, 13, 15)
#: M66 wait modes, by L: what ends the wait
WAIT_MODES = {0: "immediate", 1: "rising edge", 2: "falling edge", 3: "high", 4: "low"}


@dataclass(frozen=True)
class IoPins:
    """The ``[io]`` section: pin of each output and input by number, and the simulated inputs."""

    outputs: tuple[int, ...] = ()
    inputs: tuple[int, ...] = ()
    sim_edges: dict[int, tuple[float, ...]] = field(default_factory=dict)   # input -> toggle times, s

    def level(self, index: int, seconds: float) -> int:
        """The simulated level (0/1) of input ``index`` at ``seconds`` into the run."""
        edges = self.sim_edges.get(index, ())
        return bisect.bisect_right(edges, seconds) % 2


@dataclass(frozen=True)
class WaitOutcome:
    """What an M66 did: how long it waited (s) and the value it left in #5399."""

    seconds: float
    value: float


def read_io_section(sec: Section, axes) -> IoPins:
    """Read ``[io]``: ``out0``.., ``in0``.. (pin numbers, no gaps) and ``[io.sim]``; the port's
    rules on the pins are checked by :func:`check_io_pins` once the whole file is read."""
    outputs = _numbered(sec, "out")
    inputs = _numbered(sec, "in")
    sim = sec.section("sim", required=False)
    edges: dict[int, tuple[float, ...]] = {}
    if sim is not None:
        for k in range(len(inputs)):
            if sim.has(f"in{k}"):
                edges[k] = _edges(sim, f"in{k}")
        sim.finish()
    sec.finish()
    return IoPins(tuple(outputs), tuple(inputs), edges)


def _numbered(sec: Section, prefix: str) -> list[int]:
    pins = []
    while sec.has(f"{prefix}{len(pins)}") and len(pins) < MAX_PINS:
        pins.append(sec.get_int(f"{prefix}{len(pins)}", minval=0, maxval=255))
    return pins


def _edges(sec: Section, key: str) -> tuple[float, ...]:
    times = sec.get_list(key)
    if not all(isinstance(t, (int, float)) and not isinstance(t, bool) and math.isfinite(t)
               and 0.0 <= t <= 1e6 for t in times):
        raise sec.error(key, "must be a list of times in seconds from 0 to 1e6, e.g. [0.5, 2.0]")
    if any(b <= a for a, b in zip(times, times[1:])):
        raise sec.error(key, "the times must increase (each one toggles the input)")
    return tuple(float(t) for t in times)


def check_io_pins(file: str, port: str, axes, parts: dict) -> None:
    """The ``[io]`` pins against the machine's port and every other pin of the file."""
    io = parts.get("io")
    if io is None:
        return
    used = {pin: f"{a.name}.{what}" for a in axes
            for what, pin in (("step_pin", a.step_pin), ("dir_pin", a.dir_pin)) if pin is not None}
    ramps = parts.get("ramps")
    if ramps is not None:
        used.update({pin: f"{name}.enable" for name, pin in ramps.enable_pins.items()})
        if ramps.spindle_pwm_pin is not None:
            used[ramps.spindle_pwm_pin] = "spindle PWM"
    parport = parts.get("parport")
    if parport is not None:
        used.update({pin: f"switch {name}" for pin, name in parport.switches.items()})
        if parport.enable_pin:
            used[parport.enable_pin] = "driver enable"
    for kind, pins in (("out", io.outputs), ("in", io.inputs)):
        for k, pin in enumerate(pins):
            where = f"{file} [io] {kind}{k} = {pin}"
            _check_port(where, port, kind, pin)
            if pin in used:
                raise ConfigError(f"{where}: already used by {used[pin]}; each pin carries one signal")
            used[pin] = f"{kind}{k}"


def _check_port(where: str, port: str, kind: str, pin: int) -> None:
    if port == "db25":
        allowed = DB25_OUT if kind == "out" else DB25_IN
        if pin not in allowed:
            what = "a data pin" if kind == "out" else "a status pin"
            raise ConfigError(f"{where}: on a parallel port an {'output' if kind == 'out' else 'input'}"
                              f" is {what}: one of {', '.join(map(str, allowed))}")
    elif port == "ramps" and pin > 69:
        raise ConfigError(f"{where}: a RAMPS pin is an Arduino Mega pin D0..D69")


def port_bit(machine, index: int) -> int | None:
    """The bit of output ``index`` in the port byte, or None when its pin is not on the port."""
    io = machine.parts.get("io")
    if io is None or machine.port != "db25" or index >= len(io.outputs):
        return None
    return io.outputs[index] - 2


def wait_outcome(io: IoPins, index: int, mode: int, timeout_s: float, start_s: float) -> WaitOutcome:
    """M66 P``index`` L``mode`` Q``timeout_s`` started ``start_s`` into the run: LinuxCNC's rule.

    L0 reads the input at once; L1/L2 wait for a rising/falling edge, L3/L4 for the input to be
    high/low. #5399 gets the input's level when the wait ends, or -1 when ``timeout_s`` passed.
    """
    level = io.level(index, start_s)
    if mode == 0:
        return WaitOutcome(0.0, float(level))
    edges = [t for t in io.sim_edges.get(index, ()) if start_s < t <= start_s + timeout_s]
    if mode == 3 and level == 1 or mode == 4 and level == 0:
        return WaitOutcome(0.0, float(level))
    for t in edges:
        after = io.level(index, t)
        if mode in (1, 3) and after == 1 or mode in (2, 4) and after == 0:
            return WaitOutcome(t - start_s, float(after))
    return WaitOutcome(timeout_s, -1.0)
