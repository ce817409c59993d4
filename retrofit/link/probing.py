"""A probing move over the link: send PROB, wait until it has ended, read PROBED and the position.

The device runs the move (docs/protocol.md, PROB): it stops at the first step after which its
probe input is in the wanted state, or at the end of the line. The host then asks RDST whether
it stopped on the probe (``StatusFlags.PROBED``) and RDPS where::

    with HostLink.open("/dev/ttyUSB0", machine) as link:
        probed, steps = probe_over_link(link, parse_command("PROB Z-40"))

This waits on the device and so reads the wall clock (``clock``) and sleeps (``sleep``); both
are injected, so a test runs it on a fake clock.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import NamedTuple

from ..commands import Prob, Rdps, Rdst
from ..errors import MotionError
from ..machine.config import Machine
from .replies import Position, Status, StatusFlags, flag_names
from .transport import HostLink

#: flags that mean the device gave up (the probing move did not end normally)
_FAILED = StatusFlags.ERROR | StatusFlags.STOPPED
#: flags that mean the device still has work
_BUSY = StatusFlags.MOVING | StatusFlags.DWELLING


class ProbeResult(NamedTuple):
    """Whether the move stopped on the probe, and where the axes are, in steps."""

    probed: bool
    steps: dict[str, int]

    def mm(self, machine: Machine) -> dict[str, float]:
        """The position in mm through each axis' steps_per_mm."""
        return {name: machine.axis(name).to_mm(s) for name, s in self.steps.items()}


def probe_over_link(link: HostLink, cmd: Prob, *, wait_s: float = 0.0, poll_s: float = 0.02,
                    clock: Callable[[], float] = time.monotonic,
                    sleep: Callable[[float], None] = time.sleep) -> ProbeResult:
    """Run ``cmd`` on the device at the far end of ``link``; (probed, position steps per axis).

    PROB goes on the queued channel, after whatever was sent before it; then RDST every
    ``poll_s`` until nothing moves, dwells or waits in the queue (at most ``wait_s``; 0 waits
    as long as it takes), then RDPS. Raises LinkError when the device refuses PROB (ERR 6: it
    has no probe input, or it is in ERROR or STOPPED) and MotionError when it reports ERROR or
    STOPPED after taking it, or is still busy after ``wait_s``.
    """
    if not isinstance(cmd, Prob):
        raise TypeError(f"probe_over_link takes a PROB command, not {cmd}")
    if wait_s < 0 or poll_s <= 0:
        raise ValueError(f"probe_over_link: wait_s = {wait_s:g} must be >= 0 and poll_s = "
                         f"{poll_s:g} > 0")
    link.request(cmd, urgent=False)
    status = _wait_until_ended(link, cmd, clock() + wait_s if wait_s else None, poll_s, clock,
                               sleep)
    position = link.request(Rdps())
    if not isinstance(position, Position):
        raise MotionError(f"{cmd} over {link.name}: RDPS answered {position}, not a position")
    return ProbeResult(bool(status.flags & StatusFlags.PROBED), dict(position.steps))


def _wait_until_ended(link: HostLink, cmd: Prob, deadline: float | None, poll_s: float,
                      clock: Callable[[], float], sleep: Callable[[float], None]) -> Status:
    """RDST until the device has no move, dwell or queued command left; its last status."""
    while True:
        status = link.request(Rdst())
        if not isinstance(status, Status):
            raise MotionError(f"{cmd} over {link.name}: RDST answered {status}, not a status")
        names = ", ".join(flag_names(status.flags)) or "no flags"
        if status.flags & _FAILED:
            raise MotionError(f"{cmd} over {link.name}: the device reports "
                              f"{' and '.join(flag_names(status.flags & _FAILED))} (status {names}); "
                              f"the probing move did not end normally; INIT clears it")
        if status.queued == 0 and not status.flags & _BUSY:
            return status
        if deadline is not None and clock() >= deadline:
            raise MotionError(f"{cmd} over {link.name}: still busy when the wait ran out "
                              f"(status {names}, {status.queued} queued); give a longer wait_s")
        sleep(poll_s)
