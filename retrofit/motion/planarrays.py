"""The planner over arrays: a whole program prepared by compiled passes, no object per move.

:func:`plan_arrays` gives the same plan as ``planner.plan_program`` (the readable walker), float
for float, by other means: the commands are read once into a table of numbers (kind, axis
words, feed), one compiled pass walks it as the interpreter does (feeds, PSTN offsets, backlash
side, soft limits, the step space) and works out each move's kinematics, the look-ahead pass of
``lookahead`` gives the junction speeds, and one more pass gives each move's profile and start
time. A program the walker would refuse (a bad feed, an unknown axis, a target outside the
limits) returns None, so the readable walker runs and words the refusal.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..commands import Dely, FFdr, FMov, MFdr, PFdr, PMov, Prob, Pstn, Wait, ZMov
from ._jit import compiled, kernel
from .bresenham import STEP_SPACE_LIMIT
from .lookahead import speeds_of
from .profile import P_T1, P_T2, P_TC, P_WIDTH, trapezoid_into

K_NONE, K_FMOV, K_PMOV, K_ZMOV, K_DELY, K_PSTN, K_FFDR, K_FEED = range(8)
_KINDS = {FMov: K_FMOV, PMov: K_PMOV, ZMov: K_ZMOV, Dely: K_DELY, Pstn: K_PSTN,
          FFdr: K_FFDR, PFdr: K_FEED, MFdr: K_FEED}


@dataclass
class PlanArrays:
    """Every move of a plan as columns (row m is ``plan.moves[m]``)."""

    starts: np.ndarray           # int64 [moves, axes]: motor steps
    ends: np.ndarray             # int64 [moves, axes]: motor steps, clearance included
    targets: np.ndarray          # int64 [moves, axes]: commanded steps
    t0s: np.ndarray              # float64 [moves]: program time at the start
    profiles: np.ndarray         # float64 [moves, P_WIDTH]: profile rows (zeros for a dwell)
    has_profile: np.ndarray      # bool [moves]
    dwells: np.ndarray           # float64 [moves]: dwell seconds
    index: np.ndarray            # int64 [moves]: position of the command in the program

    def __len__(self) -> int:
        return len(self.t0s)

    @classmethod
    def of_moves(cls, moves, n_axes: int) -> PlanArrays:
        """The columns of a list of ``PlannedMove``."""
        n = len(moves)
        profiles = np.zeros((n, P_WIDTH))
        for i, move in enumerate(moves):
            if move.profile is not None:
                profiles[i] = move.profile
        return cls(np.array([m.start for m in moves], np.int64).reshape(n, n_axes),
                   np.array([m.end for m in moves], np.int64).reshape(n, n_axes),
                   np.array([m.target for m in moves], np.int64).reshape(n, n_axes),
                   np.array([m.t0_s for m in moves], np.float64), profiles,
                   np.array([m.profile is not None for m in moves], np.bool_),
                   np.array([m.dwell_s for m in moves], np.float64), np.array([m.index for m in moves], np.int64))


#: the planner's kind of each kind of row of a block of moves (FMOV, PMOV, PFDR)
_BLOCK_KINDS = np.array([K_FMOV, K_PMOV, K_FEED], np.int64)


def encode(commands, machine):
    """(kinds, axis words in mm or NaN, feed / seconds) of every command; None for a command the
    table cannot hold (an axis not on the machine: the walker words that refusal).

    ``commands`` is a list of commands, or a list with ``parts()`` (``retrofit.canon.moves``)
    whose blocks of moves (``kinds``, ``values``, ``names``) are copied into the table whole."""
    names = {n: i for i, n in enumerate(machine.axis_names)}
    n, n_axes = len(commands), len(machine.axes)
    kinds = np.zeros(n, np.int64)
    words = np.full((n, n_axes), np.nan)
    scalar = np.zeros(n)
    c = 0
    for cmd in commands.parts() if hasattr(commands, "parts") else commands:
        if hasattr(cmd, "kinds"):
            if not _block_into(cmd, names, kinds[c:], words[c:], scalar[c:]):
                return None
            c += len(cmd)
            continue
        if isinstance(cmd, (Wait, Prob)):    # an input decides (WAIT), or the walker refuses (PROB)
            return None
        kind = _KINDS.get(type(cmd), K_NONE)
        kinds[c] = kind
        if kind == K_FMOV or kind == K_PMOV or kind == K_PSTN:
            row = words[c]
            for name, mm in cmd.axes:
                i = names.get(name.upper())
                if i is None:
                    return None
                row[i] = mm
        elif kind == K_FFDR or kind == K_FEED:
            scalar[c] = cmd.feed
        elif kind == K_DELY:
            scalar[c] = cmd.seconds
        elif kind == K_ZMOV:
            for name in cmd.names or machine.axis_names:
                i = names.get(name.upper())
                if i is None:
                    return None
                words[c, i] = 1.0
        c += 1
    return kinds, words, scalar


def _block_into(block, names: dict, kinds, words, scalar) -> bool:
    """A block of moves into the first rows of the table's ``kinds``, ``words``, ``scalar``; False
    when it names an axis the machine does not have."""
    columns = [names.get(name.upper()) for name in block.names]
    if None in columns:
        return False
    m = len(block)
    kinds[:m] = _BLOCK_KINDS[block.kinds]
    feeds = kinds[:m] == K_FEED
    words[:m, columns] = block.values
    words[:m][feeds] = np.nan
    scalar[:m][feeds] = block.values[feeds, 0]
    return True


@kernel
def _kinematics_into(start, end, spm, v_axis, a_axis, feed, unit):
    """``planner.kinematics`` on arrays: (length, v_max, a_max); ``unit`` filled."""
    total = 0.0
    for k in range(start.shape[0]):
        d = (end[k] - start[k]) / spm[k]
        unit[k] = d
        total += d * d
    length = math.sqrt(total)
    if length == 0.0:
        for k in range(start.shape[0]):
            unit[k] = 0.0
        return 0.0, feed, 1.0
    v_max, a_max = feed, math.inf
    for k in range(start.shape[0]):
        unit[k] = unit[k] / length
        u = abs(unit[k])
        if u > 0:
            v_max = min(v_max, v_axis[k] / u)
            a_max = min(a_max, a_axis[k] / u)
    return length, v_max, a_max


@kernel
def _walk(kinds, words, scalar, spm, lo, hi, v_axis, a_axis, clearance, walker, feeds, limit,
          starts, ends, targets, units, lengths, v_max, a_max, stop_before, dwells, index):
    """The walker of ``planner._Walker`` over the command table, continued from its state
    (``walker`` rows: position, motor, offset, last direction; ``feeds``: rapid, feed), which it
    updates; returns (segments, refused command or -1)."""
    n_axes = spm.shape[0]
    position, motor, offset, last_dir = walker[0], walker[1], walker[2], walker[3]
    target = np.zeros(n_axes, np.int64)
    s = 0
    for c in range(kinds.shape[0]):
        kind = kinds[c]
        if kind == K_FFDR or kind == K_FEED:
            if not scalar[c] > 0:
                return s, c
            if kind == K_FFDR:
                feeds[0] = scalar[c]
            else:
                feeds[1] = scalar[c]
        elif kind == K_PSTN:
            for i in range(n_axes):
                if not np.isnan(words[c, i]):
                    offset[i] = position[i] - np.int64(np.rint(words[c, i] * spm[i]))
        elif kind == K_DELY:
            starts[s, :] = motor
            ends[s, :] = motor
            targets[s, :] = position
            units[s, :] = 0.0
            lengths[s], v_max[s], a_max[s], stop_before[s] = 0.0, 1.0, 1.0, True
            dwells[s], index[s] = scalar[c], c
            s += 1
        elif kind == K_FMOV or kind == K_PMOV or kind == K_ZMOV:
            for i in range(n_axes):
                target[i] = position[i]
                if not np.isnan(words[c, i]):
                    target[i] = 0 if kind == K_ZMOV else np.int64(np.rint(words[c, i] * spm[i])) + offset[i]
                if not lo[i] <= target[i] <= hi[i]:
                    return s, c
            for i in range(n_axes):
                if target[i] != position[i]:
                    last_dir[i] = 1 if target[i] > position[i] else -1
                ends[s, i] = target[i] + (clearance[i] if last_dir[i] > 0 else 0)
                if not -limit <= ends[s, i] <= limit:
                    return s, c
            speed = (feeds[1] if kind == K_PMOV else feeds[0]) / 60.0
            lengths[s], v_max[s], a_max[s] = _kinematics_into(motor, ends[s], spm, v_axis, a_axis, speed, units[s])
            starts[s, :] = motor
            targets[s, :] = target
            stop_before[s], dwells[s], index[s] = kind == K_ZMOV, 0.0, c
            position[:] = target
            motor[:] = ends[s]
            s += 1
    return s, -1


@kernel
def _profiles(lengths, entries, exits, v_max, a_max, dwells, profiles, has_profile, t0s, t_start):
    """Trapezoid rows and start times of every segment from ``t_start``; returns the end time."""
    t = t_start
    for m in range(lengths.shape[0]):
        t0s[m] = t
        if lengths[m] > 0.0:
            trapezoid_into(profiles[m], lengths[m], entries[m], v_max[m], exits[m], a_max[m])
            has_profile[m] = True
            t = t + (profiles[m, P_T1] + profiles[m, P_TC] + profiles[m, P_T2])
        else:
            t = t + dwells[m]
    return t


@dataclass
class Segments:
    """The walker's straight segments and dwells as columns (what the look-ahead reads)."""

    starts: np.ndarray
    ends: np.ndarray
    targets: np.ndarray
    units: np.ndarray
    lengths: np.ndarray
    v_max: np.ndarray
    a_max: np.ndarray
    stop_before: np.ndarray
    dwells: np.ndarray
    index: np.ndarray

    def __len__(self) -> int:
        return len(self.lengths)

    @classmethod
    def empty(cls, n: int, n_axes: int) -> Segments:
        def steps() -> np.ndarray:
            return np.zeros((n, n_axes), np.int64)
        return cls(steps(), steps(), steps(), np.zeros((n, n_axes)), np.zeros(n), np.zeros(n), np.zeros(n),
                   np.zeros(n, np.bool_), np.zeros(n), np.zeros(n, np.int64))

    def rows(self, lo: int, hi: int | None = None) -> Segments:
        return Segments(*(getattr(self, f)[lo:hi] for f in self.__dataclass_fields__))

    @staticmethod
    def joined(parts: list[Segments]) -> Segments:
        return Segments(*(np.concatenate([getattr(p, f) for p in parts]) for f in Segments.__dataclass_fields__))


class ArrayWalker:
    """``planner._Walker`` over command tables, batch after batch: the walker's state (position,
    motor, offset, last direction; rapid and feed) is carried from one batch to the next."""

    def __init__(self, machine, backlash_comp: bool, start: tuple[int, ...]):
        axes = machine.axes
        self.machine = machine
        self.spm = np.array([a.steps_per_mm for a in axes])
        self.lo = np.array([a.min_steps for a in axes], np.int64)
        self.hi = np.array([a.max_steps for a in axes], np.int64)
        self.v_axis = np.array([a.max_velocity_mm_s for a in axes])
        self.a_axis = np.array([a.max_accel_mm_s2 for a in axes])
        self.clearance = np.array([a.backlash_steps if backlash_comp else 0 for a in axes], np.int64)
        self.walker = np.array([start, start, [0] * len(axes), [-1] * len(axes)], np.int64)
        self.feeds = np.array([machine.motion.rapid_feed_mm_min, machine.motion.default_feed_mm_min], np.float64)
        self.commands_before = 0

    def segments(self, commands) -> Segments | None:
        """The segments of the next batch of ``commands`` (``index`` counts from the program's
        start), or None when the table cannot hold them or the walker would refuse one."""
        table = encode(commands, self.machine)
        if table is None:
            return None
        kinds, words, scalar = table
        n = int(np.count_nonzero((kinds == K_FMOV) | (kinds == K_PMOV) | (kinds == K_ZMOV) | (kinds == K_DELY)))
        seg = Segments.empty(n, len(self.spm))
        count, refused = _walk(kinds, words, scalar, self.spm, self.lo, self.hi, self.v_axis, self.a_axis,
                               self.clearance, self.walker, self.feeds, STEP_SPACE_LIMIT, seg.starts, seg.ends,
                               seg.targets, seg.units, seg.lengths, seg.v_max, seg.a_max, seg.stop_before,
                               seg.dwells, seg.index)
        if refused >= 0:
            return None
        seg.index += self.commands_before
        self.commands_before += len(commands)
        return seg


def plan_arrays(commands, machine, backlash_comp: bool, start: tuple[int, ...]):
    """(PlanArrays, end time) of ``commands``, or None when the walker must word a refusal
    or the profile is not a trapezoid."""
    if machine.motion.profile != "trapezoid":
        return None
    compiled(len(commands) * 100)
    seg = ArrayWalker(machine, backlash_comp, start).segments(commands)
    if seg is None:
        return None
    return profiled(seg, machine, 0, 0.0, 0.0, len(seg))[:2]


def profiled(seg: Segments, machine, first: int, entry: float, t_start: float, upto: int):
    """(PlanArrays, end time, exit speed) of segments ``first..upto-1`` of ``seg``, the first entered at
    ``entry`` mm/s and started at ``t_start``; ``seg``'s rows before ``first`` are moves already
    planned (the junction into ``first``), its rows from ``upto`` moves seen ahead."""
    settings, axes = machine.motion, machine.axes
    a_max = seg.a_max.copy()                  # cut for turning moves by the look-ahead
    entries, exits = speeds_of(seg.units, seg.lengths, seg.v_max, a_max, seg.stop_before,
                               settings.lookahead, settings.junction_deviation_mm, 1.0,
                               np.array([a.max_accel_mm_s2 for a in axes]), np.array([a.step_mm for a in axes]),
                               first=first, entry=entry)
    part = seg.rows(first, upto)
    n = upto - first
    profiles, has_profile, t0s = np.zeros((n, P_WIDTH)), np.zeros(n, np.bool_), np.zeros(n)
    end_s = _profiles(part.lengths, entries[first:upto], exits[first:upto], part.v_max, a_max[first:upto],
                      part.dwells, profiles, has_profile, t0s, float(t_start))
    return (PlanArrays(part.starts, part.ends, part.targets, t0s, profiles, has_profile, part.dwells, part.index),
            float(end_s), float(exits[upto - 1]) if upto > first else entry)
