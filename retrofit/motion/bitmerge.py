"""Port frames from each axis's bit changes: the merge behind the streamed fast path.

An axis's changes are its step rises and falls (which alternate: a step falls before the next
rises) and its direction turns; each flips its bits, so the port byte after any tick is the
inverted start byte with every change up to it applied. Each axis's changes are listed in tick
order (:func:`axis_events`), the lists merged two at a time (:func:`merge_two`, the changes of
one tick joined) and the last two merged and followed into port bytes (:func:`follow_two`).
When at most two axes have changes (most stretches of most programs), :func:`follow_two_axes`
walks their rises, falls and turns straight into port bytes, with no list in between.
"""

from __future__ import annotations

import numpy as np

from ..frames import PortFrames
from ._jit import kernel

_BIG = np.int64(1) << 62
_NONE = np.zeros(0, np.int64)


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


@kernel
def follow_two_axes(rises_a, i_rise_a, turns_a, high_a, step_a, dir_a,
                    rises_b, i_rise_b, turns_b, high_b, step_b, dir_b,
                    limit, invert, bits_last, out_ticks, out_values, taken):
    """The port bytes of two axes' changes before ``limit`` (what :func:`axis_events` of each
    and :func:`follow_two` make, in one walk); returns the bytes written.

    Per axis: ``rises[:i_rise]`` have risen but not fallen yet (one at most); a step falls
    ``high`` ticks after it rises; ``step``/``dir`` are the bits a rise or fall / a turn flips (an
    axis with no rises and no turns changes nothing). ``taken`` gets per axis (falls, rises,
    turns) taken: a, then b. The two axes' steps are written out twice, not shared through a
    function taking the arrays: that call costs more than the walk (three times the time).
    While one axis's next change comes before any of the other's, and before its own next turn,
    its pulses (a fall, then the next rise) are walked a pair at a time: a long pass along one
    axis costs half the time it would one change at a time.
    """
    n_ra, n_rb = np.searchsorted(rises_a, limit), np.searchsorted(rises_b, limit)
    n_ta, n_tb = np.searchsorted(turns_a, limit), np.searchsorted(turns_b, limit)
    ra, rb, ta, tb = i_rise_a, i_rise_b, 0, 0
    fall_a = rises_a[ra - 1] + high_a if ra > 0 else _BIG
    fall_b = rises_b[rb - 1] + high_b if rb > 0 else _BIG
    rise_a = rises_a[ra] if ra < n_ra else _BIG
    rise_b = rises_b[rb] if rb < n_rb else _BIG
    turn_a = turns_a[0] if n_ta > 0 else _BIG
    turn_b = turns_b[0] if n_tb > 0 else _BIG
    next_a, next_b = min(fall_a, rise_a, turn_a), min(fall_b, rise_b, turn_b)
    bits, last = bits_last[0], bits_last[1]
    count = 0
    while True:
        tick = min(next_a, next_b)
        if tick >= limit:
            break
        if next_a < next_b:                               # a alone: its steps, fall then rise, at once
            cap = min(next_b, limit, turn_a)
            while fall_a < rise_a and rise_a < cap:
                bits ^= step_a
                value = bits ^ invert
                out_ticks[count] = fall_a
                out_values[count] = value
                count += 1 if value != last else 0
                last = value
                bits ^= step_a
                value = bits ^ invert
                out_ticks[count] = rise_a
                out_values[count] = value
                count += 1 if value != last else 0
                last = value
                fall_a = rise_a + high_a
                ra += 1
                rise_a = rises_a[ra] if ra < n_ra else _BIG
            next_a = min(fall_a, rise_a, turn_a)
            tick = min(next_a, next_b)
            if tick >= limit:
                break
        if next_b < next_a:                               # b alone: the same walk
            cap = min(next_a, limit, turn_b)
            while fall_b < rise_b and rise_b < cap:
                bits ^= step_b
                value = bits ^ invert
                out_ticks[count] = fall_b
                out_values[count] = value
                count += 1 if value != last else 0
                last = value
                bits ^= step_b
                value = bits ^ invert
                out_ticks[count] = rise_b
                out_values[count] = value
                count += 1 if value != last else 0
                last = value
                fall_b = rise_b + high_b
                rb += 1
                rise_b = rises_b[rb] if rb < n_rb else _BIG
            next_b = min(fall_b, rise_b, turn_b)
            tick = min(next_a, next_b)
            if tick >= limit:
                break
        flip = 0
        if next_a == tick:
            if fall_a == tick:
                flip ^= step_a
                fall_a = _BIG
            if rise_a == tick:
                flip ^= step_a
                fall_a = tick + high_a
                ra += 1
                rise_a = rises_a[ra] if ra < n_ra else _BIG
            if turn_a == tick:
                flip ^= dir_a
                ta += 1
                turn_a = turns_a[ta] if ta < n_ta else _BIG
            next_a = min(fall_a, rise_a, turn_a)
        if next_b == tick:
            if fall_b == tick:
                flip ^= step_b
                fall_b = _BIG
            if rise_b == tick:
                flip ^= step_b
                fall_b = tick + high_b
                rb += 1
                rise_b = rises_b[rb] if rb < n_rb else _BIG
            if turn_b == tick:
                flip ^= dir_b
                tb += 1
                turn_b = turns_b[tb] if tb < n_tb else _BIG
            next_b = min(fall_b, rise_b, turn_b)
        bits ^= flip
        value = bits ^ invert
        out_ticks[count] = tick
        out_values[count] = value
        count += 1 if value != last else 0
        last = value
    bits_last[0], bits_last[1] = bits, last
    taken[0], taken[1], taken[2] = ra - (1 if fall_a != _BIG else 0), ra, ta
    taken[3], taken[4], taken[5] = rb - (1 if fall_b != _BIG else 0), rb, tb
    return count


def merge_pending(pending, limit: int, high, step_mask, dir_mask, invert: int, bits_last, first: bool) -> PortFrames:
    """Port frames of the pending events (``stream._Axes``) before ``limit``; what is merged leaves ``pending``.

    Each axis's bit changes (rise, fall, turn: each flips its bit) are listed in tick order, the
    axes' lists merged two at a time (changes at one tick joined), then the byte follows them;
    changes of two axes or fewer are walked into bytes at once.
    """
    active = [a for a in range(len(pending.rises)) if _changes_before(pending, a, limit)]
    if len(active) <= 2:
        return _merge_two_axes(pending, active, limit, high, step_mask, dir_mask, invert, bits_last, first)
    streams = []
    for a in active:
        rises, turns = pending.rises[a], pending.turns[a]
        ev_t = np.empty(2 * len(rises) + len(turns), np.int64)
        ev_m = np.empty(len(ev_t), np.uint8)
        c, fallen, risen, turned = axis_events(rises, int(pending.i_rise[a]), turns, high[a], step_mask[a],
                                                dir_mask[a], np.int64(limit), ev_t, ev_m)
        pending.rises[a] = rises[fallen:]
        pending.i_rise[a] = risen - fallen
        pending.turns[a], pending.turn_dirs[a] = turns[turned:], pending.turn_dirs[a][turned:]
        streams.append((ev_t[:c], ev_m[:c]))
    while len(streams) > 2:
        (at, am), (bt, bm) = streams.pop(), streams.pop()
        out_t, out_m = np.empty(len(at) + len(bt), np.int64), np.empty(len(at) + len(bt), np.uint8)
        c = merge_two(at, am, bt, bm, out_t, out_m)
        streams.append((out_t[:c], out_m[:c]))
    empty = (np.zeros(0, np.int64), np.zeros(0, np.uint8))
    (at, am), (bt, bm) = (streams + [empty, empty])[:2]
    start = 1 if first else 0
    out_ticks = np.empty(len(at) + len(bt) + start, np.int64)
    out_values = np.empty(len(out_ticks), np.uint8)
    if first:
        out_ticks[0], out_values[0] = 0, invert
        bits_last[0], bits_last[1] = 0, invert
    n = start + follow_two(at, am, bt, bm, np.int64(invert), bits_last, out_ticks[start:], out_values[start:])
    return PortFrames(out_ticks[:n], out_values[:n], min(int(limit), int(_BIG)))


def _changes_before(pending, a: int, limit: int) -> bool:
    """Whether axis ``a`` has a bit change before ``limit`` (a turn made ahead for a move far
    off, say, leaves the axis out of the merge until then)."""
    rises, turns = pending.rises[a], pending.turns[a]
    return bool((len(rises) and rises[0] < limit) or (len(turns) and turns[0] < limit))


def _merge_two_axes(pending, active: list[int], limit: int, high, step_mask, dir_mask, invert: int,
                    bits_last, first: bool) -> PortFrames:
    """:func:`_merge` of the changes of the two axes (or fewer) in ``active``."""
    size = 1 + sum(2 * len(pending.rises[a]) + len(pending.turns[a]) for a in active)
    out_ticks, out_values = np.empty(size, np.int64), np.empty(size, np.uint8)
    start = 1 if first else 0
    if first:
        out_ticks[0], out_values[0] = 0, invert
        bits_last[0], bits_last[1] = 0, invert
    columns = []
    for a in (active + [-1, -1])[:2]:
        if a < 0:
            columns += [_NONE, np.int64(0), _NONE, np.int64(0), np.int64(0), np.int64(0)]
        else:
            columns += [pending.rises[a], pending.i_rise[a], pending.turns[a], high[a], step_mask[a], dir_mask[a]]
    taken = np.zeros(6, np.int64)
    n = start + follow_two_axes(*columns, np.int64(limit), np.int64(invert), bits_last, out_ticks[start:],
                                out_values[start:], taken)
    for a, (fallen, risen, turned) in zip(active, (taken[:3].tolist(), taken[3:].tolist())):
        pending.rises[a] = pending.rises[a][fallen:]
        pending.i_rise[a] = risen - fallen
        pending.turns[a], pending.turn_dirs[a] = pending.turns[a][turned:], pending.turn_dirs[a][turned:]
    return PortFrames(out_ticks[:n], out_values[:n], min(int(limit), int(_BIG)))
