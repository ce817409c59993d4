"""The tool in the spindle, remembered across power cycles in a small JSON file beside the tool table.

Where the machine's state lives (:func:`state_paths`): the tool table is the LinuxCNC
``tool.tbl`` next to the machine file (``mill.toml`` -> ``mill.tbl``), or the file named with
``--tool-table``; for a shipped machine, ``<name>.tbl`` in the current folder. The spindle record
is beside the table: ``mill.tbl`` -> ``mill.spindle.json``.

The file is replaced atomically (a temporary file in the same folder, then ``os.replace``), so
after a power cut it holds either the old record or the new one, never half of one. A change
marks the file before the first move (``changing_to``) and clears the mark after the last, so
a change cut short is known as such at the next start. A missing file means the machine has
never changed a tool: the spindle is empty.

When the record is unreadable or a change was cut short, nobody knows which tool is in the
spindle, and :class:`ToolStateError` says how to recover (:data:`RECOVERY`).
"""

from __future__ import annotations

import json
import os
from pathlib import Path

from ..errors import ToolStateError
from ..atomic import write_json_atomic

#: what the operator does when the record cannot be trusted (docs/atc.md, "Recovery")
RECOVERY = ("look at the spindle, then run 'retrofit tool T<n> --recover --machine {machine}' with n "
            "the tool you see there (T0 if it is empty): the record is rewritten, the carousel is "
            "homed and T0 puts that tool back into its pocket")


def state_paths(machine, tool_table: str | Path | None = None) -> tuple[Path, Path]:
    """(tool table, spindle record) of ``machine``: see the module doc."""
    if tool_table is not None:
        table = Path(tool_table)
    else:
        source = Path(machine.source)
        shipped = source.parent.name == "machines" and source.parent.parent.name == "retrofit"
        table = Path(f"{machine.name}.tbl") if shipped else source.with_suffix(".tbl")
    return table, table.with_name(f"{table.stem}.spindle.json")


def default_state_dir() -> Path:
    """Where state files live: $RETROFIT_STATE_DIR, else $XDG_STATE_HOME/retrofit, else
    ~/.local/state/retrofit."""
    if os.environ.get("RETROFIT_STATE_DIR"):
        return Path(os.environ["RETROFIT_STATE_DIR"])
    base = os.environ.get("XDG_STATE_HOME") or Path.home() / ".local" / "state"
    return Path(base) / "retrofit"


class SpindleStore:
    """The record of the tool in the spindle of one machine (``<dir>/<machine>-spindle.json``)."""

    def __init__(self, machine: str, path: str | Path | None = None, pockets: int | None = None):
        self.machine = machine
        self.path = Path(path) if path is not None else default_state_dir() / f"{machine}-spindle.json"
        self.pockets = pockets          # the changer's pockets: the highest tool number it holds

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

    def _error(self, what: str) -> ToolStateError:
        return ToolStateError(f"{self.path}: the record of the tool in the spindle cannot be trusted: "
                              f"{what}. Recovery: {RECOVERY.format(machine=self.machine)}")
