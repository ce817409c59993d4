"""The motion controller behind the serial link, as a device process: what ``retrofit mcu`` runs.

002's controller is an 8-bit microcontroller that takes commands over a serial line. ``retrofit
mcu`` plays that part on the PC: the Python :class:`retrofit.controller.Controller` runs behind a
:class:`retrofit.link.DeviceLink` whose handler is the controller's ``submit``, on a pseudo
terminal (``--pty``; the host opens the printed ``/dev/pts/N`` like a USB serial adapter) or a
TCP socket (``--listen HOST:PORT``; the host uses ``socket://HOST:PORT``).

Time on the device is the controller's tick, not the wall clock: between two looks at the port
the loop runs ticks as fast as it can while the controller has work (stretches in which nothing
changes, such as most of a dwell, pass at once), for at most ``slice_s`` of wall time, so RDPS
and RDST are answered within a few milliseconds even during a long move.

The heartbeat (docs/protocol.md §5) counts the controller's ticks since the host's last frame.
Because the loop may run ahead of the wall clock, it does not tick past the heartbeat's moment
until the host has also been silent for HEARTBEAT_MS of wall time: a host that polls in time is
never taken for dead because the device ran fast.
"""

from __future__ import annotations

import os
import select
import socket
import time
from collections.abc import Callable

from ..errors import LinkError, MotionError
from ..link import DeviceLink
from ..link.codec import HEARTBEAT_MS
from ..machine.config import Machine

#: wall time the loop spends ticking the controller between two looks at the port
SLICE_S = 0.004
#: how long the loop waits at the port when the controller is idle
IDLE_WAIT_S = 0.01
#: ticks per call of the controller's run_until_idle (it passes over quiet stretches at once)
TICKS_PER_CALL = 250


class PtyPort:
    """The master side of a pseudo terminal, with pyserial's read / write / timeout / in_waiting.

    The slave side (``name``) is set raw (no echo, no line editing) and kept open here, so a host
    may close and reopen it without the master seeing a hang-up.
    """

    def __init__(self) -> None:
        import tty
        self.master, self._slave = os.openpty()
        tty.setraw(self._slave)
        self.name = os.ttyname(self._slave)
        self.timeout: float | None = IDLE_WAIT_S

    @property
    def in_waiting(self) -> int:
        import fcntl
        import termios
        raw = fcntl.ioctl(self.master, termios.FIONREAD, b"\0\0\0\0")
        return int.from_bytes(raw, "little")

    def read(self, size: int = 1) -> bytes:
        ready, _, _ = select.select([self.master], [], [], self.timeout)
        if not ready or size <= 0:
            return b""
        try:
            return os.read(self.master, size)
        except OSError:            # no host has the slave open: nothing to read
            time.sleep(self.timeout or 0)
            return b""

    def write(self, data: bytes) -> None:
        os.write(self.master, data)

    def close(self) -> None:
        for fd in (self.master, self._slave):
            try:
                os.close(fd)
            except OSError:
                pass


class TcpServerPort:
    """A listening TCP socket that serves one host at a time, with pyserial's port interface.

    A host that disconnects is dropped and the next one accepted; the controller keeps its state
    (the new host starts its channels with SYNC, as after any reconnection).
    """

    def __init__(self, host: str, port: int) -> None:
        try:
            self.listener = socket.create_server((host, port))
        except OSError as exc:
            raise LinkError(f"retrofit mcu --listen {host}:{port}: cannot listen there "
                            f"({exc.strerror or exc}); expected a free HOST:PORT (port 0 picks one)") from None
        self.address = self.listener.getsockname()[:2]
        self.client: socket.socket | None = None
        self.timeout: float | None = IDLE_WAIT_S

    @property
    def in_waiting(self) -> int:
        if self.client is None:
            return 0
        try:
            return len(self.client.recv(4096, socket.MSG_PEEK | socket.MSG_DONTWAIT))
        except (BlockingIOError, InterruptedError):
            return 0
        except OSError:
            return 0

    def read(self, size: int = 1) -> bytes:
        if self.client is None:
            self._accept()
            return b""
        ready, _, _ = select.select([self.client], [], [], self.timeout)
        if not ready or size <= 0:
            return b""
        try:
            data = self.client.recv(size)
        except OSError:
            data = b""
        if not data:                # the host went away
            self._drop()
        return data

    def write(self, data: bytes) -> None:
        if self.client is None:
            return
        try:
            self.client.sendall(data)
        except OSError:
            self._drop()

    def _accept(self) -> None:
        ready, _, _ = select.select([self.listener], [], [], self.timeout)
        if ready:
            self.client, _ = self.listener.accept()
            self.client.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)

    def _drop(self) -> None:
        if self.client is not None:
            self.client.close()
            self.client = None

    def close(self) -> None:
        self._drop()
        self.listener.close()


class McuLoop:
    """The device's main loop: answer the link, then run controller ticks while there is work."""

    def __init__(self, port, machine: Machine, controller, *, slice_s: float = SLICE_S,
                 ticks_per_call: int = TICKS_PER_CALL,
                 clock: Callable[[], float] = time.monotonic, name: str | None = None,
                 heartbeat_ms: float | None = HEARTBEAT_MS, sessions=None):
        self.port, self.controller, self.slice_s, self.clock = port, controller, slice_s, clock
        self.ticks_per_call = ticks_per_call
        self.heartbeat_s = None if heartbeat_ms is None else heartbeat_ms / 1000
        if heartbeat_ms is not None:
            controller.heartbeat_ticks = max(1, round(heartbeat_ms * 1000 / machine.tick_us))
        self._heard_at = clock()
        self._waiting = False           # ticked up to the heartbeat: wait for the wall clock
        self.link = DeviceLink(port, machine, controller.submit, name=name, sessions=sessions,
                               on_frame=self._heard)

    def _heard(self) -> None:
        self.controller.heard()
        self._heard_at = self.clock()

    def _budget(self) -> int:
        """Ticks the controller may run now: not past the heartbeat's moment while the host's
        silence is shorter than the heartbeat on the wall clock too."""
        due = self.controller.heartbeat_due()
        if due is None or self.clock() - self._heard_at >= self.heartbeat_s:
            return self.ticks_per_call
        return min(self.ticks_per_call, due - 1 - self.controller.ticks)

    def run_once(self) -> None:
        """One pass: look at the port (without waiting when there is work), then tick."""
        self.port.timeout = 0 if not (self.controller.idle or self._waiting) else IDLE_WAIT_S
        self.link.serve_once()
        end = self.clock() + self.slice_s
        self._waiting = False
        while not self.controller.idle and self.clock() < end:
            budget = self._budget()
            if budget <= 0:
                self._waiting = True
                break
            try:                    # ticks, passing over stretches in which nothing changes
                self.controller.run_until_idle(budget)
            except MotionError:     # still busy after them: look at the port again soon
                pass

    def serve_forever(self, should_stop: Callable[[], bool] = lambda: False) -> None:
        """Run until ``should_stop()`` is true (the command line runs until interrupted)."""
        while not should_stop():
            self.run_once()


def make_controller(machine: Machine, backlash_comp: bool = True, simulate: bool = False):
    """The Python motion controller for ``machine`` (imported here so the link stays light).

    With ``simulate`` it drives a simulated machine and reads its inputs, as the MCU reads its
    pins: ZMOV finds the switches and ISTP follows the spindle's encoder. Without, nothing is
    wired: no switch closes and there is no encoder, as for the firmware under QEMU. It ticks
    in readable Python (``kernels=False``): a device answers its link within milliseconds, and
    loading the compiled tick loop mid-run would keep it silent for a second.
    """
    from ..controller import Controller
    sim = None
    if simulate:
        from ..sim import SimMachine
        sim = SimMachine(machine)
    return Controller(machine, backlash_comp=backlash_comp, sim=sim, kernels=False)


def parse_listen(text: str) -> tuple[str, int]:
    """``"127.0.0.1:5555"`` -> ("127.0.0.1", 5555); port 0 lets the system pick a free one."""
    host, sep, port = text.rpartition(":")
    if not sep or not host or not port.isdigit() or int(port) > 65535:
        raise LinkError(f"--listen {text!r}: expected HOST:PORT, e.g. 127.0.0.1:5555 (port 0..65535)")
    return host.strip("[]"), int(port)
