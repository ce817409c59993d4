"""A simulated serial line for the link: seeded byte faults, and both endpoints on a fake clock.

``FaultyWire`` drops, flips, inserts and duplicates like a noisy cable; ``LinkBench`` joins a
HostEndpoint and a DeviceEndpoint through two wires, delivers bytes in random-sized chunks, and
advances simulated time by the bytes' transfer time and, when the line is quiet, to the host's
next deadline. Used by the tests and by labs that study the protocol under faults.
"""

from __future__ import annotations

import random
from dataclasses import dataclass
from typing import Callable

from ..errors import LinkError
from .device import DeviceEndpoint
from .host import HostEndpoint


@dataclass
class WireStats:
    """What a wire did to the bytes it carried."""

    bytes: int = 0
    dropped: int = 0
    flipped: int = 0
    inserted: int = 0
    duplicated: int = 0       # writes (frames) sent twice


class FaultyWire:
    """One direction of a serial line with independent per-byte faults (probabilities 0..1).

    ``duplicate`` repeats a whole write (a frame, as an endpoint writes them) before the byte
    faults apply to each copy.
    """

    def __init__(self, rng: random.Random, *, flip: float = 0.0, drop: float = 0.0,
                 insert: float = 0.0, duplicate: float = 0.0):
        self.rng = rng
        self.flip, self.drop, self.insert, self.duplicate = flip, drop, insert, duplicate
        self.stats = WireStats()

    def carry(self, data: bytes) -> bytes:
        """The bytes that arrive at the far end when ``data`` is written."""
        if self.duplicate and self.rng.random() < self.duplicate:
            self.stats.duplicated += 1
            data = data + data
        rng, out = self.rng, bytearray()
        for byte in data:
            self.stats.bytes += 1
            r = rng.random()
            if r < self.drop:
                self.stats.dropped += 1
                continue
            if r < self.drop + self.flip:
                self.stats.flipped += 1
                byte ^= 1 << rng.randrange(8)
            out.append(byte)
            if self.insert and rng.random() < self.insert:
                self.stats.inserted += 1
                out.append(rng.randrange(256))
        return bytes(out)


class LinkBench:
    """A host and a device joined by two wires (None: a perfect wire) on a simulated clock.

    ``on_time(now)`` is called before the device sees bytes, so a controller model behind the
    device can advance (finish moves, free queue slots) in the same simulated time.
    """

    def __init__(self, host: HostEndpoint, device: DeviceEndpoint, *,
                 to_device: FaultyWire | None = None, to_host: FaultyWire | None = None,
                 rng: random.Random | None = None, byte_time_s: float = 10 / 115200,
                 on_time: Callable[[float], None] | None = None):
        self.host, self.device = host, device
        self.to_device, self.to_host = to_device, to_host
        self.rng = rng or random.Random(0)
        self.byte_time_s = byte_time_s
        self.on_time = on_time or (lambda now: None)
        self.now = 0.0

    def step(self) -> bool:
        """Move one batch each way and poll the host; False if the line was quiet."""
        out = self.host.take_output()
        if out:
            self.now += len(out) * self.byte_time_s
            self.on_time(self.now)
            for piece in self._chunks(self.to_device.carry(out) if self.to_device else out):
                self.device.receive(piece)
        back = self.device.take_output()
        if back:
            self.now += len(back) * self.byte_time_s
            for piece in self._chunks(self.to_host.carry(back) if self.to_host else back):
                self.host.receive(piece, self.now)
        if not out and not back:
            deadline = self.host.next_deadline()
            if deadline is not None and deadline > self.now:
                self.now = deadline
                self.on_time(self.now)
        self.host.poll(self.now)
        return bool(out or back)

    def run(self, max_steps: int = 1_000_000) -> None:
        """Step until the host is idle (every command answered or failed)."""
        for _ in range(max_steps):
            if self.host.idle:
                return
            self.step()
        raise LinkError(f"simulated link: host still busy after {max_steps} steps "
                        f"({self.now:.3f} s simulated); raise max_steps or check the wires")

    def _chunks(self, data: bytes):
        i = 0
        while i < len(data):
            n = self.rng.randint(1, 16)
            yield data[i:i + n]
            i += n
