"""002's processing module: prepared entries in, one executing at a time, its steps out each tick.

The processor holds the planner's window (entries prepared ahead, ``lookahead`` moves plus one),
the entry executing (a *run*), and the output stage. Each tick, after the port byte is written:
the limit switches are checked, the run advances by one tick (and when it is done the next
entry starts in the same tick, so moves follow each other with no gap), then the pulses of the
next tick are shaped. It also keeps the position register (RDPS), the state flags (RDST), and
halts on STOP, on a limit switch or on a move that cannot run.
"""

from __future__ import annotations

from collections import deque
from fractions import Fraction

from ..commands import Cool, Pstn, Spin
from ..errors import MotionError
from ..machine.config import Machine
from ..motion.bresenham import prepare_line
from ..motion.execute import tick_of
from ..motion.pulses import PulseShaper
from .homing import HomeRun
from .indexrun import IndexRun
from .overrides import FeedOverrides
from .prepare import ActionEntry, DwellEntry, HomeEntry, IndexEntry, LineEntry, Walker
from .profiles import MoveProfile, ramp_pieces
from .record import RunRecord
from .runs import ClockRun, DwellRun
from .turnaround import Turnaround
from .window import WindowPlanner

#: entries the window may hold besides its moves (actions such as SPIN, COOL, PSTN)
EXTRA_ENTRIES = 16


class Processor(FeedOverrides):
    """Window, executing entry, position and flags of one controller."""

    def __init__(self, machine: Machine, io, backlash_comp: bool, sim):
        self.machine = machine
        self.io = io
        self.sim = sim
        self.sim_spindle = getattr(sim, "spindle", None) if sim is not None else None
        self.rate = 1e6 / machine.tick_us
        self.dda = machine.motion.interpolator == "dda"
        self.planner = WindowPlanner(machine)
        self.walker = Walker(machine, backlash_comp, io.homing)
        self.pulses = PulseShaper(machine, sim)
        self.record = RunRecord(machine)
        self.window: deque = deque()
        self.refill = lambda: None            # the interpreter: fetch more commands (set by Controller)
        n = len(machine.axes)
        self.run = None
        self.prev_kin = None                  # kinematics of the last move started
        self.exit_speed = 0.0                 # speed (mm/s) at which it ends
        self.t_plan = 0.0                     # planned time (s) at which it ends
        self.track_end: Fraction | None = None   # exact count where the last ISTP line ended
        self.shift = [0] * n                  # motor counter - walker steps
        self.comp = [0] * n                   # motor - commanded, as of the entries started
        self.offsets = [0] * n                # PSTN offsets in force (program -> machine steps)
        self.serial = 0
        self.homed = self.error = self.stopped = False
        self.host_lost = False                # the heartbeat stopped it (Controller.heard)
        self.fault: str | None = None
        self.fault_serial: int | None = None  # the command (1 = first submitted) at fault
        self._serial_now = 0                  # the command of the entry executing
        self.spindle_cmd = (0.0, 0)
        self.spindle_start: int | None = None
        self.coolant = 0
        self.closed: set[str] = set()
        self.spindle_inputs = None
        self._spindle_tick = -1
        self._events_seen = 0

    # -- prepare ----------------------------------------------------------------------------
    def has_room(self) -> bool:
        window = self.window
        if len(window) < self.planner.capacity:
            return True
        moves = sum(1 for e in window if e.is_move)
        return moves < self.planner.capacity and len(window) < self.planner.capacity + EXTRA_ENTRIES

    def prepare(self, cmd, tick: int) -> None:
        """002's first phase for one command from the queue."""
        self.serial += 1
        try:
            entries = self.walker.take(cmd, self.serial)
            self.window.extend(entries)
            if any(e.is_move for e in entries):
                self.window_grew()
        except MotionError as exc:
            self.fault_serial = self.serial
            self.halt(tick, str(exc), error=True)

    # -- inputs ------------------------------------------------------------------------------
    def read_inputs(self, tick: int) -> None:
        """Read the switches, as they are after frame ``tick`` (they change only when a carriage
        moves, so only when the simulator has recorded a change)."""
        if self.sim is None:
            return
        events = self.sim.switches.events
        if len(events) != self._events_seen:
            self._events_seen = len(events)
            self.closed = {name for name, on in self.sim.switch_states().items() if on}

    def spindle_at(self, tick: int):
        """The encoder (ICLK count, SIND) and the drive's at-speed output after frame ``tick``."""
        if self._spindle_tick != tick:
            assert self.sim_spindle is not None   # an ISTP move starts only with one (_begin_indexed)
            self.spindle_inputs = self.sim_spindle.read(tick)
            self._spindle_tick = tick
        return self.spindle_inputs

    def _guard(self, tick: int) -> None:
        """A closed limit switch stops an axis moving towards it, on the tick it closed."""
        for name in self.closed:
            spec = self.io.switches.named(name)
            if spec.kind != "limit" or (isinstance(self.run, HomeRun) and self.run.owns(name)):
                continue
            i = self.machine.axis_names.index(spec.axis)
            run = self.run
            moving = self.pulses.heading(i) == spec.side or (
                isinstance(run, (ClockRun, IndexRun)) and not run.done and run.line.direction[i] == spec.side)
            if moving:
                raise MotionError(f"limit switch {name} ({spec.axis} {'+' if spec.side > 0 else '-'}) "
                                  f"closed at tick {tick} while {spec.axis} moved towards it; motion halted")

    # -- execute ------------------------------------------------------------------------------
    def execute(self, tick: int) -> None:
        """One processing step after frame ``tick``."""
        try:
            self._guard(tick)
            while True:
                if self.run is None and not self._start(tick):
                    break
                run = self.run
                assert run is not None            # _start() began one
                if isinstance(run, IndexRun):
                    if run.signed and run.turn is None:
                        run.turn = self._turn_for(run)
                    run.step(tick, self.spindle_at(tick), self.pulses)
                elif isinstance(run, HomeRun):
                    run.step(tick, self.closed, self.pulses)
                else:
                    run.generate(tick + 1, self.pulses)
                if not run.done:
                    break
                self._finish(run, tick)
        except MotionError as exc:
            self.fault_serial = self._serial_now
            self.halt(tick, str(exc), error=True)

    def hint(self, axis: int) -> int:
        """Direction of the next step of ``axis`` not yet queued: from the running move, else the
        first prepared move that moves it (0 when unknown, or behind an ISTP move or a homing)."""
        run = self.run
        if isinstance(run, ClockRun):
            ahead = run.heading(axis)
            if ahead:
                return ahead
        elif run is not None and not isinstance(run, DwellRun):
            return 0
        return self.window_hint(axis)

    def window_hint(self, axis: int) -> int:
        """Direction of the first prepared move that moves ``axis`` (0: none, or one behind an
        ISTP move or a homing)."""
        for entry in self.window:
            if isinstance(entry, LineEntry):
                delta = entry.end[axis] - entry.start[axis]
                if delta:
                    return 1 if delta > 0 else -1
            elif isinstance(entry, (IndexEntry, HomeEntry)):
                return 0
        return 0

    def _settled(self, tick: int) -> bool:
        return not self.pulses.pending and tick + 1 >= tick_of(self.t_plan, self.rate)

    def _start(self, tick: int) -> bool:
        while self.window:
            entry = self.window[0]
            if isinstance(entry, ActionEntry):
                self.window.popleft()
                self._act(entry, tick)
                continue
            if isinstance(entry, (IndexEntry, HomeEntry)) and not self._settled(tick):
                return False
            self.window.popleft()
            self.refill()
            if self.error or self.stopped:        # a command refused while refilling halted it all
                return False
            self._serial_now = entry.serial
            self.run = self._begin(entry, tick)
            return True
        return False

    def _begin(self, entry, tick: int):
        if self.t_plan < tick / self.rate:        # the machine stood still: start now, from rest
            self.t_plan = tick / self.rate
            self.prev_kin, self.exit_speed = None, 0.0
        self.record.begin(entry, tick)
        if not isinstance(entry, IndexEntry):
            self.track_end = None
        if isinstance(entry, LineEntry):
            return self._begin_line(entry)
        self.prev_kin, self.exit_speed = entry.kin, 0.0
        if isinstance(entry, DwellEntry):
            t0 = self.t_plan
            self.t_plan = t0 + entry.seconds
            return DwellRun(entry, t0, self.rate)
        if isinstance(entry, IndexEntry):
            return self._begin_indexed(entry)
        return HomeRun(entry, self.machine, self.io, lambda: self.walker.rapid,
                       lambda i: self._homed_axis(entry, i))

    def _begin_line(self, entry: LineEntry) -> ClockRun:
        kin, v0 = entry.kin, self.exit_speed
        assert kin is not None                    # a line entry has its kinematics (Walker._line)
        moves = [kin] + [e.kin for e in self.window if e.is_move]
        exit_v, accel = self.planner.plan(self.prev_kin, moves, v0)
        profile = None
        if kin.length_mm > 0.0:
            if v0 <= kin.v_max_mm_s:
                profile = MoveProfile(self.planner.profile_row(kin, v0, exit_v, accel))
            else:                                 # entered above a lowered feed: slow down first
                pieces = ramp_pieces(kin.length_mm, v0, kin.v_max_mm_s, exit_v, accel)
                profile = MoveProfile(pieces[0][1])
                profile.replan(0.0, pieces)
                profile.length = kin.length_mm    # the whole move, not its first piece
                exit_v = profile.exit_speed
        line = prepare_line(self._real(entry.start), self._real(entry.end))
        run = ClockRun(entry, line, kin, profile, self.t_plan, self.rate, self.dda)
        run.prev = self.prev_kin
        self.t_plan = self.t_plan + (profile.duration if profile is not None else 0.0)
        self.prev_kin, self.exit_speed = kin, exit_v
        self.comp = [e - t for e, t in zip(entry.end, entry.target)]
        return run

    def _begin_indexed(self, entry: IndexEntry) -> IndexRun:
        rpm, direction = self.spindle_cmd
        if self.io.spindle is None or self.sim_spindle is None:
            raise MotionError(f"{entry.cmd} under ISTP: no spindle encoder to follow; the machine needs "
                              f"a [spindle] section and the controller a machine to read it from")
        if direction == 0 or not rpm > 0.0:
            raise MotionError(f"{entry.cmd} under ISTP: the spindle is stopped; start it (SPIN, M3/M4 "
                              f"with S) before an indexer move")
        line = prepare_line(self._real(entry.line_start), self._real(entry.end))
        takeup = tuple(b - a for a, b in zip(entry.start, entry.line_start))
        self.comp = [e - t for e, t in zip(entry.end, entry.target)]
        return IndexRun(entry, line, takeup, self.io.spindle, rpm, self.track_end if entry.chained else None,
                        self.machine, direction)

    def _turn_for(self, run: IndexRun) -> Turnaround | None:
        """A Turnaround when the next entry reverses the spindle (a rigid tap's way in or out)."""
        nxt = self.window[0] if self.window else None
        if not (isinstance(nxt, ActionEntry) and isinstance(nxt.cmd, Spin)):
            return None
        cmd = nxt.cmd
        if cmd.direction == 0 or cmd.direction == self.spindle_cmd[1] or not cmd.rpm > 0.0:
            return None
        spindle = self.io.spindle
        return Turnaround(cmd.rpm, cmd.direction, self.spindle_cmd, spindle.reverse_rpm_s,
                          spindle.encoder_counts_per_rev, self._spin)

    def _homed_axis(self, entry: HomeEntry, i: int) -> None:
        """Axis ``i`` latched on its reference switch: its position is now the home position."""
        self.shift[i] = self.pulses.motor[i] - entry.end[i]
        self.comp[i] = entry.end[i] - entry.target[i]
        self.offsets[i] = 0

    def _finish(self, run, tick: int) -> None:
        end_tick = tick_of(run.end_time, self.rate) if isinstance(run, (ClockRun, DwellRun)) else tick + 1
        self.record.finish(self.pulses.requested(), end_tick)
        if isinstance(run, IndexRun):
            self.track_end = run.end_raw
        if isinstance(run, HomeRun):
            self.homed = True
        self.run = None

    def _act(self, entry: ActionEntry, tick: int) -> None:
        cmd = entry.cmd
        if isinstance(cmd, Pstn):
            self.offsets = list(entry.offsets)
        elif isinstance(cmd, Spin):
            self._spin(tick, cmd.rpm, cmd.direction)
        else:
            assert isinstance(cmd, Cool)          # the action entries: PSTN, SPIN, COOL
            self.coolant = cmd.mode

    def _spin(self, tick: int, rpm: float, direction: int) -> None:
        """The spindle drive set from tick ``tick + 1`` on."""
        was_on = self.spindle_cmd[1] != 0
        self.spindle_cmd = (rpm, direction)
        if self.sim_spindle is not None:
            self.sim_spindle.command(tick + 1, rpm, direction)
        if direction and not was_on:
            self.spindle_start = tick + 1

    def _real(self, walker_steps) -> tuple[int, ...]:
        return tuple(s + d for s, d in zip(walker_steps, self.shift))

    # -- halts ---------------------------------------------------------------------------------
    def halt(self, tick: int, reason: str, error: bool) -> None:
        """Stop at once: no new pulse from the next tick on; queue and window emptied."""
        if self.run is not None:
            self.record.finish(self.pulses.requested(), tick + 1)
        self.pulses.clear()
        self.window.clear()
        self.run = None
        self.prev_kin, self.exit_speed, self.track_end = None, 0.0, None
        self.t_plan = min(self.t_plan, tick / self.rate)
        last_dir = [gen.direction for gen in self.pulses.gens]
        walker_motor = [m - s for m, s in zip(self.pulses.motor, self.shift)]
        self.walker.resync(walker_motor, last_dir, self.offsets)
        self.comp = list(self.walker.comp_offsets())
        if error:
            self.error, self.fault = True, reason
        else:
            self.stopped = True

    def outputs_off(self, tick: int) -> None:
        """Spindle and coolant off (the heartbeat's stop, once the axes are at rest)."""
        self.spindle_cmd, self.coolant = (0.0, 0), 0
        if self.sim_spindle is not None:
            self.sim_spindle.command(tick + 1, 0.0, 0)

    def init(self, tick: int) -> None:
        """INIT: stop, default feeds and step source, position 0, flags cleared."""
        self.halt(tick, "INIT", error=False)
        last_dir = [gen.direction for gen in self.pulses.gens]
        self.walker.reset([0] * len(self.shift), last_dir)
        self.shift = [m - w for m, w in zip(self.pulses.motor, self.walker.motor)]
        self.comp = list(self.walker.comp_offsets())
        self.offsets = [0] * len(self.shift)
        self.homed = self.error = self.stopped = self.host_lost = False
        self.fault = self.fault_serial = None

    # -- state -----------------------------------------------------------------------------------
    def idle_at(self, tick: int) -> bool:
        return (self.run is None and not self.window and not self.pulses.pending
                and not self.pulses.busy and tick >= tick_of(self.t_plan, self.rate))

    def quiet_until(self, tick: int) -> int | None:
        """The next tick that needs processing, when frames alone can run until then (else None).

        Nothing is decided before it: no step is due, no direction waits to turn, no rising edge
        (and so no switch) is in the next frame, the entry running needs no tick before then.
        """
        run = self.run
        if isinstance(run, (IndexRun, HomeRun)) or not self.pulses.settled(tick, self.hint):
            return None
        due = self.pulses.next_due()
        options = [due - 1] if due is not None else []
        if run is not None:
            run_due = run.next_due()
            assert run_due is not None            # a run ends (and leaves) in the tick it is done
            options.append(run_due - 1)
        elif self.window:
            if not isinstance(self.window[0], (IndexEntry, HomeEntry)):
                return None
            options.append(tick_of(self.t_plan, self.rate) - 1)
        elif due is None:
            options.append(max(tick_of(self.t_plan, self.rate), tick))
            if self.pulses.busy:
                return None
        return min(options)

    def position_steps(self) -> tuple[int, ...]:
        return tuple(m - s - c - o for m, s, c, o in zip(self.pulses.motor, self.shift, self.comp, self.offsets))

    def flags(self, tick: int) -> dict:
        """Flag name -> on (StatusFlags names), and 'switches': the closed switches."""
        run = self.run
        moving = (run is not None or self.pulses.pending or self.pulses.busy
                  or tick < tick_of(self.t_plan, self.rate))
        index_seen = False
        if self.sim_spindle is not None and self.spindle_start is not None and self.spindle_cmd[1]:
            self.sim_spindle.advance_to(tick - 1)
            index_seen = self.sim_spindle.index_tick >= self.spindle_start
        return {"MOVING": moving, "HOMED": self.homed, "ERROR": self.error, "STOPPED": self.stopped,
                "INDEXER": isinstance(run, IndexRun) or (run is None and self.walker.source == "index"),
                "DWELLING": isinstance(run, DwellRun), "SPINDLE_ON": self.spindle_cmd[1] != 0,
                "COOLANT_ON": self.coolant in (7, 8), "INDEX_SEEN": index_seen,
                "HOST_LOST": self.host_lost,
                "switches": set(self.closed)}

    def run_log(self, frames):
        return self.record.run_log(frames, self.pulses)
