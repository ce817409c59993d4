"""The CAM side's socket: send messages, read the controller's reply lines, stream a job.

:func:`stream_job` sends a job as fast as the socket takes it (the controller runs one loop
period per row) and waits where the protocol answers: ``A`` after ``A@``, ``H`` after ``H@``,
the position after ``#@``. A ``!`` reply or ``E1`` stops the job with a LinkError; closing the
socket then stops the machine.
"""

from __future__ import annotations

import select
import socket
import time
from collections import deque
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field

from ..errors import LinkError
from .protocol import Auto, EndOperation, Home, Message, Row, format_message, parse_position

#: rows sent in one write while streaming
BATCH_ROWS = 64
#: how long to wait for H or the position: the controller may still be running rows queued before
ANSWER_TIMEOUT_S = 60.0


class CamClient:
    """A TCP client of the CAM link (a context manager)."""

    def __init__(self, host: str, port: int, timeout_s: float = 5.0):
        self.timeout_s = timeout_s
        try:
            self.sock = socket.create_connection((host, port), timeout=timeout_s)
        except OSError as exc:
            raise LinkError(f"cannot connect to {host}:{port}: {exc.strerror or exc}") from None
        self._buffer = b""
        self.lines: deque[str] = deque()     # reply lines received and not yet taken

    def __enter__(self) -> CamClient:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def close(self) -> None:
        self.sock.close()

    def send(self, *messages: Message) -> None:
        """Send messages, each with its ``@``."""
        self.send_raw(b"".join(format_message(m) for m in messages))

    def send_raw(self, data: bytes) -> None:
        """Send bytes as they are (tests use it for malformed lines)."""
        try:
            self.sock.sendall(data)
        except OSError as exc:
            raise LinkError(f"CAM link closed while sending: {exc}") from None

    def poll(self) -> list[str]:
        """Reply lines that have arrived, without waiting."""
        self._read(0.0)
        out = list(self.lines)
        self.lines.clear()
        return out

    def read_line(self, timeout_s: float | None = None) -> str:
        """The next reply line; LinkError if none comes within the timeout or the link closes."""
        wait_s = self.timeout_s if timeout_s is None else timeout_s
        deadline = time.monotonic() + wait_s
        while not self.lines:
            left = deadline - time.monotonic()
            if left <= 0:
                raise LinkError(f"no reply from the controller within {wait_s:g} s")
            self._read(left)
        return self.lines.popleft()

    def expect(self, wanted: Callable[[str], bool], what: str, timeout_s: float | None = None) -> str:
        """Read lines until one satisfies ``wanted``; a ``!`` or ``E1`` line raises LinkError."""
        while True:
            line = self.read_line(timeout_s)
            if wanted(line):
                return line
            check_reply(line, what)

    def _read(self, timeout_s: float) -> None:
        ready, _, _ = select.select([self.sock], [], [], max(0.0, timeout_s))
        if not ready:
            return
        try:
            data = self.sock.recv(65536)
        except OSError as exc:
            raise LinkError(f"CAM link lost: {exc}") from None
        if not data:
            raise LinkError("the controller closed the CAM link")
        self._buffer += data
        *complete, self._buffer = self._buffer.split(b"\n")
        self.lines.extend(line.decode("ascii", "replace").rstrip("\r") for line in complete)


def check_reply(line: str, what: str) -> None:
    """Raise LinkError for a refusal (``!``) or an emergency stop (``E1``) seen while ``what``."""
    if line.startswith("!"):
        raise LinkError(f"controller refused a message while {what}: {line[1:]}")
    if line == "E1":
        raise LinkError(f"emergency stop pressed on the machine while {what}")


@dataclass
class JobResult:
    """What a streamed job got back."""

    rows: int = 0
    positions: list[tuple[int, int, int]] = field(default_factory=list)   # after each operation
    replies: list[str] = field(default_factory=list)                     # every reply line


def stream_job(client: CamClient, messages: Iterable[Message],
               progress: Callable[[int], None] | None = None) -> JobResult:
    """Send a job; wait at each answered message; LinkError on the first refusal."""
    result = JobResult()
    batch: list[Message] = []

    def take(line: str, what: str) -> None:
        result.replies.append(line)
        check_reply(line, what)

    for message in messages:
        if isinstance(message, Row):
            batch.append(message)
            result.rows += 1
            if len(batch) >= BATCH_ROWS:
                client.send(*batch)
                batch.clear()
                for line in client.poll():
                    take(line, "streaming rows")
                if progress:
                    progress(result.rows)
            continue
        if batch:
            client.send(*batch)
            batch.clear()
        client.send(message)
        _await(client, message, result, take)
    return result


def _await(client: CamClient, message: Message, result: JobResult, take) -> None:
    """Wait for the reply the protocol gives to ``message`` (if it gives one)."""
    if isinstance(message, Auto):
        wanted, what = (lambda line: line == "A"), "switching to auto mode"
    elif isinstance(message, Home):
        wanted, what = (lambda line: line == "H"), "homing"
    elif isinstance(message, EndOperation):
        wanted, what = (lambda line: parse_position(line) is not None), "ending the operation"
    else:
        return
    while True:
        line = client.read_line(max(client.timeout_s, ANSWER_TIMEOUT_S))
        take(line, what)
        if wanted(line):
            break
    if isinstance(message, EndOperation):
        result.positions.append(parse_position(line))
