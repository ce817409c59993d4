"""Positions rounded to 1 pm: float noise of sums and unit conversions gone, far below a step."""

from __future__ import annotations

from typing import Any

import numpy as np

#: positions and feeds are rounded to this many decimals of a mm (1 pm): float noise of G91 sums
#: and inch conversion disappears, far below any machine's step
DECIMALS = 9


def clean_mm(value: float) -> float:
    """``value`` rounded to :data:`DECIMALS`, with -0.0 made 0.0."""
    return round(value, DECIMALS) + 0.0


def clean_mm_list(values: np.ndarray[Any, np.dtype[np.float64]]) -> list[float]:
    """:func:`clean_mm` of every value of a float64 array, float for float, at array speed.

    ``rint(v * 10**DECIMALS) / 10**DECIMALS`` is Python's correctly rounded ``round`` unless the
    product's own rounding could have crossed a half (the exact product within two units in the
    last place of a half) or the product is too large to hold a fraction; those few values go
    through ``round`` itself.
    """
    scale = 10.0 ** DECIMALS
    scaled = values * scale
    out = np.rint(scaled) / scale + 0.0
    size = np.abs(scaled)
    doubtful = ~(size < 2.0 ** 52) | (np.abs(size - np.floor(size) - 0.5) <= 2.0 * np.spacing(size))
    for k in np.flatnonzero(doubtful).tolist():
        out[k] = round(float(values[k]), DECIMALS) + 0.0
    cleaned: list[float] = out.tolist()
    return cleaned
