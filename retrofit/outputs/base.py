"""The output contract: open, write port frames, close; options parsed once from the URL.

An output is chosen by URL (``sim://``, ``vcd://out.vcd``, ...). Each backend states its URL
grammar first in its docstring and declares its typed query options in ``options``; an unknown
option is refused with the accepted form repeated.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import Any, ClassVar
from urllib.parse import parse_qsl, urlsplit

from ..errors import OutputError
from ..frames import PortFrames
from ..machine.config import Machine


@dataclass(frozen=True)
class OutputURL:
    """A parsed output URL: ``scheme://target?key=value&...``."""

    text: str
    scheme: str
    target: str
    query: dict[str, str]

    @classmethod
    def parse(cls, text: str) -> OutputURL:
        if "://" not in text:
            raise OutputError(f"output {text!r} is not a URL; expected scheme://..., e.g. sim:// or vcd://out.vcd")
        parts = urlsplit(text)
        target = (parts.netloc + parts.path) if parts.netloc else parts.path
        return cls(text, parts.scheme.lower(), target, dict(parse_qsl(parts.query, keep_blank_values=True)))


class Output(ABC):
    """Base of every output. Subclasses set ``scheme``, ``grammar`` and ``options``.

    Contract: ``open()`` before the first ``write()``; ``write(frames)`` takes port frames in
    tick order (it may be called several times, each chunk continuing the last); ``close()``
    finishes and releases everything, and is safe to call twice; ``safe_stop()`` puts the machine
    side in its safe state at once (drivers off, every pin at rest) and leaves the output to be
    closed; ``abort()`` does that and closes, without finishing what was scheduled. Use as a
    context manager (an exception in the block calls ``safe_stop()`` before ``close()``).
    """

    scheme: ClassVar[str] = ""
    grammar: ClassVar[str] = ""
    summary: ClassVar[str] = ""
    #: typed query options: name -> (type, default)
    options: ClassVar[dict[str, tuple[type, Any]]] = {}

    def __init__(self, url: OutputURL, machine: Machine):
        self.url = url
        self.machine = machine
        self.opts = self._parse_options(url)
        self.is_open = False

    def _parse_options(self, url: OutputURL) -> dict[str, Any]:
        opts = {name: default for name, (_, default) in self.options.items()}
        for key, raw in url.query.items():
            if key not in self.options:
                known = ", ".join(self.options) or "none"
                raise OutputError(f"{url.text}: unknown option {key!r}; expected {self.grammar} "
                                  f"(options: {known})")
            kind = self.options[key][0]
            try:
                opts[key] = _convert(kind, raw)
            except ValueError:
                raise OutputError(f"{url.text}: option {key}={raw!r} must be {kind.__name__}; "
                                  f"expected {self.grammar}") from None
        return opts

    def open(self) -> None:
        self.is_open = True

    @abstractmethod
    def write(self, frames: PortFrames) -> None:
        """Take the next chunk of port frames."""

    def close(self) -> None:
        self.is_open = False

    def safe_stop(self) -> None:
        """The machine side safe at once: drivers' enable off, every pin at rest, flushed.

        Called when a run fails or is told to end, before ``close()`` and before anything else
        (reports, files). The base has nothing that moves a machine; outputs that do override it.
        """

    def abort(self) -> None:
        """The machine side safe at once (drivers off, every pin at rest), then closed, without
        finishing what was scheduled: what a fault or a signal calls. Safe on a closed output."""
        try:
            if self.is_open:
                self.safe_stop()
        finally:
            self.close()

    def wants_plan(self) -> bool:
        """Whether this output needs the run's plan (its moves, hence its step requests) besides
        the port frames. The run then hands it over before ``open()``, in one place
        (``outputs.deliver.hand_plan``); the base, and every output that only takes frames, says no."""
        return False

    def take_plan(self, plan) -> None:
        """The run's plan (``motion.plan.Plan``), before ``open()``, when ``wants_plan()``; None
        when the run has none (the circle demo, a run on the 002 controller)."""

    def observe(self) -> dict | None:
        """What this output knows of the machine after the run (the simulator answers; others None)."""
        return None

    def __enter__(self):
        self.open()
        return self

    def __exit__(self, *exc):
        try:
            if exc[0] is not None and self.is_open:
                self.safe_stop()          # an exception in the block: the machine stops first
        finally:
            self.close()
        return False


def _convert(kind: type, raw: str):
    if kind is bool:
        if raw.lower() in ("1", "true", "yes", "on", ""):
            return True
        if raw.lower() in ("0", "false", "no", "off"):
            return False
        raise ValueError(raw)
    return kind(raw)
