"""The two-axis walk into port bytes gives the bytes of the lists of changes, merged and followed."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from retrofit.motion.bitmerge import axis_events, follow_two, follow_two_axes


@st.composite
def axis_changes(draw, step: int, direction: int):
    """An axis's rises (a pulse ``high`` ticks long, at least one tick low between pulses), its
    turns (some on a step's tick, some alone) and whether its first pulse rose before."""
    high = draw(st.integers(1, 4))
    gaps = draw(st.lists(st.integers(high + 1, high + 6), max_size=30))
    rises = np.cumsum([draw(st.integers(0, 5))] + gaps).astype(np.int64)
    ticks = sorted(set(draw(st.lists(st.integers(0, int(rises[-1]) + 8), max_size=6))))
    return rises, draw(st.integers(0, 1)), np.array(ticks, np.int64), high, step, direction


def walked(a, b, limit, invert):
    out_t, out_v = np.empty(200, np.int64), np.empty(200, np.uint8)
    bits_last, taken = np.array([0, invert], np.int64), np.zeros(6, np.int64)
    n = follow_two_axes(*a[:2], a[2], np.int64(a[3]), np.int64(a[4]), np.int64(a[5]),
                        *b[:2], b[2], np.int64(b[3]), np.int64(b[4]), np.int64(b[5]),
                        np.int64(limit), np.int64(invert), bits_last, out_t, out_v, taken)
    return out_t[:n].tolist(), out_v[:n].tolist(), bits_last.tolist(), taken.tolist()


def listed(a, b, limit, invert):
    lists, taken = [], []
    for rises, i_rise, turns, high, step, direction in (a, b):
        ev_t, ev_m = np.empty(200, np.int64), np.empty(200, np.uint8)
        c, fallen, risen, turned = axis_events(rises, np.int64(i_rise), turns, np.int64(high), np.int64(step),
                                               np.int64(direction), np.int64(limit), ev_t, ev_m)
        lists.append((ev_t[:c], ev_m[:c]))
        taken += [int(fallen), int(risen), int(turned)]
    out_t, out_v = np.empty(200, np.int64), np.empty(200, np.uint8)
    bits_last = np.array([0, invert], np.int64)
    n = follow_two(*lists[0], *lists[1], np.int64(invert), bits_last, out_t, out_v)
    return out_t[:n].tolist(), out_v[:n].tolist(), bits_last.tolist(), taken


@settings(max_examples=150, deadline=None)
@given(axis_changes(0b01, 0b10), axis_changes(0b100, 0b1000), st.integers(0, 200), st.sampled_from([0, 0b0101]))
def test_two_axis_walk_equals_the_merged_lists(a, b, limit, invert):
    """Pulses of one axis between the other's changes, turns on a step's tick, a pulse risen
    before the window, a limit anywhere: the same bytes at the same ticks, the same taken."""
    assert walked(a, b, limit, invert) == listed(a, b, limit, invert)
