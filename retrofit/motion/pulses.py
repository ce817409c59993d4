"""003's tick loop turning step requests into pulses and port bytes (the controller's output stage).

Each axis has a :class:`~retrofit.motion.stepgen.StepGenerator` and a queue of requests (the tick a
step is wanted on and its direction). Each tick the generators give their bits, the port byte is
computed once and recorded once ('CalculByte', 'WritePort'); then each axis's next request is
tried: a step asked for during a pulse waits, and the direction turns as soon as its hold time
allows once a request in the new direction is queued (requests join the queues when their move
enters the look-ahead window, ``motion.stepshape``). The reference path (``motion.execute.shape_reference``) and the controller both use it.

A simulated machine attached here sees every byte that changes, as it happens, so the switches
the controller reads next are those of a carriage that really took the steps.
"""

from __future__ import annotations

from collections import deque

import numpy as np

from ..frames import FrameRecorder, PinMap
from ..machine.config import Machine
from .stepgen import StepGenerator, StepTiming


class PulseShaper:
    """Step generators, request queues and the port-frame record of one machine."""

    def __init__(self, machine: Machine, sim=None):
        self.pins = PinMap(machine)
        self.gens = [StepGenerator(StepTiming.of(a)) for a in machine.axes]
        self.queues: list[deque] = [deque() for _ in machine.axes]
        self.recorder = FrameRecorder()
        self.sim = sim
        self.motor = [0] * len(machine.axes)             # steps started: the motor counter
        self.wanted: list[list[int]] = [[] for _ in machine.axes]   # tick each request wanted
        self.rises: list[list[int]] = [[] for _ in machine.axes]    # tick each pulse rose
        self._last = -1

    def frame(self, tick: int) -> int:
        """Bits of every axis for ``tick`` ('PasAvans'), the port byte, recorded once."""
        bits = [gen.frame() for gen in self.gens]
        byte = self.pins.byte([b[0] for b in bits], [b[1] for b in bits])
        self.recorder.put(tick, byte)
        if byte != self._last:
            self._last = byte
            if self.sim is not None:
                self.sim.feed_frame(tick, byte)
        return byte

    def request(self, axis: int, due: int, direction: int) -> None:
        """Ask for one step of ``axis`` at tick ``due`` (or as soon after as the driver allows)."""
        self.queues[axis].append((due, direction))
        self.wanted[axis].append(due)

    def requested(self) -> tuple[int, ...]:
        """Requests made so far, per axis."""
        return tuple(len(w) for w in self.wanted)

    def shape(self, tick: int, hint) -> None:
        """After frame ``tick``: start each axis's next step if it is due at ``tick + 1``.

        ``hint(axis)`` gives the direction of an axis's next step when none is queued yet (0 when
        unknown): the direction turns as early as it would with every step already queued.
        """
        for axis, (gen, queue) in enumerate(zip(self.gens, self.queues)):
            if not queue:
                ahead = hint(axis)
                if ahead and ahead != gen.direction:
                    gen.set_direction(ahead)
                continue
            due, direction = queue[0]
            if gen.direction != direction and not gen.set_direction(direction):
                continue                                  # hold time: turn as soon as allowed
            if due <= tick + 1 and gen.start_step():
                queue.popleft()
                self.rises[axis].append(tick + 1)
                self.motor[axis] += direction

    def clear(self) -> None:
        """Drop every request not yet started (STOP, a limit); a pulse under way completes."""
        for axis, queue in enumerate(self.queues):
            if queue:
                del self.wanted[axis][len(self.wanted[axis]) - len(queue):]
                queue.clear()

    @property
    def pending(self) -> bool:
        """True while some request waits to be started."""
        return any(self.queues)

    @property
    def busy(self) -> bool:
        """True while some pulse (or its low time) is under way."""
        return any(gen.busy for gen in self.gens)

    def heading(self, axis: int) -> int:
        """Direction of the next requested step of ``axis`` (0 when none waits)."""
        queue = self.queues[axis]
        return queue[0][1] if queue else 0

    def settled(self, tick: int, hint) -> bool:
        """True when the next frame (``tick``) brings no rising edge and no axis waits to turn its
        direction: until some step is due, frames follow from the generators alone."""
        for axis, (gen, queue) in enumerate(zip(self.gens, self.queues)):
            ahead = queue[0][1] if queue else hint(axis)
            if gen.last_rise == tick or (ahead and ahead != gen.direction):
                return False
        return True

    def still(self) -> bool:
        """True when no pulse is under way and the next frames would all repeat the last one."""
        if any(gen.period or gen.high for gen in self.gens):
            return False
        return self.pins.byte([0] * len(self.gens), [gen.direction for gen in self.gens]) == self._last

    def next_due(self) -> int | None:
        """The earliest tick any queued request is wanted on."""
        heads = [q[0][0] for q in self.queues if q]
        return min(heads) if heads else None

    def skip(self, ticks: int) -> None:
        """Let ``ticks`` frames pass with nothing changing (only when :meth:`quiet`)."""
        for gen in self.gens:
            gen.tick += ticks

    def lag(self) -> int:
        """Following error: the most steps of one axis ever wanted by a tick but not yet risen."""
        worst = 0
        for wanted, risen in zip(self.wanted, self.rises):
            if not risen:
                continue
            wanted_a = np.asarray(wanted, dtype=np.int64)
            risen_a = np.asarray(risen, dtype=np.int64)
            due_by = np.searchsorted(wanted_a, risen_a, side="right")
            worst = max(worst, int(np.max(due_by - np.arange(1, len(risen_a) + 1))))
        return worst
