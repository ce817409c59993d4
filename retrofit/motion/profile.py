"""Velocity profiles of one move: trapezoidal, or the engraver paper's exponential ramp.

A profile answers one question: how long after the start of a move is the tool ``s`` mm along
it? Every step then gets the tick nearest that time. The answer comes from :func:`time_at`, a
plain arithmetic kernel on a row of floats (see ``P_*`` below) so that the reference path (plain
Python) and the fast path (the same function compiled) compute identical floats.

Trapezoid: accelerate at ``a`` from the entry speed ``v0`` to the cruise speed ``vc``, cruise,
decelerate to the exit speed ``v1``; a short move never reaches ``vc`` (a triangle).

Exponential (004): on each ramp the speed approaches an asymptote ``V`` exponentially with the
distance, ``v(s) = V - (V - v0)·exp(-s/λ)``, reaching ``vc`` where ``exp(-s/λ) = 1/21``
(``V = vc + (vc - v0)/20``); ``λ`` is chosen so the acceleration ``v·dv/ds`` never exceeds
``a``. The time has a closed form. A ramp cannot start from rest, so the exponential profile
starts from a start speed (a stepper's start frequency), as the paper's speed segments do.
"""

from __future__ import annotations

import math

import numpy as np

from ._jit import kernel

TRAPEZOID, EXPONENTIAL = 0, 1
#: columns of a profile row
(P_KIND, P_V0, P_VC, P_V1, P_A, P_LEN, P_D1, P_D2, P_T1, P_TC, P_T2,
 P_LAM1, P_LAM2, P_V1ASYM, P_V2ASYM) = range(15)
P_WIDTH = 15
_RAMP_LOG = math.log(21.0)


@kernel
def time_at(s: float, p) -> float:
    """Seconds from the start of the move to ``s`` mm along it (``p`` is a profile row)."""
    if p[P_KIND] == TRAPEZOID:
        return _trapezoid_time(s, p)
    return _exponential_time(s, p)


@kernel
def ticks_at(s, p, t0, rate, out) -> None:
    """``out[k]``: the tick nearest ``t0 + time_at(s[k], p)`` (``s`` non-decreasing), at ``rate``
    ticks per second. The same floats as :func:`time_at` step by step; a trapezoid's three
    parts are taken as three branch-free loops, which the compiler runs several steps at a time."""
    count = s.shape[0]
    if p[P_KIND] != TRAPEZOID:
        for k in range(count):
            out[k] = np.int64(np.floor((t0 + time_at(s[k], p)) * rate + 0.5))
        return
    a, vc, v0, d1 = p[P_A], p[P_VC], p[P_V0], p[P_D1]
    cruise_end = p[P_LEN] - p[P_D2]
    k1 = 0
    while k1 < count and s[k1] <= d1:
        k1 += 1
    k2 = k1
    while k2 < count and s[k2] <= cruise_end:
        k2 += 1
    for k in range(k1):
        out[k] = np.int64(np.floor((t0 + (math.sqrt(v0 * v0 + 2.0 * a * s[k]) - v0) / a) * rate + 0.5))
    t1 = p[P_T1]
    for k in range(k1, k2):
        out[k] = np.int64(np.floor((t0 + (t1 + (s[k] - d1) / vc)) * rate + 0.5))
    t12 = p[P_T1] + p[P_TC]
    for k in range(k2, count):
        under = max(vc * vc - 2.0 * a * (s[k] - cruise_end), 0.0)
        out[k] = np.int64(np.floor((t0 + (t12 + (vc - math.sqrt(under)) / a)) * rate + 0.5))


@kernel
def _trapezoid_time(s, p):
    a, vc = p[P_A], p[P_VC]
    if s <= p[P_D1]:
        v0 = p[P_V0]
        return (math.sqrt(v0 * v0 + 2.0 * a * s) - v0) / a
    cruise_end = p[P_LEN] - p[P_D2]
    if s <= cruise_end:
        return p[P_T1] + (s - p[P_D1]) / vc
    under = vc * vc - 2.0 * a * (s - cruise_end)
    if under < 0.0:
        under = 0.0
    return p[P_T1] + p[P_TC] + (vc - math.sqrt(under)) / a


@kernel
def _ramp_time(s, v_start, v_asym, lam):
    """Time to cover ``s`` on an exponential ramp starting at ``v_start`` towards ``v_asym``."""
    if lam <= 0.0:
        return s / v_start
    delta = v_asym - v_start
    return (s + lam * math.log((v_asym - delta * math.exp(-s / lam)) / v_start)) / v_asym


@kernel
def _exponential_time(s, p):
    if s <= p[P_D1]:
        return _ramp_time(s, p[P_V0], p[P_V1ASYM], p[P_LAM1])
    cruise_end = p[P_LEN] - p[P_D2]
    if s <= cruise_end:
        return p[P_T1] + (s - p[P_D1]) / p[P_VC]
    remaining = p[P_LEN] - s
    if remaining < 0.0:
        remaining = 0.0
    return p[P_T1] + p[P_TC] + p[P_T2] - _ramp_time(remaining, p[P_V1], p[P_V2ASYM], p[P_LAM2])


def trapezoid(length: float, v0: float, vc: float, v1: float, a: float) -> np.ndarray:
    """Profile row of a trapezoid over ``length`` mm (speeds mm/s, ``a`` mm/s²)."""
    row = np.zeros(P_WIDTH)
    trapezoid_into(row, length, v0, vc, v1, a)
    return row


@kernel
def trapezoid_into(row, length, v0, vc, v1, a):
    """Write the trapezoid's profile row into ``row`` (zeros beyond its columns)."""
    vc = max(vc, v0, v1)
    d1 = (vc * vc - v0 * v0) / (2.0 * a)
    d2 = (vc * vc - v1 * v1) / (2.0 * a)
    if d1 + d2 > length:                                # a triangle: the peak the length allows
        faster = max(v0, v1)
        vc = math.sqrt(max((2.0 * a * length + v0 * v0 + v1 * v1) / 2.0, faster * faster))
        d1 = min(max((vc * vc - v0 * v0) / (2.0 * a), 0.0), length)
        d2 = length - d1
    row[P_KIND], row[P_V0], row[P_VC], row[P_V1], row[P_A] = TRAPEZOID, v0, vc, v1, a
    row[P_LEN], row[P_D1], row[P_D2] = length, d1, d2
    row[P_T1] = (vc - v0) / a
    row[P_TC] = (length - d1 - d2) / vc if vc > 0 else 0.0
    row[P_T2] = (vc - v1) / a


def _ramp(v_start: float, v_end: float, a: float) -> tuple[float, float, float, float]:
    """(asymptote, λ, distance, time) of an exponential ramp from v_start up to v_end."""
    if v_end <= v_start:
        return v_start, 0.0, 0.0, 0.0
    v_asym = v_end + (v_end - v_start) / 20.0
    peak = min(max(v_asym / 2.0, v_start), v_end)       # where v·(V - v), the acceleration·λ, is largest
    lam = peak * (v_asym - peak) / a
    distance = lam * _RAMP_LOG
    return v_asym, lam, distance, _ramp_time(distance, v_start, v_asym, lam)


def exponential(length: float, v0: float, vc: float, v1: float, a: float, v_start: float) -> np.ndarray:
    """Profile row of an exponential-ramp move; entry / exit speeds are at least ``v_start``."""
    v0, v1 = max(v0, v_start), max(v1, v_start)
    vc = max(vc, v0, v1)
    lo, hi = max(v0, v1), vc
    up, down = _ramp(v0, hi, a), _ramp(v1, hi, a)
    if up[2] + down[2] > length:                        # lower the cruise speed until both ramps fit
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            if _ramp(v0, mid, a)[2] + _ramp(v1, mid, a)[2] > length:
                hi = mid
            else:
                lo = mid
        vc = lo
        up, down = _ramp(v0, vc, a), _ramp(v1, vc, a)
    row = np.zeros(P_WIDTH)
    row[[P_KIND, P_V0, P_VC, P_V1, P_A, P_LEN, P_D1, P_D2, P_T1, P_TC, P_T2, P_LAM1, P_LAM2,
         P_V1ASYM, P_V2ASYM]] = (EXPONENTIAL, v0, vc, v1, a, length, up[2], down[2], up[3],
                                 max(length - up[2] - down[2], 0.0) / vc, down[3], up[1], down[1],
                                 up[0], down[0])
    return row


def duration(p) -> float:
    """Seconds the whole move takes."""
    return float(p[P_T1] + p[P_TC] + p[P_T2])
