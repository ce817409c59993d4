"""``retrofit run`` of the lathe example on the firmware in simavr (``retrofit firmware sim``),
through serial+socket://, the AVR's time running as fast as simavr goes (--speed 0).

The example is run in three pieces, one a test (each under half a minute), which together make
every move of it: each piece is the example's set-up, a rapid to where the blocks before it left
the tool (with their feed), its blocks, and the example's way back to the safe point.
"""

import json
import re
from pathlib import Path

import pytest

import retrofit
from retrofit.cli import main
from retrofit.machine.config import load_machine

from tests import soak
from tests.conformance.targets import SimavrTarget, build_firmware, missing_tools

pytestmark = pytest.mark.skipif(bool(missing_tools()), reason="the firmware needs avr-gcc, make and "
                                "libsimavr: apt-get install gcc-avr avr-libc binutils-avr "
                                "libsimavr-dev")

EXAMPLE = Path(retrofit.__file__).parent / "examples" / "lathe-profile.ngc"
# the example's blocks (between blank lines): 0 comments, 1 set-up, 2 facing, 3 roughing the 42 mm
# diameter, 4 roughing the 30 mm diameter, 5 the finishing pass, 6 back to the safe point
PIECES = {"facing-and-42mm": (2, 4), "30mm-passes": (4, 5), "finishing": (5, 6)}


def blocks() -> list[str]:
    return EXAMPLE.read_text(encoding="utf-8").strip().split("\n\n")


def _code(text: str) -> str:
    """``text`` without its comments, ``( ... )`` and ``; ...``."""
    return re.sub(r"\(.*?\)|;.*", "", text)


def piece_of_the_example(first: int, end: int) -> str:
    """The program of blocks ``first`` to ``end - 1`` (the example is absolute, G90, throughout, so
    the last X, Z and F written before ``first`` are where the tool is and the feed in force)."""
    every = blocks()
    before = _code("\n".join(every[1:first]))
    last = {letter: re.findall(rf"\b{letter}(-?\d+\.?\d*)", before)[-1:] for letter in "XZF"}
    resume = f"G0 X{last['X'][0]} Z{last['Z'][0]}" + "".join(f"\nF{f}" for f in last["F"])
    return "\n\n".join([every[1], resume, *every[first:end], every[6]]) + "\n"


def report_of(tmp_path, program: Path, output: str, name: str) -> dict:
    path = tmp_path / f"{name}.json"
    assert main(["run", str(program), "--machine", "mitic-lathe", "--output", output,
                 "--progress", "off", "--report", str(path)]) == 0
    return json.loads(path.read_text())


def test_the_pieces_hold_every_block_of_the_example_once():
    every = blocks()
    assert len(every) == 7 and "G91" not in _code(EXAMPLE.read_text(encoding="utf-8"))
    assert [b for first, end in PIECES.values() for b in range(first, end)] == [2, 3, 4, 5]
    assert piece_of_the_example(4, 5).split("\n\n")[1] == "G0 X23 Z2\nF150"     # after the 42 mm pass
    assert piece_of_the_example(5, 6).split("\n\n")[1] == "G0 X21.5 Z2\nF150"   # after the 30 mm passes


@pytest.mark.slow
@pytest.mark.parametrize("piece", [list(PIECES)[k] for k in soak.parts(len(PIECES), 1)])   # CI: 1 of 3
def test_the_lathe_example_on_the_firmware_ends_where_it_ends_on_sim(piece, tmp_path):
    machine = load_machine("mitic-lathe")
    program = tmp_path / f"{piece}.ngc"
    program.write_text(piece_of_the_example(*PIECES[piece]), encoding="utf-8")
    local = report_of(tmp_path, program, "sim://", "local")
    build_firmware()
    with SimavrTarget("mitic-lathe", "--speed", "0") as fw:
        remote = report_of(tmp_path, program, f"{fw.output_url}?wait_s=900", "remote")
    part = remote["remote"][0]
    expected = {name: machine.axis(name).to_steps(ax["target_mm"]) for name, ax in local["axes"].items()}
    assert part["position_steps"] == expected == {"X": 3000, "Z": 800}
    assert part["status"] == []                   # no ERROR, STOPPED, MOVING; spindle, coolant off
    assert part["link"]["naks"] == 0 and part["link"]["busy"] > 0    # the queue of three was used
    assert remote["axes"] == local["axes"]
