"""A progress bar of the real work of a run, on a terminal only, cleared before the summary.

The run's stages (compile, plan, execute, outputs) each take a share of the bar
(:data:`retrofit.run.program.STAGE_WEIGHTS`, measured on a long program); within a stage the bar
follows the work done: commands planned, machine time delivered to the outputs. The estimate of
the time left is the time so far scaled by the share still to do. Off when standard error is not
a terminal, so logs and pipes stay clean.
"""

from __future__ import annotations

import sys
from collections.abc import Iterator

from .. import hold

#: the bar's resolution: units of work in the whole run
TOTAL = 1000


class Progress:
    """Stage-weighted progress; ``enabled=None``: only when standard error is a terminal.

    ``clock`` (a function returning seconds) replaces the host's clock for the estimate."""

    def __init__(self, weights: dict[str, float], enabled: bool | None = None, stream=None, clock=None):
        self.stream = stream or sys.stderr
        if enabled is None:
            enabled = self.stream.isatty()
        self.weights = weights
        self.base: dict[str, float] = {}
        acc = 0.0
        for name, weight in weights.items():
            self.base[name] = acc
            acc += weight
        self.scale = 1.0 / acc
        self.bar = None
        self.shown = 0
        if enabled:
            from tqdm import tqdm
            self.bar = tqdm(total=TOTAL, leave=False, file=self.stream, dynamic_ncols=True,
                            bar_format="{percentage:3.0f}% |{bar}| eta {remaining_s:.0f} s "
                                       "({elapsed_s:.0f} s so far)")
            if clock is not None:                  # the estimate read on another clock (the tests' ticks)
                self.bar._time = clock
                self.bar.reset(total=TOTAL)

    def fraction(self, stage: str, done: float) -> None:
        """``done`` (0..1) of ``stage`` is finished."""
        share = (self.base[stage] + self.weights[stage] * min(max(done, 0.0), 1.0)) * self.scale
        units = int(share * TOTAL)
        if hold.UNITS is not None:
            hold.progress(units)
        if self.bar is not None and units > self.shown:
            self.bar.update(units - self.shown)
            self.shown = units

    def whole(self, done: float) -> None:
        """``done`` (0..1) of a run whose stages go together (a program read ahead): the bar as
        one stage."""
        end = max(self.base[stage] + self.weights[stage] for stage in self.base)
        units = int(min(max(done, 0.0), 1.0) * end * self.scale * TOTAL)
        if hold.UNITS is not None:
            hold.progress(units)
        if self.bar is not None and units > self.shown:
            self.bar.update(units - self.shown)
            self.shown = units

    def done(self, stage: str) -> None:
        """``stage`` is finished."""
        self.fraction(stage, 1.0)

    def counting(self, stage: str, items: list) -> Iterator:
        """Iterate ``items``, moving the bar through ``stage`` as they are taken."""
        if self.bar is None:
            return iter(items)
        return self._count(stage, items)

    def _count(self, stage: str, items: list) -> Iterator:
        n = max(len(items), 1)
        every = max(n // 200, 1)
        for i, item in enumerate(items):
            if i % every == 0:
                self.fraction(stage, i / n)
            yield item
        self.done(stage)

    def close(self) -> None:
        """Clear the bar from the terminal."""
        if self.bar is not None:
            self.bar.close()
            self.bar = None


def silent(weights: dict[str, float]) -> Progress:
    """A progress that shows nothing."""
    return Progress(weights, enabled=False)


