"""The controller's tick loop, compiled: a stretch of ticks of one running move at a time.

The same rules as the readable tick (:meth:`Controller.tick`), in the same order, on the state
packed into small arrays by :mod:`retrofit.controller.spans`:

1. the frame: each axis's step generator gives its bits (003's ``PasAvans``), the port byte is
   recorded when it changes, and the simulated carriage follows each rising edge;
2. execute: a clock-timed move queues the steps of the cycles now due (their ticks computed
   beforehand by the fast path's :func:`~retrofit.motion.fast.move_requests`); an ISTP move
   reads the spindle's encoder and runs the indexer's two Bresenhams (counts -> base steps ->
   every axis); a homing jogs its axis towards (or off) its switch;
3. shape: each axis's next request starts a pulse when it is due and the generator allows.

Ticks in which none of that can change anything are passed over (:func:`_quiet_until`). A span
stops *before* any tick the readable controller must decide itself -- a switch that would
change, the arming of an ISTP pass on an index pulse, the last cycle of a move, the end of a
homing's back-off -- and hands that tick back; so the two paths give the same frames, bit for
bit, however they take turns.
"""

from __future__ import annotations

import numpy as np

from ..motion._jit import kernel
from ..motion.fast import _tie
from ..sim.spindle import F_RPM, F_TARGET, FRACTION_BITS, S_ANGLE, S_INDEX_COUNT, S_TICK, spindle_step

# step generator slots (gen[a, :]) and timing slots (tim[a, :])
G_HIGH, G_PERIOD, G_TICK, G_DIR, G_RISE, G_TURN = range(6)
T_HIGH, T_LOW, T_SETUP, T_HOLD = range(4)
# queue slots (qs[a, :]): first waiting, one past the last queued, one past the last known
Q_HEAD, Q_TAIL, Q_KNOWN = range(3)
# indexer slots (ix[:])
(X_PHASE, X_SEEN, X_SNUM, X_SDEN, X_ONUM, X_ODEN, X_LEAD, X_COUNTS, X_STEPS, X_CAP, X_CYCLE,
 X_LAST_COUNT, X_LAST_DUE, X_N) = range(14)
SYNC, ARMED, RUN = 1, 2, 3
# homing jog slots: integers (hj[:]) and floats (hf[:])
J_AXIS, J_DIR, J_STEPS, J_MAX, J_STOP = range(5)
J_SPEED, J_OWED, J_TARGET, J_ACCEL, J_DT = range(5)
CLOCK, INDEX, HOME = 0, 1, 2
_EPS_MM = 1e-9


@kernel
def index_target(ix, count):
    """Whole base steps due at encoder ``count`` (``IndexerTrack.target``, exact integers)."""
    o_num, o_den, lead = ix[X_ONUM], ix[X_ODEN], ix[X_LEAD]
    if count * o_den <= o_num - lead * o_den:
        return 0
    if lead and count * o_den < o_num + lead * o_den:
        rel = count * o_den - o_num + lead * o_den
        num = ix[X_SNUM] * rel * rel
        den = ix[X_SDEN] * 4 * ix[X_COUNTS] * lead * o_den * o_den
    else:
        num = ix[X_SNUM] * (count * o_den - o_num)
        den = ix[X_SDEN] * ix[X_COUNTS] * o_den
    due = (2 * num + den) // (2 * den)
    return min(max(due, 0), ix[X_STEPS])


@kernel
def _switch_would_change(gen, sim, gap, width, spm, sw_axis, sw_side, sw_trip, sw_hyst, sw_closed):
    """True when a step rising in the next frame would open or close a switch."""
    for a in range(gen.shape[0]):
        if gen[a, G_HIGH] <= 0 or sim[a, 0] != 0:
            continue
        d = gen[a, G_DIR]
        g = min(max(gap[a] + d, 0.0), width[a])
        carriage = (sim[a, 1] + d - g) / spm[a]
        for k in range(sw_axis.shape[0]):
            if sw_axis[k] != a:
                continue
            slack = sw_hyst[k] if sw_closed[k] else 0.0
            now = 1 if sw_side[k] * (carriage - sw_trip[k]) >= -slack - _EPS_MM else 0
            if now != sw_closed[k]:
                return True
    return False


@kernel
def _frame(t, gen, smask, dmask, invert, has_sim, sim, gap, width):
    """The port byte of frame ``t``; the generators advance, the carriages follow the rises."""
    value = 0
    for a in range(gen.shape[0]):
        step = 0
        if gen[a, G_HIGH] > 0:
            step = 1
            gen[a, G_HIGH] -= 1
            gen[a, G_PERIOD] -= 1
        elif gen[a, G_PERIOD] > 0:
            gen[a, G_PERIOD] -= 1
        gen[a, G_TICK] += 1
        if step:
            value |= smask[a]
        if gen[a, G_DIR] > 0:
            value |= dmask[a]
        if has_sim:
            if step == 1 and sim[a, 0] == 0:
                sim[a, 1] += gen[a, G_DIR]
                gap[a] = min(max(gap[a] + gen[a, G_DIR], 0.0), width[a])
            sim[a, 0] = step
    return value ^ invert


@kernel
def _turn(gen, tim, a, direction):
    """``StepGenerator.set_direction``: False while the hold time forbids the turn."""
    if direction == gen[a, G_DIR]:
        return True
    if (gen[a, G_TICK] + 1) - gen[a, G_RISE] < tim[a, T_HOLD]:
        return False
    gen[a, G_DIR] = direction
    gen[a, G_TURN] = gen[a, G_TICK] + 1
    return True


@kernel
def _shape(t, gen, tim, q_due, q_dir, qs, hint, motor, r_ticks, r_n):
    """``PulseShaper.shape`` after frame ``t``."""
    for a in range(gen.shape[0]):
        head = qs[a, Q_HEAD]
        if head == qs[a, Q_TAIL]:
            if hint[a] != 0 and hint[a] != gen[a, G_DIR]:
                _turn(gen, tim, a, hint[a])
            continue
        direction = q_dir[a, head]
        if gen[a, G_DIR] != direction and not _turn(gen, tim, a, direction):
            continue
        if q_due[a, head] <= t + 1 and gen[a, G_PERIOD] == 0 and \
                (gen[a, G_TICK] + 1) - gen[a, G_TURN] >= tim[a, T_SETUP]:
            gen[a, G_HIGH] = tim[a, T_HIGH]
            gen[a, G_PERIOD] = tim[a, T_HIGH] + tim[a, T_LOW]
            gen[a, G_RISE] = gen[a, G_TICK] + 1
            qs[a, Q_HEAD] = head + 1
            r_ticks[a, r_n[a]] = t + 1
            r_n[a] += 1
            motor[a] += direction


@kernel
def _clock_execute(t, q_gen, qs, line_dir, left, hint, win_hint):
    """The cycles due by ``t + 1`` join the queues; the hint of an axis whose steps are all
    queued passes to the next move in the window."""
    for a in range(qs.shape[0]):
        j = qs[a, Q_TAIL]
        while j < qs[a, Q_KNOWN] and q_gen[a, j] <= t + 1:
            j += 1
            left[a] -= 1
        qs[a, Q_TAIL] = j
        hint[a] = line_dir[a] if left[a] > 0 else win_hint[a]


@kernel
def _index_cycles(t, due, ix, err, inc, line_dir, q_due, q_dir, qs):
    """The line's Bresenham cycles up to base step ``due``; their steps wanted at ``t + 1``."""
    n = ix[X_N]
    while ix[X_CYCLE] < due:
        ix[X_CYCLE] += 1
        k = ix[X_CYCLE]
        for a in range(err.shape[0]):
            err[a] += inc[a]
            if err[a] > n or (err[a] == n and _tie(k, n, line_dir[a])):
                err[a] -= 2 * n
                j = qs[a, Q_TAIL]
                q_due[a, j] = t + 1
                q_dir[a, j] = line_dir[a]
                qs[a, Q_TAIL] = j + 1


@kernel
def _index_decide(ix, si, sf, qs):
    """What the ISTP move does at this tick: (phase, seen index, base steps due), or phase 0
    when the readable controller must take the tick (arming on an index, the last cycle)."""
    phase, seen, due = ix[X_PHASE], ix[X_SEEN], 0
    count = si[S_ANGLE] >> FRACTION_BITS
    if phase == SYNC:
        pending = False
        for a in range(qs.shape[0]):
            if qs[a, Q_HEAD] < qs[a, Q_TAIL]:
                pending = True
        if pending or not sf[F_RPM] == sf[F_TARGET]:
            seen = si[S_INDEX_COUNT]
        elif si[S_INDEX_COUNT] != seen:
            return 0, seen, due
    if phase == ARMED and count * ix[X_ODEN] >= ix[X_ONUM] - ix[X_LEAD] * ix[X_ODEN]:
        phase = RUN
    if phase == RUN:
        if count > ix[X_CAP]:
            return 0, seen, due
        if count != ix[X_LAST_COUNT]:                  # the target moves only with the count
            ix[X_LAST_COUNT], ix[X_LAST_DUE] = count, index_target(ix, count)
        due = ix[X_LAST_DUE]
        if due >= ix[X_STEPS]:
            return 0, seen, due
    return phase, seen, due


@kernel
def _jog(t, hj, hf, q_due, q_dir, qs):
    """``homing.Jog.step`` after frame ``t``: ramp towards the target speed, step when owed."""
    accel_dt = hf[J_ACCEL] * hf[J_DT]
    if hf[J_SPEED] < hf[J_TARGET]:
        hf[J_SPEED] = min(hf[J_TARGET], hf[J_SPEED] + accel_dt)
    else:
        hf[J_SPEED] = max(hf[J_TARGET], hf[J_SPEED] - accel_dt)
    hf[J_OWED] = min(hf[J_OWED] + hf[J_SPEED] * hf[J_DT], 2.0)
    a = hj[J_AXIS]
    if hf[J_OWED] >= 1.0 and qs[a, Q_HEAD] == qs[a, Q_TAIL]:
        hf[J_OWED] -= 1.0
        hj[J_STEPS] += 1
        j = qs[a, Q_TAIL]
        q_due[a, j] = t + 1
        q_dir[a, j] = hj[J_DIR]
        qs[a, Q_TAIL] = j + 1


@kernel
def _quiet_until(t, t_end, timed, gen, dmask, invert, last, q_due, q_dir, q_gen, qs, hint, stop_due):
    """The first tick from ``t`` on whose frame or shaping changes something (``t``: this one),
    when no step is under way, none is due and the directions wait for nothing; ``timed``: the
    clock's cycles decide when requests come (else one tick at a time, the encoder decides)."""
    value = 0
    until = t_end
    if timed:
        until = min(until, stop_due - 1)
    for a in range(gen.shape[0]):
        if gen[a, G_HIGH] > 0 or gen[a, G_PERIOD] > 0:
            return t
        if gen[a, G_DIR] > 0:
            value |= dmask[a]
        head = qs[a, Q_HEAD]
        if head < qs[a, Q_TAIL]:
            if q_dir[a, head] != gen[a, G_DIR]:
                return t
            until = min(until, q_due[a, head] - 1)
        elif hint[a] != 0 and hint[a] != gen[a, G_DIR]:
            return t
        if timed and qs[a, Q_TAIL] < qs[a, Q_KNOWN]:
            until = min(until, q_gen[a, qs[a, Q_TAIL]] - 1)
    if value ^ invert != last or until <= t:
        return t
    return until if timed else t + 1


@kernel
def run_span(kind, t, t_end, gen, tim, smask, dmask, invert, last, q_due, q_dir, q_gen, qs, motor,
             r_ticks, r_n, f_ticks, f_values, line_dir, left, win_hint, stop_due,
             has_sim, sim, gap, width, spm, sw_axis, sw_side, sw_trip, sw_hyst, sw_closed,
             ix, err, inc, si, sf, spar, draws, history, hj, hf):
    """Ticks ``t`` .. at most ``t_end - 1`` of one running move (``kind`` CLOCK, INDEX or HOME).

    Returns (first tick not run, last byte, frames recorded, spindle ticks run).
    """
    hint = np.zeros(gen.shape[0], dtype=np.int64)
    if kind == CLOCK:
        for a in range(gen.shape[0]):
            hint[a] = line_dir[a] if left[a] > 0 else win_hint[a]
    n_f = 0
    h = 0
    while t < t_end:
        phase, seen, due = 0, 0, 0
        if kind == CLOCK:
            if stop_due <= t + 1:
                break
        elif kind == HOME:
            if hj[J_STEPS] > hj[J_MAX] or hj[J_STEPS] >= hj[J_STOP]:
                break
        else:
            while si[S_TICK] < t:                      # the spindle to the end of tick t
                spindle_step(si, sf, spar, draws, si[S_TICK] + 1)
                history[h] = si[S_ANGLE]
                h += 1
            phase, seen, due = _index_decide(ix, si, sf, qs)
            if phase == 0:
                break
        if kind != HOME and (kind == CLOCK or phase != RUN or due <= ix[X_CYCLE]):
            quiet = _quiet_until(t, t_end, kind == CLOCK, gen, dmask, invert, last, q_due, q_dir, q_gen, qs,
                                 hint, stop_due)
            if quiet > t:                              # frames alone: the generators' clocks run on
                for a in range(gen.shape[0]):
                    gen[a, G_TICK] += quiet - t
                if kind == INDEX:
                    ix[X_PHASE], ix[X_SEEN] = phase, seen
                t = quiet
                continue
        if has_sim and _switch_would_change(gen, sim, gap, width, spm, sw_axis, sw_side, sw_trip,
                                            sw_hyst, sw_closed):
            break
        value = _frame(t, gen, smask, dmask, invert, has_sim, sim, gap, width)
        if value != last:
            f_ticks[n_f] = t
            f_values[n_f] = value
            n_f += 1
            last = value
        if kind == CLOCK:
            _clock_execute(t, q_gen, qs, line_dir, left, hint, win_hint)
        elif kind == HOME:
            _jog(t, hj, hf, q_due, q_dir, qs)
        else:
            ix[X_PHASE], ix[X_SEEN] = phase, seen
            if phase == RUN:
                _index_cycles(t, due, ix, err, inc, line_dir, q_due, q_dir, qs)
        _shape(t, gen, tim, q_due, q_dir, qs, hint, motor, r_ticks, r_n)
        t += 1
    return t, last, n_f, h
