"""The per-axis position-error loop of the lathe paper ('EvaluateEroare'), tick by tick.

Reference path, written to be read next to the paper. Each tick:

1. every axis's step generator gives this tick's bits ('PasAvans') and the port byte is
   computed once from all of them ('CalculByte') and recorded once ('WritePort');
2. per axis, error = desired - instantaneous position in steps; its sign sets the direction
   (with backlash compensation on a reversal) and a non-zero error asks for a step;
3. when every axis error is zero, the next target is loaded ('CalcNextInput').
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence

from ..backlash import BacklashCompensator
from ..frames import FrameRecorder, PinMap
from ..machine.config import Machine
from ..runlog import RunLog, Waypoint
from .stepgen import StepGenerator, StepTiming


def _sign(value: int) -> int:
    return (value > 0) - (value < 0)


class PositionErrorLoop:
    """Drives every axis of ``machine`` to a sequence of targets in steps, as 003 does."""

    def __init__(self, machine: Machine, backlash_comp: bool = True,
                 start_steps: Sequence[int] | None = None):
        self.machine = machine
        self.pins = PinMap(machine)
        self.gens = [StepGenerator(StepTiming.of(a)) for a in machine.axes]
        self.comps = [BacklashCompensator(a.backlash_steps, backlash_comp) for a in machine.axes]
        self.position = list(start_steps or [0] * len(machine.axes))   # 'PozInst'
        self.steps_emitted = [0] * len(machine.axes)

    def run(self, targets: Iterable[Sequence[int]], max_ticks: int = 50_000_000) -> RunLog:
        """Visit every target in turn; return the frames and when each target was reached."""
        pending = iter(targets)
        recorder = FrameRecorder()
        log = RunLog(self.machine, frames=None,  # type: ignore[arg-type]  # set when the run ends
                     start_steps=tuple(self.position))
        desired = self._next(pending, log, tick=0)              # 'PozDorita'
        tick = 0
        while tick < max_ticks:
            bits = [gen.frame() for gen in self.gens]
            recorder.put(tick, self.pins.byte([b[0] for b in bits], [b[1] for b in bits]))
            if desired is None and not any(gen.busy for gen in self.gens):
                break
            if desired is not None:
                errors = self.evaluate(desired, tick)
                log.max_following_error_steps = max(log.max_following_error_steps,
                                                    max(abs(e) for e in errors))
                if not any(errors):
                    log.waypoints[-1].reached_tick = tick     # every rising edge is on the wire by now
                    desired = self._next(pending, log, tick + 1)
            tick += 1
        else:
            raise RuntimeError(f"run did not finish within {max_ticks} ticks")
        log.frames = recorder.frames(tick + 1)
        log.steps_emitted = {a.name: n for a, n in zip(self.machine.axes, self.steps_emitted)}
        return log

    def evaluate(self, desired: Sequence[int], tick: int) -> list[int]:
        """One 'EvaluateEroare' after frame ``tick``; returns the errors it started from."""
        errors = [d - p for d, p in zip(desired, self.position)]
        for i, error in enumerate(errors):
            if error == 0:
                continue
            direction = _sign(error)
            gen = self.gens[i]
            if gen.direction != direction:
                if not gen.set_direction(direction):
                    continue                      # direction hold: try again next tick
                self.position[i] = self.comps[i].on_reversal(self.position[i], direction)
            if gen.start_step():
                self.position[i] += direction
                self.steps_emitted[i] += 1
        return errors

    def _next(self, pending, log: RunLog, tick: int):
        target = next(pending, None)
        if target is None:
            return None
        target = tuple(int(t) for t in target)
        log.waypoints.append(Waypoint(target, loaded_tick=tick))
        return target
