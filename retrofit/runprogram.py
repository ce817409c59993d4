"""Run a part program: G-code → commands → plan → step schedule → port frames → outputs → report."""

from __future__ import annotations

import sys
from pathlib import Path

from .config import Machine
from .errors import GcodeError, MotionError, OutputError
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
    return plan_compiled(load_program(path, machine), machine, backlash_comp)


def plan_compiled(program, machine: Machine, backlash_comp: bool = True):
    """(program, plan) of a compiled program; a GcodeError naming file:line when it cannot be planned."""
    from .motion.planner import plan_program
    try:
        return program, plan_program(program.commands, machine, backlash_comp)
    except MotionError as exc:
        index = getattr(exc, "command_index", None)
        line = program.lines[index] if index is not None and index < len(program.lines) else None
        raise GcodeError(str(exc), program.file, line) from None


def controller_reason(commands, machine: Machine) -> str | None:
    """Why a program must run through the controller rather than the planner, or None.

    Moves timed by the spindle (ISTP: G33, G76) and homing against switches (ZMOV on a machine
    with ``[homing]``) depend on inputs read while the program runs.
    """
    from .commands import IStp, ZMov
    if any(isinstance(c, IStp) for c in commands):
        return "threads under the spindle's indexer"
    if "homing" in machine.parts and any(isinstance(c, ZMov) for c in commands):
        return "homing against switches"
    return None


def run_on_controller(program, machine: Machine, backlash_comp: bool = True) -> RunLog:
    """Run a compiled program through the tick-by-tick controller driving a simulated machine
    (its switches and spindle are the controller's inputs); a GcodeError naming file:line when the
    controller refuses a command or halts with an error."""
    from .controller.program import ProgramError, run_commands
    from .sim import SimMachine
    try:
        ctl = run_commands(program.commands, machine, backlash_comp=backlash_comp, sim=SimMachine(machine))
    except ProgramError as exc:
        index = exc.command_index
        line = program.lines[index] if index is not None and 0 <= index < len(program.lines) else None
        raise GcodeError(str(exc), program.file, line) from None
    return ctl.run_log()


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


def command_outputs(urls: list[str], machine: Machine, commands) -> tuple[list[str], list[dict]]:
    """Run ``commands`` on the command-level outputs among ``urls`` (``serial://``, ...).

    Such outputs (``takes_commands``) get the program's commands, not its port frames, and
    report what the controller at the far end did. Returns the URLs left for the port frames
    and one report part per command-level output (``remote`` in docs/report.md).
    """
    from .outputs import OutputURL, open_output, output_class
    frame_urls, remote = [], []
    for url in urls:
        if not getattr(output_class(OutputURL.parse(url).scheme), "takes_commands", False):
            frame_urls.append(url)
            continue
        if commands is None:
            raise OutputError(f"{url}: this output runs a program's commands; this run has only "
                              "port frames (use it with retrofit run)")
        with open_output(url, machine) as out:
            remote.append(out.send_program(commands))
    return frame_urls, remote


def remote_lines(remote: list[dict]) -> list[str]:
    """One summary line per remote controller: its final position (RDPS) and status."""
    lines = []
    for part in remote:
        pos = ", ".join(f"{name} {mm:.3f}" for name, mm in part["position_mm"].items())
        lines.append(f"  remote {part['url']}: RDPS {pos} mm; status {' '.join(part['status']) or '-'}"
                     f"; {part['commands']} commands in {part['wall_s']:.2f} s")
    return lines
