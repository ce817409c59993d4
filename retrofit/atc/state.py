"""The tool in the spindle, remembered across power cycles in a small JSON file in the machine's state folder.

Where the machine's state lives (:func:`state_dir`, :func:`state_paths`), the same from any
working directory: for a shipped machine, ``$XDG_STATE_HOME/retrofit/<name>/`` (else
``~/.local/state/retrofit/<name>/``; ``$RETROFIT_STATE_DIR/<name>/`` when that is set), holding
``tool.tbl`` and ``spindle.json``; for a machine file of the user's, the file's own folder:
``mill.toml`` -> ``mill.tbl`` and ``mill.spindle.json``. ``--tool-table`` names another tool
table; the spindle record stays in the state folder (it belongs to the machine, not the table).

A run that moves no machine (``sim://``, ``vcd://``, ``parport+record://``: :func:`drives_machine`)
keeps its own record, ``spindle-sim.json`` (``mill.spindle-sim.json``): the simulated spindle.
It never reads or writes the machine's record, so a simulation cannot leave it wrong.

The file is replaced atomically (:mod:`retrofit.atomic`), so after a power cut it holds either
the old record or the new one, never half of one. A run on a machine marks the file before the
first move (``changing_to``) and clears the mark after the last, so a change cut short is known
as such at the next start. A missing file means the machine has never changed a tool: the
spindle is empty.

When the record is unreadable or a change was cut short, nobody knows which tool is in the
spindle, and :class:`ToolStateError` says how to recover: the ``retrofit tool --recover``
command to type, with the machine and output as the user gave them.
"""

from __future__ import annotations

import json
import os
import shlex
from pathlib import Path

from ..atomic import write_json_atomic
from ..errors import ToolStateError

#: outputs that move no machine: their runs keep the simulated spindle's record
SIMULATED_SCHEMES = ("sim", "vcd", "parport+record", "fpga-sim")


def default_state_dir() -> Path:
    """Where state files live: $RETROFIT_STATE_DIR, else $XDG_STATE_HOME/retrofit, else
    ~/.local/state/retrofit. A relative path in either variable is ignored (as the XDG base
    directory rules say): the state must not depend on the working folder."""
    own = os.environ.get("RETROFIT_STATE_DIR", "")
    if os.path.isabs(own):
        return Path(own)
    base = os.environ.get("XDG_STATE_HOME", "")
    return (Path(base) if os.path.isabs(base) else Path.home() / ".local" / "state") / "retrofit"


def is_shipped(machine) -> bool:
    """Whether ``machine`` was read from a machine file that ships with retrofit."""
    from ..machine.config import machines_dir
    return Path(machine.source).resolve().parent == Path(str(machines_dir())).resolve()


def state_dir(machine) -> Path:
    """The folder of ``machine``'s state (see the module doc), absolute."""
    if is_shipped(machine):
        return (default_state_dir() / machine.name).absolute()
    return Path(machine.source).resolve().parent


def state_paths(machine, tool_table: str | Path | None = None,
                simulated: bool = False) -> tuple[Path, Path]:
    """(tool table, spindle record) of ``machine``: see the module doc."""
    folder = state_dir(machine)
    prefix = "" if is_shipped(machine) else f"{Path(machine.source).stem}."
    table = Path(tool_table) if tool_table is not None else \
        folder / (f"{prefix}tbl" if prefix else "tool.tbl")
    return table, folder / f"{prefix}spindle{'-sim' if simulated else ''}.json"


def drives_machine(urls) -> str | None:
    """The first of ``urls`` that moves a machine (not in :data:`SIMULATED_SCHEMES`), or None."""
    from ..outputs import OutputURL
    return next((u for u in urls if OutputURL.parse(u).scheme not in SIMULATED_SCHEMES), None)


def spindle_store(machine, machine_arg: str, urls, tool_table=None) -> tuple[Path, SpindleStore]:
    """(tool table, spindle record) of a command on ``machine`` (named ``machine_arg`` on its
    command line) with outputs ``urls``: the machine's record when an output moves a machine,
    else the simulated spindle's."""
    real = drives_machine(urls)
    table, record = state_paths(machine, tool_table, simulated=real is None)
    atc = machine.parts.get("atc")
    words = ["--machine", str(machine_arg)] + (["--output", real] if real else [])
    return table, SpindleStore(machine.name, record, getattr(atc, "pockets", None),
                               recover=shlex.join(words), changer=atc is not None, real=real is not None)


class SpindleStore:
    """The record of the tool in the spindle of one machine (``<dir>/<machine>-spindle.json``)."""

    def __init__(self, machine: str, path: str | Path | None = None, pockets: int | None = None,
                 recover: str | None = None, changer: bool = True, real: bool = True):
        self.machine = machine
        self.path = Path(path) if path is not None else default_state_dir() / f"{machine}-spindle.json"
        self.pockets = pockets          # the changer's pockets: the highest tool number it holds
        #: the options of the recovery command, as the user gave them (machine, output)
        self.recover = recover if recover is not None else shlex.join(["--machine", machine])
        self.changer = changer          # False: tools are changed by hand
        self.real = real                # the record of a machine (False: of the simulated spindle)

    def describe(self) -> str:
        """The record in words, for a summary line."""
        return f"spindle record: {self.path}" if self.real else f"simulated spindle record: {self.path}"

    def load(self) -> int:
        """The tool in the spindle (0: empty); ToolStateError when the record cannot be trusted."""
        if not self.path.exists():
            return 0
        try:
            data = json.loads(self.path.read_text(encoding="utf-8"))
            if not isinstance(data, dict):
                raise ValueError("not a JSON object")
            tool = data["spindle_tool"]
            changing = data.get("changing_to")
            machine = data.get("machine", self.machine)
        except (OSError, ValueError, KeyError, TypeError, AttributeError, RecursionError) as exc:
            raise self._error(f"unreadable ({type(exc).__name__}: {str(exc)[:80]})") from None
        if isinstance(tool, bool) or not isinstance(tool, int) or tool < 0:
            raise self._error(f"spindle_tool = {tool!r} is not a tool number (a whole number >= 0)")
        if tool > 99999 or (self.pockets is not None and tool > self.pockets):
            raise self._error(f"spindle_tool = T{tool} is not a tool of this machine "
                              f"(T0..T{self.pockets if self.pockets is not None else 99999})")
        if changing is not None and (isinstance(changing, bool) or not isinstance(changing, int)):
            raise self._error(f"changing_to = {str(changing)[:20]!r} is not a tool number")
        if machine != self.machine:
            raise self._error(f"it belongs to machine {str(machine)[:40]!r}, not {self.machine!r}")
        if changing is not None:
            raise self._error(f"the change from T{tool} to T{changing} was cut short; the spindle "
                              f"may hold either tool, or none")
        return tool

    def save(self, tool: int, changing_to: int | None = None) -> None:
        """Record ``tool`` in the spindle (and a change under way to ``changing_to``), atomically."""
        self.path.parent.mkdir(parents=True, exist_ok=True)
        write_json_atomic(self.path, {"machine": self.machine, "spindle_tool": int(tool),
                                      "changing_to": changing_to})

    def begin(self, tool: int, new: int) -> None:
        """Mark a change from ``tool`` to ``new`` as under way (before its first move)."""
        self.save(tool, changing_to=new)

    def finish(self, new: int) -> None:
        """The change is done: ``new`` is in the spindle."""
        self.save(new)

    def recovery(self) -> str:
        """What the operator does when the record cannot be trusted (docs/atc.md, "Recovery")."""
        what = ("rewrite the record, home the carousel and put that tool back into its pocket "
                "(T0)") if self.changer else "rewrite the record"
        return (f"look at the spindle, then, to {what}, run this with n the tool you see there (T0 "
                f"if it is empty): retrofit tool T<n> --recover {self.recover}")

    def _error(self, what: str) -> ToolStateError:
        return ToolStateError(f"{self.path}: the record of the tool in the spindle cannot be trusted: "
                              f"{what}. Recovery: {self.recovery()}")
