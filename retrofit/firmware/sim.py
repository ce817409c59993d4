"""The compiled firmware in simavr with its pins wired to retrofit's simulated machine.

``firmware/harness/hil.c`` (``make -C firmware harness``) runs ``firmware.elf`` on simavr's
cycle-exact ATmega2560; this module builds both, turns a machine file into the harness's wiring
(RAMPS sockets, endstop connectors, the setter's beam, the spindle encoder on D21 / D20), serves
the USART on TCP or feeds it timed bytes, and reads back every pin change and byte sent, stamped
with the AVR's cycle. :func:`sim_machine` feeds the step pins to the driver model of ``sim://``
one tick a cycle; :func:`step_times` gives the raw edges, in cycles (no host clock).
"""

from __future__ import annotations

import dataclasses
import math
import signal
import subprocess
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import RetrofitError
from ..frames import PortFrames
from ..machine.config import Machine

ROOT = Path(__file__).resolve().parents[2]
FIRMWARE = ROOT / "firmware"
HARNESS = FIRMWARE / "build" / "hil"
F_CPU = 16_000_000

#: Arduino Mega pin -> (AVR port, bit) for the pins the RAMPS 1.4 sockets use
MEGA_PINS = {54: ("F", 0), 55: ("F", 1), 60: ("F", 6), 61: ("F", 7), 46: ("L", 3), 48: ("L", 1),
             26: ("A", 4), 28: ("A", 6), 36: ("C", 1), 34: ("C", 3)}
#: the RAMPS sockets' (step, dir) pins, as firmware/board.h wires them
SOCKET_PINS = {"X": (54, 55), "Y": (60, 61), "Z": (46, 48), "E0": (26, 28), "E1": (36, 34)}
#: the RAMPS sockets' driver ENABLE pins -> (AVR port, bit); low = driver on (A4988, DRV8825)
ENABLE_PINS = {"X": ("D", 7), "Y": ("F", 2), "Z": ("K", 0), "E0": ("A", 2), "E1": ("C", 7)}
#: the RAMPS endstop connectors -> (AVR port, bit)
CONNECTOR_PINS = {"XMIN": ("E", 5), "XMAX": ("E", 4), "YMIN": ("J", 1), "YMAX": ("J", 0),
                  "ZMIN": ("D", 3), "ZMAX": ("D", 2)}
CONNECTORS = ("XMIN", "XMAX", "YMIN", "YMAX", "ZMIN", "ZMAX")
#: the 002 switches on fixed connectors, with their bit in the status word
SWITCH_CONNECTORS = {"nlsx": ("XMIN", 2), "plsx": ("XMAX", 3), "plsz": ("ZMAX", 4),
                     "ppsx": ("YMIN", 5), "ppsz": ("YMAX", 6)}


class HarnessError(RetrofitError):
    """The harness or the firmware could not be built or run."""


def firmware_axes(machine: Machine) -> list:
    """The machine's axes in the firmware's order: ascending link mask bit (codec.axis_bits)."""
    from ..link.codec import axis_bits
    bits = axis_bits(machine)
    return sorted(machine.axes, key=lambda a: bits[a.name])


def sockets(machine: Machine) -> dict[str, str]:
    """Axis letter -> RAMPS socket: X, Y and Z their own, any other letter E0, then E1."""
    spare = ["E0", "E1"]
    out = {}
    for a in firmware_axes(machine):
        if a.name in ("X", "Y", "Z"):
            out[a.name] = a.name
        elif spare:
            out[a.name] = spare.pop(0)
        else:
            raise HarnessError(f"{machine.source}: axis {a.name} has no RAMPS socket left "
                               "(X, Y, Z, E0 and E1 drive five axes)")
    return out


def supported_machines() -> list[str]:
    """The shipped machines the firmware builds for (RAMPS pins, at most five axes)."""
    from ..machine.config import load_machine
    out = []
    for path in sorted((ROOT / "retrofit" / "machines").glob("*.toml")):
        name = path.stem
        m = load_machine(name)
        if m.port == "ramps" or (FIRMWARE / "machines" / f"{name}.h").exists():
            out.append(name)
    return out


def switch_connectors(machine: Machine) -> list[tuple[object, str, int]]:
    """(switch spec, endstop connector, status bit or -1) for each switch: the 002 switches on
    their fixed connectors, the others on the free connectors in order."""
    switches = machine.parts.get("switches")
    specs = switches.specs if switches else ()
    taken = {SWITCH_CONNECTORS[s.name][0] for s in specs if s.name in SWITCH_CONNECTORS}
    free = [c for c in CONNECTORS if c not in taken]
    out = []
    for spec in specs:
        connector, bit = SWITCH_CONNECTORS.get(spec.name, (None, -1))
        if connector is None:
            if not free:
                raise HarnessError(f"{machine.source} [switches]: more switches than the six "
                                   "RAMPS endstop connectors")
            connector = free.pop(0)
        out.append((spec, connector, bit))
    return out


def probe_connector(machine: Machine) -> str | None:
    """The endstop connector of the tool setter's beam (the probe input): the first one the
    switches leave free; None without a ``[setter]``."""
    if "setter" not in machine.parts:
        return None
    taken = {connector for _, connector, _ in switch_connectors(machine)}
    for c in (c for c in CONNECTORS if c not in taken):
        return c
    raise HarnessError(f"{machine.source} [setter]: no RAMPS endstop connector left for the beam "
                       "(the switches take all six)")


def beam_args(machine: Machine, tool: tuple[float, float] | int | None) -> list[str]:
    """The setter's beam (and the magazine, for a tool number): :func:`retrofit.atc.hil.beam_args`."""
    connector = probe_connector(machine)
    if connector is None:
        return []
    from ..atc.hil import beam_args as options
    port, bit = CONNECTOR_PINS[connector]
    return options(machine, f"{port}{bit}", {a.name: i for i, a in enumerate(firmware_axes(machine))}, tool)


def wiring_args(machine: Machine, start_steps: dict[str, int] | None = None,
                spindle_rpm: float = 0.0, tool: tuple[float, float] | None = None) -> list[str]:
    """The harness options that wire ``machine`` to the firmware's pins; ``tool``: (length,
    diameter) in mm of the tool in the spindle (what the setter's beam sees)."""
    start_steps = start_steps or {}
    axes = firmware_axes(machine)
    args: list[str] = []
    for a in axes:
        step, direction = (MEGA_PINS[p] for p in SOCKET_PINS[sockets(machine)[a.name]])
        args += ["--axis", f"{step[0]}{step[1]},{direction[0]}{direction[1]},"
                           f"{int(a.invert_dir)},{int(start_steps.get(a.name, 0))}"]
    index = {a.name: i for i, a in enumerate(axes)}
    for spec, connector, _ in switch_connectors(machine):
        spm = machine.axis(spec.axis).steps_per_mm
        at = (math.ceil(spec.trip_mm * spm - 1e-9) if spec.side > 0
              else math.floor(spec.trip_mm * spm + 1e-9))
        port, bit = CONNECTOR_PINS[connector]
        args += ["--switch", f"{port}{bit},{index[spec.axis]},{'>' if spec.side > 0 else '<'},{at},1"]
    args += beam_args(machine, tool)
    spindle = machine.parts.get("spindle")
    if spindle is not None and spindle_rpm > 0:
        args += ["--spindle", f"{spindle_rpm:g},{spindle.encoder_counts_per_rev}"]
    return args


def _make(*targets: str, machine: str | None = None, tree: Path = FIRMWARE) -> None:
    cmd = ["make", "-C", str(tree), *targets] + ([f"MACHINE={machine}"] if machine else [])
    try:
        run = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    except FileNotFoundError as exc:
        raise HarnessError(f"make: not found ({exc}); apt-get install make gcc-avr avr-libc "
                           "libsimavr-dev") from None
    if run.returncode != 0:
        tail = (run.stdout + run.stderr).strip().splitlines()[-5:]
        raise HarnessError(f"{tree}/Makefile: `{' '.join(cmd[3:])}` failed: " + " | ".join(tail))


def build(machine_name: str) -> Path:
    """Build the harness and the firmware of ``machine_name``; the ELF's path."""
    _make("harness")
    header = FIRMWARE / "machines" / f"{machine_name}.h"
    if not header.exists():
        _make("machine", machine=machine_name)
    _make(f"build/{machine_name}/firmware.elf", machine=machine_name)
    return FIRMWARE / "build" / machine_name / "firmware.elf"


def build_copy(machine: Machine, workdir: Path, source: Path = FIRMWARE) -> Path:
    """The ELF for ``machine`` (any machine file), built in a copy of ``source`` (this tree's
    ``firmware/`` or an older one) under ``workdir``: the tree's machine headers stay as they are."""
    import shutil  # noqa: E401
    import sys
    _make("harness")
    copy = Path(workdir) / "firmware"
    if not copy.exists():
        shutil.copytree(source, copy, ignore=shutil.ignore_patterns("build", "*.elf", "*.hex"))
    sys.path.insert(0, str(FIRMWARE / "tools"))
    from machine_header import header
    name = machine.name
    (copy / "machines" / f"{name}.h").write_text(header(machine))
    _make(f"build/{name}/firmware.elf", machine=name, tree=copy)
    return copy / "build" / name / "firmware.elf"


@dataclass
class HarnessLog:
    """What the harness saw: output-port values, bytes the firmware sent, inputs it drove."""

    ports: dict[str, list[tuple[int, int]]] = field(default_factory=dict)   # port -> (cycle, value)
    uart: list[tuple[int, int]] = field(default_factory=list)               # (cycle, byte)
    inputs: list[tuple[int, str, int, int]] = field(default_factory=list)   # (cycle, port, bit, level)
    end_cycle: int = 0
    stats: dict[str, int] = field(default_factory=dict)
    steps: list[int] = field(default_factory=list)      # the harness's own count per axis
    stalled_at: int | None = None                        # the cycle --stall hung the main loop
    spindle_tool: int | None = None                      # the magazine's, at the end
    drive: list[tuple[int, int, float]] = field(default_factory=list)   # (cycle, tick, rpm) set

    @classmethod
    def read(cls, log_path: Path, stdout: str) -> HarnessLog:
        log = cls()
        for line in Path(log_path).read_text().splitlines():
            kind, *rest = line.split()
            if kind == "P":
                log.ports.setdefault(rest[1], []).append((int(rest[0]), int(rest[2], 16)))
            elif kind == "U":
                log.uart.append((int(rest[0]), int(rest[1], 16)))
            elif kind == "I":
                log.inputs.append((int(rest[0]), rest[1], int(rest[2]), int(rest[3])))
            elif kind == "S":
                log.stalled_at = int(rest[0])
            elif kind == "R":                            # the spindle drive's new speed
                log.drive.append((int(rest[0]), int(rest[1]), float(rest[2])))
        for line in stdout.splitlines():
            words = line.split()
            if not words:
                continue
            pairs = dict(w.split("=", 1) for w in words[1:] if "=" in w)
            if words[0] == "stats":
                log.stats = {k: int(v) for k, v in pairs.items()}
            elif words[0] == "axis":
                log.steps.append(int(pairs["steps"]))
            elif words[0] == "magazine":
                log.spindle_tool = int(pairs["spindle"])
            elif words[0] == "end":
                log.end_cycle = int(pairs["cycles"])
        return log

    def pin(self, port: str, bit: int) -> tuple[np.ndarray, np.ndarray]:
        """(cycles, levels) of one output pin at each change of its port."""
        changes = self.ports.get(port, [])
        cycles = np.array([c for c, _ in changes], dtype=np.int64)
        levels = np.array([(v >> bit) & 1 for _, v in changes], dtype=np.int8)
        return cycles, levels

    def answer_bytes(self) -> bytes:
        return bytes(b for _, b in self.uart)


def step_times(log: HarnessLog, machine: Machine, axis: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(rising-edge cycles, falling-edge cycles, direction pin level at each rise) of one axis."""
    step_pin, dir_pin = (MEGA_PINS[p] for p in SOCKET_PINS[sockets(machine)[machine.axis(axis).name]])
    cycles, levels = log.pin(*step_pin)
    prev = np.concatenate(([0], levels[:-1]))
    rises = cycles[(levels == 1) & (prev == 0)]
    falls = cycles[(levels == 0) & (prev == 1)]
    dcycles, dlevels = log.pin(*dir_pin)
    at = np.searchsorted(dcycles, rises, side="right") - 1
    dirs = np.where(at >= 0, dlevels[np.maximum(at, 0)], 0)
    return rises, falls, dirs


def cycle_machine(machine: Machine) -> Machine:
    """``machine`` with one tick per AVR cycle (driver minimum times scaled up to match)."""
    per_tick = machine.tick_us * F_CPU / 1e6

    def scale(t: int) -> int:
        return int(math.ceil(t * per_tick - 1e-9))

    axes = tuple(dataclasses.replace(a, pulse_high_ticks=scale(a.pulse_high_ticks),
                                     pulse_low_ticks=scale(a.pulse_low_ticks),
                                     dir_setup_ticks=scale(a.dir_setup_ticks),
                                     dir_hold_ticks=scale(a.dir_hold_ticks)) for a in machine.axes)
    return dataclasses.replace(machine, tick_us=1e6 / F_CPU, axes=axes)


def port_frames(log: HarnessLog, machine: Machine) -> PortFrames:
    """The step and direction pins as the port byte of ``machine`` (PinMap bit positions)."""
    events = []
    for a in machine.axes:
        step_pin, dir_pin = (MEGA_PINS[p] for p in SOCKET_PINS[sockets(machine)[a.name]])
        for (port, bit), target in ((step_pin, a.step_bit), (dir_pin, a.dir_bit)):
            cycles, levels = log.pin(port, bit)
            events += [(int(c), target, int(v)) for c, v in zip(cycles, levels)]
    events.sort()
    value, ticks, values = 0, [0], [0]
    for cycle, target, level in events:
        value = (value & ~(1 << target)) | (level << target)
        if ticks[-1] == cycle:
            values[-1] = value
        elif values[-1] != value:
            ticks.append(cycle)
            values.append(value)
    return PortFrames(np.array(ticks), np.array(values), max(log.end_cycle, ticks[-1] + 1))


def sim_machine(log: HarnessLog, machine: Machine, start_steps: dict[str, int] | None = None):
    """The simulated machine of ``sim://`` after the firmware's step pins (one tick a cycle)."""
    from ..sim import SimMachine
    fine = cycle_machine(machine)
    start = tuple(int((start_steps or {}).get(a.name, 0)) for a in machine.axes)
    sim = SimMachine(fine, start)
    sim.feed(port_frames(log, fine))
    return sim


def report(log: HarnessLog, machine: Machine, start_steps: dict[str, int] | None = None) -> dict:
    """A run report of the same kind as ``sim://``: carriages, motors, violations, AVR time."""
    sim = sim_machine(log, machine, start_steps)
    return {
        "machine": machine.name,
        "cycles": log.end_cycle,
        "duration_s": log.end_cycle / F_CPU,
        "motor_steps": dict(zip(machine.axis_names, sim.motor_steps)),
        "carriage_mm": {a: round(sim.carriage_mm(a), 6) for a in machine.axis_names},
        "violations": [v.as_dict() | {"cycle": v.tick} for v in sim.violations],
        "bytes_sent": len(log.uart),
    }


def _die_with_parent() -> None:
    """In the harness process, before exec: Linux ends it when the Python side dies, however."""
    import sys
    if sys.platform.startswith("linux"):
        import ctypes
        ctypes.CDLL("libc.so.6", use_errno=True).prctl(1, signal.SIGTERM)   # PR_SET_PDEATHSIG


class Harness:
    """One run of the harness: ``start()``, then ``stop()`` for its :class:`HarnessLog`."""

    def __init__(self, elf: Path, machine: Machine, *, listen: str | None = None,
                 script: list[tuple[int, bytes]] | None = None, cycles: int = 0,
                 start_steps: dict[str, int] | None = None, spindle_rpm: float = 0.0,
                 vcd: Path | None = None, stats: bool = False, speed: float | None = None,
                 boot_ms: float = 0.0, stall: tuple[int, bool] | None = None,
                 glitches: list[tuple[str, int, int, int]] = (),
                 tool: tuple[float, float] | None = None, spindle_stalled: bool | int = False):
        """``spindle_rpm``: an encoder at that fixed speed, else the spindle in the loop
        (retrofit.firmware.spindle; ``spindle_stalled``: jammed, or from a cycle on); ``tool``:
        (length, diameter) mm of the tool in the spindle; ``boot_ms``: a bootloader's time before
        the firmware starts (bytes sent meanwhile are lost); ``stall``: (cycle, interrupts off?)
        the main loop hangs; ``glitches``: (connector or pin such as "XMAX" / "E4", cycle, cycles,
        level) an input driven for a while."""
        self.tmp = tempfile.TemporaryDirectory(prefix="retrofit-hil-")
        self.log_path = Path(self.tmp.name) / "pins.log"
        self.args = [str(HARNESS), str(elf), "--log", str(self.log_path),
                     *wiring_args(machine, start_steps, spindle_rpm, tool)]
        from .spindle import spindle_model_args
        self.args += [] if spindle_rpm > 0 else spindle_model_args(
            machine, Path(self.tmp.name) / "draws.bin", spindle_stalled)
        if listen:
            self.args += ["--listen", listen]
        if script:
            path = Path(self.tmp.name) / "script.txt"
            path.write_text("".join(f"{c} {data.hex()}\n" for c, data in sorted(script, key=lambda x: x[0])))
            self.args += ["--script", str(path)]
        if cycles:
            self.args += ["--cycles", str(int(cycles))]
        if vcd:
            self.args += ["--vcd", str(vcd)]
        if stats:
            self.args += ["--stats"]
        if speed is not None:
            self.args += ["--speed", f"{speed:g}"]
        if boot_ms:
            self.args += ["--boot-ms", f"{boot_ms:g}"]
        if stall is not None:
            self.args += ["--stall", f"{int(stall[0])}" + (",cli" if stall[1] else "")]
        for pin, cycle, cycles, level in glitches:
            port, bit = CONNECTOR_PINS.get(pin, (pin[0], pin[1:]))
            self.args += ["--glitch", f"{port}{bit},{int(cycle)},{int(cycles)},{int(level)}"]
        self.proc: subprocess.Popen | None = None
        self.address = ""

    def start(self) -> Harness:
        self.proc = subprocess.Popen(self.args, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL,
                                     text=True, preexec_fn=_die_with_parent)
        if "--listen" in self.args:
            line = self.proc.stdout.readline()
            while line.startswith("Loaded "):               # simavr's own note of the ELF
                line = self.proc.stdout.readline()
            if not line.startswith("listening on "):
                self.proc.kill()
                raise HarnessError(f"{HARNESS}: did not start listening ({line.strip() or 'no output'})")
            self.address = line.split()[-1]
        return self

    def stop(self, timeout_s: float | None = None) -> HarnessLog:
        """End the run (SIGTERM unless it ends by itself within ``timeout_s``); read its log."""
        assert self.proc is not None
        try:
            out, _ = self.proc.communicate(timeout=timeout_s if timeout_s is not None else 0.01)
        except subprocess.TimeoutExpired:
            self.proc.send_signal(signal.SIGTERM)
            out, _ = self.proc.communicate(timeout=30)
        try:
            return HarnessLog.read(self.log_path, out)
        finally:
            self.tmp.cleanup()

    def run(self, timeout_s: float = 120.0) -> HarnessLog:
        """Run a scripted harness (``cycles`` set) to its end."""
        self.start()
        return self.stop(timeout_s)
