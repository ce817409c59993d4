"""What a steered run hands on as it goes: its port frames to the real outputs, a chunk at a time,
and the programmed feed in force at each command (the base of the operator's feed override)."""

from __future__ import annotations

import numpy as np

from ..commands import Command, PFdr
from ..frames import PortFrames


def send_frames(frames: PortFrames, sent_tick: int, outputs) -> int:
    """The frames of ``frames`` from ``sent_tick`` on, to every output; the tick sent up to."""
    lo = max(int(np.searchsorted(frames.ticks, sent_tick, side="right")) - 1, 0)
    chunk = PortFrames(np.maximum(frames.ticks[lo:], sent_tick), frames.values[lo:], frames.end_tick)
    for out in outputs:
        out.write(chunk)
    return frames.end_tick


def programmed_feeds(commands: list[Command], default: float) -> list[float]:
    """The programmed feed (PFDR, mm/min) in force at each command."""
    feeds, feed = [], default
    for cmd in commands:
        if isinstance(cmd, PFdr):
            feed = cmd.feed
        feeds.append(feed)
    return feeds
