"""The processor's side of 004's second split: a plan's moves as line records for the gateware's
digital integration (``retrofit.fpga.di``), and the layouts of those records.

What the processor sends, and why (docs/fpga.md, "The second split"):

* per line, its counts: ``n`` (the base axis's pulses), ``d`` and the direction of every axis;
* per base pulse, its tick as a ``delay`` after the previous base pulse — and, for each short axis
  whose pulse falls *between* two base pulses in that interval (SHORT not a whole number), its
  ``offset`` in ticks after the base pulse;
* per direction turn, its tick (the processor's look-ahead decides when a reversal may begin).

The gateware decides which axes pulse in which interval (COUNT/LONG/SHORT) and shapes the pulses
to the driver's timing. The offsets are the processor's because the reference places every pulse
at its own place on the velocity profile (``motion.dda``, ``motion.fast``): under acceleration a
pulse at SHORT = 4.5 is not halfway in time between base pulses 4 and 5, so no integrator fed only
the base ticks can put it on the same tick. A pulse that falls on a base pulse needs no offset.
"""

from __future__ import annotations

import numpy as np

from ..errors import OutputError

COUNT_BITS = 16
DELAY_BITS = 16
MAX_DELAY = (1 << DELAY_BITS) - 1
MAX_COUNT = (1 << COUNT_BITS) - 1
TIME, LINE, TURN = 0, 1, 2           # the FIFOs: the write port's ``wr_axis``


class LineLayout:
    """Bit fields of the three records for ``axes`` axes (field -> (first bit, width))."""

    def __init__(self, axes: int):
        self.axes = axes
        self.time = self._fields([("delay", DELAY_BITS), ("wait", 1)]
                                 + [(f"offset{a}", DELAY_BITS) for a in range(axes)])
        self.line = self._fields([("n", COUNT_BITS)] + [(f"d{a}", COUNT_BITS) for a in range(axes)]
                                 + [(f"dir{a}", 1) for a in range(axes)])
        self.turn = self._fields([("delay", DELAY_BITS)] + [(f"turn{a}", 1) for a in range(axes)]
                                 + [(f"dir{a}", 1) for a in range(axes)])

    @staticmethod
    def _fields(spec):
        out, at = {}, 0
        for name, width in spec:
            out[name] = (at, width)
            at += width
        out["bits"] = (at, 0)
        return out

    @staticmethod
    def bits(fields) -> int:
        return fields["bits"][0]

    @staticmethod
    def pack(fields, **values) -> int:
        word = 0
        for name, value in values.items():
            at, width = fields[name]
            assert 0 <= value < (1 << width), (name, value)
            word |= value << at
        return word

    @staticmethod
    def get(fields, word, name: str):
        """A field of a record: of a packed int (host) or of a Signal (gateware)."""
        at, width = fields[name]
        if isinstance(word, int):
            return (word >> at) & ((1 << width) - 1)
        return word[at:at + width]


def compile_lines(plan, frames) -> list[list[int]]:
    """[time records, line records, turn records] of a plan whose run made ``frames``."""
    from ..motion.fast import request_steps_fast
    machine = plan.machine
    _check_interpolator(machine)
    return line_records(machine, request_steps_fast(plan), frames)


def line_records(machine, req, frames) -> list[list[int]]:
    """The records of step requests ``req`` (``motion.execute.StepRequests``: each pulse's wanted
    tick, per move its counts) whose run made ``frames`` (its direction turns)."""
    lay = LineLayout(len(machine.axes))
    times, lines = _lines(lay, req)
    return [times, lines, _turns(lay, machine, frames)]


def _lines(lay: LineLayout, req) -> tuple[list[int], list[int]]:
    axes = lay.axes
    done = np.zeros(axes, np.int64)
    times, lines, last = [], [], 0
    for counts in req.counts:
        d = counts - done
        n = int(d.max()) if axes else 0
        if n == 0:
            continue
        if n > MAX_COUNT:
            raise OutputError(f"a line of {n} base pulses; a line record holds 1..{MAX_COUNT}")
        base = int(np.argmax(d))
        dirs = [int(req.dirs[a][done[a]] > 0) if d[a] else 0 for a in range(axes)]
        lines.append(lay.pack(lay.line, n=n, **{f"d{a}": int(d[a]) for a in range(axes)},
                              **{f"dir{a}": dirs[a] for a in range(axes)}))
        ticks = [req.ticks[a][done[a]:done[a] + d[a]] for a in range(axes)]
        offsets = [dict() for _ in range(n + 1)]        # base pulse k -> {axis: offset}
        for a in range(axes):
            for j in range(1, int(d[a]) + 1):
                k, frac = divmod(j * n, int(d[a]))
                off = int(ticks[a][j - 1]) - int(ticks[base][k - 1])
                if frac == 0 and off != 0 or not 0 <= off <= MAX_DELAY:
                    raise OutputError(f"axis {a} pulse {j} of {d[a]} at tick {ticks[a][j - 1]}: {off} ticks "
                                      f"from base pulse {k}; a line record places it 0..{MAX_DELAY} ticks after")
                if frac:
                    offsets[k][a] = off
        for k in range(1, n + 1):
            tick = int(ticks[base][k - 1])
            delay = tick - last
            if delay < (1 if times else 0):
                raise OutputError(f"base pulses at tick {last} and {tick}: a time record holds one a tick")
            while delay > MAX_DELAY:
                times.append(lay.pack(lay.time, delay=MAX_DELAY, wait=1))
                delay -= MAX_DELAY
            times.append(lay.pack(lay.time, delay=delay, **{f"offset{a}": o for a, o in offsets[k].items()}))
            last = tick
        done = counts.copy()
    return times, lines


def _turns(lay: LineLayout, machine, frames) -> list[int]:
    """The direction pins' changes in the run's frames, merged by tick, as turn records."""
    return TurnRecords(lay, machine).feed(frames)


class TurnRecords:
    """The direction pins' changes, merged by tick, as turn records: chunk after chunk of frames."""

    def __init__(self, lay: LineLayout, machine):
        from ..frames import PinMap
        pins = PinMap(machine)
        self.lay, self.invert, self.dir_masks = lay, pins.invert, pins.dir_masks
        self.last, self.prev = 0, [False] * lay.axes

    def feed(self, frames) -> list[int]:
        """The turn records of the next chunk of frames (ticks after the last chunk's)."""
        lay = self.lay
        logical = frames.values.astype(np.int64) ^ self.invert
        dirs = [(logical & m) != 0 for m in self.dir_masks]
        ticks = frames.ticks.astype(np.int64)
        out = []
        for i in range(len(ticks)):
            now = [bool(d[i]) for d in dirs]
            if now == self.prev:
                continue
            delay = int(ticks[i]) - self.last
            while delay > MAX_DELAY:
                out.append(lay.pack(lay.turn, delay=MAX_DELAY))
                delay -= MAX_DELAY
            turned = {f"turn{a}": int(now[a] != self.prev[a]) for a in range(lay.axes)}
            out.append(lay.pack(lay.turn, delay=delay, **turned, **{f"dir{a}": int(now[a]) for a in range(lay.axes)}))
            self.last, self.prev = int(ticks[i]), now
        return out


class LineFeed:
    """The digital-integration engine's records of a run, as ``fpga-sim://?variant=di`` streams
    them: the time and line records from the plan's step requests (all of them with the first
    chunk), the turn records from each chunk of the run's frames (the same interface as
    ``host.RecordCompiler``: per FIFO, the records to add)."""

    def __init__(self, plan):
        _check_interpolator(plan.machine)
        self.plan, self.turns = plan, TurnRecords(LineLayout(len(plan.machine.axes)), plan.machine)
        self.started = False

    def feed(self, frames) -> list[list[int]]:
        """[time, line, turn] records to add after these frames."""
        turns = self.turns.feed(frames)
        if self.started:
            return [[], [], turns]
        self.started = True
        from ..motion.fast import request_steps_fast
        times, lines = _lines(self.turns.lay, request_steps_fast(self.plan))
        return [times, lines, turns]

    def finish(self, end_tick: int) -> list[list[int]]:
        """Nothing is left at the run's end (every record is whole when made)."""
        return [[], [], []] if self.started else self.feed(_no_frames(end_tick))


def _no_frames(end_tick: int):
    from ..frames import PortFrames
    return PortFrames(np.zeros(0, np.int64), np.zeros(0, np.uint8), end_tick)


def _check_interpolator(machine) -> None:
    if machine.motion.interpolator != "dda":
        raise OutputError(f"{machine.name}: the digital-integration gateware runs 004's interpolator; "
                          f"this machine's is {machine.motion.interpolator!r} (interpolator = \"dda\")")


def bus_words(records: list[list[int]], lay: LineLayout) -> int:
    """32-bit bus words a real link needs: a time record 1 word plus one per short offset it
    carries (16 bits each, two to a word), a line record 2 words (up to 3 axes), a turn 1 word."""
    times, lines, turns = records
    words = 0
    for rec in times:
        offs = sum(1 for a in range(lay.axes) if lay.get(lay.time, rec, f"offset{a}"))
        words += 1 + (offs + 1) // 2
    return words + len(lines) * ((lay.axes + 1) * COUNT_BITS + lay.axes + 31) // 32 + len(turns)
