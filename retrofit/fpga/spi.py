"""The engine's bus on a board: an SPI target (mode 0, 32-bit words, most significant bit first),
as the bridge board of 004 would wire the processor to the FPGA.

SPI rather than a parallel FIFO bus because it needs four wires on any board (the iCEBreaker's
PMOD, a Raspberry Pi or a microcontroller as the host) and a record is one 32-bit word: at a
12 MHz SPI clock (a quarter of 48 MHz) that is 375 000 records a second, more than the engraver's
three axes need (3 x 4 800 steps a second at 60 mm/s and 80 steps/mm).

Words from the host (bits 31..29 the operation):

* ``001 aa . record`` — append the 25-bit record (``retrofit.fpga.record``) to axis ``aa``'s
  FIFO; a record sent to a full FIFO is lost, so it stops the engine (as ``stop``);
* ``010 ...... r c s`` — control: ``s`` = stop (held while 1), ``c`` = clear the latched
  flags, ``r`` = run (ticks count; set it once the FIFOs are primed);
* ``011 aa ...`` — choose the axis whose position and FIFO level the next replies carry.

Each word's reply (shifted out while the next word is shifted in, latched when ``cs_n`` falls):
bits 0..23 the chosen axis's position (two's complement), 24..28 its FIFO level, 29 underrun,
30 fault (a record refused), 31 stopped (by ``stop``, the stop pin, or a lost record).
The SPI clock must be at most a quarter of the FPGA clock (the inputs are synchronised).
"""

from __future__ import annotations

from amaranth.hdl import Cat, Elaboratable, Module, Signal
from amaranth.lib.cdc import FFSynchronizer

OP_RECORD, OP_CONTROL, OP_SELECT = 1, 2, 3


class SpiBridge(Elaboratable):
    """SPI target in front of a :class:`~retrofit.fpga.engine.PulseEngine` (or its variant)."""

    def __init__(self, engine):
        self.engine = engine
        self.word_bits = word_bits(engine)
        self.sck, self.copi, self.cs_n = Signal(), Signal(), Signal(init=1)
        self.cipo = Signal()
        self.stop_in = Signal()               # the stop pin, already active-high
        self.lost = Signal()                  # a record met a full FIFO

    def elaborate(self, platform):
        m, eng = Module(), self.engine
        sck, copi, cs_n = Signal(), Signal(), Signal(init=1)
        m.submodules += [FFSynchronizer(self.sck, sck), FFSynchronizer(self.copi, copi),
                         FFSynchronizer(self.cs_n, cs_n, init=1)]
        sck_was, cs_was = Signal(), Signal(init=1)
        m.d.sync += [sck_was.eq(sck), cs_was.eq(cs_n)]
        w = self.word_bits
        shift_in, shift_out, count = Signal(w), Signal(w), Signal(range(w + 1))
        held_stop, run, select = Signal(), Signal(), Signal(2)
        level = Signal(5)
        m.d.comb += level.eq(eng.rd_level)
        reply = Cat(eng.rd_position[:24], level, eng.underrun, eng.fault, eng.stopped)
        m.d.comb += [self.cipo.eq(shift_out[w - 1]), eng.rd_axis.eq(select), eng.run.eq(run),
                     eng.wr_axis.eq(shift_in[w - 5:w - 3]), eng.wr_data.eq(shift_in[:len(eng.wr_data)])]
        with m.If(cs_was & ~cs_n):                                 # selected: a word begins
            m.d.sync += [count.eq(0), shift_out.eq(reply << (w - 32))]
        with m.Elif(~cs_n & sck & ~sck_was):                       # rising SCK: sample COPI
            m.d.sync += [shift_in.eq(Cat(copi, shift_in[:w - 1])), count.eq(count + 1)]
        with m.Elif(~cs_n & ~sck & sck_was):                       # falling SCK: next bit out
            m.d.sync += shift_out.eq(shift_out << 1)
        # the stop sources are registers; their OR is one more, so the engine's halt is one gate
        stop = Signal()
        m.d.sync += stop.eq(held_stop | self.stop_in | self.lost)
        m.d.comb += eng.stop.eq(stop)
        # a whole word ended (deselected after w bits), acted on a clock later from a register
        done = Signal()
        m.d.sync += done.eq(~cs_was & cs_n & (count == w))
        op = shift_in[w - 3:w]
        m.d.comb += [eng.wr_en.eq(done & (op == OP_RECORD)), eng.clear.eq(done & (op == OP_CONTROL) & shift_in[1])]
        with m.If(done & (op == OP_RECORD) & ~eng.wr_rdy & ~eng.halted):
            m.d.sync += self.lost.eq(1)
        with m.If(done & (op == OP_CONTROL)):
            m.d.sync += [held_stop.eq(shift_in[0]), run.eq(shift_in[2])]
            with m.If(shift_in[1]):
                m.d.sync += self.lost.eq(0)
        with m.If(done & (op == OP_SELECT)):
            m.d.sync += select.eq(shift_in[w - 5:w - 3])
        return m


def word_bits(engine) -> int:
    """32 for the pulse engine; the digital-integration engine's wider records make its words
    longer (whole bytes): operation and selector stay the top five bits, the reply the top 32."""
    return max(32, -(-(5 + len(engine.wr_data)) // 8) * 8)


def word(op: int, axis: int = 0, payload: int = 0, bits: int = 32) -> int:
    """A host word of ``bits`` bits (``SpiBridge.word_bits``; for tests and a host driver)."""
    return (op << (bits - 3)) | (axis << (bits - 5)) | payload
