"""The link's pieces checked where a mutation run found them unchecked (bench/mutation.py): the
bytes stuffing writes, a scripted host's first frames, and how often a simulated noisy wire inserts bytes."""

from __future__ import annotations

import random

from retrofit.commands import PMov
from retrofit.link.codec import OPCODES, SYNC, decode_command
from retrofit.link.framing import FrameDecoder, stuff
from retrofit.link.script import SIMAVR_FIRST_SESSION, SYNC_COPIES, ScriptedHost
from retrofit.link.simwire import FaultyWire
from retrofit.machine.config import load_machine


def test_stuffing_escapes_the_frame_start_and_the_escape_byte():
    # 0x7E -> 0x7D 0x5E and 0x7D -> 0x7D 0x5D (the byte XOR 0x20); other bytes pass
    assert stuff(bytes([0x7E, 0x7D, 0x41])) == bytes([0x7D, 0x5E, 0x7D, 0x5D, 0x41])


def test_a_wire_that_only_inserts_inserts_at_its_rate():
    wire = FaultyWire(random.Random(7), insert=0.25)
    out = wire.carry(bytes(4000))
    assert 850 < wire.stats.inserted < 1150               # 1000 expected; 5 standard deviations
    assert len(out) == 4000 + wire.stats.inserted
    assert wire.stats.dropped == wire.stats.flipped == 0


def test_a_wire_that_drops_and_inserts_does_both_at_their_rates():
    wire = FaultyWire(random.Random(7), drop=0.1, insert=0.1)
    out = wire.carry(bytes(4000))
    assert 300 < wire.stats.dropped < 500 and 300 < wire.stats.inserted < 500     # 400 each expected
    assert len(out) == 4000 - wire.stats.dropped + wire.stats.inserted


def test_a_scripted_hosts_first_command_opens_its_session_then_follows_bound():
    machine = load_machine("chivu-lathe")
    data = ScriptedHost(machine).frame("PMOV X12.5 Z-3")
    frames = list(FrameDecoder(lambda seq: SIMAVR_FIRST_SESSION if seq == 1 else None).events(data))
    assert [(f.seq, f.payload[0], f.bound) for f in frames] == [(0, SYNC, False)] * SYNC_COPIES + [(1, OPCODES[PMov], True)]
    assert decode_command(frames[-1].payload, machine) == PMov((("X", 12.5), ("Z", -3.0)))
