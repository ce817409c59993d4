"""Send a run's port frames to its outputs and collect what the machine did.

Frames go out in slices of machine time, so a progress bar follows the work, and the run stops
at each pause (a manual tool change, M0, M1, M60) for the operator when an output drives a real
machine. File outputs (``vcd://``, ``parport+record://``) are written under a temporary name and
renamed when complete (:mod:`retrofit.atomic`): an interrupted run leaves no half file.

When the run fails or is stopped (an exception, Ctrl-C, SIGHUP, SIGTERM), every open output gets
``safe_stop()`` first (:mod:`retrofit.failsafe`); a port's recording is then kept, ending with
the byte that stopped the machine (what the port did, up to the stop), the other files removed.
An output paced in real time gets frames a tenth of a second of its time at a time, so a signal
is acted on within that even while the compiled loop writes.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from contextlib import ExitStack
from pathlib import Path

import numpy as np

from ..failsafe import stop_all
from ..frames import PortFrames
from ..outputs import OutputURL, open_output
from ..outputs.sim import SimOutput
from ..runlog import RunLog
from ..sim import SimMachine

#: outputs that write a file named by the URL's target
FILE_SCHEMES = ("vcd", "parport+record")
#: outputs that stand for no real machine: a pause is recorded, nobody is asked
SIMULATED_SCHEMES = ("sim", "vcd", "fpga-sim")
#: ticks per slice of frames handed to the outputs (a progress step)
SLICE_TICKS = 200_000
#: the longest slice of real time an output paced in real time is handed at once (seconds)
PACED_SLICE_S = 0.1


def is_real(url: str) -> bool:
    """Whether ``url`` drives a machine (a pause then waits for the operator)."""
    return OutputURL.parse(url).scheme not in SIMULATED_SCHEMES


def slice_frames(frames: PortFrames, start: int, end: int) -> PortFrames:
    """The frames of ticks ``start`` (included) to ``end`` (excluded)."""
    lo, hi = np.searchsorted(frames.ticks, [start, end])
    return PortFrames(frames.ticks[lo:hi], frames.values[lo:hi], min(end, frames.end_tick))


def staged_url(url: str, stack: ExitStack) -> str:
    """``url`` with its file (vcd://, parport+record://) written through a staged temporary name."""
    from ..atomic import staged
    parsed = OutputURL.parse(url)
    if parsed.scheme not in FILE_SCHEMES or not parsed.target:
        return url
    # a port's recording is kept when the run stops early: it ends with the safe byte
    tmp = stack.enter_context(staged(Path(parsed.target), keep_on_error=parsed.scheme == "parport+record"))
    return url.replace(parsed.target, str(tmp), 1)


def deliver(log: RunLog, urls: Sequence[str], pauses: Sequence[tuple[int, str]] = (),
            wait: Callable[[str], None] | None = None,
            progress: Callable[[int], None] | None = None, plan=None) -> SimMachine:
    """Write ``log.frames`` to every output in ``urls``; return the simulated machine's state.

    ``pauses`` are (tick, words): with a real output among ``urls``, ``wait(words)`` is called
    when the frames before the tick are out. ``progress(ticks)`` is told how far the frames are.
    The report needs a machine that saw the frames: the ``sim://`` output when one was asked for,
    otherwise a simulator fed alongside (its carriage then shows what the frames command).
    ``plan``: the plan that made the frames, for an output that asks for it (``hand_plan``).
    """
    from ..outputs.deliver import hand_plan
    with ExitStack() as files:
        staged_urls = [staged_url(url, files) for url in urls]
        outputs = [open_output(url, log.machine) for url in staged_urls]
        hand_plan(outputs, plan)
        for out in outputs:
            if isinstance(out, SimOutput):
                out.start_steps = log.start_steps
        stops = sorted(pauses) if wait is not None and any(is_real(u) for u in urls) else []
        opened = []
        try:
            for out in outputs:
                out.open()
                opened.append(out)
            _write_slices(log.frames, outputs, stops, wait, progress, slice_ticks(outputs))
        except BaseException:
            stop_all(opened)                # the machine stops before anything else
            for out in opened:              # their files are discarded: a failing close adds nothing
                try:
                    out.close()
                except Exception:
                    pass
            raise
        for out in opened:
            out.close()
        sim = next((seen["sim"] for seen in (out.observe() for out in outputs)
                    if seen and "sim" in seen), None)
    if sim is None:
        sim = SimMachine(log.machine, log.start_steps)
        sim.feed(log.frames)
    return sim


def slice_ticks(outputs) -> int:
    """Ticks per slice: :data:`SLICE_TICKS`, fewer for an output paced in real time (at most
    :data:`PACED_SLICE_S` of its time: a signal is acted on between slices)."""
    paced = [out.tick_ns for out in outputs if getattr(out, "opts", {}).get("paced") and hasattr(out, "tick_ns")]
    return min([SLICE_TICKS] + [max(1, round(PACED_SLICE_S * 1e9 / tick_ns)) for tick_ns in paced])


def _write_slices(frames: PortFrames, outputs, stops, wait, progress, step: int = SLICE_TICKS) -> None:
    end = int(frames.end_tick)
    bounds = sorted({*range(0, end, step), *(t for t, _ in stops if 0 < t < end), end})
    says = {}
    for tick, words in stops:
        says.setdefault(min(max(tick, 0), end), []).append(words)
    start = 0
    for bound in bounds:
        if bound > start:
            part = slice_frames(frames, start, bound)
            for out in outputs:
                out.write(part)
            start = bound
        for words in says.pop(bound, []):
            wait(words)
        if progress is not None:
            progress(start)
