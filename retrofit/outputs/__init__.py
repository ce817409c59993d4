"""Outputs chosen by URL scheme; each backend is imported only when it is asked for.

``open_output("sim://", machine)`` gives the built-in simulator; hardware backends (parallel port,
serial) import pyparallel / pyserial lazily, so ``sim://`` never needs them.
"""

from __future__ import annotations

from importlib import import_module

from ..errors import OutputError
from ..machine.config import Machine
from .base import Output, OutputURL

#: scheme -> "module:Class", imported on first use
REGISTRY: dict[str, str] = {
    "sim": "retrofit.outputs.sim:SimOutput",
    "parport": "retrofit.outputs.parport:ParportOutput",
    "parport+record": "retrofit.outputs.record:RecordOutput",
    "vcd": "retrofit.outputs.vcd:VcdOutput", "fpga-sim": "retrofit.outputs.fpga_sim:FpgaSimOutput",
    "serial": "retrofit.outputs.serial:SerialOutput", "serial+socket": "retrofit.outputs.serial:SerialSocketOutput",
}


def known_schemes() -> list[str]:
    return sorted(REGISTRY)


def output_class(scheme: str) -> type[Output]:
    """The backend class for a scheme (imports its module)."""
    try:
        where = REGISTRY[scheme]
    except KeyError:
        raise OutputError(f"unknown output '{scheme}://'; known: {', '.join(known_schemes())}") from None
    module, _, name = where.partition(":")
    return getattr(import_module(module), name)


def open_output(url: str, machine: Machine) -> Output:
    """Create the output for ``url`` (not yet opened; use it as a context manager)."""
    parsed = OutputURL.parse(url)
    return output_class(parsed.scheme)(parsed, machine)


__all__ = ["Output", "OutputURL", "REGISTRY", "known_schemes", "open_output", "output_class"]
