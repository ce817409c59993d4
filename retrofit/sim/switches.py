"""The switches of the simulated machine: each closes when its carriage reaches its trip point.

A switch reads the **carriage**, not the motor: with a lead screw's dead band the carriage is
where the cam or flag really is. It is closed while the carriage is at or beyond its trip point
on its side and opens again only once the carriage is back inside by the switch's hysteresis,
as a mechanical switch or a proximity sensor does. Every change is recorded with its tick.
"""

from __future__ import annotations

from dataclasses import dataclass

#: carriage positions closer than this to a trip point count as on it (float noise of mm)
EPS_MM = 1e-9


@dataclass(frozen=True)
class SwitchEvent:
    """A switch changed state at the end of frame ``tick``."""

    tick: int
    name: str
    closed: bool


class SimSwitch:
    """One switch (a :class:`~retrofit.controller.settings.SwitchSpec`) and its state."""

    def __init__(self, spec, carriage_mm: float):
        self.spec = spec
        self.closed = self._beyond(carriage_mm, 0.0)

    def _beyond(self, carriage_mm: float, slack_mm: float) -> bool:
        spec = self.spec
        return spec.side * (carriage_mm - spec.trip_mm) >= -slack_mm - EPS_MM

    def update(self, carriage_mm: float) -> bool:
        """Follow the carriage; True when the state changed."""
        now = self._beyond(carriage_mm, self.spec.hysteresis_mm if self.closed else 0.0)
        changed = now != self.closed
        self.closed = now
        return changed


class SwitchBank:
    """Every switch of a machine, fed with each carriage position as the simulator moves it.

    ``switches`` is the machine's :class:`~retrofit.controller.settings.Switches` (or None).
    """

    def __init__(self, machine, switches, start_carriage_mm: dict[str, float]):
        specs = switches.specs if switches is not None else ()
        self.by_axis: dict[str, list[SimSwitch]] = {a.name: [] for a in machine.axes}
        self.switches: dict[str, SimSwitch] = {}
        for spec in specs:
            switch = SimSwitch(spec, start_carriage_mm[spec.axis])
            self.by_axis[spec.axis].append(switch)
            self.switches[spec.name] = switch
        self.events: list[SwitchEvent] = []

    def on_carriage(self, axis: str, tick: int, carriage_mm: float) -> None:
        """The carriage of ``axis`` is at ``carriage_mm`` after frame ``tick``."""
        for switch in self.by_axis[axis]:
            if switch.update(carriage_mm):
                self.events.append(SwitchEvent(tick, switch.spec.name, switch.closed))

    def states(self) -> dict[str, bool]:
        """Name -> closed, for every switch."""
        return {name: s.closed for name, s in self.switches.items()}

    def first_change(self, name: str, closed: bool, after_tick: int = -1) -> int | None:
        """Tick at which switch ``name`` first became ``closed`` (or open) after ``after_tick``."""
        for event in self.events:
            if event.name == name and event.closed == closed and event.tick > after_tick:
                return event.tick
        return None

    def hard_travel(self, axis) -> tuple[float, float]:
        """The carriage's physical travel (mm): the soft limits, widened to reach every switch
        of the axis plus its overtravel (a carriage may run onto a limit switch, not past it)."""
        lo, hi = axis.min_mm, axis.max_mm
        for switch in self.by_axis[axis.name]:
            spec = switch.spec
            lo = min(lo, spec.trip_mm - spec.overtravel_mm)
            hi = max(hi, spec.trip_mm + spec.overtravel_mm)
        return lo, hi
