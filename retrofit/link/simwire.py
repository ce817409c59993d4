"""A simulated serial line for the link: seeded byte faults, and both endpoints on a fake clock.

``FaultyWire`` drops, flips, inserts and duplicates like a noisy cable; ``LinkBench`` joins a
HostEndpoint and a DeviceEndpoint through two wires, delivers bytes in random-sized chunks, and
advances simulated time by the bytes' transfer time and, when the line is quiet, to the host's
next deadline. Used by the tests and by labs that study the protocol under faults.
"""

from __future__ import annotations

import math
import random
from collections.abc import Callable
from dataclasses import dataclass

from ..errors import LinkError
from .device import DeviceEndpoint, SessionNumbers
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

    ``duplicate`` repeats a whole write (a frame, as an endpoint writes them); the copy arrives
    right after it, or with ``late`` > 0 after up to that many later writes (a stale copy). The
    byte faults then apply to every copy. Bytes between faults are skipped over in one step (the
    gap to the next fault is drawn from its geometric law), so a clean stretch costs one draw.
    """

    def __init__(self, rng: random.Random, *, flip: float = 0.0, drop: float = 0.0,
                 insert: float = 0.0, duplicate: float = 0.0, late: int = 0):
        self.rng = rng
        self.flip, self.drop, self.insert, self.duplicate = flip, drop, insert, duplicate
        self.late = late
        self.stats = WireStats()
        self._pending: list[list] = []          # [writes still to wait, bytes] of late copies
        # a byte is "hit" when it is dropped, flipped or followed by an inserted byte
        self._hit = 1.0 - (1.0 - drop - flip) * (1.0 - insert)
        self._log_miss = math.log(1.0 - self._hit) if 0 < self._hit < 1 else 0.0
        keep = 1.0 - drop - flip
        self._outcomes = [((kind, extra), p * (insert if extra else 1.0 - insert))
                          for kind, p in (("drop", drop), ("flip", flip), ("keep", keep))
                          for extra in (False, True) if kind != "keep" or extra]

    def carry(self, data: bytes) -> bytes:
        """The bytes that arrive at the far end when ``data`` is written."""
        copies = [data]
        if self.duplicate and self.rng.random() < self.duplicate:
            self.stats.duplicated += 1
            delay = self.rng.randint(0, self.late) if self.late else 0
            if delay:
                self._pending.append([delay, data])
            else:
                copies.append(data)
        for item in self._pending:
            item[0] -= 1
        copies += [d for n, d in self._pending if n <= 0]
        self._pending = [item for item in self._pending if item[0] > 0]
        return b"".join(self._damage(c) for c in copies)

    def _damage(self, data: bytes) -> bytes:
        self.stats.bytes += len(data)
        if self._hit <= 0:
            return data
        rng, out, i, n = self.rng, bytearray(), 0, len(data)
        while True:
            gap = 0 if self._hit >= 1 else int(math.log(1.0 - rng.random()) / self._log_miss)
            if i + gap >= n:
                return bytes(out + data[i:])
            out += data[i:i + gap]
            i += gap
            self._fault(data[i], out)
            i += 1

    def _fault(self, byte: int, out: bytearray) -> None:
        """One hit byte: dropped, or flipped, and/or followed by an inserted byte."""
        rng, r = self.rng, self.rng.random() * self._hit
        for outcome, weight in self._outcomes:      # the byte's faults, given that it was hit
            if r < weight:
                break
            r -= weight
        kind, extra = outcome
        if kind == "drop":
            self.stats.dropped += 1
        else:
            if kind == "flip":
                self.stats.flipped += 1
                byte ^= 1 << rng.getrandbits(3)
            out.append(byte)
        if extra:
            self.stats.inserted += 1
            out.append(rng.getrandbits(8))


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
        if host.nonce_is_random:
            # a seeded bench runs the same way every time: the host's SYNC bytes (and so
            # where the wires' faults land) come from the bench's generator, not the OS
            host.nonce, host.nonce_is_random = self.rng.getrandbits(32), False
        if getattr(device.sessions, "random_start", False):     # and so do the device's
            device.sessions = SessionNumbers(self.rng.getrandbits(32))
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
