"""G-code probing (G38.2-G38.5) made on the simulated mill, against its tool setter's beam.

The interpreter cannot know where a probing move stops (:mod:`retrofit.gcode.probing`): as
LinuxCNC's interpreter waits for its motion controller at a G38 block, retrofit's translator
asks a prober. :class:`SimProber` is the prober of the simulated mill: at each probing move it
runs the program compiled so far on a :class:`~retrofit.atc.cell.SimCell` (tool changes by the
changer's sequences, so the tool really in the spindle is the one the beam sees), then makes the
move step by step against the beam and stops at the first step that changes it.
"""

from __future__ import annotations

from ..commands import PFdr, PMov
from ..errors import RetrofitError
from ..gcode.errors import RuleError
from ..gcode.probing import ProbeRequest, ProbeResult
from ..gcode.program import Program
from ..machine.config import Machine
from .cell import SimCell
from .front import expand_host_commands
from .magazine import MagazineState


class SimProber:
    """Makes a program's probing moves on a simulated ``machine`` (``[setter]`` and ``[atc]``)."""

    def __init__(self, machine: Machine, spindle_tool: int = 0,
                 start_mm: dict[str, float] | None = None):
        self.machine = machine
        self.spindle_tool = spindle_tool
        self.start_mm = start_mm
        self.cell: SimCell | None = None     # made at the first probing move
        self.done = 0                 # commands of the expanded program the cell has run
        self.moves = 0                # probing moves made

    def __call__(self, request: ProbeRequest) -> ProbeResult:
        """Bring the cell to where the program is, then make the probing move."""
        self._catch_up(request)
        cell = self.cell
        if cell.beam_broken() == request.toward:
            return ProbeResult(False, cell.commanded_mm(), already=True)
        move = [PFdr(request.feed_mm_min), PMov(tuple(request.end_mm.items()))]
        hit = cell.probe(move, until_broken=request.toward)
        self.moves += 1
        if hit is None:
            return ProbeResult(False, dict(request.end_mm))
        return ProbeResult(True, hit.position_mm)

    def _catch_up(self, request: ProbeRequest) -> None:
        """Run the commands compiled since the last probing move (host commands expanded)."""
        if self.cell is None:
            self.cell = SimCell(self.machine, MagazineState.loaded(self.machine, self.spindle_tool),
                                self.start_mm)
        program = Program(list(request.commands), list(request.lines), "<program>")
        try:
            expanded = expand_host_commands(program, self.machine, self.spindle_tool)
            todo = expanded.commands[self.done:]
            if todo:
                self.cell.run(todo)
        except RetrofitError as exc:
            raise RuleError(f"the probing move cannot be made: {exc}") from None
        self.done = len(expanded.commands)
