"""004's second split in gateware: the digital integration (base axis, COUNT/LONG/SHORT) runs in
the FPGA from line records; the processor sends each line's pulse counts, the tick of every base
pulse, the offset of each short-axis pulse that falls between two base pulses, and the turns.

Three FIFOs (records in ``retrofit.fpga.lines``):

* **line** — ``n`` (the base axis's pulses) and ``d`` and the direction of every axis;
* **time** — one record per base pulse: its ``delay`` in ticks after the previous one, and for each
  axis the ``offset`` of its pulse in this base interval when that pulse falls between two base
  pulses (``wait`` = a filler that only carries time);
* **turn** — ``delay`` after the previous turn record, the axes that turn and their directions.

On each base pulse (LONG += 1) every axis's integrator adds its count ``d`` to ``e`` (004's
``SHORT - LONG``, kept as the integer ``e = (LONG + 1) d - SHORT n``): ``e > 0`` means the axis
pulses in this interval, on the base pulse itself when ``e == d`` (SHORT is a whole number), else
``offset`` ticks later; then ``e -= n`` (SHORT += COUNT). Each pulse so placed is a request; an
axis's shaper raises its step pin for the first request it may: not closer than ``period`` ticks
to its last rise nor ``setup`` ticks to its last turn, and only once the direction pin shows the
request's direction (the same rule as ``motion.stepshape``).

Safety as :mod:`retrofit.fpga.engine`: ``stop`` drops the step pins at once and empties the FIFOs;
``underrun`` (a time or turn record that arrives after its tick, a base pulse with no line, a pulse
that waits 255 ticks for the turn to its direction);
``fault`` (a line whose short axis has more pulses than its base axis, a turn closer than
``hold`` to the last rise, or one that would reverse pulses still waiting).
"""

from __future__ import annotations

from amaranth.hdl import Cat, Elaboratable, Module, Mux, ResetInserter, Signal, signed
from amaranth.lib.fifo import SyncFIFOBuffered

from .engine import GUARD_MAX, AxisTiming
from .lines import COUNT_BITS, DELAY_BITS, MAX_DELAY, LineLayout

#: requests an axis's shaper may hold before they rise
PENDING_BITS = 4


class DiAxis(Elaboratable):
    """One axis: its integrator ``e``, the offset countdown, the shaper and the pins."""

    def __init__(self, timing: AxisTiming, width: int):
        self.timing, self.width = timing, width
        self.tick = Signal()
        self.halt = Signal()                    # in: clear the state (a clock after ``drop``)
        self.drop = Signal()                    # in: the step pin low and no rise, at once
        self.base = Signal()                    # in: a base pulse of the line this tick
        self.start = Signal()                   # in: with ``base``: the line's first base pulse
        self.d = Signal(COUNT_BITS)             # in: this axis's pulses in the line
        self.n = Signal(COUNT_BITS)             # in: the base axis's pulses in the line
        self.line_dir = Signal()                # in: the line's direction for this axis
        self.offset = Signal(DELAY_BITS)        # in: the time record's offset for this axis
        self.turn = Signal()                    # in: the turn record turns this axis this tick
        self.turn_dir = Signal()
        self.step = Signal()
        self.dir = Signal()
        self.position = Signal(signed(24))
        self.refused = Signal()                 # out: a turn breaking hold or reversing waiting pulses
        self.stalled = Signal()                 # out: a request waited GUARD_MAX ticks for its turn

    def elaborate(self, platform):
        m = Module()
        arrived = Signal(2)                      # requests placed on this tick (0, 1 or 2)
        m.d.comb += arrived.eq(self._integrator(m))
        self._shaper(m, arrived)
        return m

    def _integrator(self, m: Module):
        """004's COUNT/LONG/SHORT: which base intervals this axis pulses in, and when in them."""
        e = Signal(signed(COUNT_BITS + 2))                  # (LONG + 1) d - SHORT n
        e_in = Mux(self.start, self.d - self.n, e)          # a new line: SHORT starts at COUNT
        e_add = Signal(signed(COUNT_BITS + 2))
        m.d.comb += e_add.eq(e_in + self.d)                 # LONG += 1
        pulse = self.base & (e_add > 0)                     # int(SHORT) == LONG: it pulses here
        on_base = pulse & (e_add == self.d)                 # SHORT == LONG: on the base pulse
        later = pulse & ~on_base                            # between base pulses: at the offset
        countdown, counting = Signal(DELAY_BITS), Signal()
        expire = self.tick & counting & (countdown == 1)
        with m.If(self.halt):
            m.d.sync += counting.eq(0)
        with m.Elif(self.tick & ~self.drop):
            with m.If(self.base):
                m.d.sync += e.eq(Mux(pulse, e_add - self.n, e_add))     # SHORT += COUNT
            with m.If(later & (self.offset != 0)):
                m.d.sync += [countdown.eq(self.offset), counting.eq(1)]
            with m.Elif(counting):
                m.d.sync += [countdown.eq(countdown - 1), counting.eq(countdown != 1)]
        return on_base + (later & (self.offset == 0)) + expire

    def _shaper(self, m: Module, arrived) -> None:
        """Requests to pulses: the driver's period and set-up, the direction, the width, the count."""
        t = self.timing
        pending, pending_dir = Signal(PENDING_BITS), Signal()
        since_rise = Signal(range(GUARD_MAX + 1), init=GUARD_MAX)
        since_turn = Signal(range(GUARD_MAX + 1), init=GUARD_MAX)
        high, started = Signal(8), Signal()
        waiting = pending + arrived
        turning = self.turn & (self.turn_dir != self.dir)
        pin_dir = Mux(turning, self.turn_dir, self.dir)
        wanted_dir = Mux(pending != 0, pending_dir, self.line_dir)      # the oldest request's
        set_up = 1 if t.setup == 0 else ~turning & (since_turn >= t.setup)
        rise = Signal()
        m.d.comb += rise.eq(self.tick & ~self.drop & started & (waiting != 0) & (since_rise >= t.period)
                            & set_up & (pin_dir == wanted_dir))
        reversing = (pending != 0) & (pending_dir == self.dir)         # a turn under waiting requests
        mixed = (arrived != 0) & (pending != 0) & (pending_dir != self.line_dir)
        m.d.comb += [self.step.eq((high != 0) & ~self.drop),
                     self.refused.eq(self.tick & ((turning & ((since_rise < t.hold) | reversing)) | mixed
                                                  | (waiting >= (1 << PENDING_BITS))))]
        self._stall(m, (waiting != 0) & (pin_dir != wanted_dir))
        with m.If(self.halt):
            m.d.sync += [high.eq(0), pending.eq(0)]
        with m.Elif(self.tick & ~self.drop):
            m.d.sync += [started.eq(1), pending.eq(waiting - rise), self.dir.eq(pin_dir)]
            with m.If(arrived != 0):
                m.d.sync += pending_dir.eq(self.line_dir)
            self._count(m, since_rise, rise)
            self._count(m, since_turn, turning)
            with m.If(rise):
                m.d.sync += [high.eq(self.width), self.position.eq(self.position + Mux(pin_dir, 1, -1))]
            with m.Elif(high != 0):
                m.d.sync += high.eq(high - 1)

    def _stall(self, m: Module, stuck) -> None:
        """A request the direction pin does not serve waits at most ``hold`` ticks for its turn in
        the reference: GUARD_MAX ticks mean the turn record is missing or late (``stalled``)."""
        stall = Signal(range(GUARD_MAX + 1))
        m.d.comb += self.stalled.eq(stall == GUARD_MAX)
        with m.If(self.halt | ~stuck):
            m.d.sync += stall.eq(0)
        with m.Elif(self.tick & (stall != GUARD_MAX)):
            m.d.sync += stall.eq(stall + 1)

    @staticmethod
    def _count(m, counter, restart):
        with m.If(restart):
            m.d.sync += counter.eq(1)
        with m.Elif(counter != GUARD_MAX):
            m.d.sync += counter.eq(counter + 1)


class _Head(Elaboratable):
    """A FIFO's next record in a register, and the ticks since the last record of its kind fired."""

    def __init__(self, fifo: SyncFIFOBuffered, delay_of):
        self.fifo, self.delay_of = fifo, delay_of
        self.tick, self.halt, self.drop = Signal(), Signal(), Signal()
        self.data = Signal(fifo.width)
        self.valid = Signal()
        self.fire = Signal()             # out: its tick is this one
        self.late = Signal()             # out: its tick has passed

    def elaborate(self, platform):
        m = Module()
        since = Signal(range(MAX_DELAY + 2))
        delay = self.delay_of(self.data)
        m.d.comb += [self.fire.eq(self.tick & self.valid & (delay == since) & ~self.drop),
                     self.late.eq(self.valid & (delay < since)),
                     self.fifo.r_en.eq(~self.valid | self.fire)]
        with m.If(self.halt):
            m.d.sync += [self.valid.eq(0), since.eq(0)]
        with m.Else():
            with m.If(self.fifo.r_rdy & self.fifo.r_en):
                m.d.sync += [self.data.eq(self.fifo.r_data), self.valid.eq(1)]
            with m.Elif(self.fire):
                m.d.sync += self.valid.eq(0)
            with m.If(self.tick & self.fire):
                m.d.sync += since.eq(1)
            with m.Elif(self.tick & (since != MAX_DELAY + 1)):
                m.d.sync += since.eq(since + 1)
        return m


class DiEngine(Elaboratable):
    """N axes driven by the line, time and turn FIFOs; the same ports as ``PulseEngine`` (the
    write port's ``wr_axis`` selects the FIFO: 0 time, 1 line, 2 turn; ``rd_level`` is the time
    records waiting)."""

    def __init__(self, timings, widths, clocks_per_tick: int = 1, depth: int = 16):
        self.layout = lay = LineLayout(len(timings))
        self.axes = [DiAxis(t, w) for t, w in zip(timings, widths)]
        self.fifos = [SyncFIFOBuffered(width=lay.bits(f), depth=depth) for f in (lay.time, lay.line, lay.turn)]
        self.clocks_per_tick = clocks_per_tick
        self.wr_axis = Signal(2)
        self.wr_data = Signal(max(f.width for f in self.fifos))
        self.wr_en, self.wr_rdy = Signal(), Signal()
        self.rd_axis = Signal(range(max(len(timings), 2)))
        self.rd_position = Signal(signed(24))
        self.rd_level = Signal(range(depth + 2))
        self.run, self.stop, self.clear = Signal(), Signal(), Signal()
        self.underrun, self.fault, self.stopped, self.halted = Signal(), Signal(), Signal(), Signal()
        self.tick, self.tick_next = Signal(), Signal()
        self.steps = [a.step for a in self.axes]
        self.dirs = [a.dir for a in self.axes]
        self.w_rdys = [f.w_rdy for f in self.fifos]

    def elaborate(self, platform):
        from .engine import PulseEngine
        m, lay = Module(), self.layout
        PulseEngine._prescaler(self, m)
        latched, halt_q = Signal(), Signal()
        m.d.comb += self.halted.eq(self.stop | latched)
        m.d.sync += halt_q.eq(self.halted)
        get = LineLayout.get
        time_f, line_f, turn_f = self.fifos
        heads = [_Head(time_f, lambda r: get(lay.time, r, "delay")), _Head(turn_f, lambda r: get(lay.turn, r, "delay"))]
        for k, fifo in enumerate(self.fifos):
            m.submodules[f"fifo{k}"] = ResetInserter(halt_q)(fifo)
            m.d.comb += [fifo.w_data.eq(self.wr_data), fifo.w_en.eq(self.wr_en & (self.wr_axis == k))]
            with m.If(self.wr_axis == k):
                m.d.comb += self.wr_rdy.eq(fifo.w_rdy & ~self.halted)
        for k, head in enumerate(heads):
            m.submodules[f"head{k}"] = head
            m.d.comb += [head.tick.eq(self.tick), head.halt.eq(halt_q), head.drop.eq(self.halted)]
        times, turns = heads
        # the line: the one running, or at its end (left == 0) the line FIFO's next one
        left = Signal(COUNT_BITS)
        current = Signal(line_f.width)
        start = left == 0
        line = Mux(start, line_f.r_data, current)
        base = times.fire & ~get(lay.time, times.data, "wait")
        missing = base & start & ~line_f.r_rdy
        n = get(lay.line, line, "n")
        bad = base & start & ((n == 0) | Cat(*[get(lay.line, line, f"d{a}") > n for a in range(lay.axes)]).any())
        m.d.comb += line_f.r_en.eq(base & start & ~bad)
        with m.If(halt_q):
            m.d.sync += left.eq(0)
        with m.Elif(base & ~missing & ~bad):
            m.d.sync += [current.eq(line), left.eq(Mux(start, n, left) - 1)]
        refused, stalled = [], []
        for a, axis in enumerate(self.axes):
            m.submodules[f"axis{a}"] = axis
            m.d.comb += [axis.tick.eq(self.tick), axis.halt.eq(halt_q), axis.drop.eq(self.halted),
                         axis.base.eq(base & ~missing & ~bad), axis.start.eq(start), axis.n.eq(n),
                         axis.d.eq(get(lay.line, line, f"d{a}")), axis.line_dir.eq(get(lay.line, line, f"dir{a}")),
                         axis.offset.eq(get(lay.time, times.data, f"offset{a}")),
                         axis.turn.eq(turns.fire & get(lay.turn, turns.data, f"turn{a}")),
                         axis.turn_dir.eq(get(lay.turn, turns.data, f"dir{a}"))]
            with m.If(self.rd_axis == a):
                m.d.comb += self.rd_position.eq(axis.position)
            refused.append(axis.refused)
            stalled.append(axis.stalled)
        m.d.comb += self.rd_level.eq(time_f.level + times.valid)
        late = self.tick & ~self.halted & (times.late | turns.late | missing | Cat(*stalled).any())
        wrong = self.tick & ~self.halted & (bad | Cat(*refused).any())
        with m.If(self.stop):
            m.d.sync += [self.stopped.eq(1), latched.eq(1)]
        with m.Elif(self.clear):
            m.d.sync += [self.stopped.eq(0), self.underrun.eq(0), self.fault.eq(0), latched.eq(0)]
        with m.Else():
            with m.If(late):
                m.d.sync += [self.underrun.eq(1), latched.eq(1)]
            with m.If(wrong):
                m.d.sync += [self.fault.eq(1), latched.eq(1)]
        return m
