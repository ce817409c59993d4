"""parport+record://FILE[?tick_us=US&every_tick=1&force=1&paced=0&engine=E] — the parport loop, recorded.

URL grammar: ``parport+record://FILE`` (relative path) or ``parport+record:///abs/FILE``, with the
options of ``parport://``. The very same paced loop runs as for a real port; the bytes go to a
recording instead of the data register.

File format: raw bytes, no header, one byte per tick: byte ``i`` is the port byte (DB25 pins
2..9 = bits 0..7) during tick ``i``, from tick 0 to the run's end tick - 1. When the loop writes
only the change ticks, the recorder holds the last byte over the ticks between, as the port's
latch does; with ``every_tick=1`` every byte is one write of the loop (``filled`` stays 0).
Read it back with :func:`load_recording`.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from ..errors import OutputError
from ..frames import PortFrames
from .parport import ParportOutput


class RecordPort:
    """Stands in for the port: keeps every tick's byte in tick order; writes the file on close.

    ``status_register`` and ``control_register`` are raw register values, as ppdev reads and
    writes them, so the pin inversions can be checked without hardware.
    """

    def __init__(self, path: Path):
        self.path = path
        self.buffer = bytearray()
        self.held = 0                  # the byte on the "port" (0 after opening)
        self.writes = 0                # bytes written by the loop
        self.filled = 0                # ticks held over between writes
        self.status_register = 0
        self.control_register = 0

    memory = True                      # a memory target: the compiled writer may hand bytes over after a chunk

    @property
    def next_tick(self) -> int:
        return len(self.buffer)

    def write(self, tick: int, value: int) -> None:
        if tick < self.next_tick:
            raise OutputError(f"{self.path}: write for tick {tick} after tick {self.next_tick - 1}; "
                              "the port takes bytes in tick order only")
        gap = tick - self.next_tick
        if gap:
            self.buffer += bytes((self.held,)) * gap
            self.filled += gap
        self.buffer.append(value)
        self.held = value
        self.writes += 1

    def hold_until(self, end_tick: int) -> None:
        """Hold the last byte to the end of the run."""
        gap = end_tick - self.next_tick
        if gap > 0:
            self.buffer += bytes((self.held,)) * gap
            self.filled += gap

    def frob_control(self, mask: int, bits: int) -> None:
        self.control_register = (self.control_register & ~mask) ^ bits

    def read_status(self) -> int:
        return self.status_register

    def discard(self) -> None:
        """The run never started: leave no file behind."""
        self.buffer.clear()

    def close(self) -> None:
        try:                           # never through a link planted at the name (O_NOFOLLOW)
            fd = os.open(self.path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC | os.O_NOFOLLOW, 0o666)
            with os.fdopen(fd, "wb") as fh:
                fh.write(bytes(self.buffer))
        except OSError as exc:
            raise OutputError(f"cannot write the recording {self.path}: {exc.strerror or exc}") from None


class RecordOutput(ParportOutput):
    """parport+record://FILE[?tick_us=US&every_tick=1&force=1&paced=0] — parport:// recorded to FILE."""

    scheme = "parport+record"
    grammar = "parport+record://FILE[?tick_us=US&every_tick=1&force=1&paced=0&engine=auto|compiled|python]"
    summary = "the parport:// loop writing every tick's byte to FILE (raw, one byte per tick) instead of a port"
    default_device = ""

    def _open_port(self) -> RecordPort:
        if not self.url.target:
            raise OutputError(f"{self.url.text}: a file is needed; expected {self.grammar}")
        path = Path(self.url.target)
        if not path.parent.is_dir():
            raise OutputError(f"{self.url.text}: folder {path.parent} does not exist")
        return RecordPort(path)

    @property
    def recording(self) -> RecordPort:
        return self.port


def load_recording(path: str | Path) -> PortFrames:
    """The port frames of a recording (one byte per tick, see the module docstring)."""
    try:
        data = np.fromfile(Path(path), dtype=np.uint8)
    except OSError as exc:
        raise OutputError(f"cannot read the recording {path}: {exc.strerror or exc}") from None
    return PortFrames.from_per_tick(data)
