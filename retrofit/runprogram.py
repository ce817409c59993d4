"""Run a part program: G-code → commands → plan → step schedule → port frames → outputs → report."""

from __future__ import annotations

import sys
from pathlib import Path

from .config import Machine
from .errors import GcodeError, MotionError
from .runlog import RunLog


def resolve_program(name: str | Path) -> Path:
    """A program by path, or by the name of a shipped example (``lathe-profile.ngc``)."""
    from importlib import resources
    path = Path(name)
    if path.is_file():
        return path
    shipped = resources.files("retrofit") / "examples" / path.name
    if not path.parent.parts and shipped.is_file():
        return Path(str(shipped))
    examples = sorted(p.name for p in (resources.files("retrofit") / "examples").iterdir()
                      if p.name.endswith(".ngc"))
    raise GcodeError(f"no such program; shipped examples: {', '.join(examples)}", str(name))


def plan_gcode(path: str | Path, machine: Machine, backlash_comp: bool = True):
    """Compile and plan a program; every problem is a GcodeError naming file:line, before any step."""
    from .gcode import load_program
    from .motion.planner import plan_program
    program = load_program(path, machine)
    try:
        return program, plan_program(program.commands, machine, backlash_comp)
    except MotionError as exc:
        index = getattr(exc, "command_index", None)
        line = program.lines[index] if index is not None and index < len(program.lines) else None
        raise GcodeError(str(exc), program.file, line) from None


def execute(plan, reference: bool = False) -> RunLog:
    """Step schedule and port frames of a plan, by the fast path unless ``reference``."""
    if reference:
        from .motion.execute import execute_reference
        return execute_reference(plan)
    from .motion.fast import execute_fast
    return execute_fast(plan)


class Progress:
    """Stage-by-stage progress on a terminal (a tqdm bar); silent when output is not a terminal."""

    def __init__(self, stages: list[str], enabled: bool | None = None):
        enabled = sys.stderr.isatty() if enabled is None else enabled
        self.bar = None
        if enabled:
            from tqdm import tqdm
            self.bar = tqdm(total=len(stages), desc=stages[0], unit="stage", leave=False)
        self.stages = stages
        self.done = 0

    def next(self) -> None:
        self.done += 1
        if self.bar is not None:
            self.bar.update(1)
            if self.done < len(self.stages):
                self.bar.set_description(self.stages[self.done])

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()
