"""A whole program through the controller, its queue of three kept full, to the last pulse.

The commands go in as a host that never lets the queue run dry would send them (see
:meth:`Controller.stream`): whenever the interpreter takes a command from the queue, the next
one takes its place. Front ends that need the controller itself -- threads under ISTP, homing
against switches -- run their programs through here.
"""

from __future__ import annotations

from collections.abc import Iterable

from ..commands import Command
from ..errors import MotionError
from ..machine.config import Machine
from . import Controller

#: ticks a program may take by default (about 28 hours at 100 us)
DEFAULT_MAX_TICKS = 1_000_000_000


class ProgramError(MotionError):
    """A program stopped: a command refused or a halt with an error; ``command_index`` names it."""

    def __init__(self, message: str, command_index: int | None):
        super().__init__(message)
        self.command_index = command_index


def run_commands(commands: Iterable[Command], machine: Machine, *, backlash_comp: bool = True,
                 sim=None, controller: Controller | None = None,
                 max_ticks: int = DEFAULT_MAX_TICKS, kernels: bool = True) -> Controller:
    """Run ``commands`` to the end, the queue kept full; return the controller (its frames, run
    log, position). ``kernels=False`` ticks every tick in readable Python (the reference).

    Raises ProgramError (a MotionError) when the controller refuses a command or halts with an
    error; ``command_index`` is the index in ``commands`` of the command at fault.
    """
    ctl = controller or Controller(machine, backlash_comp=backlash_comp, sim=sim, kernels=kernels)
    if ctl.processor.error or ctl.processor.stopped:
        raise ProgramError(f"{machine.name}: the controller is halted ({ctl.fault or 'STOP'}); send INIT",
                           None)
    base = ctl.processor.serial
    ctl.stream(commands)
    ctl.run_until_idle(max_ticks)
    if ctl.fault:
        serial = ctl.processor.fault_serial
        raise ProgramError(ctl.fault, serial - base - 1 if serial is not None and serial > base else None)
    return ctl
