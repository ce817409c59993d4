"""Send a run's port frames to its outputs and collect what the machine did."""

from __future__ import annotations

from .outputs import open_output
from .outputs.sim import SimOutput
from .runlog import RunLog
from .sim import SimMachine


def deliver(log: RunLog, urls: list[str]) -> SimMachine:
    """Write ``log.frames`` to every output in ``urls``; return the simulated machine's state.

    The report needs a machine that saw the frames: the ``sim://`` output when one was asked for,
    otherwise a simulator fed alongside (its carriage then shows what the frames command).
    """
    outputs = [open_output(url, log.machine) for url in urls]
    sim = None
    for out in outputs:
        if isinstance(out, SimOutput):
            out.start_steps = log.start_steps
    try:
        for out in outputs:
            out.open()
        for out in outputs:
            out.write(log.frames)
    finally:
        for out in outputs:
            out.close()
    for out in outputs:
        seen = out.observe()
        if seen and "sim" in seen:
            sim = seen["sim"]
            break
    if sim is None:
        sim = SimMachine(log.machine, log.start_steps)
        sim.feed(log.frames)
    return sim
