"""The mill at the far end of the serial link: the changer's and the setter's moves made there.

:class:`LinkCell` is the executor of :class:`~retrofit.atc.changer.ToolChanger` and the prober of
:class:`~retrofit.atc.measure.ToolSetter` for a controller on the link (``serial://`` or
``serial+socket://``: the firmware on its board, or in simavr with ``retrofit firmware sim``).
It sends commands through a :class:`~retrofit.outputs.serial.SerialOutput` and waits until the
machine rests; a probing move is one PROB (docs/protocol.md §7): the controller moves until its
probe input (the setter's beam) changes and stops there, and the status bit PROBED says whether
it did. Positions come back from the controller (RDPS), so every next move starts where the
machine really is.

The first command list sent starts with INIT (the controller's position is then 0, the machine
standing at home, as the simulated cell starts). :class:`LinkProber` makes a part program's
G38 moves the same way, as the program is read (``retrofit run`` with a serial output).
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence

from ..commands import Command, PFdr, PMov, Prob
from ..errors import LinkError, MotionError, OutputError, ProbeError
from ..link.probing import probe_over_link
from ..machine.config import Machine
from .cell import ProbeHit


class LinkCell:
    """Commands and probing moves on the controller behind ``output`` (a serial output)."""

    def __init__(self, output, machine: Machine):
        if not getattr(output, "takes_commands", False):
            raise OutputError(f"{output.url.text}: the tool changer and the setter need a controller "
                              f"on the serial link (serial:// or serial+socket://) or sim://")
        self.output = output
        self.machine = machine
        self.steps = {a.name: 0 for a in machine.axes}    # where the controller says it is
        self.probes = 0

    def run(self, commands: Sequence[Command]) -> dict:
        """Send ``commands``, wait until the machine rests; the far end's summary."""
        remote = self.output.send_program(list(commands))
        self.output.opts["init"] = False                 # INIT once: positions go on from here
        self.steps = dict(remote["position_steps"])
        return remote

    def commanded_mm(self) -> dict[str, float]:
        return {a.name: a.to_mm(self.steps[a.name]) for a in self.machine.axes}

    def probe(self, commands: Iterable[Command], until_broken: bool = True) -> ProbeHit | None:
        """The setter's probing move (its feed, then one PMOV) as a PROB; where it stopped on the
        beam, or None when it reached its end with the beam unchanged."""
        commands = list(commands)
        moves = [c for c in commands if isinstance(c, PMov)]
        if len(moves) != 1 or any(not isinstance(c, (PFdr, PMov)) for c in commands):
            raise ProbeError(f"a probing move is a feed and one PMOV; got {'; '.join(map(str, commands))}")
        self.run([c for c in commands if c is not moves[0]])       # its feed (INIT first, once)
        opts = self.output.opts
        try:
            got = probe_over_link(self.output.link, Prob(moves[0].axes, away=not until_broken),
                                  wait_s=opts["wait_s"], poll_s=opts["poll_ms"] / 1000)
        except (LinkError, MotionError) as exc:
            raise OutputError(f"{self.output.url.text}: {exc}") from None
        self.steps = dict(got.steps)
        self.probes += 1
        if not got.probed:
            return None
        return ProbeHit(-1, self.commanded_mm(), {a.name: a.step_mm for a in self.machine.axes})


class LinkProber:
    """Makes a program's probing moves (G38) on the controller behind ``output``, as the program
    is read: at each one the program's commands so far (tool changes expanded) are run there,
    then the move is one PROB, and where it stopped goes back to the interpreter. The run then
    sends the rest of the program on the same connection (:meth:`handoff`).
    """

    def __init__(self, output, machine: Machine, spindle_tool: int = 0):
        self.cell = LinkCell(output, machine)
        self.machine = machine
        self.spindle_tool = spindle_tool
        self.sent = 0                 # device commands of the expanded program run so far
        self.moves = 0

    def __call__(self, request):
        from ..gcode.errors import RuleError
        from ..gcode.probing import ProbeResult
        from ..gcode.program import Program
        from .front import expand_host_commands
        expanded = expand_host_commands(Program(list(request.commands), list(request.lines),
                                                "<program>"), self.machine, self.spindle_tool)
        if expanded.pauses:
            raise RuleError(f"{self.cell.output.url.text}: the program pauses before this probing "
                            f"move ({expanded.pauses[0].says}); on the link a probing program "
                            f"runs without pauses before its last probe")
        device = [c for c in expanded.commands if not c.host]
        if not self.moves:
            self.cell.output.open()                    # the port, at the first probing move
        self.cell.run(device[self.sent:])              # (INIT first, at the first one)
        self.sent = len(device)
        before = self.cell.commanded_mm()
        hit = self.cell.probe([PFdr(request.feed_mm_min), PMov(tuple(request.end_mm.items()))],
                              until_broken=request.toward)
        self.moves += 1
        if hit is None:
            return ProbeResult(False, self.cell.commanded_mm())
        if all(abs(hit.position_mm[a] - before[a]) < hit.step_mm[a] / 2 for a in before):
            return ProbeResult(False, before, already=True)
        return ProbeResult(True, hit.position_mm)

    def handoff(self) -> tuple[str, object, int]:
        """(URL, the open output, device commands already run) for the rest of the run."""
        return self.cell.output.url.text, self.cell.output, self.sent

    def close(self) -> None:
        """Close the port (after the run, or when reading the program failed)."""
        self.cell.output.close()
