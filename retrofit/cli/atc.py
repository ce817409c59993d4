"""Utilities of the mill with the tool changer: ``retrofit tool`` and ``retrofit setter``.

Each runs on the simulated machine (``sim://``), which starts at home with the tools where the
simulated spindle's record says they are, or on the controller at the far end of a serial link
(``--output``), with the machine's record; each reads and updates the same records as
``retrofit run`` in the machine's state folder (:mod:`retrofit.atc.state`): the tool table and
the spindle record. On a machine without a tool changer ``retrofit tool`` shows the record and
``--recover`` sets it (tools are changed by hand). Part programs run with
``retrofit run PROGRAM --machine tul-mill``.
"""

from __future__ import annotations

from ..errors import RetrofitError
from . import machine_option


def add_commands(sub) -> None:
    """Add ``tool`` and ``setter`` to the ``retrofit`` command line."""
    t = sub.add_parser("tool", help="show or change the tool in the spindle (T0..T12 on tul-mill)",
                       description="Without a tool: show the tool in the spindle. With Tn: change to it "
                                   "on the simulated mill (T0 puts the tool back). With --recover: take "
                                   "Tn as the tool you see in the spindle, home the carousel and put it back.")
    t.add_argument("tool", nargs="?", help="T0..T12")
    t.add_argument("--recover", action="store_true",
                   help="the record is lost: TOOL is what you see in the spindle (T0 if empty)")
    _common(t)
    t.set_defaults(func=cmd_tool)

    s = sub.add_parser("setter", help="measure tools on the optical tool setter; show the tool table")
    s.add_argument("action", choices=["reference", "measure", "table"],
                   help="reference: calibrate with the reference tool; measure T..: length and "
                        "diameter of each tool; table: print the tool table")
    s.add_argument("tools", nargs="*", help="tools to measure (T3 T5 ...)")
    _common(s)
    s.set_defaults(func=cmd_setter)



def _common(p) -> None:
    machine_option(p, "tul-mill")
    p.add_argument("--output", default="sim://", metavar="URL",
                   help="where the moves are made: sim:// (the simulated mill, default) or the "
                        "controller on the serial link (serial:///dev/ttyACM0, serial+socket://HOST:PORT, "
                        "e.g. the firmware in retrofit firmware sim); it starts with INIT at home")
    p.add_argument("--tool-table", metavar="FILE.tbl",
                   help="LinuxCNC tool table (default: in the machine's state folder, see "
                        "docs/atc.md); the spindle record stays in the state folder")


def _tool_number(text: str) -> int:
    body = text[1:] if text[:1] in "Tt" else text
    if not (body.isascii() and body.isdigit() and len(body) <= 5):
        raise RetrofitError(f"tool {text!r}: expected T followed by a number, e.g. T3 (T0: spindle empty)")
    return int(body)


class _Mill:
    """The machine, its records and a simulated cell that starts from what the records say."""

    def __init__(self, args):
        from ..atc.cell import SimCell
        from ..atc.changer import ToolChanger
        from ..atc.magazine import MagazineState
        from ..atc.state import spindle_store
        from ..atc.tooltable import ToolTableStore
        from ..machine.config import load_machine
        self.machine = load_machine(args.machine)
        self.url = getattr(args, "output", None) or "sim://"
        tbl, self.store = spindle_store(self.machine, args.machine, [self.url], args.tool_table)
        self.tables = ToolTableStore(self.machine.name, tbl.with_name(f"{tbl.stem}.setter.json"), tbl)
        self.output = self.changer = self._cell = None
        if not self.store.changer:                 # tools changed by hand: only the record
            return
        recover = getattr(args, "recover", False)
        self.changer = ToolChanger(self.machine, self.store, read_record=not recover)
        tool = _tool_number(args.tool) if recover and args.tool else self.changer.spindle_tool
        self._cell = (SimCell(self.machine, MagazineState.loaded(self.machine, tool or 0))
                      if self.url.split("://")[0] == "sim" else None)

    @property
    def cell(self):
        """The simulated cell, or the controller on the link (its port opened at the first use)."""
        if self._cell is None:
            from ..atc.linkcell import LinkCell
            from ..outputs import open_output
            self.output = open_output(self.url, self.machine)
            self._cell = LinkCell(self.output, self.machine)
            self.output.open()
        return self._cell

    def finish(self) -> int:
        """Print what the machine holds (and, simulated, every violation; 1 when there was one)."""
        if self.output is not None:
            return self._finish_remote()
        state = self.cell.magazine.state
        spindle = f"T{state.spindle}" if state.spindle else "empty"
        pockets = " ".join(f"{p}:{'T%d' % t if t else '-'}" for p, t in sorted(state.pockets.items()))
        print(f"  sim: spindle {spindle}; pockets {pockets}")
        found = self.cell.violations
        print(f"  violations: {len(found)}")
        for v in found:
            print(f"    tick {v.tick} {v.axis} {v.kind}: {v.detail}")
        return 1 if found else 0

    def _finish_remote(self) -> int:
        at = " ".join(f"{a} {mm:.3f}" for a, mm in self.cell.commanded_mm().items())
        print(f"  {self.output.url.text}: at {at} mm; {self.cell.probes} probing moves")
        self.close()
        return 0

    def close(self) -> None:
        if self.output is not None:
            self.output.close()
            self.output = None


def cmd_tool(args) -> int:
    """``retrofit tool [Tn] [--recover]``."""
    if args.recover and args.tool is None:
        import shlex
        raise RetrofitError("--recover needs the tool you see in the spindle, e.g. retrofit tool T3 "
                            f"--recover --machine {shlex.quote(args.machine)}")
    return _on_mill(args, _tool)


def _tool(args, mill) -> int:
    if mill.changer is None:
        return _manual_tool(args, mill)
    if args.recover:
        seen = _tool_number(args.tool)
        steps = mill.changer.recover(seen, mill.cell)
        _print_steps(f"{mill.machine.name}: recovery with T{seen} in the spindle", steps)
        return mill.finish()
    if args.tool is None:
        _print_spindle(mill, mill.changer.spindle_tool)
        return 0
    seq = mill.changer.change(_tool_number(args.tool), mill.cell)
    title = {0: "already in the spindle, nothing to do", 1: "condition 1: pick",
             2: "condition 2: put back, then pick", 3: "condition 3: put back (T0)"}[seq.condition]
    _print_steps(f"{mill.machine.name}: T{seq.current} -> T{seq.new}, {title}", seq.steps)
    return mill.finish()


def _manual_tool(args, mill) -> int:
    """A machine whose tools are changed by hand: show the record, or set it (--recover)."""
    if args.tool is not None and not args.recover:
        tool = _tool_number(args.tool)
        raise RetrofitError(f"{mill.machine.name} has no tool changer (no [atc] section in "
                            f"{mill.machine.source}): put T{tool} in the spindle by hand, then record "
                            f"it with: retrofit tool T{tool} --recover {mill.store.recover}")
    if args.recover:
        mill.store.save(_tool_number(args.tool))
    _print_spindle(mill, mill.store.load())
    return 0


def _print_spindle(mill, tool: int) -> None:
    which = "" if mill.store.real else " (simulated)"
    print(f"{mill.machine.name}: {'T%d' % tool if tool else 'no tool'} in the spindle{which} "
          f"(record {mill.store.path})")


def cmd_setter(args) -> int:
    """``retrofit setter reference | measure T.. | table``."""
    return _on_mill(args, _setter)


def _setter(args, mill) -> int:
    from ..atc.measure import ToolSetter
    from ..atc.settings import atc_of
    atc_of(mill.machine)                   # the setter's tools are changed by the changer
    table = mill.tables.load()
    setter = ToolSetter(mill.machine, table)
    name = mill.machine.name
    if args.action == "reference":
        mill.changer.change(setter.settings.reference_tool, mill.cell)
        ref = setter.calibrate(mill.cell, mill.changer.spindle_tool)
        mill.tables.save(table)
        print(f"{name}: reference T{ref.tool} ({ref.length_mm:g} mm) meets the beam at Z {ref.z_break_mm:.4f}")
    elif args.action == "measure":
        if not args.tools:
            raise RetrofitError("setter measure needs the tools to measure, e.g. retrofit setter measure T3 T5")
        setter.reference()                  # before any tool moves
        for tool in [_tool_number(t) for t in args.tools]:
            mill.changer.change(tool, mill.cell)
            got = setter.measure(mill.cell, mill.changer.spindle_tool)
            mill.tables.save(table)
            print(f"{name}: T{tool} length {got.length_mm:.4f} mm, diameter {got.diameter_mm:.4f} mm, "
                  f"offset {table.length_offset(tool):+.4f} mm")
    else:
        _print_table(name, table, mill.tables.path)
        return 0
    return mill.finish()


def _on_mill(args, command) -> int:
    """``command(args, mill)`` on the mill; an error or a stop (Ctrl-C, SIGHUP, SIGTERM) puts the
    link's output in a safe state before anything else."""
    from ..failsafe import signals_raise
    with signals_raise():
        mill = _Mill(args)
        try:
            return command(args, mill)
        except BaseException:
            if mill.output is not None:
                mill.output.safe_stop()
            raise
        finally:
            mill.close()


def _print_steps(title: str, steps) -> None:
    print(title)
    for i, step in enumerate(steps, 1):
        print(f"  {i}. {step.says}: {'; '.join(str(c) for c in step.commands)}")


def _print_table(name: str, table, path) -> None:
    ref = table.reference
    print(f"{name} tool table ({path})")
    print("  reference: " + (f"T{ref.tool}, {ref.length_mm:g} mm, beam at Z {ref.z_break_mm:.4f}"
                             if ref else "none (retrofit setter reference)"))
    for tool, entry in sorted(table.tools.items()):
        length = "-" if entry.length_mm is None else f"{entry.length_mm:.4f}"
        diameter = "-" if entry.diameter_mm is None else f"{entry.diameter_mm:.4f}"
        print(f"  T{tool}: length {length} mm, diameter {diameter} mm")
