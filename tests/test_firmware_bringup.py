"""Bring-up: the host waits out the bootloader of a board whose port it has just opened."""

from __future__ import annotations

import pytest

from retrofit.commands import FMov
from retrofit.config import load_machine
from retrofit.errors import OutputError
from retrofit.outputs import open_output
from tests.conformance.targets import SimavrTarget, build_firmware, missing_tools

pytestmark = pytest.mark.skipif(bool(missing_tools()), reason="the firmware needs avr-gcc, make "
                                "and libsimavr: apt-get install gcc-avr avr-libc libsimavr-dev")


@pytest.fixture(scope="module")
def board():
    """The firmware in simavr at the board's pace, deaf for its first 1.5 s like a Mega."""
    build_firmware()
    with SimavrTarget("mitic-lathe", "--boot-ms", "1500") as target:
        yield target


def test_the_host_waits_out_the_bootloader_then_runs_the_program(board):
    machine = load_machine("mitic-lathe")
    out = open_output(f"{board.output_url}?boot_ms=4000", machine)
    out.open()
    try:
        remote = out.send_program([FMov((("X", 0.5),))])
    finally:
        out.close()
    assert remote["position_steps"] == {"X": 50, "Z": 0}


def test_without_the_wait_the_bootloader_swallows_the_first_frames():
    build_firmware()
    machine = load_machine("mitic-lathe")
    with SimavrTarget("mitic-lathe", "--boot-ms", "3000") as target:
        out = open_output(f"{target.output_url}?boot_ms=300", machine)
        with pytest.raises(OutputError, match="no answer to SYNC within 0.3 s"):
            out.open()
