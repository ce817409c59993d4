"""ZMOV against switches: find machine zero axis by axis, in the machine file's homing order.

For each axis (``[homing.<axis>]``):

1. **seek** -- towards the seek switch (a limit or home switch) at the fast feed (FFDR), ramping up
   at the axis's acceleration, until the switch closes; the axis stops on that tick;
2. **back off** -- away from it at the fast feed until it opens again (and the precise-position
   switch too), then ``backoff_mm`` further;
3. **latch** -- towards the precise-position switch at the slow ``latch_mm_min`` until it closes;
   the axis stops on that tick and its position becomes ``home_mm``.

Every phase reads the switches after each frame, so the step that closes a switch is the last.
An axis that does not find its switch within its whole travel stops with an error.
"""

from __future__ import annotations

from ..errors import MotionError


class Jog:
    """One axis stepping one way at a speed it ramps up (or down) to at its acceleration."""

    def __init__(self, axis: int, direction: int, accel_steps_s2: float, tick_s: float):
        self.axis, self.direction = axis, direction
        self.accel, self.dt = accel_steps_s2, tick_s
        self.speed = 0.0                      # steps/s
        self.owed = 0.0                       # fraction of a step travelled, not yet stepped
        self.steps = 0                        # steps requested so far

    def step(self, tick: int, pulses, speed_steps_s: float) -> None:
        """After frame ``tick``: ramp towards ``speed_steps_s``; request a step when one is owed."""
        if self.speed < speed_steps_s:
            self.speed = min(speed_steps_s, self.speed + self.accel * self.dt)
        else:
            self.speed = max(speed_steps_s, self.speed - self.accel * self.dt)
        self.owed = min(self.owed + self.speed * self.dt, 2.0)
        if self.owed >= 1.0 and not pulses.queues[self.axis]:
            self.owed -= 1.0
            self.steps += 1
            pulses.request(self.axis, tick + 1, self.direction)


class HomeRun:
    """The homing of one ZMOV: its axes one after the other, each through seek, back-off, latch."""

    needs_spindle = False

    def __init__(self, entry, machine, io, fast_mm_min, homed):
        """``fast_mm_min()`` gives the current fast feed; ``homed(axis_index)`` is called when an
        axis has latched (the controller then sets its position)."""
        self.entry = entry
        self.machine = machine
        self.io = io
        self.fast_mm_min = fast_mm_min
        self.homed = homed
        self.todo = list(entry.axes)
        self.axis: str | None = None
        self.phase = "next"
        self.jog: Jog | None = None
        self.backoff_from: int | None = None

    @property
    def done(self) -> bool:
        return self.phase == "done"

    def owns(self, switch_name: str) -> bool:
        """True for the switches of the axis being homed (their closing is expected)."""
        spec = self.io.switches.named(switch_name)
        return spec is not None and spec.axis == self.axis

    def step(self, tick: int, closed: set[str], pulses) -> None:
        """Advance after frame ``tick``, the switches in ``closed`` being closed."""
        if self.phase == "next":
            self._next_axis()
        if self.phase in ("seek", "backoff", "latch"):
            getattr(self, f"_{self.phase}")(tick, closed, pulses)

    def _next_axis(self) -> None:
        if not self.todo:
            self.phase = "done"
            return
        self.axis = self.todo.pop(0)
        self.i = self.machine.axis_names.index(self.axis)
        axis = self.machine.axes[self.i]
        self.how = self.io.homing.axes[self.axis]
        self.seek_switch = self.io.switches.named(self.how.switch)
        self.ref_switch = self.io.switches.named(self.how.precise or self.how.switch)
        lo = min([axis.min_mm] + [s.trip_mm - s.overtravel_mm for s in self.io.switches.on_axis(self.axis)])
        hi = max([axis.max_mm] + [s.trip_mm + s.overtravel_mm for s in self.io.switches.on_axis(self.axis)])
        self.max_steps = round((hi - lo + 2.0 * self.how.backoff_mm + 5.0) * axis.steps_per_mm)
        self._phase("seek", self.seek_switch.side)

    def _phase(self, name: str, direction: int) -> None:
        axis = self.machine.axes[self.i]
        self.phase = name
        self.jog = Jog(self.i, direction, axis.max_accel_mm_s2 * axis.steps_per_mm, self.machine.tick_s)
        self.backoff_from = None

    def _speed(self, mm_min: float) -> float:
        axis = self.machine.axes[self.i]
        return min(mm_min / 60.0, axis.max_velocity_mm_s) * axis.steps_per_mm

    def _travel(self, tick: int, pulses, mm_min: float, what: str) -> None:
        jog = self._jog()
        if jog.steps > self.max_steps:
            raise MotionError(f"homing {self.axis}: {what} not found within {self.max_steps} steps "
                              f"({self.max_steps / self.machine.axes[self.i].steps_per_mm:.1f} mm); "
                              f"check the switch and its wiring ([switches] in {self.machine.name})")
        jog.step(tick, pulses, self._speed(mm_min))

    def _jog(self) -> Jog:
        if self.jog is None:
            raise MotionError(f"homing {self.axis}: no phase under way")
        return self.jog

    def _stop(self, pulses) -> None:
        pulses.queues[self.i].clear()

    def _seek(self, tick: int, closed: set[str], pulses) -> None:
        if self.seek_switch.name in closed:
            self._stop(pulses)
            self._phase("backoff", -self.seek_switch.side)
            return
        self._travel(tick, pulses, self.fast_mm_min(), f"switch {self.seek_switch.name}")

    def _backoff(self, tick: int, closed: set[str], pulses) -> None:
        clear = self.seek_switch.name not in closed and self.ref_switch.name not in closed
        steps = self._jog().steps
        if clear and self.backoff_from is None:
            self.backoff_from = steps
        if clear and self.backoff_from is not None and steps - self.backoff_from >= round(
                self.how.backoff_mm * self.machine.axes[self.i].steps_per_mm):
            self._stop(pulses)
            self._phase("latch", self.ref_switch.side)
            return
        self._travel(tick, pulses, self.fast_mm_min(), f"the open side of switch {self.seek_switch.name}")

    def _latch(self, tick: int, closed: set[str], pulses) -> None:
        if self.ref_switch.name in closed:
            self._stop(pulses)
            self.homed(self.i)
            self.phase = "next"
            self._next_axis()
            return
        self._travel(tick, pulses, self.how.latch_mm_min, f"switch {self.ref_switch.name}")
