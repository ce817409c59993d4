"""The firmware in simavr in lockstep with a host written in Python: the AVR's time is the only clock.

The harness runs with ``--pipe``: it stops at the cycle it was granted, takes the host's bytes for
the USART and the next grant from its stdin, and reports every byte the firmware sent, stamped
with its cycle. A host polled on the AVR's time (``now = cycle / F_CPU``) therefore sees the
board as it would on the wire, with no wall clock anywhere: a run is the same on a loaded machine
as on an idle one, and runs as fast as simavr does.

    >>> board = Lockstep(elf, machine).start()                  # doctest: +SKIP
    >>> board.write(frame); answer = board.advance(16_000)      # doctest: +SKIP
    >>> log = board.stop()                                      # doctest: +SKIP
"""

from __future__ import annotations

import subprocess
from pathlib import Path

from ..machine.config import Machine
from .sim import F_CPU, Harness, HarnessError, HarnessLog, _die_with_parent


class Lockstep:
    """One harness run in lockstep: :meth:`write` bytes, :meth:`advance` the AVR, :meth:`stop`."""

    def __init__(self, elf: Path, machine: Machine, *, port_log: bool = True, **harness_options):
        """``harness_options``: those of :class:`retrofit.firmware.sim.Harness` (wiring, spindle,
        start steps...), except ``listen``, ``script`` and ``speed``; ``port_log=False``: the log
        holds no pin changes (a long run checks its steps on :attr:`sent`'s counts instead)."""
        self.harness = Harness(elf, machine, **harness_options)
        self.harness.args += ["--pipe"] + ([] if port_log else ["--no-port-log"])
        self.cycle = 0
        self._pending = bytearray()
        #: (cycle, byte, the harness's step count of each axis then) of every byte the firmware
        #: sent; the counts in the firmware's axis order (sim.firmware_axes)
        self.sent: list[tuple[int, int, tuple[int, ...]]] = []

    @property
    def now(self) -> float:
        """The AVR's time, seconds."""
        return self.cycle / F_CPU

    def start(self) -> Lockstep:
        self.harness.proc = subprocess.Popen(
            self.harness.args, stdin=subprocess.PIPE, stdout=subprocess.PIPE,
            stderr=subprocess.DEVNULL, text=True, bufsize=1, preexec_fn=_die_with_parent)
        self._read_until_granted()
        return self

    def write(self, data: bytes) -> None:
        """Bytes for the USART, delivered at the start of the next :meth:`advance`."""
        self._pending += data

    sendall = write                       # so that a line filter written for a socket takes it

    def advance(self, cycles: int, early: bool = False) -> bytes:
        """Run ``cycles`` more AVR cycles (``early``: or until just after the firmware sends a
        frame's flag, 0x7E); the bytes the firmware sent meanwhile."""
        proc = self.harness.proc
        out = f"B {self._pending.hex()}\n" if self._pending else ""
        self._pending.clear()
        try:
            proc.stdin.write(out + f"{'W' if early else 'R'} {self.cycle + max(1, int(cycles))}\n")
            proc.stdin.flush()
        except BrokenPipeError:
            raise HarnessError(f"the harness ended at cycle {self.cycle}") from None
        return self._read_until_granted()

    def _read_until_granted(self) -> bytes:
        got = bytearray()
        for line in self.harness.proc.stdout:
            if line.startswith("U "):
                _, cycle, byte, *counts = line.split()
                got.append(int(byte, 16))
                self.sent.append((int(cycle), got[-1], tuple(map(int, counts))))
            elif line.startswith("A "):
                self.cycle = int(line.split()[1])
                return bytes(got)
        raise HarnessError(f"the harness ended at cycle {self.cycle} without reaching its grant")

    def stop(self) -> HarnessLog:
        """End the run (EOF on its stdin) and read its log."""
        return self.harness.stop(60)
