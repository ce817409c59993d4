"""serial:// — a motion controller at the far end of the serial link; it takes commands, not frames.

URL grammar: ``serial:///dev/ttyUSB0?baud=115200`` (a serial device: an Arduino Mega running
``firmware/``, or the pty printed by ``retrofit mcu --pty``) or ``serial+socket://HOST:PORT``
(the same bytes over TCP: ``retrofit mcu --listen``, or the firmware in simavr: ``retrofit firmware sim``). Options:
``baud`` (int, 115200), ``timeout_ms`` (float, 100: resend when unanswered, docs/protocol.md §6),
``tries`` (int, 10), ``init`` (bool, 1: send INIT first), ``wait_s`` (float, 0: how long to wait
for the motion to end; 0 waits as long as it takes), ``poll_ms`` (float, 20: RDST interval),
``boot_ms`` (float, 3000: how long to wait for the device to answer after the port opens).

This is a *command-level* output (``takes_commands = True``). A bit-level output takes port
frames through ``write``; here the controller at the far end makes its own port bytes, so
``write`` refuses frames and the program goes through :meth:`SerialOutput.send_program`:

1. open the port (pyserial, imported only now) and wait out the device's start: opening an
   Arduino's USB port resets it (DTR) into its bootloader for 1-2 s, which swallows bytes, so a
   SYNC frame is repeated every 100 ms until the firmware's start line (its banner: machine,
   link version, reset cause; a firmware built for another machine is refused) or the first
   answer comes (at most ``boot_ms``); then SYNC both channels;
2. INIT, unless ``init=0``: position 0, default feeds, empty queue, as the local plan starts;
3. every command in order on the queued channel (BUSY waited out, NAK and timeouts resent);
4. RDST every ``poll_ms`` until nothing moves, dwells or waits; ERROR or STOPPED fail the run
   (the polls are also the device's heartbeat: a device that hears nothing for 500 ms brakes);
5. RDPS: the final position, compared with where the commands end (in steps): a device that
   reports anything else fails the run, naming both positions.

The port is opened for this host alone (docs/protocol.md §1): a second host on the same tty is
refused before it sends a byte.

``observe()`` then returns ``{"remote": {...}}``: what the far end reported (``remote`` in
docs/report.md). ``retrofit run`` hands command-level outputs the program's commands.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Iterable
from dataclasses import dataclass

from ..commands import Command, CStp, FMov, Init, IStp, PMov, Prob, Pstn, Rdps, Rdst, Spin, Stop, ZMov
from ..errors import LinkError, OutputError
from ..frames import PortFrames
from ..link.codec import HEARTBEAT_MS
from ..link.host import BANNER
from ..link.replies import flag_names
from .base import Output

#: flags that mean the far end gave up on the program
_FAILED = ("ERROR", "STOPPED")
#: flags that mean the far end still has work
_BUSY = ("MOVING", "DWELLING")


class SerialOutput(Output):
    scheme = "serial"
    grammar = "serial:///dev/ttyUSB0?baud=115200 or serial+socket://HOST:PORT"
    summary = ("a motion controller on the serial link (firmware/ on an Arduino Mega, or "
               "retrofit mcu): sends the program's commands, reads the final position (RDPS)")
    options = {"baud": (int, 115200), "timeout_ms": (float, 100.0), "tries": (int, 10),
               "init": (bool, True), "wait_s": (float, 0.0), "poll_ms": (float, 20.0),
               "boot_ms": (float, 3000.0)}
    takes_commands = True

    def __init__(self, url, machine):
        super().__init__(url, machine)
        if not self.url.target:
            raise OutputError(f"{url.text}: no device or address; expected {self.grammar}")
        if self.opts["timeout_ms"] <= 0 or self.opts["poll_ms"] <= 0 or self.opts["tries"] < 1:
            raise OutputError(f"{url.text}: timeout_ms and poll_ms must be > 0 and tries >= 1")
        if self.opts["poll_ms"] > HEARTBEAT_MS / 2:
            raise OutputError(f"{url.text}: poll_ms = {self.opts['poll_ms']:g} is too long: the "
                              f"device stops a machine whose host is silent for {HEARTBEAT_MS} ms; "
                              f"expected at most {HEARTBEAT_MS // 2}")
        self.link = None
        self.remote: dict | None = None
        self.banner: Banner | None = None

    @property
    def port_url(self) -> str:
        """What pyserial opens: the device path, or ``socket://HOST:PORT``."""
        if self.url.scheme == "serial+socket":
            return f"socket://{self.url.target}"
        return self.url.target

    def open(self) -> None:
        if self.link is None:
            from ..link import HostLink
            try:
                self.link = HostLink.open(self.port_url, self.machine, baudrate=self.opts["baud"],
                                          timeout_s=self.opts["timeout_ms"] / 1000,
                                          max_tries=self.opts["tries"])
                self.banner = wait_for_device(self.link.port, self.opts["boot_ms"] / 1000,
                                              self.url.text, self.machine.name)
            except LinkError as exc:
                raise OutputError(f"{self.url.text}: {exc}") from None
        super().open()

    def write(self, frames: PortFrames) -> None:
        raise OutputError(f"{self.url.text}: a serial controller takes commands, not port frames; "
                          "use send_program(commands) (retrofit run does)")

    def send_program(self, commands: Iterable[Command]) -> dict:
        """Run ``commands`` on the far end, wait for the motion to end, read the position.

        Returns the ``remote`` part of the report; raises OutputError naming the command that
        failed, or the status flags that stopped the program.
        """
        program = ([Init()] if self.opts["init"] else []) + list(commands)
        refuse_rigid_tap(self.url.text, program)
        if self.link is None:
            self.open()
        started = time.monotonic()
        try:
            start = None if self.opts["init"] else dict(self.link.request(Rdps()).steps)
            sent = [self.link.submit(cmd, urgent=False) for cmd in program]
            for t in sent:
                self.link.wait(t)
            status = self._wait_for_rest(started)
            position = self.link.request(Rdps())
        except LinkError as exc:
            raise OutputError(f"{self.url.text}: {exc}") from None
        self._check_end(end_steps(self.machine, program, start), dict(position.steps))
        self.remote = self._summary(len(program), status, position, time.monotonic() - started)
        return self.remote

    def _check_end(self, expected: dict[str, int | None], reported: dict[str, int]) -> None:
        """OutputError when the device's RDPS is not where the commands end (axes a probing
        or homing move left unknown are not compared)."""
        wrong = [n for n, steps in expected.items() if steps is not None and reported.get(n) != steps]
        if not wrong:
            return
        def text(pos):
            return " ".join(f"{n}{'?' if pos.get(n) is None else pos[n]}" for n in expected)
        raise OutputError(f"{self.url.text}: the controller reports the end position {text(reported)} "
                          f"steps (RDPS), but the program ends at {text(expected)} steps; "
                          f"{', '.join(wrong)} differ: the machine's position cannot be trusted")

    def _wait_for_rest(self, started: float):
        """RDST until the far end has no move, dwell or queued command left; its last status."""
        limit = self.opts["wait_s"]
        while True:
            status = self.link.request(Rdst())
            names = flag_names(status.flags)
            failed = [n for n in _FAILED if n in names]
            if failed:
                raise OutputError(f"{self.url.text}: the controller reports {' and '.join(failed)} "
                                  f"(status {', '.join(names)}); the program did not finish")
            if status.queued == 0 and not any(n in names for n in _BUSY):
                return status
            if limit and time.monotonic() - started > limit:
                raise OutputError(f"{self.url.text}: still moving after wait_s={limit:g} s "
                                  f"(status {', '.join(names)}, {status.queued} queued)")
            time.sleep(self.opts["poll_ms"] / 1000)

    def _summary(self, count: int, status, position, wall_s: float) -> dict:
        stats = self.link.endpoint.stats
        return {
            "url": self.url.text,
            "commands": count,
            "position_steps": {name: int(steps) for name, steps in position.steps},
            "position_mm": {name: round(mm, 6) for name, mm in position.mm(self.machine).items()},
            "status": flag_names(status.flags),
            "link": {"frames_sent": stats.frames_sent, "resends": stats.resends,
                     "timeouts": stats.timeouts, "naks": stats.naks, "busy": stats.busy},
            "wall_s": round(wall_s, 3),
            "banner": dataclasses.asdict(self.banner) if self.banner else None,
        }

    def observe(self) -> dict | None:
        return {"remote": self.remote} if self.remote is not None else None

    def safe_stop(self) -> None:
        """STOP on the immediate channel, at once (a run that fails or is told to end). Best
        effort: a link that does not answer leaves it to the device's heartbeat (500 ms)."""
        if self.link is None:
            return
        try:
            self.link.request(Stop(), urgent=True)
        except (LinkError, OSError):
            pass

    def close(self) -> None:
        if self.link is not None:
            self.link.close()
            self.link = None
        super().close()


#: why a controller on the link cannot run a rigid tap
RIGID_TAP_REASON = ("reverses the spindle inside a synchronised (ISTP) chain, a rigid tap (G33.1); the "
                    "firmware's indexer counts its encoder one way and cannot follow the spindle back; "
                    "run rigid taps on sim://, or tap with G84/G74 and a floating holder")


def reverses_in_chain(cmd, indexing: bool, direction: int) -> bool:
    """Whether ``cmd`` reverses a spindle turning ``direction`` inside an ISTP chain."""
    return isinstance(cmd, Spin) and indexing and direction != 0 and cmd.direction == -direction


def refuse_rigid_tap(url: str, program) -> None:
    """OutputError, before a byte is sent, for a spindle reversed between ISTP moves (G33.1)."""
    indexing, direction = False, 0
    for k, cmd in enumerate(program):
        if isinstance(cmd, (IStp, CStp)):
            indexing = isinstance(cmd, IStp)
        elif isinstance(cmd, Spin):
            if reverses_in_chain(cmd, indexing, direction):
                raise OutputError(f"{url}: command {k + 1} ({cmd}) {RIGID_TAP_REASON}")
            direction = cmd.direction


def end_steps(machine, program, start: dict[str, int] | None = None) -> dict[str, int | None]:
    """Where ``program`` leaves each axis in steps (program coordinates, as RDPS reports them),
    from ``start`` (None: 0, as after INIT); None for an axis a homing or probing move ends
    where its switch is."""
    pos: dict[str, int | None] = {a.name: 0 for a in machine.axes} if start is None else dict(start)
    for cmd in program:
        if isinstance(cmd, Init):
            pos = {name: 0 for name in pos}
        elif isinstance(cmd, (FMov, PMov, Pstn)):
            pos.update((name, machine.axis(name).to_steps(mm)) for name, mm in cmd.axes)
        elif isinstance(cmd, Prob):
            pos.update((name, None) for name, _ in cmd.axes)
        elif isinstance(cmd, ZMov):
            pos.update((name, None) for name in (cmd.names or tuple(pos)))
    return pos


class SerialSocketOutput(SerialOutput):
    """``serial+socket://HOST:PORT``: the serial protocol over TCP (pyserial's socket://)."""

    scheme = "serial+socket"
    grammar = "serial+socket://HOST:PORT"
    summary = ("the serial protocol over TCP: retrofit mcu --listen, or the firmware in simavr "
               "(retrofit firmware sim --listen)")


#: the link version this host speaks (docs/protocol.md)
LINK_VERSION = 3


@dataclass(frozen=True)
class Banner:
    """What the firmware's start line says: its machine, link version and reset cause."""

    machine: str
    link: int
    reset: str

    @classmethod
    def find(cls, data: bytes) -> Banner | None:
        found = BANNER.search(data)
        return cls(found[1].decode("ascii", "replace"), int(found[2]),
                   found[3].decode("ascii", "replace")) if found else None

    def check(self, machine: str, name: str) -> None:
        """LinkError when the firmware was built for another machine or link version."""
        if self.link != LINK_VERSION:
            raise LinkError(f"{name}: the firmware speaks link version {self.link}; this host "
                            f"speaks {LINK_VERSION} (flash the firmware of this retrofit)")
        if self.machine != machine:
            raise LinkError(f"{name}: the firmware was built for machine {self.machine!r}, the run "
                            f"is for {machine!r} (make -C firmware flash MACHINE={machine})")


def wait_for_device(port, boot_s: float, name: str, machine: str = "") -> Banner | None:
    """Wait until the device is up after the port opened: its start line (the banner), or an
    answer to the SYNC frame sent every 100 ms meanwhile. Returns the banner if one came.
    LinkError after ``boot_s``, or when the banner names another machine than ``machine``."""
    from ..link import QUEUED, FrameDecoder, encode_frame, seq_byte
    from ..link.transport import read_some, write_all
    sync = encode_frame(seq_byte(QUEUED, 0), bytes((0x7F,)))
    decoder, seen, start = FrameDecoder(), b"", time.monotonic()
    while True:
        write_all(port, sync, name)
        until = time.monotonic() + 0.1
        while time.monotonic() < until:
            data = read_some(port, name)
            seen = (seen + data)[-256:]
            banner = Banner.find(seen)
            if decoder.feed(data) or banner:
                if banner and machine:
                    banner.check(machine, name)
                time.sleep(0.05)
                read_some(port, name)                 # an answer to a SYNC in flight, if any
                return banner
        if time.monotonic() - start > boot_s:
            raise LinkError(f"{name}: no banner and no answer to SYNC within {boot_s:g} s of "
                            "opening the port (is the firmware flashed and the baud rate right?)")
