"""When a run's digital outputs (DOUT) and input waits (WAIT) act, and the outputs in the frames.

A ``DOUT M62``/``M63`` acts as the next planned move starts (at the run's end when no move
follows); a ``DOUT M64``/``M65`` as the moves before it end. On a machine whose output pins are
on its parallel port (``[io]`` on ``port = "db25"``), the output's data bit is written in the
port byte from that tick on, so the simulator, ``vcd://`` and ``parport://`` see it; on other
ports the changes are in the report only (:func:`io_report`). A ``WAIT`` is a dwell as long as
the simulated input makes it (:func:`retrofit.motion.planner.wait_seconds`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..commands import Dout, Wait
from ..frames import PortFrames
from ..machine.iopins import port_bit, wait_outcome
from ..motion.execute import tick_of


@dataclass(frozen=True)
class OutputChange:
    """Output ``output`` goes to ``level`` at ``tick``; ``index`` is the DOUT in the program."""

    tick: int
    output: int
    level: int
    index: int


def output_changes(plan, commands) -> list[OutputChange]:
    """The tick of every DOUT of ``commands`` in the run ``plan`` made of them."""
    rate = 1.0 / plan.machine.tick_s
    moves = plan.moves
    changes, k = [], 0
    ended = 0.0                                   # when the moves before the command end
    for index, cmd in enumerate(commands):
        while k < len(moves) and moves[k].index < index:
            ended = max(ended, moves[k].t0_s + moves[k].duration_s)
            k += 1
        if not isinstance(cmd, Dout):
            continue
        at = ended
        if cmd.synced:
            at = moves[k].t0_s if k < len(moves) else plan.end_s
        changes.append(OutputChange(tick_of(at, rate), cmd.output, cmd.level, index))
    return changes


def with_outputs(frames: PortFrames, changes: list[OutputChange], machine) -> PortFrames:
    """``frames`` with the port bits of the outputs on the port set from each change on."""
    bits = [(c, port_bit(machine, c.output)) for c in changes]
    bits = [(c, b) for c, b in bits if b is not None]
    if not bits:
        return frames
    mask = 0
    event_ticks, event_values, state = [], [], 0
    for change, bit in sorted(bits, key=lambda cb: cb[0].tick):
        mask |= 1 << bit
        state = state | (1 << bit) if change.level else state & ~(1 << bit)
        if event_ticks and event_ticks[-1] == change.tick:
            event_values[-1] = state
        else:
            event_ticks.append(change.tick)
            event_values.append(state)
    end = max(frames.end_tick, event_ticks[-1] + 1)
    ticks = np.union1d(np.union1d(frames.ticks, np.asarray(event_ticks, np.int64)), [0])
    ticks = ticks[ticks < end]
    at = np.searchsorted(frames.ticks, ticks, side="right") - 1
    base = np.where(at >= 0, frames.values[np.maximum(at, 0)], 0).astype(np.int64)
    ev = np.searchsorted(np.asarray(event_ticks, np.int64), ticks, side="right") - 1
    outs = np.where(ev >= 0, np.asarray(event_values, np.int64)[np.maximum(ev, 0)], 0)
    values = (base & ~mask) | outs
    keep = np.concatenate(([True], values[1:] != values[:-1]))
    return PortFrames(ticks[keep], values[keep].astype(np.uint8), end)


def io_report(plan, commands, lines, changes: list[OutputChange]) -> dict:
    """The report's ``io`` part: every output change and every wait, with its line and tick."""
    machine = plan.machine
    io = machine.parts.get("io")
    outs = [{"tick": c.tick, "time_s": round(c.tick * machine.tick_s, 6), "output": c.output,
             "pin": io.outputs[c.output] if io and c.output < len(io.outputs) else None,
             "level": c.level, "in_port_byte": port_bit(machine, c.output) is not None,
             "line": lines[c.index]} for c in changes]
    waits = []
    for move in plan.moves:
        cmd = commands[move.index]
        if isinstance(cmd, Wait):
            value = wait_outcome(io, cmd.input, cmd.mode, cmd.timeout, move.t0_s).value
            waits.append({"line": lines[move.index], "input": cmd.input, "mode": cmd.mode,
                          "start_s": round(move.t0_s, 6), "waited_s": round(move.dwell_s, 6),
                          "value": value, "timed_out": value == -1.0})
    return {"outputs": outs, "waits": waits}
