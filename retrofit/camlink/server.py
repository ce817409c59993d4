"""The controller's end of the CAM link: a TCP server for one client at a time.

One thread runs :meth:`CamLinkServer.serve_forever`: it waits on the listening socket and the
client's socket, rebuilds ``@``-ended messages, has the :class:`~.machine.CamMill` execute each
one (a row is one loop period), and sends back the machine's replies and a ``!`` line for every
refused message. Rows are paced by the socket: the loop runs one period per row received.

* A second client is told ``!busy: ...`` and closed; the first one carries on. A client that
  closed its connection is let go before a new one is looked at, so a reconnection right after
  a close is accepted.
* A client that sends nothing for ``idle_timeout_s`` (default 30 s) is told ``!idle: ...`` and
  dropped, so a silent connection cannot keep every other client out.
* A client that disconnects (or stops reading its replies) stops the machine: drives to 0,
  spindle and coolant off.
"""

from __future__ import annotations

import select
import socket
import threading
import time
from collections.abc import Callable

from ..errors import LinkError, RetrofitError
from .machine import CamMill
from .protocol import LineSplitter, error_reply, format_reply, parse_message

#: how long the server waits for a client to take its replies before giving it up
SEND_TIMEOUT_S = 5.0
#: how often the server looks at the machine's outbox when no byte arrives (e-stop, joystick)
POLL_S = 0.01
#: how long a client may send nothing before it is dropped
IDLE_TIMEOUT_S = 30.0


def parse_listen(text: str) -> tuple[str, int]:
    """``"127.0.0.1:5000"`` -> ("127.0.0.1", 5000); port 0 picks a free one."""
    host, sep, port = text.rpartition(":")
    if not sep or not host or not port.isdigit() or int(port) > 65535:
        raise LinkError(f"--listen {text!r}: expected HOST:PORT, e.g. 127.0.0.1:5000 (port 0..65535)")
    return host.strip("[]"), int(port)


class CamLinkServer:
    """Serves a :class:`CamMill` on ``host:port`` (``port`` 0: the system picks one)."""

    def __init__(self, mill: CamMill, host: str = "127.0.0.1", port: int = 0,
                 log: Callable[[str], None] | None = None, *,
                 idle_timeout_s: float = IDLE_TIMEOUT_S,
                 clock: Callable[[], float] = time.monotonic):
        if not idle_timeout_s > 0:
            raise LinkError(f"CAM link idle timeout {idle_timeout_s!r} s: must be > 0")
        self.mill = mill
        self.log = log or (lambda text: None)
        self.idle_timeout_s, self.clock = idle_timeout_s, clock
        self._last_heard = 0.0
        try:
            self.listener = socket.create_server((host, port))
        except OSError as exc:
            raise LinkError(f"cannot listen on {host}:{port}: {exc.strerror or exc}") from None
        self.address: tuple[str, int] = self.listener.getsockname()[:2]
        self.client: socket.socket | None = None
        self.splitter = LineSplitter()
        self._stopping = threading.Event()
        self._thread: threading.Thread | None = None

    # -- life cycle ---------------------------------------------------------------------------
    def start(self) -> CamLinkServer:
        """Serve in a background thread; returns self."""
        self._thread = threading.Thread(target=self.serve_forever, name="camlink-server", daemon=True)
        self._thread.start()
        return self

    def shutdown(self) -> None:
        """Stop serving (the machine is stopped if a client was connected) and close the sockets."""
        self._stopping.set()
        if self._thread is not None:
            self._thread.join(timeout=5.0)
        if self.client is not None:
            self._drop("server shut down")
        self.listener.close()

    def __enter__(self) -> CamLinkServer:
        return self.start()

    def __exit__(self, *exc) -> None:
        self.shutdown()

    def serve_forever(self) -> None:
        """Accept, read, execute, reply; until :meth:`shutdown`."""
        while not self._stopping.is_set():
            watched = [self.listener] + ([self.client] if self.client is not None else [])
            try:
                readable, _, _ = select.select(watched, [], [], POLL_S)
            except (OSError, ValueError):
                break                                  # listener closed under us
            if self.client is not None and self.client in readable:
                self._receive()                        # first: a client that left is let go
            if self.listener in readable:
                self._accept()
            if self.client is not None and self.mill.outbox:
                self._send(self.mill.replies())
            if self.client is not None and self.clock() - self._last_heard > self.idle_timeout_s:
                self._drop_idle()

    # -- one client -----------------------------------------------------------------------------
    def _accept(self) -> None:
        conn, peer = self.listener.accept()
        if self.client is not None and self._client_has_left():
            self._receive()                            # its last bytes, then its end
        if self.client is not None:
            self.log(f"refused {peer[0]}:{peer[1]}: a client is already connected")
            try:
                conn.sendall(format_reply("!busy: another client is connected; the CAM link "
                                          "serves one client at a time"))
            except OSError:
                pass
            conn.close()
            return
        conn.settimeout(SEND_TIMEOUT_S)
        self.client, self.splitter = conn, LineSplitter()
        self._last_heard = self.clock()
        self.mill.replies()                            # nothing stale for the new client
        self.log(f"client {peer[0]}:{peer[1]} connected")
        if self.mill.estop:
            self._send(["E1"])

    def _receive(self) -> None:
        try:
            data = self.client.recv(65536)
        except OSError:
            data = b""
        if not data:
            self._drop("client disconnected")
            return
        self._last_heard = self.clock()
        out: list[str] = []
        for item in self.splitter.feed(data):
            try:
                if isinstance(item, LinkError):
                    raise item
                self.mill.handle(parse_message(item))
                out.extend(self.mill.replies())
            except RetrofitError as exc:
                out.extend(self.mill.replies())
                out.append(error_reply(exc))
        if out:
            self._send(out)

    def _client_has_left(self) -> bool:
        """True when the client's socket is readable at once (its close, or bytes before it)."""
        try:
            readable, _, _ = select.select([self.client], [], [], 0)
        except (OSError, ValueError):
            return True
        return bool(readable)

    def _drop_idle(self) -> None:
        quiet = f"{self.idle_timeout_s:g} s"
        self._send([f"!idle: no message for {quiet}; the CAM link drops a silent client so "
                    "that others can connect (connect again to carry on)"])
        if self.client is not None:
            self._drop(f"client idle for {quiet}")

    def _send(self, replies: list[str]) -> None:
        if self.client is None or not replies:
            return
        try:
            self.client.sendall(b"".join(format_reply(r) for r in replies))
        except OSError:
            self._drop("connection lost while sending replies (or the client stopped reading them)")

    def _drop(self, reason: str) -> None:
        """Stop the machine (drives, spindle, coolant), then close the client."""
        client, self.client = self.client, None
        record = self.mill.halt(reason)        # first: the machine is stopped before the client sees the close
        if client is not None:
            try:
                client.close()
            except OSError:
                pass
        run_on = " ".join(str(c) for c in record.coast_pulses)
        self.log(f"{reason}: machine stopped at tick {record.tick}, axes ran on {run_on} pulses "
                 f"in {record.coast_periods} loop periods")
