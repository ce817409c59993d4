"""The simulated Grenoble mill behind the CAM link: three servo axes, spindle, coolant, pendant.

:class:`CamMill` executes the messages of :mod:`.protocol` the way the paper's real-time task
does: each trajectory row is one loop period of every axis (read encoder, correct feedrate,
drive); the replies it owes the client go to an outbox. The pendant (e-stop, joystick) is a set
of methods a test or a front panel calls. Time is loop periods, counted in ``tick``; nothing here
reads the wall clock.
"""

from __future__ import annotations

import threading
from collections import deque
from dataclasses import dataclass

from ..errors import LinkError
from ..machine.config import Machine
from .loop import PositionLoop, ServoAxis
from .motor import ServoMotor
from .protocol import (
    FEED_LIMIT,
    Auto,
    EndOperation,
    Home,
    Jog,
    JogFeed,
    Machining,
    Message,
    Operation,
    Row,
    Spindle,
    ToolChange,
    format_position,
)
from .servo import servo_of
from .trajectory import plan_rows, xyz_axes

#: a row may move an axis at most this many times its max velocity for one period
MAX_ROW_JUMP = 2.0


@dataclass(frozen=True)
class StopRecord:
    """What happened when the machine was stopped (e-stop, client gone)."""

    reason: str
    tick: int                     # loop period at which the stop was ordered
    last_row_tick: int            # loop period of the last row executed before it
    coast_periods: int            # periods until every axis was at rest
    coast_pulses: tuple[int, ...]  # distance each axis ran on after the stop


class CamMill:
    """A simulated 3-axis servo mill that speaks the CAM link (001)."""

    def __init__(self, machine: Machine, start_mm: tuple[float, ...] | None = None,
                 record: bool = False):
        self.machine, self.servo = machine, servo_of(machine)
        axes = xyz_axes(machine)
        period = machine.tick_s
        start = start_mm or (0.0,) * len(axes)       # powered up at home, machine zero
        self.axes = [ServoAxis(ServoMotor(a, self.servo, a.to_steps(mm)), PositionLoop(self.servo, period),
                               period) for a, mm in zip(axes, start)]
        self.max_jump = [MAX_ROW_JUMP * a.max_velocity_mm_s * a.steps_per_mm * period for a in axes]
        self.lock = threading.RLock()
        self.outbox: deque[str] = deque()
        self.mode = "A"               # "A" auto, "JX" / "JY" / "JZ" jog on an axis
        self.machining = False        # between M1 and M0: jog requests are ignored
        self.operation = False        # between P0/P1 and #: rows are accepted
        self.coolant = False
        self.spindle = 0              # 0..255, clockwise
        self.jog_feed = 100           # 0..255
        self.tool, self.tool_length_mm = 0, 0
        self.estop = False
        self.tick = 0                 # loop periods run so far
        self.last_row_tick = 0
        self.stops: list[StopRecord] = []
        self.trace: list[tuple[int, ...]] | None = [] if record else None   # encoder after each period
        self._handlers = {Row: self._row, Auto: self._on_auto, Jog: self._on_jog,
                          Machining: self._on_machining, Operation: self._on_operation,
                          EndOperation: self._on_end_operation, Spindle: self._on_spindle,
                          JogFeed: self._on_jog_feed, ToolChange: self._on_tool_change, Home: self._on_home}

    # -- what the client and the tests read ---------------------------------------------------
    def positions(self) -> tuple[int, ...]:
        """Encoder positions in pulses, X, Y, Z."""
        return tuple(a.motor.encoder() for a in self.axes)

    def drive(self) -> tuple[int, ...]:
        """The feedrate each drive is applying now."""
        return tuple(a.motor.feed for a in self.axes)

    def at_rest(self) -> bool:
        return all(a.motor.at_rest for a in self.axes)

    def replies(self) -> list[str]:
        """Take the replies owed to the client, oldest first."""
        with self.lock:
            out = list(self.outbox)
            self.outbox.clear()
            return out

    @property
    def spindle_rpm(self) -> float:
        return self.spindle * self.servo.spindle_max_rpm / FEED_LIMIT

    # -- messages ---------------------------------------------------------------------------
    def handle(self, message: Message) -> None:
        """Execute one client message; raise LinkError (and do nothing) if it is refused."""
        with self.lock:
            self._handlers[type(message)](message)

    def _on_auto(self, message: Auto) -> None:
        self.mode = "A"
        self.outbox.append("A")

    def _on_jog(self, message: Jog) -> None:
        if not (self.machining or self.operation):      # ignored while machining (001, step 2)
            self.mode = f"J{message.axis}"
        self.outbox.append(self.mode)

    def _on_machining(self, message: Machining) -> None:
        if message.on:
            self._refuse_in_estop(message)
            self.machining = True
            if self.mode != "A":
                self.mode = "A"
                self.outbox.append("A")
            return
        if self.operation:
            self._on_end_operation(EndOperation())
        self.machining = False
        self.spindle = 0

    def _on_operation(self, message: Operation) -> None:
        self._refuse_in_estop(message)
        if self.mode != "A":
            raise LinkError(f"{message}: the machine is in jog mode {self.mode}; send A@ first")
        if self.operation:
            raise LinkError(f"{message}: an operation is already open; end it with #@ first")
        for axis in self.axes:
            axis.stop_here()
        self.operation, self.coolant = True, message.coolant

    def _on_end_operation(self, message: EndOperation) -> None:
        if not self.operation:
            raise LinkError("#: no operation is open; start one with P1@ or P0@")
        self.coolant = False
        self.settle()
        self.operation = False
        self.outbox.append(format_position(self.positions()))

    def _on_spindle(self, message: Spindle) -> None:
        if message.speed:
            self._refuse_in_estop(message)
        self.spindle = message.speed

    def _on_jog_feed(self, message: JogFeed) -> None:
        self.jog_feed = message.feed

    def _on_tool_change(self, message: ToolChange) -> None:
        self._refuse_in_estop(message)
        self.tool, self.tool_length_mm = message.tool, message.length_mm

    def _on_home(self, message: Home) -> None:
        self._refuse_in_estop(message)
        if self.operation:
            raise LinkError("H: an operation is open; end it with #@ before homing")
        here = [a.to_mm(p) for a, p in zip(self.machine.axes, self.positions())]
        home = [0.0] * len(self.axes)
        feed = self.machine.motion.rapid_feed_mm_min
        moves = [((here[0], here[1], home[2]), feed), (tuple(home), feed)]   # Z clear first
        for row in plan_rows(self.machine, here, moves):
            self._step(row)
        self.settle()
        self.outbox.append("H")

    def _refuse_in_estop(self, message: Message) -> None:
        if self.estop:
            raise LinkError(f"{message}: refused, the emergency stop is pressed; release it first")

    # -- rows and loop periods ----------------------------------------------------------------
    def _row(self, row: Row) -> None:
        self._refuse_in_estop(row)
        if not self.operation:
            raise LinkError(f"row {str(row)!r} outside an operation; send P1@ or P0@ first, #@ after")
        for axis, ax, target, jump in zip(self.machine.axes, self.axes, row.positions, self.max_jump):
            if not axis.min_steps <= target <= axis.max_steps:
                raise LinkError(f"row {str(row)!r}: {axis.name} position {target} outside travel "
                                f"{axis.min_steps}..{axis.max_steps} pulses")
            if abs(target - ax.setpoint) > jump:
                raise LinkError(f"row {str(row)!r}: {axis.name} jumps {target - ax.setpoint} pulses in "
                                f"one period from {ax.setpoint}; at most {jump:g} are accepted")
        self._step(row)
        self.last_row_tick = self.tick

    def _step(self, row: Row) -> None:
        """One loop period of every axis towards this row's positions."""
        for axis, position, feed in zip(self.axes, row.positions, row.feeds):
            axis.step(position, feed)
        self._tick()

    def _tick(self) -> None:
        self.tick += 1
        if self.trace is not None:
            self.trace.append(self.positions())

    def settle(self) -> bool:
        """Hold the set-points until every axis is in position (bounded); True if they got there."""
        tolerance = self.servo.in_position_pulses
        for _ in range(self.servo.settle_timeout_ms):
            if all(a.in_position(tolerance) for a in self.axes):
                return True
            for axis in self.axes:
                axis.hold()
            self._tick()
        return all(a.in_position(tolerance) for a in self.axes)

    # -- stops --------------------------------------------------------------------------------
    def halt(self, reason: str) -> StopRecord:
        """Stop at once: drives to 0 from the next period, spindle and coolant off, operation over.

        The axes then brake on their motors' back-emf until at rest; the set-points become where
        they stopped.
        """
        with self.lock:
            start = self.positions()
            self.spindle, self.coolant = 0, False
            self.operation = self.machining = False
            tick, periods = self.tick, 0
            while not self.at_rest() and periods < self.servo.settle_timeout_ms:
                for axis in self.axes:
                    axis.brake()
                self._tick()
                periods += 1
            for axis in self.axes:
                axis.stop_here()
                axis.motor.feed = 0
            coast = tuple(p - s for p, s in zip(self.positions(), start))
            record = StopRecord(reason, tick, self.last_row_tick, periods, coast)
            self.stops.append(record)
            return record

    # -- the pendant ----------------------------------------------------------------------------
    def press_estop(self) -> None:
        """The emergency-stop button: halt, and tell the client ``E1``."""
        with self.lock:
            if not self.estop:
                self.estop = True
                self.halt("emergency stop")
                self.outbox.append("E1")

    def release_estop(self) -> None:
        """Release the emergency stop; the client hears ``E0``."""
        with self.lock:
            if self.estop:
                self.estop = False
                self.outbox.append("E0")

    def joystick(self, direction: int, periods: int) -> bool:
        """Push the joystick (+1 / -1) for ``periods`` loop periods in jog mode, then let go.

        The jog axis moves at the jog feedrate (F), ramping at its max acceleration; when it
        stops, the client gets the position. Returns False (nothing moves) unless the machine is
        in jog mode, not machining and not in e-stop.
        """
        with self.lock:
            if self.estop or self.machining or self.operation or self.mode == "A" or direction == 0:
                return False
            index = "XYZ".index(self.mode[1])
            self._jog(index, 1 if direction > 0 else -1, periods)
            self.settle()
            self.outbox.append(format_position(self.positions()))
            return True

    def _jog(self, index: int, direction: int, periods: int) -> None:
        axis, servo_axis = self.machine.axes[index], self.axes[index]
        top = direction * self.jog_feed * axis.max_velocity_mm_s / FEED_LIMIT * axis.steps_per_mm
        dv = axis.max_accel_mm_s2 * axis.steps_per_mm * self.machine.tick_s   # pulses/s per period
        setpoint, speed, k = float(servo_axis.setpoint), 0.0, 0
        while k < periods or speed != 0.0:
            target = top if k < periods else 0.0
            speed = min(speed + dv, target) if speed < target else max(speed - dv, target)
            ahead = setpoint + speed * self.machine.tick_s
            if not axis.min_steps <= ahead <= axis.max_steps:      # soft limit: stop there
                ahead, speed, periods = min(max(ahead, axis.min_steps), axis.max_steps), 0.0, 0
            setpoint = ahead
            feed = round(speed / self.servo.gain_pulses_s(axis))
            rows = [(a.setpoint, 0) for a in self.axes]
            rows[index] = (round(setpoint), feed)
            self._step(Row(tuple(f for _, f in rows), tuple(p for p, _ in rows)))
            k += 1

    def status(self) -> dict:
        """A snapshot of the machine's state (for the CLI and tests)."""
        with self.lock:
            return {"mode": self.mode, "machining": self.machining, "operation": self.operation,
                    "coolant": self.coolant, "spindle": self.spindle, "jog_feed": self.jog_feed,
                    "tool": self.tool, "tool_length_mm": self.tool_length_mm, "estop": self.estop,
                    "tick": self.tick, "positions": self.positions(), "drive": self.drive()}
