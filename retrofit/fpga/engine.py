"""The pulse engine of 004's FPGA: per axis a FIFO of pulse records, counters that raise the step
pin after each record's delay for its width, the direction set at the event, a position counter.

All counting is in ticks: a prescaler divides the FPGA clock by ``clocks_per_tick`` (48 at 48 MHz
for the engraver's 1 us tick); in simulation it is 1. With two or more clocks a tick the fire
decision is registered a clock ahead of the tick (the counters only change at ticks). On each tick the engine computes the pins
of the next tick ``n``: the head record fires when ``n`` is ``delay`` ticks after the axis's last
event. The pins hold what was computed until the next tick.

Safety (all latched until ``clear``; while any holds, every FIFO is emptied and refuses writes,
and every step pin is low):

* ``stop`` — the operator's stop: the FIFOs empty and the step pins drop in the same clock cycle
  (a pulse under way is cut short; its step was already counted at the rising edge);
* ``underrun`` — a record reached the head of its FIFO after its tick had passed: the axes
  would leave the path, so all of them stop;
* ``fault`` — a record breaks the driver's timing (a direction turn closer than ``hold`` ticks
  after a rise, a rise closer than ``setup`` ticks after a turn or ``period`` ticks after the
  last rise): the engine refuses it and stops, it never sends a pulse the driver may miss.
"""

from __future__ import annotations

from dataclasses import dataclass

from amaranth.hdl import Cat, Elaboratable, Module, Mux, ResetInserter, Signal, signed
from amaranth.lib.fifo import SyncFIFOBuffered

from .record import MAX_DELAY, RECORD_BITS, PulseRecord

#: how far the counters since the last rise / turn count before they saturate (above any guard)
GUARD_MAX = 255


@dataclass(frozen=True)
class AxisTiming:
    """The driver's timing an axis is guarded by, in ticks (from the machine file)."""

    period: int      # shortest rise-to-rise distance (pulse_high_ticks + pulse_low_ticks)
    setup: int       # direction set-up before a rise
    hold: int        # direction hold after a rise

    @classmethod
    def of(cls, axis) -> AxisTiming:
        return cls(axis.pulse_high_ticks + axis.pulse_low_ticks, axis.dir_setup_ticks, axis.dir_hold_ticks)


class AxisEngine(Elaboratable):
    """One axis: its record FIFO, the delay and width counters, the step and direction pins."""

    def __init__(self, timing: AxisTiming, depth: int = 16, registered: bool = False):
        if max(timing.period, timing.setup, timing.hold) > GUARD_MAX:
            raise ValueError(f"axis timing {timing} above {GUARD_MAX} ticks: the guard counters are 8 bits")
        self.timing = timing
        self.registered = registered     # decide a clock ahead of the tick (needs 2+ clocks a tick)
        self.fifo = SyncFIFOBuffered(width=RECORD_BITS, depth=depth)
        self.tick = Signal()                    # in: one clock cycle per tick
        self.tick_next = Signal()               # in: the next clock is a tick (registered mode)
        self.run = Signal()                     # in: ticks count (registered mode)
        self.halt = Signal()                    # in: empty the FIFO (a clock after ``drop``)
        self.drop = Signal()                    # in: the step pin low and no event, at once
        self.stop = Signal()                    # in: ``drop`` is ``stop | latched`` (the registered
        self.latched = Signal()                 #     mode reads them apart: one gate to ``fired``)
        self.step = Signal()                    # out: the step pin (logical level)
        self.dir = Signal()                     # out: the direction pin (1 = positive)
        self.position = Signal(signed(24))      # out: rises counted, +1 / -1 by direction
        self.late = Signal()                    # out: the head record's tick has passed
        self.refused = Signal()                 # out: the head record breaks the driver's timing
        self.fired = Signal()                   # out: an event is made this tick
        self.waiting = Signal(range(depth + 2))  # out: records not yet fired (FIFO and head)

    def elaborate(self, platform):
        m = Module()
        m.submodules.fifo = ResetInserter(self.halt)(self.fifo)
        head = PulseRecord(Signal(RECORD_BITS))          # the next record, out of the FIFO's RAM
        head_valid = Signal()
        since_event = Signal(range(MAX_DELAY + 2))      # next tick's distance from the last event
        high = Signal(8)                                # step-high ticks still to come
        since_rise = Signal(range(GUARD_MAX + 1), init=GUARD_MAX)
        since_turn = Signal(range(GUARD_MAX + 1), init=GUARD_MAX)
        t = self.timing

        turning = head.dir != self.dir
        rising = head.width != 0
        due = Signal()
        # the event tick is since_* + 1 ticks after the last rise / turn: compared with constants
        at_delay = head_valid & (head.delay == since_event)
        breaks = ((turning & (since_rise < t.hold - 1)) | (rising & (since_rise < t.period - 1))
                  | (rising & turning & (t.setup > 0)) | (rising & (since_turn < t.setup - 1)))
        decide = [due.eq(at_delay), self.late.eq(head_valid & (head.delay < since_event)),
                  self.refused.eq(at_delay & breaks)]
        if self.registered:          # the state a clock before the tick is the state at the tick
            m.d.sync += decide
            ready = Signal()         # fires at the next clock, a tick (one gate from the flip-flop to fired)
            m.d.sync += ready.eq(self.tick_next & at_delay & ~breaks)
            m.d.comb += self.fired.eq(self.run & ready & ~self.stop & ~self.latched)
            # the record leaves the head and the counters restart without waiting for the stop's
            # gate: a stop in this very clock clears them all a clock later (``halt``), and the
            # guards only err on the safe side (a rise that was stopped still counts as one)
            go = self.run & ready
        else:
            m.d.comb += decide
            m.d.comb += self.fired.eq(self.tick & due & ~self.refused & ~self.drop)
            go = self.fired
        m.d.comb += [
            self.step.eq((high != 0) & ~self.drop),
            self.fifo.r_en.eq(~head_valid | go),
        ]
        with m.If(self.halt):
            m.d.sync += [high.eq(0), since_event.eq(0), head_valid.eq(0)]
        with m.Elif(self.fifo.r_rdy & self.fifo.r_en):      # the head register refilled
            m.d.sync += [head.eq(self.fifo.r_data), head_valid.eq(1)]
        with m.Elif(go):
            m.d.sync += head_valid.eq(0)
        m.d.comb += self.waiting.eq(self.fifo.level + head_valid)
        with m.If(self.tick & ~self.halt):
            self._count(m, since_event, MAX_DELAY + 1, restart=go, to=1)
            self._count(m, since_turn, GUARD_MAX, restart=go & turning, to=0)
            self._count(m, since_rise, GUARD_MAX, restart=go & rising, to=0)
            with m.If(self.fired):
                m.d.sync += self.dir.eq(head.dir)
            with m.If(self.fired & rising):
                m.d.sync += high.eq(head.width)
            with m.Elif(high != 0):
                m.d.sync += high.eq(high - 1)
        # the position counts a clock after the rise (read over the bus, it is a clock late: the
        # 24-bit adder is off the path from the fire decision)
        rose, rose_up = Signal(), Signal()
        m.d.sync += [rose.eq(self.fired & rising & self.tick & ~self.halt), rose_up.eq(head.dir)]
        with m.If(rose):
            m.d.sync += self.position.eq(self.position + Mux(rose_up, 1, -1))
        return m

    @staticmethod
    def _count(m: Module, counter: Signal, top: int, restart, to: int) -> None:
        """``counter`` restarts at ``to`` on ``restart``, else counts up to ``top`` and stays."""
        with m.If(restart):
            m.d.sync += counter.eq(to)
        with m.Elif(counter != top):
            m.d.sync += counter.eq(counter + 1)


class PulseEngine(Elaboratable):
    """N axes behind one write port and one read port, a tick prescaler and the shared stop.

    Write port: ``wr_axis`` selects the axis, ``wr_data`` is a packed record, ``wr_en`` writes it
    when ``wr_rdy`` (the selected FIFO has room). Read port: ``rd_axis`` selects whose
    ``rd_position`` and ``rd_level`` (records waiting) show. Status: ``underrun``, ``fault``,
    ``stopped`` (latched; ``clear`` releases them once ``stop`` is low).
    """

    def __init__(self, timings, clocks_per_tick: int = 1, depth: int = 16):
        self.axes = [AxisEngine(t, depth, registered=clocks_per_tick > 1) for t in timings]
        self.clocks_per_tick = clocks_per_tick
        n = len(self.axes)
        self.wr_axis = Signal(range(max(n, 2)))
        self.wr_data = Signal(RECORD_BITS)
        self.wr_en = Signal()
        self.wr_rdy = Signal()
        self.rd_axis = Signal(range(max(n, 2)))
        self.rd_position = Signal(signed(24))
        self.rd_level = Signal(range(depth + 2))
        self.run = Signal()                 # the host primed the FIFOs: ticks may start
        self.stop = Signal()
        self.clear = Signal()
        self.underrun = Signal()
        self.fault = Signal()
        self.stopped = Signal()
        self.halted = Signal()
        self.tick = Signal()
        self.tick_next = Signal()           # the next clock is a tick (when ``run`` stays high)
        self.steps = [a.step for a in self.axes]
        self.dirs = [a.dir for a in self.axes]
        self.w_rdys = [a.fifo.w_rdy for a in self.axes]      # the FIFOs the write port selects

    def elaborate(self, platform):
        m = Module()
        self._prescaler(m)
        latched = Signal()      # underrun | fault | stopped, kept in one register (one gate to halted)
        m.d.comb += self.halted.eq(self.stop | latched)
        # the FIFOs and counters clear a clock after the halt (a register: off the critical path);
        # the step pins drop and the events stop in the halt's own clock (``drop``)
        halt_q = Signal()
        m.d.sync += halt_q.eq(self.halted)
        for k, axis in enumerate(self.axes):
            m.submodules[f"axis{k}"] = axis
            selected = self.wr_axis == k
            m.d.comb += [axis.tick.eq(self.tick), axis.tick_next.eq(self.tick_next), axis.run.eq(self.run),
                         axis.halt.eq(halt_q), axis.drop.eq(self.halted),
                         axis.stop.eq(self.stop), axis.latched.eq(latched),
                         axis.fifo.w_data.eq(self.wr_data), axis.fifo.w_en.eq(self.wr_en & selected)]
            with m.If(selected):
                m.d.comb += self.wr_rdy.eq(axis.fifo.w_rdy & ~self.halted)
            with m.If(self.rd_axis == k):
                m.d.comb += [self.rd_position.eq(axis.position), self.rd_level.eq(axis.waiting)]
            with m.If(self.tick & axis.late & ~self.halted):
                m.d.sync += self.underrun.eq(1)
            with m.If(self.tick & axis.refused & ~self.halted):
                m.d.sync += self.fault.eq(1)
        late = Cat(*[a.late for a in self.axes]).any()
        refused = Cat(*[a.refused for a in self.axes]).any()
        with m.If(self.stop):
            m.d.sync += [self.stopped.eq(1), latched.eq(1)]
        with m.Elif(self.clear):
            m.d.sync += [self.stopped.eq(0), self.underrun.eq(0), self.fault.eq(0), latched.eq(0)]
        with m.Elif(self.tick & ~self.halted & (late | refused)):
            m.d.sync += latched.eq(1)
        return m

    def _prescaler(self, m: Module) -> None:
        if self.clocks_per_tick == 1:
            m.d.comb += self.tick.eq(self.run)
            return
        count = Signal(range(self.clocks_per_tick))       # the first tick is the first clock of ``run``
        at_zero = Signal(init=1)                          # count == 0, kept in a register
        m.d.comb += [self.tick.eq(self.run & at_zero),
                     self.tick_next.eq(~self.run | (~at_zero & (count == 1)))]
        with m.If(~self.run):
            m.d.sync += [count.eq(0), at_zero.eq(1)]
        with m.Elif(at_zero):
            m.d.sync += [count.eq(self.clocks_per_tick - 1), at_zero.eq(0)]
        with m.Else():
            m.d.sync += [count.eq(count - 1), at_zero.eq(count == 1)]
