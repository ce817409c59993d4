"""The controller's kernels checked where a mutation run found them unchecked
(bench/mutation.py): a compiled span hands back the frame whose step would open or close a
limit switch, of its own axis only."""

from __future__ import annotations

import numpy as np

from retrofit.controller.kernels import G_DIR, G_HIGH, _switch_would_change


def would_change(motor_steps, direction, trip_mm, switch_axis, closed=0):
    """Axis 0 (100 steps/mm, no backlash) has a step rising in the next frame from ``motor_steps``
    towards ``direction``; one switch on ``switch_axis`` trips at ``trip_mm`` (+ side)."""
    gen = np.zeros((2, 6), np.int64)
    gen[0, G_HIGH], gen[0, G_DIR] = 1, direction
    sim = np.zeros((2, 2), np.int64)
    sim[0, 1] = motor_steps
    return bool(_switch_would_change(gen, sim, np.zeros(2), np.zeros(2), np.array([100.0, 100.0]),
                                     np.array([switch_axis], np.int64), np.array([1], np.int64),
                                     np.array([trip_mm]), np.array([0.0]), np.array([closed], np.int64)))


def test_the_step_that_reaches_a_switch_is_seen_before_its_frame():
    assert would_change(99, 1, 1.0, switch_axis=0)            # 0.99 mm -> 1.00 mm: it closes
    assert not would_change(98, 1, 1.0, switch_axis=0)        # 0.99 mm: still open
    assert not would_change(99, 1, 1.0, switch_axis=1)        # another axis's switch
    assert would_change(100, -1, 1.0, switch_axis=0, closed=1)   # backing off 1.00 -> 0.99: opens
