"""Feed one axis of a :class:`~retrofit.sim.SimMachine` a chunk of frames through the compiled decoder.

The machine's readable state (its ``DriverInput``, ``DeadBand``, switches, counters) is the one
source of truth: it is packed into small arrays for the kernel and unpacked after it, so the
compiled chunks and the per-step reference (``feed_reference``, ``feed_frame``) can follow one
another on the same machine.
"""

from __future__ import annotations

import numpy as np

from ..frames import PortFrames
from .drivers import Violation
from .kernels import KINDS, V_TRAVEL, decode_axis
from .switches import SwitchEvent


def axis_params(axis) -> np.ndarray:
    """The int64 parameter row of an axis (slots ``kernels.P_*``)."""
    return np.array([(axis.invert_step << axis.step_bit) | (axis.invert_dir << axis.dir_bit),
                     axis.step_bit, axis.dir_bit, axis.pulse_high_ticks, axis.pulse_low_ticks,
                     axis.dir_setup_ticks, axis.dir_hold_ticks], dtype=np.int64)


def _detail(kind: str, value: int, carriage: float, axis, travel) -> str:
    """The same words as ``DriverInput._check`` and ``SimMachine._check_travel``."""
    if kind == "dir_hold":
        return f"direction changed {value} tick(s) after a rising step edge; needs >= {axis.dir_hold_ticks}"
    if kind == "pulse_high":
        return f"step high for {value} tick(s); needs >= {axis.pulse_high_ticks}"
    if kind == "pulse_low":
        return f"step low for {value} tick(s) before rising; needs >= {axis.pulse_low_ticks}"
    if kind == "dir_setup":
        return (f"direction changed {value} tick(s) before a rising step edge; "
                f"needs >= {axis.dir_setup_ticks}")
    lo, hi = travel
    return f"carriage at {carriage:.3f} mm, outside {lo:g}..{hi:g} mm"


#: frames decoded per kernel call (bounds the event buffers, whatever the chunk's size)
SUB_CHUNK = 1 << 16


def feed_axis(sim, i: int, frames, watch: np.ndarray, watch_out: np.ndarray, changing: int = 0xFF) -> None:
    """Decode axis ``i`` of ``sim`` over ``frames``; ``watch_out[:, i]`` gets (motor, carriage mm)
    at the end of each watched tick. ``changing``: the bits not the same in every frame
    (:func:`changing_bits`; an axis none of whose bits change is not read frame by frame)."""
    axis, driver, screw = sim.machine.axes[i], sim.drivers[i], sim.screws[i]
    busy = sim.__dict__.setdefault("_decode_busy", {})
    given = len(frames)
    frames = _own_frames(axis, driver, frames, changing, busy.get(i, False))
    if not len(frames):                                # no edge of this axis in the chunk: it holds
        if len(watch):
            end = frames.end_tick
            held = watch < end
            watch_out[held, i, 0] = sim.motor_steps[i]
            watch_out[held, i, 1] = (sim.motor_steps[i] - screw.gap) / axis.steps_per_mm
        return
    ds = np.array([driver.step, driver.direction, driver.last_rise, driver.last_fall,
                   driver.last_dir_change], dtype=np.int64)
    ms = np.array([sim.motor_steps[i], sim._last_dir[i], sim.reversals[i], int(sim._out_of_travel[i])],
                  dtype=np.int64)
    gap = np.array([screw.gap], dtype=np.float64)
    switches = sim.switches.by_axis[axis.name]
    params, side, trip, hysteresis = _constants(sim, i)
    sw = (side, trip, hysteresis, np.array([int(s.closed) for s in switches], dtype=np.int64))
    buffers = _buffers(sim, min(len(frames.ticks), SUB_CHUNK))
    w_out = np.zeros((len(watch), 2), np.float64)      # rows stay contiguous when sliced
    lo, hi = sim._travel[i]
    done_watch, steps = 0, 0
    for start in range(0, max(len(frames.ticks), 1), SUB_CHUNK):
        stop = min(start + SUB_CHUNK, len(frames.ticks))
        end = int(frames.ticks[stop]) if stop < len(frames.ticks) else frames.end_tick
        args = (frames.ticks[start:stop], frames.values[start:stop], params, ds, ms, gap, float(screw.width),
                float(axis.steps_per_mm), float(lo), float(hi), *sw,
                watch[done_watch:], w_out[done_watch:], np.int64(end))
        counts, strided = _decode(sim, sim.traces[axis.name], args, buffers)
        done_watch, steps = done_watch + counts[3], steps + counts[4]
        _events(sim, i, switches, (lo, hi), buffers, counts, strided)
    busy[i] = 4 * steps > given           # its rises and falls were over half the chunk's frames
    driver.step, driver.direction = int(ds[0]), int(ds[1])
    driver.last_rise, driver.last_fall, driver.last_dir_change = int(ds[2]), int(ds[3]), int(ds[4])
    sim.motor_steps[i], sim._last_dir[i], sim.reversals[i] = int(ms[0]), int(ms[1]), int(ms[2])
    sim._out_of_travel[i] = bool(ms[3])
    screw.gap, screw.motor = float(gap[0]), int(ms[0])
    for k, s in enumerate(switches):
        s.closed = bool(sw[3][k])
    if len(watch):
        watch_out[:, i, :] = w_out


def _constants(sim, i: int) -> tuple:
    """(parameter row, switch sides, trip points, hystereses) of axis ``i``, made once per machine."""
    cache = sim.__dict__.setdefault("_decode_constants", {})
    if i not in cache:
        switches = sim.switches.by_axis[sim.machine.axes[i].name]
        cache[i] = (axis_params(sim.machine.axes[i]),
                    np.array([s.spec.side for s in switches], dtype=np.float64),
                    np.array([s.spec.trip_mm for s in switches], dtype=np.float64),
                    np.array([s.spec.hysteresis_mm for s in switches], dtype=np.float64))
    return cache[i]


def _buffers(sim, n: int) -> tuple:
    """The kernel's event buffers for ``n`` frames: trace points (one a frame), violations (four
    a frame, and one), switch changes; kept by the machine for the next chunk (only the rows a
    kernel call reports are read)."""
    kept = sim.__dict__.get("_decode_buffers")
    if kept is None or len(kept[0]) < n:
        kept = sim._decode_buffers = (
            np.empty(n, np.int64), np.empty(n, np.int64), np.empty(n, np.float64),
            np.empty(4 * n + 1, np.int64), np.empty(4 * n + 1, np.int64), np.empty(4 * n + 1, np.int64),
            np.empty(4 * n + 1, np.float64), np.empty(n, np.int64), np.empty(n, np.int64), np.empty(n, np.int64))
    return kept


def changing_bits(frames) -> int:
    """The port bits that are not the same in every frame of ``frames``."""
    if not len(frames):
        return 0
    return int(np.bitwise_or.reduce(frames.values)) ^ int(np.bitwise_and.reduce(frames.values))


def _own_frames(axis, driver, frames, changing: int, busy: bool = False):
    """The frames that change this axis's step or direction bits (the others change nothing for
    its driver), as the driver last saw them; the chunk's end tick kept. ``busy``: most frames of
    the last chunk were the axis's own, so all are kept (the decoder passes over a frame that
    changes nothing for less than it costs to sort the frames out first)."""
    if driver.direction == 0 or not len(frames):
        return frames
    mask = (1 << axis.step_bit) | (1 << axis.dir_bit)
    logical = (driver.step << axis.step_bit) | ((1 if driver.direction > 0 else 0) << axis.dir_bit)
    seen = logical ^ ((axis.invert_step << axis.step_bit) | (axis.invert_dir << axis.dir_bit))
    if not changing & mask and int(frames.values[0]) & mask == seen:     # the axis's bits hold
        return PortFrames(frames.ticks[:0], frames.values[:0], frames.end_tick)
    if busy:
        return frames
    bits = frames.values & np.uint8(mask)               # a few passes over bytes: cheaper than a loop
    own = np.flatnonzero(bits[1:] != bits[:-1]) + 1
    if int(bits[0]) != seen:
        own = np.concatenate((np.zeros(1, own.dtype), own))
    return PortFrames(frames.ticks[own], frames.values[own], frames.end_tick)


def _decode(sim, trace, args, buffers) -> tuple[tuple, bool]:
    """``decode_axis`` over one sub-chunk (``args`` up to its end tick): its counts, and whether
    the trace points written are only those a decimated trace keeps (every stride-th step).

    A decimated trace that keeps the points near violations in full gets every point of a
    sub-chunk with violations: that sub-chunk is decoded again from the state it started from.
    """
    first = trace.kept_from()
    if trace.limit == 0 or first is None:
        return decode_axis(*args, 0, 1 if trace.limit != 0 else 0, *buffers), False
    state = (args[3], args[4], args[5], args[13])          # ds, ms, gap, the switches closed
    before = [a.copy() for a in state] if sim.trace_around else None
    counts = decode_axis(*args, first, trace.stride, *buffers)
    if before is None or not counts[1]:
        return counts, True
    for now, then in zip(state, before):
        now[:] = then
    return decode_axis(*args, 0, 1, *buffers), False


def _events(sim, i: int, switches, travel, buffers, counts, strided: bool) -> None:
    """Word the kernel's violations and switch changes; extend the trace."""
    axis, driver, trace = sim.machine.axes[i], sim.drivers[i], sim.traces[sim.machine.axes[i].name]
    tr_t, tr_m, tr_c, v_t, v_c, v_v, v_car, sw_t, sw_i, sw_s = buffers
    n_tr, n_v, n_sw, _, steps = counts
    for j in range(n_v):
        kind = KINDS[v_c[j]]
        found = Violation(int(v_t[j]), axis.name, kind, _detail(kind, int(v_v[j]), float(v_car[j]), axis, travel))
        (sim.extra_violations if v_c[j] == V_TRAVEL else driver.violations).append(found)
    for j in range(n_sw):
        sim.switches.events.append(SwitchEvent(int(sw_t[j]), switches[sw_i[j]].spec.name, bool(sw_s[j])))
    if strided:
        trace.extend_kept(tr_t[:n_tr], tr_m[:n_tr], tr_c[:n_tr], steps)
    elif trace.limit != 0 and n_tr:
        keep = None
        if trace.limit is not None and n_v and sim.trace_around:
            keep = _near(tr_t[:n_tr], v_t[:n_v], sim.trace_around)
        trace.extend(tr_t[:n_tr], tr_m[:n_tr], tr_c[:n_tr], keep)


def _near(ticks: np.ndarray, marks: np.ndarray, around: int) -> np.ndarray:
    """True for the ticks within ``around`` of any mark."""
    marks = np.sort(marks)
    j = np.searchsorted(marks, ticks)
    before = np.abs(ticks - marks[np.maximum(j - 1, 0)]) <= around
    after = np.abs(marks[np.minimum(j, len(marks) - 1)] - ticks) <= around
    return before | after
