"""The simulator's compiled decoder: one axis's driver, lead screw and switches over a chunk of frames.

Same rules as the readable per-step path (``drivers.DriverInput`` and ``SimMachine._move``), run
as one compiled loop over the port frames of a chunk. Everything the loop needs to continue with
the next chunk lives in small state arrays, so a run of any length is decoded chunk by chunk:

* driver state ``ds`` (int64): step bit, direction, last rise, last fall, last direction turn;
* motor state ``ms`` (int64): motor steps, last direction moved, reversals, out of travel;
* the screw's gap ``gap[0]`` (float64, motor steps inside the dead band);
* every switch of the axis closed or open (``sw_closed``).

Violations and switch changes come back as events (tick, code, values) the caller words;
the carriage after a step goes to a trace buffer for the steps asked (``trace_first``, then every
``trace_stride``-th step of the call; a stride of 0 keeps none).
"""

from __future__ import annotations

import numpy as np

from ..motion._jit import kernel

# driver state slots
D_STEP, D_DIR, D_RISE, D_FALL, D_TURN = 0, 1, 2, 3, 4
# motor state slots
M_MOTOR, M_LAST_DIR, M_REVERSALS, M_OUT = 0, 1, 2, 3
# axis parameter slots (int64)
P_INVERT, P_STEP_BIT, P_DIR_BIT, P_HIGH, P_LOW, P_SETUP, P_HOLD = 0, 1, 2, 3, 4, 5, 6
# violation codes, in the order the driver checks them at one tick
V_DIR_HOLD, V_PULSE_HIGH, V_PULSE_LOW, V_DIR_SETUP, V_TRAVEL = 0, 1, 2, 3, 4
KINDS = ("dir_hold", "pulse_high", "pulse_low", "dir_setup", "travel")

_EPS_MM = 1e-9


@kernel
def decode_axis(ticks, values, par, ds, ms, gap, width, spm, lo, hi,
                sw_side, sw_trip, sw_hyst, sw_closed,
                watch, watch_out, end_tick, trace_first, trace_stride,
                tr_ticks, tr_motor, tr_carriage,
                v_ticks, v_codes, v_values, v_carriage, sw_ticks, sw_index, sw_state):
    """Decode one axis over a chunk of frames; return (trace points, violations, switch events,
    watched, steps).

    ``watch`` is a sorted array of ticks whose (motor, carriage) at the end of the tick are
    written to ``watch_out`` (a row per watched tick: motor, carriage) for those below ``end_tick``.
    Output buffers must hold one row per frame (violations: four per frame plus one per frame).
    """
    logical_mask = par[P_INVERT]
    sb, db = par[P_STEP_BIT], par[P_DIR_BIT]
    p_hold, p_high, p_low, p_setup = par[P_HOLD], par[P_HIGH], par[P_LOW], par[P_SETUP]
    n_watch, n_sw_k = watch.shape[0], sw_side.shape[0]
    lo_in, hi_in = lo - 1e-9, hi + 1e-9
    n_tr = 0
    n_v = 0
    n_sw = 0
    w = 0
    step, direction = ds[D_STEP], ds[D_DIR]
    last_rise, last_fall, last_turn = ds[D_RISE], ds[D_FALL], ds[D_TURN]
    motor, last_dir, reversals, out = ms[M_MOTOR], ms[M_LAST_DIR], ms[M_REVERSALS], ms[M_OUT]
    g = gap[0]
    steps = 0
    kept_next = trace_first
    for i in range(ticks.shape[0]):
        tick = ticks[i]
        logical = np.int64(values[i]) ^ logical_mask
        s = (logical >> sb) & 1
        d = np.int64(1) if (logical >> db) & 1 else np.int64(-1)
        if d != direction:                                     # direction changed
            if tick - last_rise < p_hold:
                v_ticks[n_v] = tick
                v_codes[n_v] = V_DIR_HOLD
                v_values[n_v] = tick - last_rise
                n_v += 1
            last_turn = tick
        if step == 1 and s == 0:                                # step fell
            if tick - last_rise < p_high:
                v_ticks[n_v] = tick
                v_codes[n_v] = V_PULSE_HIGH
                v_values[n_v] = tick - last_rise
                n_v += 1
            last_fall = tick
        rise = step == 0 and s == 1
        if rise:                                                # step rose
            if tick - last_fall < p_low:
                v_ticks[n_v] = tick
                v_codes[n_v] = V_PULSE_LOW
                v_values[n_v] = tick - last_fall
                n_v += 1
            if tick - last_turn < p_setup:
                v_ticks[n_v] = tick
                v_codes[n_v] = V_DIR_SETUP
                v_values[n_v] = tick - last_turn
                n_v += 1
            last_rise = tick
        step, direction = s, d
        if not rise:
            continue
        while w < n_watch and watch[w] < tick:          # the state before this step
            watch_out[w, 0] = motor
            watch_out[w, 1] = (motor - g) / spm
            w += 1
        if last_dir != 0 and d != last_dir:
            reversals += 1
        last_dir = d
        motor += d
        g = min(max(g + d, 0.0), width)
        carriage = (motor - g) / spm
        if steps == kept_next and trace_stride > 0:
            tr_ticks[n_tr] = tick
            tr_motor[n_tr] = motor
            tr_carriage[n_tr] = carriage
            n_tr += 1
            kept_next += trace_stride
        steps += 1
        outside = not (lo_in <= carriage <= hi_in)
        if outside and out == 0:
            v_ticks[n_v] = tick
            v_codes[n_v] = V_TRAVEL
            v_values[n_v] = 0
            v_carriage[n_v] = carriage
            n_v += 1
        out = 1 if outside else 0
        for k in range(n_sw_k):
            slack = sw_hyst[k] if sw_closed[k] else 0.0
            now = 1 if sw_side[k] * (carriage - sw_trip[k]) >= -slack - _EPS_MM else 0
            if now != sw_closed[k]:
                sw_closed[k] = now
                sw_ticks[n_sw] = tick
                sw_index[n_sw] = k
                sw_state[n_sw] = now
                n_sw += 1
    while w < watch.shape[0] and watch[w] < end_tick:
        watch_out[w, 0] = motor
        watch_out[w, 1] = (motor - g) / spm
        w += 1
    ds[D_STEP], ds[D_DIR], ds[D_RISE], ds[D_FALL], ds[D_TURN] = step, direction, last_rise, last_fall, last_turn
    ms[M_MOTOR], ms[M_LAST_DIR], ms[M_REVERSALS], ms[M_OUT] = motor, last_dir, reversals, out
    gap[0] = g
    return n_tr, n_v, n_sw, w, steps
