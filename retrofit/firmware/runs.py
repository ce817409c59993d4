"""Measurements of whole runs on the firmware in simavr: a program streamed through the link as a
host sends it, and the acceleration an axis really had, from its step times (the bench's and the
step-generation tests' figures)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..machine.config import Machine
from .sim import F_CPU, Harness


def send_through_link(elf: Path, machine: Machine, commands, speed: float = 1.0):
    """Run ``commands`` on the firmware in simavr as a host streams them through the link
    (``serial+socket://``: BUSY waited out, NAKs resent), the AVR's time at most ``speed`` times
    the wall clock's; (the harness log, the ``remote`` summary of the serial output)."""
    from ..outputs import open_output
    harness = Harness(elf, machine, listen="127.0.0.1:0", speed=speed).start()
    try:
        out = open_output(f"serial+socket://{harness.address}", machine)
        try:
            remote = out.send_program(commands)
        finally:
            out.close()
    finally:
        log = harness.stop(5)
    return log, remote


def windowed_accel(rises: np.ndarray, window_s: float, step_s: float = 0.001) -> float:
    """The largest acceleration (steps/s^2) of one axis from its step times (cycles): the second
    difference of the step count over windows of ``window_s``, sampled every ``step_s``. Counting
    whole steps, each count is off by less than one step, so the figure may exceed the real
    acceleration by less than 2 steps / window_s^2 (the quantisation)."""
    if len(rises) < 3:
        return 0.0
    w, h = int(window_s * F_CPU), int(step_s * F_CPU)
    t = np.arange(int(rises[0]) + w, int(rises[-1]) - w, h)
    if not len(t):
        return 0.0
    x = lambda at: np.searchsorted(rises, at, side="right").astype(np.float64)   # noqa: E731
    second = x(t + w) - 2 * x(t) + x(t - w)
    return float(np.abs(second).max() / window_s ** 2)
