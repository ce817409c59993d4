"""The motion controller of 002: a pipelined interpreter, prepare/execute, clock or indexer steps.

002's controller is three loops; here they are three methods of :class:`Controller`::

    async_comm / interpret:  submit(cmd)  immediate commands (STOP, RDPS, RDST, and the feed
                                          overrides FFDR / MFDR, INIT) act at once; the others
                                          wait in a queue of three, then are *prepared* into the
                                          planner's window of look-ahead moves
    processing:              tick()       one step cycle: the port byte, the switches, the entry
                                          being *executed*, then the pulses of the next tick

Time is the integer tick: nothing here reads a clock or sleeps. With ``heartbeat_ticks`` set, a
controller with work that has not *heard* from its host (:meth:`heard`, called by the link for
every frame of the host's session) for that many ticks brakes to a stop by itself. The controller may drive a
:class:`~retrofit.sim.SimMachine` (``sim=``): it then reads that machine's switches and spindle,
as the MCU reads its input pins, and the machine sees every port byte as it is written.
"""

from __future__ import annotations

from collections import deque

from ..commands import Command, FFdr, Init, MFdr, Rdps, Rdst, Stop
from ..errors import MotionError
from ..frames import PortFrames
from ..link.codec import ERR_REFUSED, ERR_VALUE, OPCODES
from ..link.replies import Busy, Err, Position, Status
from ..machine.config import Machine
from ..runlog import RunLog
from .processor import Processor
from .settings import machine_io
from .spans import SpanRunner
from .status import position_reply, status_reply

__all__ = ["Controller"]


class Controller:
    """002's motion controller for ``machine``, tick by tick.

    Parameters
    ----------
    machine : Machine
    backlash_comp : bool
        Compensate each axis's backlash clearance on reversals (003's JocL / JocT).
    sim : SimMachine, optional
        A simulated machine to drive and read: its switches and its spindle's encoder are this
        controller's inputs. Without one, no switch ever closes and ISTP cannot run.
    kernels : bool
        Let :meth:`run_until_idle` and :meth:`run_until_room` run the stretches of a move by the
        compiled tick loop (:mod:`retrofit.controller.spans`), the same frames as ticking in
        Python; False keeps every tick in readable Python (the reference).

    Examples
    --------
    >>> from retrofit.machine.config import load_machine
    >>> from retrofit.commands import parse_command
    >>> ctl = Controller(load_machine("chivu-lathe"))
    >>> ctl.submit(parse_command("PMOV X1 Z-2")) is None          # queued
    True
    >>> ctl.run_until_idle(100_000)
    >>> ctl.position_steps
    (40, -100)
    """

    QUEUE_DEPTH = 3

    def __init__(self, machine: Machine, *, backlash_comp: bool = True, sim=None, kernels: bool = True):
        self.machine = machine
        self.sim = sim
        self.io = machine_io(machine)
        self.queue: deque[Command] = deque()
        self.processor = Processor(machine, self.io, backlash_comp, sim)
        self.processor.refill = self._interpret
        self._source = None                   # a program being streamed (see stream)
        self._tick = 0
        self._idle_frame = False
        self.spans = SpanRunner(self) if kernels else None
        #: ticks of silence from the host after which a controller with work brakes (None: never)
        self.heartbeat_ticks: int | None = None
        self._heard = 0                       # the tick of the host's last frame
        self._braking = False
        #: (tick of the host's last frame, tick the heartbeat braked) of the last heartbeat stop
        self.host_lost_at: tuple[int, int] | None = None

    # -- the interpreter: commands in ----------------------------------------------------------
    def submit(self, cmd: Command) -> object | None:
        """Hand one command to the controller (what the serial link does with each command).

        Immediate commands act at once and answer: STOP (None), RDPS (:class:`Position`), RDST
        (:class:`Status`); so do FFDR and MFDR (the operator's feed overrides, None) and INIT
        (None). Any other command is queued: None when accepted, :class:`Busy` when three
        commands already wait, :class:`Err` when the controller refuses it (after STOP or an
        error, until INIT; or when it cannot be prepared, e.g. a target outside the soft limits).
        """
        proc = self.processor
        if isinstance(cmd, Rdps):
            return self.position()
        if isinstance(cmd, Rdst):
            return self.status
        if isinstance(cmd, Stop):
            self._braking = False
            proc.halt(self._tick, "STOP", error=False)
            self.queue.clear()
            self._source = None
            return None
        if isinstance(cmd, Init):
            self._braking = False
            proc.init(self._tick)
            self.queue.clear()
            self._source = None
            return None
        if isinstance(cmd, (FFdr, MFdr)):
            if not cmd.feed > 0:
                return Err(ERR_VALUE, OPCODES[type(cmd)])
            proc.override(cmd, self._tick)
            return None
        if proc.error or proc.stopped:
            return Err(ERR_REFUSED, OPCODES.get(type(cmd), 0))
        if len(self.queue) >= self.QUEUE_DEPTH:
            return Busy()
        self.queue.append(cmd)
        faulted = proc.error
        self._interpret()
        if proc.error and not faulted:
            return Err(ERR_REFUSED, OPCODES.get(type(cmd), 0))
        return None

    def stream(self, commands) -> None:
        """Take a whole program as a host that keeps the queue full does: whenever a place in the
        queue frees up, the next command takes it (a batch run's way of calling :meth:`submit`)."""
        self._source = iter(commands)
        self._interpret()

    def _interpret(self) -> None:
        """Move commands from the queue into the planner's window while it has room (prepare)."""
        proc = self.processor
        while True:
            while self._source is not None and len(self.queue) < self.QUEUE_DEPTH:
                cmd = next(self._source, None)
                if cmd is None or proc.error or proc.stopped:
                    self._source = None
                else:
                    self.queue.append(cmd)
            if not (self.queue and proc.has_room()):
                return
            proc.prepare(self.queue.popleft(), self._tick)
            if proc.error:
                self.queue.clear()
                self._source = None

    # -- the heartbeat -------------------------------------------------------------------------
    def heard(self) -> None:
        """The host is there (a frame of its session arrived): the heartbeat counts from now."""
        self._heard = self._tick

    def heartbeat_due(self) -> int | None:
        """The tick at which the heartbeat brakes if nothing is heard before (None: not armed)."""
        if self.heartbeat_ticks is None or self._braking or self.processor.host_lost:
            return None
        return self._heard + self.heartbeat_ticks

    def _heartbeat(self, n: int) -> None:
        """The host fell silent while the machine had work: brake (docs/protocol.md §5), drop the
        queue, refuse motion until INIT; at rest, halt and switch spindle and coolant off."""
        proc = self.processor
        if self._braking:
            if proc.braked():
                self._braking = False
                proc.halt(n, "the host fell silent", error=False)
                proc.outputs_off(n)
            return
        due = self.heartbeat_due()
        if due is None or n < due or (not self.queue and self._source is None and proc.idle_at(n)):
            return
        self.queue.clear()
        self._source = None
        self.host_lost_at = (self._heard, n)
        proc.host_lost = proc.stopped = True
        self._braking = proc.brake(n)
        if not self._braking:
            proc.halt(n, "the host fell silent", error=False)
            proc.outputs_off(n)

    # -- the processor: one tick ---------------------------------------------------------------
    def tick(self) -> int:
        """Advance one tick; return the port byte written this tick."""
        n = self._tick
        proc = self.processor
        byte = proc.pulses.frame(n)
        proc.read_inputs(n)
        proc.execute(n)
        if self.heartbeat_ticks is not None:
            self._heartbeat(n)
        self._interpret()
        self._idle_frame = not self.queue and self._source is None and proc.idle_at(n)
        if not self._idle_frame:
            proc.pulses.shape(n, proc.hint)
        self._tick = n + 1
        return byte

    def run_until_idle(self, max_ticks: int) -> None:
        """Tick until the controller is idle (every command done, the last pulse over).

        Ticks in which nothing can be decided (no step due, no switch to read) only write their
        frame, and stretches in which even the frame cannot change are passed over at once: the
        frames are those of ticking through. Raises MotionError when still busy after
        ``max_ticks`` ticks.
        """
        if not self._run(max_ticks, lambda: self._idle_frame):
            raise MotionError(f"{self.machine.name}: the controller is still busy after {max_ticks} "
                              f"ticks ({max_ticks * self.machine.tick_s:g} s of machine time); give "
                              f"more ticks")

    def run_until_room(self, max_ticks: int) -> bool:
        """Tick until the queue takes another command (or the controller is idle); False when
        ``max_ticks`` ran out first. What a host streaming a program waits for after BUSY."""
        return self._run(max_ticks, lambda: self._idle_frame or len(self.queue) < self.QUEUE_DEPTH)

    def _run(self, max_ticks: int, done) -> bool:
        end = self._tick + max_ticks
        pulses = self.processor.pulses
        heartbeat = self.heartbeat_ticks is not None
        while self._tick < end:
            if self.spans is not None and not heartbeat and self.spans.run(end):
                if done():
                    return True
                continue
            self.tick()
            if done():
                return True
            quiet = self.processor.quiet_until(self._tick)
            if quiet is None:
                continue
            due = self.heartbeat_due()
            quiet = min(quiet, end, end if due is None else max(due, self._tick))
            while self._tick < quiet:
                if pulses.still():
                    pulses.skip(quiet - self._tick)
                    self._tick = quiet
                    break
                pulses.frame(self._tick)
                self._tick += 1
        return False

    # -- what the controller shows ---------------------------------------------------------------
    @property
    def ticks(self) -> int:
        """Ticks run so far (the next frame's tick)."""
        return self._tick

    @property
    def idle(self) -> bool:
        """True when every command is done and no pulse is under way."""
        return not self.queue and self._source is None and self.processor.idle_at(self._tick)

    @property
    def fault(self) -> str | None:
        """Why the controller stopped with an error (None when it did not)."""
        return self.processor.fault

    @property
    def position_steps(self) -> tuple[int, ...]:
        """The actual position register (RDPS) in steps, in the machine's axis order."""
        return self.processor.position_steps()

    def position(self) -> Position:
        """The RDPS answer."""
        return position_reply(self.machine, self.position_steps)

    @property
    def status(self) -> Status:
        """The RDST answer: status flags and the number of commands waiting in the queue."""
        state = self.processor.flags(self._tick)
        state["QUEUE_FULL"] = len(self.queue) >= self.QUEUE_DEPTH
        return status_reply(state, len(self.queue))

    def frames(self) -> PortFrames:
        """Every port byte written so far, run-length."""
        return self.processor.pulses.recorder.frames(self._tick)

    def run_log(self) -> RunLog:
        """The run so far as a RunLog, for :func:`retrofit.run.report.build_report`."""
        return self.processor.run_log(self.frames())
