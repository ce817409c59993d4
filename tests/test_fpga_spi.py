"""The engine's SPI bus: records written as 32-bit words come out as pulses; the reply carries the
position and the flags; a record sent to a full FIFO stops the engine."""

from amaranth.hdl import Module
from amaranth.sim import Simulator

from retrofit.fpga.engine import AxisTiming, PulseEngine
from retrofit.fpga.record import pack
from retrofit.fpga.spi import OP_CONTROL, OP_RECORD, OP_SELECT, SpiBridge, word, word_bits


def spi_session(words, after_cycles=60, depth=4, eng=None):
    eng = eng or PulseEngine([AxisTiming(4, 2, 2)] * 2, clocks_per_tick=1, depth=depth)
    top = Module()
    spi = SpiBridge(eng)
    top.submodules.eng, top.submodules.spi = eng, spi
    replies, steps = [], []

    async def bench(ctx):
        for w in words:
            if w is None:                                # the host waits a while
                await ctx.tick().repeat(40)
                continue
            ctx.set(spi.cs_n, 0)
            await ctx.tick().repeat(4)
            got = 0
            for bit in range(spi.word_bits - 1, -1, -1):
                ctx.set(spi.copi, w >> bit & 1)
                await ctx.tick().repeat(3)
                ctx.set(spi.sck, 1)
                got = got << 1 | ctx.get(spi.cipo)
                await ctx.tick().repeat(3)
                ctx.set(spi.sck, 0)
            await ctx.tick().repeat(3)
            ctx.set(spi.cs_n, 1)
            await ctx.tick().repeat(6)
            replies.append(got)
        for _ in range(after_cycles):
            await ctx.tick()
            steps.append(ctx.get(eng.steps[1]))

    sim = Simulator(top)
    sim.add_clock(1e-6)
    sim.add_testbench(bench)
    sim.run()
    return replies, steps


def test_records_over_spi_become_pulses_and_the_reply_counts_them():
    words = [word(OP_SELECT, 1), word(OP_RECORD, 1, pack(2, 0, 3)), word(OP_RECORD, 1, pack(10, 0, 3)),
             word(OP_CONTROL, payload=0b100), None, word(OP_CONTROL, payload=0b100)]
    replies, steps = spi_session(words)
    assert replies[-1] & 0xFFFFFF == 0xFFFFFE          # position -2: both pulses went out
    assert replies[-1] >> 29 == 0                       # no underrun, no fault, not stopped
    assert replies[3] >> 24 & 0x1F == 2                 # both records waited before run


def test_a_record_to_a_full_fifo_stops_the_engine():
    words = [word(OP_RECORD, 0, pack(1, 0, 1))] * 6 + [word(OP_SELECT, 0)]   # room for 4 + the head
    replies, steps = spi_session(words, after_cycles=5, depth=4)
    assert replies[-1] >> 31 == 1 and replies[-1] >> 24 & 0x1F == 0   # stopped, FIFO emptied


def test_line_and_time_records_over_spi_drive_the_digital_integration_engine():
    from retrofit.fpga.di import DiEngine
    from retrofit.fpga.lines import LINE, TIME, TURN, LineLayout
    eng, lay = DiEngine([AxisTiming(4, 2, 2)] * 2, [2, 2], depth=4), LineLayout(2)
    bits = word_bits(eng)                                              # 56 for two axes
    line = lay.pack(lay.line, n=2, d0=2, d1=1, dir0=1, dir1=1)       # X 2 pulses, Y 1 (on X's second)
    words = [word(OP_SELECT, 1, bits=bits), word(OP_RECORD, LINE, line, bits),
             *[word(OP_RECORD, TIME, lay.pack(lay.time, delay=d), bits) for d in (3, 10)],
             word(OP_RECORD, TURN, lay.pack(lay.turn, delay=0, turn0=1, turn1=1, dir0=1, dir1=1), bits),
             word(OP_CONTROL, payload=0b100, bits=bits), None, word(OP_CONTROL, payload=0b100, bits=bits)]
    replies, _ = spi_session(words, eng=eng)
    reply = replies[-1] >> (bits - 32)                                 # the reply is the top 32 bits
    assert reply & 0xFFFFFF == 1 and reply >> 29 == 0                  # Y +1, no flag
