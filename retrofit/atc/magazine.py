"""The simulated magazine: which tool is where, judged from what the simulated axes really did.

:class:`MagazineModel` replays the carriage traces of a :class:`~retrofit.sim.SimMachine` (X, Y,
Z in mm, the carousel in its units) in tick order and moves tools the way the hardware would:
an empty spindle that comes down to the clamp height over a pocket's tool clamps it; a spindle
that lifts off while its tool sits in the fork of the pocket at the spindle leaves the tool
there. It reports, as violations:

* ``carousel_turn`` — the carousel turned while the spindle was inside the magazine zone below
  Z_POINT_1 (the tools or the spindle would be dragged along);
* ``pocket_misaligned`` — the spindle went into the magazine where no pocket was at the spindle
  (off the station X1, or the disc not within ``tolerance_deg`` of a pocket);
* ``wrong_pocket`` — a tool went into a pocket that is not its own (tool n lives in pocket n);
* ``pocket_occupied`` — a pocket that already holds a tool received a second one.

Leaving the work volume is the simulator's own ``travel`` violation.
"""

from __future__ import annotations

import bisect
from dataclasses import dataclass, field

import numpy as np

from ..machine.config import Machine
from ..sim import SimMachine, Violation
from .settings import atc_of, tools_of

#: how far past Z_POINT_1 (mm) counts as below it: float noise, far under one step
_EPS_MM = 1e-6


@dataclass
class MagazineState:
    """Which tool the spindle holds (None: empty) and which tool each pocket holds."""

    spindle: int | None
    pockets: dict[int, int | None] = field(default_factory=dict)

    @classmethod
    def loaded(cls, machine: Machine, spindle_tool: int = 0) -> MagazineState:
        """Every simulated tool in its own pocket, except ``spindle_tool``, which is in the spindle."""
        atc = atc_of(machine)
        tools = tools_of(machine).sim
        pockets = {n: (n if n in tools and n != spindle_tool else None) for n in range(1, atc.pockets + 1)}
        return cls(spindle_tool or None, pockets)

    def copy(self) -> MagazineState:
        """An independent copy (the pockets' dict is not shared)."""
        return MagazineState(self.spindle, dict(self.pockets))


class MagazineModel:
    """Tools in the spindle and the pockets, moved by replaying a simulated machine's traces."""

    def __init__(self, machine: Machine, state: MagazineState, start_mm: dict[str, float]):
        self.machine = machine
        self.atc = atc_of(machine)
        self.geometry = self.atc.sim
        self.inward = 1.0 if self.atc.y_point_b > self.atc.y_point_a else -1.0
        self.state = state
        self.names = ("X", "Y", "Z", self.atc.axis)
        self.pos = np.array([start_mm.get(n, 0.0) for n in self.names], dtype=float)
        self.violations: list[Violation] = []
        self.events: list[tuple[int, str]] = []          # (tick, what happened to a tool)
        self._flags = self._flags_of(self.pos[None, :])[:, 0]
        self._turning = False
        self._seated_pocket: int | None = None

    # -- geometry -----------------------------------------------------------------------------
    def pocket_at(self, carousel: float) -> int | None:
        """The pocket at the spindle with the carousel at ``carousel`` units, or None."""
        g = self.geometry
        angle = carousel * g.degrees_per_unit
        for pocket in range(1, self.atc.pockets + 1):
            if abs(angle - g.pocket_angle_deg(pocket)) <= g.tolerance_deg:
                return pocket
        return None

    def _flags_of(self, at: np.ndarray) -> np.ndarray:
        """(inside the magazine below Z_POINT_1, at a pocket's clamp point) for rows of positions."""
        a, g = self.atc, self.geometry
        x, y, z = at[:, 0], at[:, 1], at[:, 2]
        inside = (y - g.magazine_y_mm) * self.inward > 0.0
        low = z < a.z_point_1 - _EPS_MM                  # Z+ is up: below the safe height
        seated = (inside & low & (np.abs(y - a.y_point_b) <= g.tolerance_mm)
                  & (np.abs(x - a.x1) <= g.tolerance_mm)
                  & (z <= a.z_point_2 + g.tolerance_mm))
        return np.vstack([inside & low, seated])

    # -- replay ---------------------------------------------------------------------------------
    def replay(self, sim: SimMachine, from_tick: int) -> None:
        """Replay every step of ``sim`` at or after ``from_tick`` (in tick order)."""
        ticks, rows, turned = self._samples(sim, from_tick)
        if not len(ticks):
            return
        flags = self._flags_of(rows)
        before = np.concatenate([self._flags[:, None], flags[:, :-1]], axis=1)
        turn = turned & (flags[0] | before[0])
        turn_before = np.concatenate([[self._turning], turn[:-1]])
        changed = np.flatnonzero((flags != before).any(axis=0) | (turn & ~turn_before))
        for k in changed.tolist():
            self._on_change(int(ticks[k]), rows[k], flags[:, k], before[:, k], turn[k] and not turn_before[k])
        self.pos = rows[-1].copy()
        self._flags = flags[:, -1]
        self._turning = bool(turn[-1])

    def _samples(self, sim: SimMachine, from_tick: int):
        """Positions after each tick that moved an axis: (ticks, rows of X Y Z C, carousel moved)."""
        parts = []
        for a, name in enumerate(self.names):
            trace = sim.traces[name]
            i0 = bisect.bisect_left(trace.ticks, from_tick)
            t = np.asarray(trace.ticks[i0:], dtype=np.int64)
            parts.append((t, np.asarray(trace.carriage_mm[i0:], dtype=float), np.full(len(t), a)))
        ticks = np.concatenate([p[0] for p in parts])
        if not len(ticks):
            return ticks, np.zeros((0, 4)), np.zeros(0, bool)
        order = np.argsort(ticks, kind="stable")
        ticks = ticks[order]
        values = np.concatenate([p[1] for p in parts])[order]
        which = np.concatenate([p[2] for p in parts])[order]
        n = len(ticks)
        rows = np.empty((n, 4))
        for a in range(4):
            last = np.maximum.accumulate(np.where(which == a, np.arange(n), -1))
            rows[:, a] = np.where(last >= 0, values[np.maximum(last, 0)], self.pos[a])
        end_of_tick = np.append(ticks[1:] != ticks[:-1], True)
        group = np.cumsum(np.append(True, end_of_tick[:-1])) - 1
        turned = np.zeros(int(group[-1]) + 1, dtype=bool)
        turned[group[which == 3]] = True
        return ticks[end_of_tick], rows[end_of_tick], turned

    def _on_change(self, tick: int, at: np.ndarray, now, before, turn_started: bool) -> None:
        if turn_started:
            self._flag(tick, "carousel_turn", f"the carousel turned (now at {at[3]:.3f}) while the spindle "
                       f"was inside the magazine at Y {at[1]:.3f}, Z {at[2]:.3f}, below Z_POINT_1 "
                       f"{self.atc.z_point_1:g}; it may turn there only at or above Z_POINT_1")
        if now[0] and not before[0]:
            self._enter(tick, at)
        if now[1] and not before[1]:
            self._seat(tick, at)
        if before[1] and not now[1]:
            self._unseat(tick, at)

    def _enter(self, tick: int, at: np.ndarray) -> None:
        a, g = self.atc, self.geometry
        pocket = self.pocket_at(at[3])
        if abs(at[0] - a.x1) > g.tolerance_mm or pocket is None:
            angle = at[3] * g.degrees_per_unit
            self._flag(tick, "pocket_misaligned", f"the spindle went into the magazine at X {at[0]:.3f} "
                       f"with the disc at {angle:.2f} deg, where no pocket is at the spindle (station "
                       f"X1 {a.x1:g} +- {g.tolerance_mm:g} mm, pocket n at "
                       f"{g.pocket_angle_deg(1):g} + {g.pocket_pitch_deg:g}(n-1) deg +- {g.tolerance_deg:g})")

    def _seat(self, tick: int, at: np.ndarray) -> None:
        pocket = self.pocket_at(at[3])
        self._seated_pocket = pocket
        if pocket is None:
            return
        tool, held = self.state.spindle, self.state.pockets.get(pocket)
        if tool is not None:
            if held is not None:
                self._flag(tick, "pocket_occupied", f"T{tool} pushed into pocket {pocket}, which "
                           f"already holds T{held}; a pocket takes one tool")
            elif tool != pocket:
                self._flag(tick, "wrong_pocket", f"T{tool} went into pocket {pocket}; tool n lives "
                           f"in pocket n, so T{tool} belongs in pocket {tool}")
        elif held is not None:
            self.state.spindle, self.state.pockets[pocket] = held, None
            self.events.append((tick, f"T{held} clamped from pocket {pocket}"))

    def _unseat(self, tick: int, at: np.ndarray) -> None:
        a, g = self.atc, self.geometry
        pocket, self._seated_pocket = self._seated_pocket, None
        lifted = at[2] > a.z_point_2 + g.tolerance_mm
        in_fork = abs(at[1] - a.y_point_b) <= g.tolerance_mm
        tool = self.state.spindle
        if pocket is None or tool is None or not (lifted and in_fork):
            return
        if self.state.pockets.get(pocket) is None:
            self.state.spindle, self.state.pockets[pocket] = None, tool
            self.events.append((tick, f"T{tool} released into pocket {pocket}"))

    def _flag(self, tick: int, kind: str, detail: str) -> None:
        self.violations.append(Violation(tick, "ATC", kind, detail))
