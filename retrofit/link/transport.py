"""The link endpoints over a real port: any object with pyserial's read(n), write(b) and timeout.

That is a ``serial.Serial``, a ``serial.serial_for_url("socket://host:port")``, or a test double.
pyserial itself is imported only by ``open_port``, never when ``retrofit.link`` is imported.
This is the one place of the link that reads the wall clock and waits on I/O.

    with HostLink.open("/dev/ttyUSB0", machine, baudrate=115200) as link:
        link.request(parse_command("PMOV X12.5 Z-3"))     # -> Ack()
        link.request(Rdps())                              # -> Position(steps=...)
"""

from __future__ import annotations

import errno
import threading
import time
from collections.abc import Callable
from typing import Protocol

from ..commands import Command, Rdps
from ..errors import LinkError
from ..machine.config import Machine
from .device import DeviceEndpoint, Handler
from .host import MAY_HAVE_RUN, HostEndpoint, Transaction
from .replies import Position, Reply


class Port(Protocol):
    """What the link needs of a port (pyserial's interface)."""

    timeout: float | None

    def read(self, size: int = 1) -> bytes: ...

    def write(self, data: bytes) -> int | None: ...


def open_port(url: str, baudrate: int = 115200, timeout_s: float = 0.01) -> Port:
    """Open a serial device path or a pyserial URL (``socket://``, ``loop://``, ``rfc2217://``).

    A device path is opened for this process alone: pyserial's ``exclusive`` (an advisory lock,
    which every host of this toolkit takes) and, on POSIX, TIOCEXCL (the kernel refuses any later
    open but root's). A port another host holds is a LinkError saying so.
    """
    try:
        import serial
    except ImportError as exc:
        raise LinkError(f"serial link {url!r}: pyserial is not installed "
                        "(python3 -m pip install pyserial)") from exc
    try:
        port = serial.serial_for_url(url, baudrate=baudrate, timeout=timeout_s, exclusive=True)
    except (OSError, ValueError) as exc:
        if "exclusively lock" in str(exc) or getattr(exc, "errno", None) == errno.EBUSY:
            raise LinkError(f"serial link {url!r}: another host holds the port (a run in progress?); "
                            "one host at a time drives a machine: wait until it has finished") from exc
        raise LinkError(f"serial link {url!r}: cannot open it ({exc}); expected a device such as "
                        "/dev/ttyUSB0 or COM3, or a URL such as socket://127.0.0.1:5555") from exc
    _exclusive_tty(port)
    return port


def _exclusive_tty(port) -> None:
    """TIOCEXCL on a POSIX tty: no one else may open it while this host has it open."""
    fd = getattr(port, "fd", None)
    if fd is None:
        return
    try:
        import fcntl
        import termios
        fcntl.ioctl(fd, termios.TIOCEXCL)
    except (ImportError, OSError, AttributeError):
        pass


def read_some(port: Port, name: str) -> bytes:
    """Wait up to ``port.timeout`` for one byte, then take whatever else is already waiting."""
    try:
        data = port.read(1)
        waiting = getattr(port, "in_waiting", 0) if data else 0
        return data + port.read(waiting) if waiting else data
    except LinkError:
        raise
    except OSError as exc:
        raise LinkError(f"serial link {name}: read failed: {exc}") from exc


def write_all(port: Port, data: bytes, name: str) -> None:
    """Write ``data``; an OSError becomes a LinkError naming the port."""
    if not data:
        return
    try:
        port.write(data)
    except LinkError:
        raise
    except OSError as exc:
        raise LinkError(f"serial link {name}: write failed: {exc}") from exc


class HostLink:
    """The host endpoint driven over a port; thread-safe, so STOP can be sent while a move waits.

    Sets ``port.timeout`` to ``poll_s``. Endpoint options (``timeout_s``, ``max_tries``,
    ``busy_retry_s``, ``busy_limit_s``) pass through to HostEndpoint.
    """

    def __init__(self, port: Port, machine: Machine, *, clock: Callable[[], float] = time.monotonic,
                 poll_s: float = 0.005, name: str | None = None, **endpoint_options):
        self.port, self.clock = port, clock
        self.name = name or str(getattr(port, "port", None) or type(port).__name__)
        self.endpoint = HostEndpoint(machine, **endpoint_options)
        port.timeout = poll_s
        self._lock = threading.RLock()

    @classmethod
    def open(cls, url: str, machine: Machine, *, baudrate: int = 115200, **options) -> HostLink:
        """Open ``url`` with pyserial (see open_port) and put a HostLink on it."""
        return cls(open_port(url, baudrate), machine, name=url, **options)

    def submit(self, cmd: Command, *, urgent: bool | None = None) -> Transaction:
        """Queue a command without waiting; ``wait`` (or a later ``request``) carries it out."""
        with self._lock:
            t = self.endpoint.send(cmd, self.clock(), urgent=urgent)
            write_all(self.port, self.endpoint.take_output(), self.name)
            return t

    def wait(self, t: Transaction) -> Reply:
        """Run the link until ``t`` is answered; its reply, or its LinkError raised.

        When the host gave up on ``t`` without an answer the command may have run: the error
        then also says where RDPS finds the machine, so the operator can tell.
        """
        while not t.done:
            with self._lock:
                self._step(t)
        if t.error is None:
            assert t.reply is not None           # done: answered or failed
            return t.reply
        if t.unacknowledged and not isinstance(t.cmd, Rdps):
            said = f"{MAY_HAVE_RUN}; RDPS says {self._where()}"
            raise LinkError(str(t.error).replace(MAY_HAVE_RUN, said, 1)) from t.error
        raise t.error

    def _where(self) -> str:
        """The position RDPS reads now, in mm, or why it could not be read."""
        try:
            reply = self.request(Rdps(), urgent=True)
        except LinkError:
            return "nothing either (no answer)"
        if not isinstance(reply, Position):
            return f"{type(reply).__name__.upper()} instead of a position"
        mm = reply.mm(self.endpoint.machine)
        return " ".join(f"{name}{value:g}" for name, value in mm.items()) + " mm"

    def request(self, cmd: Command, *, urgent: bool | None = None) -> Reply:
        """Send ``cmd`` and wait for its answer (Ack, Position for RDPS, Status for RDST)."""
        return self.wait(self.submit(cmd, urgent=urgent))

    def _step(self, t: Transaction) -> None:
        if t.done:
            return
        data = read_some(self.port, self.name)
        try:
            if data:
                self.endpoint.receive(data, self.clock())
            self.endpoint.poll(self.clock())
        except LinkError:
            pass    # recorded in the failed Transaction; wait() raises it to that one's waiter
        write_all(self.port, self.endpoint.take_output(), self.name)

    def close(self) -> None:
        """Close the port (if it can be closed)."""
        close = getattr(self.port, "close", None)
        if close is not None:
            close()

    def __enter__(self) -> HostLink:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


class DeviceLink:
    """The device endpoint driven over a port: what ``retrofit mcu`` runs (or a test's server)."""

    def __init__(self, port: Port, machine: Machine, handler: Handler, *, name: str | None = None,
                 **endpoint_options):
        self.port = port
        self.name = name or str(getattr(port, "port", None) or type(port).__name__)
        self.endpoint = DeviceEndpoint(machine, handler, **endpoint_options)

    def serve_once(self) -> bool:
        """Read what arrived within ``port.timeout`` and answer it; True if bytes came."""
        data = read_some(self.port, self.name)
        if data:
            self.endpoint.receive(data)
            write_all(self.port, self.endpoint.take_output(), self.name)
        return bool(data)

    def serve(self, stop: threading.Event) -> None:
        """Answer the host until ``stop`` is set."""
        while not stop.is_set():
            self.serve_once()
