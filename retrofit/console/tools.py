"""The console's tools as ``retrofit run`` has them: the same spindle record, tool table and changer.

The console reads the tool in the spindle from the machine's state folder (docs/atc.md): the
simulated spindle's record (``spindle-sim.json``) when it drives only ``sim://`` and files, the
machine's (``spindle.json``) when an output moves a machine. A program is compiled with that tool
and the tool table; its tool changes become the changer's sequences (:mod:`retrofit.atc.front`),
or, on a machine changed by hand, a dialog. When a run that changed tools has ended, the record
says the tool in the spindle; on a machine, a run marks the change under way before its first
move, so a run cut short is known as such at the next start.
"""

from __future__ import annotations

from pathlib import Path

from ..machine.config import Machine


def machine_words(machine: Machine) -> str:
    """How a user names ``machine`` on the command line (for the recovery command printed)."""
    from ..atc.state import is_shipped
    return machine.name if is_shipped(machine) else str(Path(machine.source))


class SpindleTools:
    """The spindle record and tool table of ``machine`` for a console whose outputs are ``urls``."""

    def __init__(self, machine: Machine, urls: list[str], machine_arg: str | None = None):
        from ..atc.state import spindle_store
        self.machine = machine
        self.urls = list(urls)
        self.table_path, self.store = spindle_store(machine, machine_arg or machine_words(machine),
                                                    ["sim://", *urls])
        self._known, self._marked = 0, False   # the tool the record says; a change marked under way

    def tool(self) -> int:
        """The tool in the spindle; ToolStateError (with the recovery) when the record cannot be trusted."""
        return self.store.load()

    def compile(self, text: str, name: str, spindle_tool: int, **options):
        """``text`` compiled for the machine with its tool table and the tool in the spindle
        (a ``.cmds`` file: a command list, see :func:`retrofit.console.server.command_list`). A
        program run from the machine's zero probes (G38) on the simulated machine, as in ``retrofit
        run``, and is refused on a console that drives a real machine. M62-M66 are refused with
        their line: the console's controller does not make them (``retrofit run`` does)."""
        from ..run.program import refuse_io_on_controller
        program = self._compiled(text, name, spindle_tool, **options)
        refuse_io_on_controller(program, "the console steps the 002 controller")
        return program

    def _compiled(self, text: str, name: str, spindle_tool: int, **options):
        from ..gcode.program import compile_program
        from ..machine.tooltable import ToolTable
        from ..run.program import refuse_real_probing, sim_prober
        if name.endswith(".cmds"):
            from .server import command_list
            return command_list(text, name)
        prober = None if "start_mm" in options else sim_prober(self.machine, spindle_tool)
        program = compile_program(text, self.machine, name, tool_table=ToolTable.load(self.table_path),
                                  spindle_tool=spindle_tool, probe=prober, **options)
        if prober is not None and prober.moves:
            refuse_real_probing(self.urls, name)
        return program

    def expand(self, program, spindle_tool: int):
        """The program's tool changes by the changer (its pauses and manual changes kept as
        dialogs): :func:`retrofit.atc.front.expand_host_commands`."""
        from ..atc.front import expand_host_commands
        return expand_host_commands(program, self.machine, spindle_tool, keep_pauses=True)

    def begin(self, expanded) -> None:
        """Before the first move: a machine's record says a change is under way."""
        self._known = expanded.start_tool
        if self.store.real and expanded.changes_the_tool:
            self.store.begin(expanded.start_tool, expanded.end_tool)
            self._marked = True

    def finish(self, tool: int) -> None:
        """A run has ended well with ``tool`` in the spindle: the record says so."""
        if self._marked or tool != self._known:
            self.store.save(tool)
        self._known, self._marked = tool, False


def clamped_feeds(program, machine: Machine, default_feed: float) -> list[str]:
    """Warnings for cuts whose programmed feed the axes cannot keep (the planner runs them at the
    most the slowest axis of the move allows): the first such line and how many there are."""
    import math

    from ..run.plot import toolpath
    from .handing import programmed_feeds
    feeds = programmed_feeds(program.commands, default_feed)
    found = []
    for seg in toolpath(program.commands, machine):
        length = math.dist(seg.start, seg.end)
        if seg.kind != "cut" or length == 0:
            continue
        allowed, slowest = min((a.max_velocity_mm_s * 60 * length / abs(e - b), a.name)
                               for a, b, e in zip(machine.axes, seg.start, seg.end) if e != b)
        if feeds[seg.index] > allowed * (1 + 1e-9):
            found.append((program.lines[seg.index], feeds[seg.index], allowed, slowest))
    if not found:
        return []
    line, feed, allowed, axis = found[0]
    more = len({f[0] for f in found}) - 1
    return [f"{program.file}:{line}: F{feed:g} mm/min is more than {axis} can move "
            f"(max_velocity_mm_s {machine.axis(axis).max_velocity_mm_s:g}); the cut runs at "
            f"{allowed:.0f} mm/min" + (f"; {more} more line{'s are' if more > 1 else ' is'} slowed so" if more else "")]
