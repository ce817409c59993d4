"""The console's one seam with the engine: a program run on the 002 controller, steerable.

A :class:`SteeredRun` drives the tick-by-tick controller (``retrofit.controller.Controller``)
on a simulated machine in a thread of its own, a chunk of ticks at a time. Between chunks it
hands the operator's actions to the controller as 002's immediate commands -- STOP, MFDR and
FFDR act on the tick they arrive, mid-move -- and publishes a snapshot (DRO, line, flags) for
the page. Host commands (TOOL, PAUS) wait for the machine to stand still, then for the
operator's answer. Any exception in the run STOPs the controller and puts every output safe
(:meth:`SteeredRun.fail`); STOP acts in every state. Time inside is the tick; only the paced
mode compares it with the clock.
"""

from __future__ import annotations

import threading
import time
from collections import deque
from contextlib import suppress

from ..commands import PAUSE_REASONS, Command, FFdr, MFdr, Stop, Tool
from ..errors import MotionError
from ..machine.config import Machine
from .handing import programmed_feeds, send_frames

#: machine time one chunk of ticks covers (s): the longest an operator's action waits
CHUNK_S = 0.02
#: machine time a feed hold ramps down before the run stands still (s)
HOLD_RAMP_S = 1.0
#: the feed a hold ramps to, as a fraction of the feed in force
HOLD_FRACTION = 1e-4
#: the longest the paced loop sleeps at once (s): it looks at the operator's actions at least this often
MAX_WAIT_S = 0.1
#: how long STOP waits for the run's thread to take it (s) before putting the outputs safe itself
STOP_WAIT_S = 2.0
#: what :meth:`SteeredRun.act` takes
ACTIONS = ("stop", "hold", "resume", "feed", "rapid", "answer", "speed")


class SteeredRun:
    """``commands`` (with their program ``lines``) run on ``machine``'s controller and sim://.

    ``paced``: keep machine time with the clock times ``speed``; else as fast as possible.
    ``outputs``: frame outputs (opened) that get every chunk of port frames as it is made.
    ``tool``: the tool in the spindle; ``changes``: the changer's tool changes in ``commands``
    (:class:`retrofit.atc.front.HostEvent`); ``on_done(run)`` is called when the run has ended well.
    """

    def __init__(self, machine: Machine, commands: list[Command], lines: list[int], *,
                 backlash_comp: bool = True, paced: bool = False, speed: float = 1.0, outputs=(),
                 tool: int = 0, changes=(), on_done=None):
        from ..controller import Controller
        from ..sim import SimMachine
        self.machine = machine
        self.commands, self.lines = list(commands), list(lines)
        self.sim = SimMachine(machine)
        self.ctl = Controller(machine, backlash_comp=backlash_comp, sim=self.sim)
        self.paced, self.speed, self.outputs = paced, speed, list(outputs)
        self.chunk = max(int(CHUNK_S / machine.tick_s), 1)
        self.next = 0                          # the next program command to hand over
        self.serial_index: list[int] = []      # serial (1-based) - 1 -> program index (-1: operator)
        self.starts: list[tuple[int, int]] = []  # (tick, serial) of every entry the controller began
        self.events: list[dict] = []
        self.feed_pct = self.rapid_pct = 100.0
        self.base_rapid = self.ctl.processor.walker.rapid
        self._mfdr_base = None
        self.default_feed = self.ctl.processor.walker.feed
        self.feeds = programmed_feeds(self.commands, self.default_feed)
        self.trail: list[tuple] = []           # (time s, commanded mm..., carriage mm...) per chunk
        self._snap: dict = {}
        self.held = False
        self.dialog: dict | None = None
        self.state = "ready"
        self.error: str | None = None
        self._halted = threading.Event()      # set once stopped or in error
        self.tool = self.start_tool = tool
        self._changes = deque(changes)         # the changer's changes not yet reached
        self.on_done = on_done
        self._actions: deque = deque()
        self._wake = threading.Event()
        self._lock = threading.Lock()
        self._sent_tick = 0
        self._repace = False
        self._thread: threading.Thread | None = None
        record = self.ctl.processor.record
        begin = record.begin

        def begin_and_mark(entry, tick):       # which command each entry came from, and when
            self.starts.append((tick, entry.serial))
            begin(entry, tick)
        record.begin = begin_and_mark

    # -- the operator ---------------------------------------------------------------------------
    def start(self) -> None:
        """Run in a thread of its own."""
        self.begin()
        self._thread = threading.Thread(target=self._loop, name="retrofit-console-run", daemon=True)
        self._thread.start()

    def extend(self, commands: list[Command], lines: list[int], changes=()) -> None:
        """More commands after the program (jog, home, MDI); the run goes on, or starts again."""
        from dataclasses import replace
        with self._lock:
            self._changes.extend(replace(e, index=e.index + len(self.commands)) for e in changes)
            self.commands += list(commands)
            self.lines += list(lines)
            self.feeds = programmed_feeds(self.commands, self.default_feed)
            if self._thread is None or self.state == "done":
                self.join()
                self.start()

    def act(self, kind: str, **args) -> None:
        """Queue an operator's action: stop, hold, resume, feed (pct), rapid (pct), answer,
        speed (factor; 0 = as fast as possible). Jog, home and MDI are commands: :meth:`extend`."""
        if kind not in ACTIONS:
            raise ValueError(f"unknown action {kind!r}; known: {', '.join(ACTIONS)}")
        self._actions.append((kind, args))
        self._wake.set()

    def join(self, timeout: float | None = None) -> None:
        if self._thread is not None:
            self._thread.join(timeout)

    @property
    def finished(self) -> bool:
        return self.state in ("done", "stopped", "error")

    # -- the loop --------------------------------------------------------------------------------
    def _loop(self) -> None:
        """Step chunk after chunk; when paced, wait until the clock catches up with machine time.
        Any exception stops the machine and puts the outputs safe before anything else."""
        try:
            wall0, tick0 = time.perf_counter(), self.ctl.ticks
            while self.step():
                if self._repace or self.waiting:
                    if self.waiting:
                        self._wake.wait(0.05)
                        self._wake.clear()
                    wall0, tick0, self._repace = time.perf_counter(), self.ctl.ticks, False
                elif self.paced and self.speed > 0:
                    ahead = (self.ctl.ticks - tick0) * self.machine.tick_s / self.speed - (time.perf_counter() - wall0)
                    if ahead > 0:
                        self._wake.wait(min(ahead, MAX_WAIT_S))
                        self._wake.clear()
            self._send_frames()
            self._publish()
            if self.state == "done" and self.on_done is not None:
                self.on_done(self)
        except BaseException as exc:                # noqa: BLE001 -- whatever it is, the machine stops
            self.fail(exc)

    def fail(self, exc: BaseException) -> None:
        """STOP the controller and put every output safe, then say what went wrong (state error)."""
        with suppress(BaseException):               # the outputs go safe whatever the controller does
            self.ctl.submit(Stop())
        self.make_outputs_safe()
        self.error = f"{type(exc).__name__}: {exc}".replace("\n", " ")
        self.state, self.dialog = "error", None
        self._halted.set()
        self._snap = dict(self._snap, state="error", fault=self.error)
        with suppress(BaseException):
            self._event("error", f"the run stopped on an error: {self.error}")
            self._publish()

    def make_outputs_safe(self) -> None:
        """Every output at once in its safe state (drivers off, data pins at rest), then closed."""
        outputs, self.outputs = self.outputs, []
        for out in outputs:
            with suppress(Exception):               # the next output goes safe all the same
                out.abort()

    def stop(self) -> None:
        """STOP in every state: through the run's thread when it steps, else here and now; a thread
        that does not answer within STOP_WAIT_S gets its outputs put safe from here."""
        if self._thread is not None and self._thread.is_alive():
            self.act("stop")
            if not self._halted.wait(STOP_WAIT_S):
                self.fail(MotionError(f"the run did not answer STOP within {STOP_WAIT_S:g} s"))
            return
        with self._lock:
            if self.state == "error":
                self.make_outputs_safe()
                return
            try:
                self._do_stop()
                self._publish()
            except BaseException as exc:            # noqa: BLE001
                self.fail(exc)

    def begin(self) -> None:
        """Hand the program to the controller (what :meth:`start` does before its thread steps)."""
        self.state = "running"
        self.ctl.stream(self._device_commands())

    @property
    def waiting(self) -> bool:
        """True while a dialog waits for the operator, or a feed hold has brought the axes to rest."""
        return self.dialog is not None or (self.held and self._hold_done())

    def step(self) -> bool:
        """Apply the operator's actions, then run one chunk of ticks (none while waiting) and
        publish the snapshot; False once the run has ended (done, stopped or in error)."""
        if self._apply_actions():
            self._repace = True
        if self.state in ("stopped", "error"):       # error: failed from outside (STOP not taken)
            self._publish()
            return False
        if self.waiting:
            self._publish()
            return True
        idle = self._run_chunk()
        self._keep_feed_override()
        self._send_frames()
        going = True
        if self.ctl.fault:
            self.make_outputs_safe()
            self._event("error", self.ctl.fault)
            self.state, self.error, going = "error", str(self.ctl.fault), False
            self._halted.set()
        elif idle:
            with self._lock:
                if not self._after_idle():
                    self.state, going = "done", False
        self._publish()
        return going

    def _run_chunk(self) -> bool:
        """Tick one chunk; True when the controller is idle."""
        try:
            self.ctl.run_until_idle(self.chunk)
            return True
        except MotionError:
            return False

    def _after_idle(self) -> bool:
        """The controller stands still: open the host command's dialog, or end. False: the end."""
        if self.next >= len(self.commands):
            return False
        cmd = self.commands[self.next]
        if not cmd.host:                       # commands added since (jog, MDI)
            self.ctl.stream(self._device_commands())
            return True
        line = self.lines[self.next]
        self.next += 1
        if isinstance(cmd, Tool):
            self.dialog = {"kind": "tool", "line": line, "tool": cmd.number,
                           "text": f"Manual tool change: put tool {cmd.number} in the spindle, then continue"}
        else:
            self.dialog = {"kind": "pause", "line": line, "reason": cmd.reason,
                           "text": f"Program paused: {PAUSE_REASONS.get(cmd.reason, 'pause')}; continue when ready"}
        self._event(self.dialog["kind"], self.dialog["text"], line)
        return True

    def _device_commands(self):
        """The program's commands up to the next host command, numbered as the controller takes them."""
        while self.next < len(self.commands):
            cmd = self.commands[self.next]
            if cmd.host:
                return
            self.serial_index.append(self.next)
            self.next += 1
            yield cmd

    # -- actions -----------------------------------------------------------------------------------
    def _apply_actions(self) -> bool:
        """Hand queued actions to the controller; True when pacing must restart from now."""
        changed = False
        while self._actions:
            kind, args = self._actions.popleft()
            changed = True
            getattr(self, f"_do_{kind}")(**args)
        return changed

    def _do_stop(self) -> None:
        self.ctl.submit(Stop())
        self.dialog = None
        self._event("stop", "STOP")
        self.state = "stopped"
        self._halted.set()

    def _do_feed(self, pct: float) -> None:
        self.feed_pct = float(pct)
        self._event("feed", f"feed override {pct:g} %")
        self._send_feed()

    def _do_rapid(self, pct: float) -> None:
        self.rapid_pct = float(pct)
        self._event("rapid", f"rapid override {pct:g} %")
        self._send_rapid()

    def _do_hold(self) -> None:
        if not self.held:
            self.held, self._hold_tick = True, self.ctl.ticks
            self._event("hold", "feed hold")
            self._send_feed()
            self._send_rapid()

    def _do_resume(self) -> None:
        if self.held:
            self.held = False
            self._event("resume", "resume")
            self._send_feed()
            self._send_rapid()

    def _do_answer(self) -> None:
        if self.dialog is not None:
            if self.dialog["kind"] == "tool":
                self.tool = self.dialog["tool"]
            self._event("answer", f"continue after {self.dialog['kind']}", self.dialog["line"])
            self.dialog = None
            self.ctl.stream(self._device_commands())

    def _do_speed(self, factor: float) -> None:
        self.paced, self.speed = factor > 0, float(factor)

    def _hold_done(self) -> bool:
        return self.ctl.ticks - self._hold_tick >= HOLD_RAMP_S / self.machine.tick_s

    def _send_feed(self) -> None:
        base = self._programmed_feed()
        self._mfdr_base = base
        scale = HOLD_FRACTION if self.held else self.feed_pct / 100.0
        self.ctl.submit(MFdr(feed=max(base * scale, 1e-6)))

    def _send_rapid(self) -> None:
        scale = HOLD_FRACTION if self.held else self.rapid_pct / 100.0
        self.ctl.submit(FFdr(feed=max(self.base_rapid * scale, 1e-6)))

    def _keep_feed_override(self) -> None:
        """A new programmed feed (PFDR) took over: apply the operator's override to it too."""
        if (self.feed_pct != 100.0 or self.held) and self._programmed_feed() != self._mfdr_base:
            self._send_feed()

    def _programmed_feed(self) -> float:
        """The programmed feed (mm/min) of the command running (or the next one, before the first)."""
        return self.feeds[max(self.running_index(), 0)] if self.feeds else self.default_feed

    # -- what the page shows ------------------------------------------------------------------------
    def running_index(self) -> int:
        """Program index of the command the controller executes (-1 before the first)."""
        serial = self.ctl.processor._serial_now
        return self.serial_index[serial - 1] if 0 < serial <= len(self.serial_index) else -1

    def snapshot(self) -> dict:
        """The DRO and status as of the last chunk (the page reads it ten times a second)."""
        return self._snap or self._make_snapshot()

    def _publish(self) -> None:
        self._follow_changes()
        snap = self._make_snapshot()
        row = (snap["time_s"], *snap["commanded_mm"].values(), *snap["carriage_mm"].values())
        if not self.trail or self.trail[-1][1:] != row[1:]:
            self.trail.append(row)
        self._snap = snap

    def _follow_changes(self) -> None:
        """The changer's changes the controller has reached: the tool shown, an event each."""
        index = len(self.commands) if self.state == "done" else self.running_index()
        while self._changes and self._changes[0].index <= index:
            change = self._changes.popleft()
            self.tool = change.tool
            self._event("tool change", change.says, change.line)

    def _make_snapshot(self) -> dict:
        ctl, machine = self.ctl, self.machine
        index = self.running_index()
        pos = ctl.position_steps
        status = ctl.status
        return {
            "state": "held" if self.held and self.state == "running" else self.state,
            "tick": ctl.ticks, "time_s": round(ctl.ticks * machine.tick_s, 4),
            "line": self.dialog["line"] if self.dialog else (self.lines[index] if index >= 0 else None),
            "commanded_mm": {a.name: round(p / a.steps_per_mm, 4) for a, p in zip(machine.axes, pos)},
            "carriage_mm": {a.name: round(self.sim.carriage_mm(a.name), 4) for a in machine.axes},
            "flags": [f.name for f in type(status.flags) if f in status.flags],
            "spindle": list(ctl.processor.spindle_cmd), "coolant": ctl.processor.coolant,
            "tool": self.tool, "feed_pct": self.feed_pct, "rapid_pct": self.rapid_pct,
            "dialog": self.dialog, "events": len(self.events), "fault": self.error,
        }

    def _event(self, kind: str, text: str, line: int | None = None) -> None:
        if line is None:
            index = self.running_index()
            line = self.lines[index] if index >= 0 else None
        self.events.append({"tick": self.ctl.ticks, "kind": kind, "text": text, "line": line})

    def close(self) -> None:
        """Stop the run if it goes on and finish its real outputs (a VCD file is whole only then)."""
        if self._thread is not None and self._thread.is_alive():
            self.act("stop")
            self.join(10)
        for out in self.outputs:
            out.close()
        self.outputs = []

    def _send_frames(self) -> None:
        """The port frames made since the last chunk, to the real outputs."""
        if self.outputs and self.ctl.ticks > self._sent_tick:
            self._sent_tick = send_frames(self.ctl.frames(), self._sent_tick, self.outputs)
