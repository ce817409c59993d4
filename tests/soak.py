"""How much of a long random run the slow stage draws: a share of it in CI, all of it on demand.

A soak test (thousands of random programs, minutes of simulated board time) is split into parts
of its full set. CI's slow stage runs ``ci`` of the ``full`` parts, chosen from the offset
``RETROFIT_SOAK_OFFSET`` (.ci/run sets it to the run's printed seed, so successive CI runs walk
through the whole set and a failing part can be drawn again); ``RETROFIT_SOAK=1`` runs every part.
"""
from __future__ import annotations

import os


def parts(full: int, ci: int) -> list[int]:
    """The parts of ``range(full)`` this run draws: all with RETROFIT_SOAK=1, else ``ci`` of them
    in a row (wrapping) from the offset, in order."""
    if os.environ.get("RETROFIT_SOAK") == "1" or ci >= full:
        return list(range(full))
    start = int(os.environ.get("RETROFIT_SOAK_OFFSET", "0")) * ci % full
    return sorted((start + k) % full for k in range(ci))
