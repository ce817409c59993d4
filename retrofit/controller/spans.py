"""Stretches of a controller's run handed to its compiled tick loop (:mod:`.kernels`).

While a clock-timed move, an ISTP move or a homing runs, :class:`SpanRunner` packs the
controller's state -- step generators, request queues, the simulated carriages and switches, the
spindle, the indexer, the homing jog -- into arrays, lets the compiled loop run as many ticks as
it can, and unpacks it. The readable objects stay the one source of truth: between spans the
controller ticks in Python, and a span stops before every tick the readable controller has to
decide (see the kernels' module doc). Starting a move, dwells, halts and commands stay in Python,
and so do ISTP moves on a spindle whose encoder counts both ways (rigid tapping).
"""

from __future__ import annotations

import numpy as np

from ..frames import PortFrames
from ..motion._jit import compiled
from ..motion.fast import move_requests
from ..sim.spindle import FRACTION_BITS, S_TICK
from . import kernels as K
from .homing import HomeRun
from .indexrun import IndexRun
from .runs import ClockRun

#: most ticks one span runs (bounds its buffers)
SPAN_TICKS = 1 << 20
#: most cycles of a clock-timed move computed ahead at once
SPAN_CYCLES = 1 << 16
#: indexer products stay below this (int64 with room)
_INT_ROOM = 1 << 62


class SpanRunner:
    """The compiled tick loop of one :class:`~retrofit.controller.Controller`."""

    def __init__(self, ctl):
        self.ctl = ctl
        proc = ctl.processor
        machine = ctl.machine
        self.tim = np.array([[g.timing.pulse_high, g.timing.pulse_low, g.timing.dir_setup, g.timing.dir_hold]
                             for g in proc.pulses.gens], dtype=np.int64)
        pins = proc.pulses.pins
        self.smask = np.array(pins.step_masks, dtype=np.int64)
        self.dmask = np.array(pins.dir_masks, dtype=np.int64)
        self.invert = int(pins.invert)
        sim = proc.sim
        self.usable = sim is None or all(m is None for m in sim.motors)
        self.sw = self._switch_arrays(machine, sim)
        self.spm = np.array([a.steps_per_mm for a in machine.axes], dtype=np.float64)
        self.ticks = 0                          # ticks run by the compiled loop so far

    @staticmethod
    def _switch_arrays(machine, sim):
        names = machine.axis_names
        switches = [s for name in names for s in (sim.switches.by_axis[name] if sim is not None else [])]
        return (switches, np.array([names.index(s.spec.axis) for s in switches], dtype=np.int64),
                np.array([s.spec.side for s in switches], dtype=np.float64),
                np.array([s.spec.trip_mm for s in switches], dtype=np.float64),
                np.array([s.spec.hysteresis_mm for s in switches], dtype=np.float64))

    # -- when -------------------------------------------------------------------------------------
    def run(self, end: int) -> bool:
        """Run ticks of the move running, by the compiled loop, up to ``end`` at most; True when
        some ran (the controller then ticks the next one itself)."""
        proc = self.ctl.processor
        run = proc.run
        if isinstance(run, ClockRun):
            work = self._clock_work(run)
        elif isinstance(run, IndexRun) and not run.signed and (
                run.phase in ("armed", "run") or (run.phase == "sync" and run.seen is not None)):
            work = self._index_work(run)
        elif isinstance(run, HomeRun):
            work = self._home_work(run)
        else:
            return False
        if work is None or not compiled(work):
            return False
        if not self.usable or proc.error or proc.stopped or self._limit_closed():
            return False
        t0 = self.ctl._tick
        t_end = min(end, t0 + SPAN_TICKS)
        if isinstance(run, IndexRun):
            t_end = min(t_end, run.index_deadline())    # the controller's own tick says "no index"
            if t_end <= t0:
                return False
        if isinstance(run, ClockRun):
            self._clock(run, t_end)
        elif isinstance(run, IndexRun):
            if run.phase != "sync" and self._count_cap(run) < proc.sim_spindle.angle >> FRACTION_BITS:
                return False                        # its integers would not fit: the controller's
            self._index(run, t_end)
        else:
            self._home(run, t_end)
        self.ticks += self.ctl._tick - t0
        return self.ctl._tick > t0

    def _limit_closed(self) -> bool:
        """A closed limit switch (other than one a homing seeks): every tick is the controller's."""
        switches, run = self.ctl.io.switches, self.ctl.processor.run
        return any(switches.named(name).kind == "limit"
                   and not (isinstance(run, HomeRun) and run.owns(name)) for name in self.ctl.processor.closed)

    def _clock_work(self, run: ClockRun):
        """Ticks to go in the run, this move included (None: nothing for the compiled loop)."""
        if run.done or run.profile is None or run.cycle >= run.line.n - 1:
            return None
        return max(round(run.end_time * self.ctl.processor.rate), self.ctl._tick)

    def _index_work(self, run: IndexRun):
        """Ticks to go in the run, this move included."""
        proc = self.ctl.processor
        if proc.sim_spindle is None:
            return None
        revs = (run.line.n - (run.executor.bresenham.cycle if run.executor else 0)) / max(float(run.s), 1e-9)
        return self.ctl._tick + round(revs * 60.0 / max(run.rpm, 1e-9) * proc.rate)

    # -- packing ------------------------------------------------------------------------------------
    def _common(self, room: list[int]):
        """Generator state, queues (with ``room`` more places per axis), motor counters."""
        pulses = self.ctl.processor.pulses
        gen = np.array([[g.high, g.period, g.tick, g.direction, g.last_rise, g.last_dir_change]
                        for g in pulses.gens], dtype=np.int64)
        n_axes = len(pulses.gens)
        cap = max(len(q) + r for q, r in zip(pulses.queues, room)) + 1
        q_due = np.zeros((n_axes, cap), dtype=np.int64)
        q_dir = np.zeros((n_axes, cap), dtype=np.int64)
        q_gen = np.full((n_axes, cap), -(1 << 62), dtype=np.int64)
        qs = np.zeros((n_axes, 3), dtype=np.int64)
        for a, queue in enumerate(pulses.queues):
            for j, (due, direction) in enumerate(queue):
                q_due[a, j], q_dir[a, j] = due, direction
            qs[a] = (0, len(queue), len(queue))
        return gen, q_due, q_dir, q_gen, qs, np.array(pulses.motor, dtype=np.int64)

    def _sim_state(self):
        sim = self.ctl.processor.sim
        n_axes = len(self.ctl.machine.axes)
        if sim is None:
            return (False, np.zeros((n_axes, 2), np.int64), np.zeros(n_axes), np.zeros(n_axes),
                    np.zeros(0, np.int64))
        state = np.array([[d.step, s.motor] for d, s in zip(sim.drivers, sim.screws)], dtype=np.int64)
        gap = np.array([s.gap for s in sim.screws], dtype=np.float64)
        width = np.array([s.width for s in sim.screws], dtype=np.float64)
        return True, state, gap, width, np.array([int(s.closed) for s in self.sw[0]], dtype=np.int64)

    def _call(self, kind, t_end, queues, clock=None, index=None, spindle=None, home=None):
        """Run the kernel and unpack what every path shares; returns the kernel's queue state."""
        proc = self.ctl.processor
        gen, q_due, q_dir, q_gen, qs, motor = queues
        has_sim, sim, gap, width, closed = self._sim_state()
        n_axes, t = len(gen), self.ctl._tick
        zeros = np.zeros(n_axes, np.int64)
        clock = clock or (zeros, zeros, zeros, 0)
        index = index or (np.zeros(K.X_N + 1, np.int64), zeros, zeros)
        spindle = spindle or (np.zeros(5, np.int64), np.zeros(4), np.zeros(5), np.zeros(1))
        home = home or (np.zeros(5, np.int64), np.zeros(5))
        r_ticks = np.zeros((n_axes, q_due.shape[1]), dtype=np.int64)
        r_n = np.zeros(n_axes, dtype=np.int64)
        f_ticks = np.empty(t_end - t, dtype=np.int64)
        f_values = np.empty(t_end - t, dtype=np.int64)
        history = np.empty(t_end - t, dtype=np.int64)
        last = proc.pulses._last
        t_out, last, n_f, h = K.run_span(
            kind, t, t_end, gen, self.tim, self.smask, self.dmask, self.invert, last, q_due, q_dir, q_gen,
            qs, motor, r_ticks, r_n, f_ticks, f_values, *clock, has_sim, sim, gap, width, self.spm,
            *self.sw[1:3], self.sw[3], self.sw[4], closed, *index, *spindle, history, *home)
        self._unpack_pulses(gen, q_due, q_dir, qs, motor, r_ticks, r_n, last)
        self._feed(f_ticks[:n_f], f_values[:n_f])
        self.ctl._tick = int(t_out)
        return qs, history[:h]

    def _unpack_pulses(self, gen, q_due, q_dir, qs, motor, r_ticks, r_n, last) -> None:
        pulses = self.ctl.processor.pulses
        for a, g in enumerate(pulses.gens):
            g.high, g.period, g.tick, g.direction, g.last_rise, g.last_dir_change = (int(v) for v in gen[a])
            queue = pulses.queues[a]
            old = len(queue)
            queue.clear()
            head, tail = int(qs[a, K.Q_HEAD]), int(qs[a, K.Q_TAIL])
            queue.extend(zip(q_due[a, head:tail].tolist(), q_dir[a, head:tail].tolist()))
            pulses.wanted[a].extend(q_due[a, old:tail].tolist())
            pulses.rises[a].extend(r_ticks[a, :r_n[a]].tolist())
        pulses.motor = [int(m) for m in motor]
        pulses._last = int(last)

    def _feed(self, ticks, values) -> None:
        """The frames of the span to the recorder and to the simulated machine."""
        if not len(ticks):
            return
        recorder = self.ctl.processor.pulses.recorder
        recorder.ticks.extend(ticks.tolist())
        recorder.values.extend(values.tolist())
        recorder._last = int(values[-1])
        sim = self.ctl.processor.sim
        if sim is not None:
            sim.feed(PortFrames(ticks, values.astype(np.uint8), int(ticks[-1]) + 1))

    # -- a clock-timed move -----------------------------------------------------------------------
    def _clock(self, run: ClockRun, t_end: int) -> None:
        proc = self.ctl.processor
        line, n, c0 = run.line, run.line.n, run.cycle
        c_stop = min(n - 1, c0 + SPAN_CYCLES)
        before = self._steps_so_far(run)
        queues = self._common([min(abs(d) - s, c_stop - c0 + 1) for d, s in zip(line.delta, before)])
        q_due, q_gen, qs = queues[1], queues[3], queues[4]
        state = np.zeros((2, line.axes), dtype=np.int64)
        if run.bresenham is not None:
            state[0] = run.bresenham.error
        else:
            assert run.dda is not None                # no Bresenham executor: a DDA one
            state[0], state[1] = run.dda.sent, run.dda.short_num
        profile = run.profile
        assert profile is not None                    # _clock_work() said there is work
        starts, offsets = np.array(profile.starts, np.float64), np.array(profile.offsets, np.float64)
        rows = np.array(profile.rows, np.float64)
        cycle_due = np.zeros(c_stop - c0 + 1, dtype=np.int64)
        delta = np.array(line.delta, dtype=np.int64)
        fill = qs[:, K.Q_KNOWN].copy()
        move_requests(run.bresenham is None, n, c0, c_stop + 1, delta, state, profile.length, run.t0,
                      starts, offsets, rows, proc.rate, q_due, q_gen, fill, cycle_due)
        qs[:, K.Q_KNOWN] = fill
        stop_due = int(cycle_due[-1])          # cycle c_stop + 1 is left to the controller
        q_dir = queues[2]
        for a in range(line.axes):
            q_dir[a, len(proc.pulses.queues[a]):qs[a, K.Q_KNOWN]] = line.direction[a]
        left = np.array([abs(d) - s for d, s in zip(line.delta, before)], dtype=np.int64)
        win = np.array([proc.window_hint(a) for a in range(line.axes)], dtype=np.int64)
        clock = (np.array(line.direction, dtype=np.int64), left, win, stop_due)
        qs, _ = self._call(K.CLOCK, t_end, queues, clock=clock)
        generated = [abs(d) - int(r) for d, r in zip(line.delta, left)]
        cycles = c0 + int(np.searchsorted(cycle_due[:-1], self.ctl._tick, side="right"))
        self._set_clock(run, cycles, generated)

    @staticmethod
    def _steps_so_far(run: ClockRun) -> list[int]:
        if run.bresenham is not None:
            return [abs(p - s) for p, s in zip(run.bresenham._position, run.line.start)]
        assert run.dda is not None                    # no Bresenham executor: a DDA one
        return list(run.dda.sent)

    @staticmethod
    def _set_clock(run: ClockRun, cycles: int, steps: list[int]) -> None:
        """The interpolator as it is after ``cycles`` cycles that made ``steps`` steps per axis."""
        line = run.line
        run.cycle, run._due = cycles, None
        position = [s + d * k for s, d, k in zip(line.start, line.direction, steps)]
        if run.bresenham is not None:
            ex = run.bresenham
            ex.cycle = cycles
            ex.error = [cycles * inc - line.error_dec * k for inc, k in zip(line.error_inc, steps)]
            ex._position = position
        else:
            dda = run.dda
            assert dda is not None                    # no Bresenham executor: a DDA one
            dda.long, dda.sent = cycles, list(steps)
            dda.short_num = [line.n * (k + 1) for k in steps]
            dda._position = position
            run.sent = list(steps)

    # -- an ISTP move -------------------------------------------------------------------------------
    @staticmethod
    def _count_cap(run: IndexRun) -> int:
        """The highest encoder count for which the indexer's integers fit in int64 (-1: none)."""
        track = run.track
        if track is None:
            return 0
        s_num, o_num, o_den, lead = track.s_num, abs(track.o_num), track.o_den, track.lead
        if lead:                        # the lead-in: (count - start) * o_den < 2 * lead * o_den
            den = track.s_den * 4 * track.counts * lead * o_den * o_den
            if 2 * s_num * (2 * lead * o_den + 1) ** 2 + den >= _INT_ROOM:
                return -1
        den = track.s_den * track.counts * o_den
        room = (_INT_ROOM - den) // (2 * s_num) - o_num - lead * o_den if den < _INT_ROOM else -1
        return room // o_den if room > 0 else -1

    def _index(self, run: IndexRun, t_end: int) -> None:
        proc = self.ctl.processor
        spindle = proc.sim_spindle
        line = run.line
        ex = run.executor
        cycle = ex.bresenham.cycle if ex is not None else 0
        error = list(ex.bresenham.error) if ex is not None else [0] * line.axes
        steps = [(cycle * inc - e) // line.error_dec for inc, e in zip(line.error_inc, error)]
        queues = self._common([abs(d) - s for d, s in zip(line.delta, steps)])
        phase = {"sync": K.SYNC, "armed": K.ARMED, "run": K.RUN}[run.phase]
        track = run.track
        ix = np.zeros(K.X_N + 1, dtype=np.int64)
        ix[K.X_PHASE], ix[K.X_SEEN], ix[K.X_CYCLE], ix[K.X_N] = phase, run.seen or 0, cycle, line.n
        ix[K.X_LAST_COUNT] = -1
        if track is not None:
            ix[K.X_SNUM], ix[K.X_SDEN], ix[K.X_ONUM], ix[K.X_ODEN] = track.s_num, track.s_den, track.o_num, track.o_den
            ix[K.X_LEAD], ix[K.X_COUNTS], ix[K.X_STEPS] = track.lead, track.counts, track.steps
            ix[K.X_CAP] = self._count_cap(run)
        index = (ix, np.array(error, dtype=np.int64), np.array(line.error_inc, dtype=np.int64))
        clock = (np.array(line.direction, dtype=np.int64), np.zeros(line.axes, np.int64),
                 np.zeros(line.axes, np.int64), 0)
        draws = spindle.draws_until(t_end)
        si, sf, par = spindle.state()
        _, history = self._call(K.INDEX, t_end, queues, clock=clock, index=index, spindle=(si, sf, par, draws))
        spindle.set_state(si, sf, history)
        if int(si[S_TICK]) >= 0:
            proc._spindle_tick = -1                 # read it again (same values) when next asked
        run.seen = int(ix[K.X_SEEN])
        run.phase = {K.SYNC: "sync", K.ARMED: "armed", K.RUN: "run"}[int(ix[K.X_PHASE])]
        if ex is not None:
            done = int(ix[K.X_CYCLE])
            ex.bresenham.cycle = done
            ex.bresenham.error = [int(e) for e in index[1]]
            made = [(done * inc - int(e)) // line.error_dec for inc, e in zip(line.error_inc, index[1])]
            ex.bresenham._position = [s + d * k for s, d, k in zip(line.start, line.direction, made)]

    # -- a homing ----------------------------------------------------------------------------------
    def _home_work(self, run: HomeRun):
        """Ticks to go (a guess: the axis's whole travel at the latch feed), or None when the tick
        is the controller's (a switch it waits for is closed, a back-off starts counting)."""
        closed = self.ctl.processor.closed
        if run.phase == "seek" and run.seek_switch.name not in closed:
            pass
        elif run.phase == "latch" and run.ref_switch.name not in closed:
            pass
        elif not (run.phase == "backoff" and (self._backoff_clear(run) is False or run.backoff_from is not None)):
            return None
        axis = self.ctl.machine.axes[run.i]
        return self.ctl._tick + round(run.max_steps / axis.steps_per_mm / (run.how.latch_mm_min / 60.0)
                                      * self.ctl.processor.rate)

    def _backoff_clear(self, run: HomeRun) -> bool:
        closed = self.ctl.processor.closed
        return run.seek_switch.name not in closed and run.ref_switch.name not in closed

    def _home(self, run: HomeRun, t_end: int) -> None:
        jog, axis = run._jog(), self.ctl.machine.axes[run.i]
        stop = 1 << 62
        if run.phase == "backoff" and self._backoff_clear(run):
            stop = run.backoff_from + round(run.how.backoff_mm * axis.steps_per_mm)
        feed = run.fast_mm_min() if run.phase != "latch" else run.how.latch_mm_min
        hj = np.array([run.i, jog.direction, jog.steps, run.max_steps, stop], dtype=np.int64)
        hf = np.array([jog.speed, jog.owed, run._speed(feed), jog.accel, jog.dt], dtype=np.float64)
        room = [0] * len(self.ctl.machine.axes)
        room[run.i] = min(max(t_end - self.ctl._tick, 0) // 2, run.max_steps - jog.steps) + 2
        self._call(K.HOME, t_end, self._common(room), home=(hj, hf))
        jog.steps, jog.speed, jog.owed = int(hj[K.J_STEPS]), float(hf[K.J_SPEED]), float(hf[K.J_OWED])
