"""The processor's side of 004's split: the run's port frames turned into each axis's pulse
records (delay, direction, width in ticks), as the ARM sends them to the FPGA.

The step timing itself (rises, turns, set-up and hold) is the controller's, already in the frames
(``motion.stepshape``); this module only reads each axis's events back out of them: a rising
edge of the step pin (its width known at the falling edge) or a change of the direction pin.
A gap longer than a record's delay can hold is bridged by fillers (width 0, direction unchanged).
"""

from __future__ import annotations

from ..errors import OutputError
from ..frames import PinMap, PortFrames
from .record import MAX_DELAY, MAX_WIDTH, pack


class AxisRecords:
    """One axis's events read from its step and direction bits, chunk after chunk."""

    def __init__(self, name: str, step_mask: int, dir_mask: int):
        self.name, self.step_mask, self.dir_mask = name, step_mask, dir_mask
        self.step, self.dir = 0, 0            # the pins' levels so far (logical)
        self.last_event, self.held = 0, 0     # tick and direction of the last record
        self.events: list[list[int]] = []     # [tick, dir, width]; width -1 until the pulse falls
        self.words: list[int] = []

    def feed(self, tick: int, logical: int) -> None:
        step, direction = int(bool(logical & self.step_mask)), int(bool(logical & self.dir_mask))
        if self.step and not step:
            pulse = next(e for e in self.events if e[2] < 0)
            pulse[2] = tick - pulse[0]
        if step and not self.step:
            self.events.append([tick, direction, -1])      # a turn at a rise goes in its record
        elif direction != self.dir:
            self.events.append([tick, direction, 0])       # a turn alone
        self.step, self.dir = step, direction
        while self.events and self.events[0][2] >= 0:
            self._emit(*self.events.pop(0))

    @property
    def rising(self) -> bool:
        """True while a pulse is high (its record waits for the falling edge)."""
        return bool(self.events)

    def _emit(self, tick: int, direction: int, width: int) -> None:
        if width > MAX_WIDTH:
            raise OutputError(f"axis {self.name}: a pulse of {width} ticks at tick {tick}; a record "
                              f"holds 1..{MAX_WIDTH} ticks (pulse_high_ticks in the machine file)")
        delay = tick - self.last_event
        while delay > MAX_DELAY:
            self.words.append(pack(MAX_DELAY, self.held, 0))
            delay -= MAX_DELAY
        self.words.append(pack(delay, direction, width))
        self.last_event, self.held = tick, direction

    def take(self) -> list[int]:
        """The records completed so far, removed from the queue."""
        words, self.words = self.words, []
        return words


class RecordCompiler:
    """Every axis's records from a machine's port frames (streamed: chunks in tick order)."""

    def __init__(self, machine):
        pins = PinMap(machine)
        self.invert = pins.invert
        self.axes = [AxisRecords(a.name, sm, dm)
                     for a, sm, dm in zip(machine.axes, pins.step_masks, pins.dir_masks)]

    def feed(self, frames: PortFrames) -> list[list[int]]:
        """The records each axis completed with these frames."""
        for tick, value in zip(frames.ticks.tolist(), frames.values.tolist()):
            logical = value ^ self.invert
            for axis in self.axes:
                axis.feed(tick, logical)
        return [axis.take() for axis in self.axes]


    def finish(self, end_tick: int) -> list[list[int]]:
        """The records left at the run's end (a pulse still high is closed at ``end_tick``)."""
        for axis in self.axes:
            if axis.rising:
                axis.feed(end_tick, axis.dir_mask if axis.dir else 0)
        return [axis.take() for axis in self.axes]


def compile_records(machine, frames: PortFrames) -> list[list[int]]:
    """All records of a whole run's frames, per axis."""
    comp = RecordCompiler(machine)
    return [a + b for a, b in zip(comp.feed(frames), comp.finish(frames.end_tick))]
