"""A test hook: hold a command at one named moment until a signal ends it (``RETROFIT_HOLD_AT``).

The interruption tests stop ``retrofit run`` at exact points of its work (part way through, with a
file's temporary copy empty, drawn or whole, after the report) on any machine at any load: they
set ``RETROFIT_HOLD_AT`` to a moment's name, wait for the line ``retrofit: held at NAME`` on
standard error, and send their signal, which ends the hold as it would end the work. Without
the variable (always, outside the tests) each point costs one comparison with None.

Moments:

- ``progress N``: the first report of the run's progress (:mod:`retrofit.run.progress`, whether or
  not a bar is shown) at N or more of its 1000 units;
- ``open NAME``: the temporary file beside the output file NAME is made, still empty;
- ``draw NAME``: the plot NAME is drawn, its bytes not yet written;
- ``wrote NAME``: the temporary file is complete and flushed, not yet renamed;
- ``renamed NAME``: NAME is in place.

The hold happens once, and ends by itself after :data:`CEILING_S` if no signal comes.
"""

from __future__ import annotations

import os
import sys
import time

#: the moment to hold at (None: never)
AT: str | None = os.environ.get("RETROFIT_HOLD_AT") or None
#: the progress units to hold at, when the moment is ``progress N``
UNITS: int | None = int(AT.split()[1]) if AT and AT.startswith("progress ") else None
#: a hold no signal ends lasts this long, then the command goes on
CEILING_S = 300


def hold(moment: str) -> None:
    """Hold here if ``moment`` is the one named (once)."""
    global AT, UNITS
    if moment != AT:
        return
    AT = UNITS = None
    sys.stderr.write(f"retrofit: held at {moment}\n")       # one write: the line whole
    sys.stderr.flush()
    time.sleep(CEILING_S)               # a signal's handler raises out of the sleep


def progress(units: int) -> None:
    """The run has reached ``units`` of 1000 (called only while :data:`UNITS` is set)."""
    if UNITS is not None and units >= UNITS:
        hold(AT)


def on_draw(fig, name: str) -> None:
    """Hold at ``draw NAME`` when the figure saved as NAME has been drawn."""
    if AT == f"draw {name}":
        fig.canvas.mpl_connect("draw_event", lambda event: hold(f"draw {name}"))
