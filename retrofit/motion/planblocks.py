"""The planner a batch of commands at a time: the plan of ``plan_program``, move for move, without
the whole program.

A move's junction and exit speeds depend on the moves the look-ahead sees after it
(``lookahead``), no further (:mod:`retrofit.motion.lookahead`): move i is final once move
``i + lookahead`` is known. :class:`BlockPlanner` walks each batch of commands on from where the
last one left the walker (``planarrays.ArrayWalker``), and hands on, as columns, every move that
is final; it keeps the last move handed on (its junction into the next) and the moves seen ahead.
So memory holds the look-ahead and a batch, whatever the program's length.
"""

from __future__ import annotations

from typing import NoReturn

from ..commands import Prob, Wait
from ..errors import MotionError
from ._jit import compiled
from .planarrays import ArrayWalker, Segments, profiled


class NotInBlocks(Exception):
    """The batch needs what planning by blocks does not do (a WAIT, a PROB, a profile other
    than the trapezoid): plan the program whole (``plan_program``)."""


class BlockPlanner:
    """Plans batches of commands in program order (see the module doc)."""

    def __init__(self, machine, backlash_comp: bool = True, start_steps=None):
        if machine.motion.profile != "trapezoid":
            raise NotInBlocks(f"the {machine.motion.profile} profile")
        self.machine, self.backlash_comp = machine, backlash_comp
        self.start = tuple(start_steps or (0,) * len(machine.axes))
        self.walker = ArrayWalker(machine, backlash_comp, self.start)
        self.ahead = Segments.empty(0, len(machine.axes))   # [last move handed on] + moves seen ahead
        self.has_last = False
        self.entry, self.t = 0.0, 0.0
        self.margin = machine.motion.lookahead + 1

    def add(self, commands: list) -> None:
        """Walk the next batch of commands; a MotionError (with ``command_index`` from the
        program's start) when the walker refuses one of them."""
        compiled(len(commands) * 100)          # as plan_arrays: compiled once the work pays
        saved = self.walker.walker.copy(), self.walker.feeds.copy(), self.walker.commands_before
        seg = self.walker.segments(commands)
        if seg is None:
            self.walker.walker, self.walker.feeds, self.walker.commands_before = saved
            self._refuse(commands)
        self.ahead = Segments.joined([self.ahead, seg]) if len(self.ahead) else seg

    def planned(self, final: bool = False):
        """(PlanArrays, end time) of the moves now final (all of them when ``final``: the
        program has ended), or None when there are none yet."""
        first = 1 if self.has_last else 0
        upto = len(self.ahead) if final else len(self.ahead) - self.margin
        if upto <= first:
            return None
        arrays, self.t, self.entry = profiled(self.ahead, self.machine, first, self.entry, self.t, upto)
        self.ahead = self.ahead.rows(upto - 1)
        self.has_last = True
        return arrays, self.t

    def _refuse(self, commands: list) -> NoReturn:
        """Word the refusal of the first command the array walker cannot take."""
        if any(isinstance(c, (Wait, Prob)) for c in commands):
            raise NotInBlocks("an input wait or a probing move")
        from .planner import _Walker
        w = _Walker(self.machine, self.backlash_comp, self.start)
        state, feeds = self.walker.walker, self.walker.feeds
        w.position, w.motor, w.offset, w.last_dir = (list(map(int, row)) for row in state)
        w.rapid, w.feed = float(feeds[0]), float(feeds[1])
        for i, cmd in enumerate(commands):
            try:
                for _ in w.take(cmd, i):
                    pass
            except MotionError as exc:
                exc.command_index = self.walker.commands_before + i
                raise
        raise NotInBlocks("a command the planner over arrays does not hold")


def plan_in_blocks(commands: list, machine, backlash_comp: bool = True, size: int = 1000):
    """(PlanArrays of every move, end time): ``commands`` planned ``size`` at a time (for tests:
    equal, move for move, to ``plan_program``'s)."""
    planner = BlockPlanner(machine, backlash_comp)
    parts, end_s = [], 0.0
    for lo in range(0, max(len(commands), 1), size):
        planner.add(commands[lo:lo + size])
        final = lo + size >= len(commands)
        got = planner.planned(final)
        if got is not None:
            parts.append(got[0])
            end_s = got[1]
    from .columns import _joined
    return _joined(parts) if parts else None, end_s

