"""Port frames from each axis's bit changes: the merge behind the streamed fast path.

An axis's changes are its step rises and falls (which alternate: a step falls before the next
rises) and its direction turns; each flips its bits, so the port byte after any tick is the
inverted start byte with every change up to it applied. Each axis's changes are listed in tick
order (:func:`axis_events`), the lists merged two at a time (:func:`merge_two`, the changes of
one tick joined) and the last two merged and followed into port bytes (:func:`follow_two`).
"""

from __future__ import annotations

import numpy as np

from ._jit import kernel

_BIG = np.int64(1) << 62


@kernel
def axis_events(rises, i_rise, turns, high, step_mask, dir_mask, limit, ev_t, ev_m):
    """One axis's bit changes before ``limit`` in tick order: (count, falls, rises, turns taken).

    ``rises[:i_rise]`` have risen but not fallen yet (one at most); a change's mask holds the bits
    it flips. Steps alternate rise, fall; the rare turns are slotted in between.
    """
    n_r = rises.shape[0]
    n_rise = np.searchsorted(rises[i_rise:], limit) if i_rise < n_r else 0
    n_fall = np.searchsorted(rises[:i_rise + n_rise], limit - high)      # rise + high < limit
    n_turn = np.searchsorted(turns, limit)
    c = min(n_fall, i_rise)
    for k in range(c):                                    # the fall of a step risen before
        ev_t[k] = rises[k] + high
    taken = rises[i_rise:i_rise + n_rise]                 # rise, then fall (dropped past the limit)
    ev_t[c:c + 2 * n_rise:2] = taken
    ev_t[c + 1:c + 2 * n_rise:2] = taken + high
    steps = n_rise + n_fall
    ev_m[:steps] = step_mask
    if n_turn == 0:
        return steps, n_fall, i_rise + n_rise, 0
    return _slot_turns(ev_t, ev_m, steps, turns[:n_turn], dir_mask), n_fall, i_rise + n_rise, n_turn


@kernel
def _slot_turns(ev_t, ev_m, steps, turns, dir_mask):
    """Slot direction turns into a list of ``steps`` step changes (in place, tick order; a turn at
    the tick of a step change joins it). Returns the new length."""
    n = steps + turns.shape[0]
    src = steps - 1
    dst = n - 1
    for k in range(turns.shape[0] - 1, -1, -1):         # from the end, so nothing is overwritten
        while src >= 0 and ev_t[src] > turns[k]:
            ev_t[dst], ev_m[dst] = ev_t[src], ev_m[src]
            src -= 1
            dst -= 1
        if src >= 0 and ev_t[src] == turns[k]:
            ev_t[dst], ev_m[dst] = ev_t[src], ev_m[src] ^ dir_mask
            src -= 1
        else:
            ev_t[dst], ev_m[dst] = turns[k], dir_mask
        dst -= 1
    gap = dst - src                                      # joined turns leave a gap after ev[:src + 1]
    if gap > 0:
        for k in range(dst + 1, n):
            ev_t[k - gap], ev_m[k - gap] = ev_t[k], ev_m[k]
    return n - gap


@kernel
def merge_two(at, am, bt, bm, out_t, out_m):
    """Two lists of bit changes merged in tick order, the changes of one tick joined."""
    i, j, c = 0, 0, 0
    na, nb = at.shape[0], bt.shape[0]
    while i < na and j < nb:
        ta, tb = at[i], bt[j]
        tick = min(ta, tb)
        out_t[c] = tick
        out_m[c] = (am[i] if ta == tick else 0) ^ (bm[j] if tb == tick else 0)
        i += 1 if ta == tick else 0
        j += 1 if tb == tick else 0
        c += 1
    out_t[c:c + na - i] = at[i:]
    out_m[c:c + na - i] = am[i:]
    c += na - i
    out_t[c:c + nb - j] = bt[j:]
    out_m[c:c + nb - j] = bm[j:]
    return c + nb - j


@kernel
def follow_two(at, am, bt, bm, invert, bits_last, out_ticks, out_values):
    """The port byte after each change of two lists merged in tick order (the changes of one
    tick joined; a byte written only when it differs from the last one)."""
    bits, last = bits_last[0], bits_last[1]
    i, j, count = 0, 0, 0
    na, nb = at.shape[0], bt.shape[0]
    while i < na or j < nb:
        ta = at[i] if i < na else _BIG
        tb = bt[j] if j < nb else _BIG
        tick = min(ta, tb)
        bits ^= (am[i] if ta == tick else 0) ^ (bm[j] if tb == tick else 0)
        i += 1 if ta == tick else 0
        j += 1 if tb == tick else 0
        value = bits ^ invert
        out_ticks[count] = tick
        out_values[count] = value
        count += 1 if value != last else 0
        last = value
    bits_last[0], bits_last[1] = bits, last
    return count
