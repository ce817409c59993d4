"""How the labs draw: matplotlib on the Agg backend when there is no display, PNG files."""

from __future__ import annotations

import os
from pathlib import Path


def pyplot():
    """``matplotlib.pyplot``, drawing to PNG files (the Agg backend) when there is no display."""
    import matplotlib
    if not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")) or os.environ.get("MPLBACKEND") == "Agg":
        matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def save_figure(fig, out_dir: str | Path, name: str) -> Path:
    """Save a figure as ``out_dir/name`` (PNG), close it, and return the path."""
    path = Path(out_dir) / name
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110, bbox_inches="tight")
    pyplot().close(fig)
    return path
