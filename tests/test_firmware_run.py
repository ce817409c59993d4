"""``retrofit run`` of the lathe example on the firmware in simavr (``retrofit firmware sim``),
through serial+socket://, the AVR's time running as fast as simavr goes (--speed 0)."""

import json

import pytest

from retrofit.cli import main
from retrofit.config import load_machine
from tests.conformance.targets import SimavrTarget, build_firmware, missing_tools

pytestmark = pytest.mark.skipif(bool(missing_tools()), reason="the firmware needs avr-gcc, make and "
                                "libsimavr: apt-get install gcc-avr avr-libc binutils-avr "
                                "libsimavr-dev")


def report_of(tmp_path, output: str, name: str) -> dict:
    path = tmp_path / f"{name}.json"
    assert main(["run", "lathe-profile.ngc", "--machine", "mitic-lathe", "--output", output,
                 "--progress", "off", "--report", str(path)]) == 0
    return json.loads(path.read_text())


@pytest.mark.slow
def test_the_lathe_example_on_the_firmware_ends_where_it_ends_on_sim(tmp_path):
    machine = load_machine("mitic-lathe")
    local = report_of(tmp_path, "sim://", "local")
    build_firmware()
    with SimavrTarget("mitic-lathe", "--speed", "0") as fw:
        remote = report_of(tmp_path, f"{fw.output_url}?wait_s=900", "remote")
    part = remote["remote"][0]
    expected = {name: machine.axis(name).to_steps(ax["target_mm"]) for name, ax in local["axes"].items()}
    assert part["position_steps"] == expected == {"X": 3000, "Z": 800}
    assert part["status"] == []                   # no ERROR, STOPPED, MOVING; spindle, coolant off
    assert part["link"]["naks"] == 0 and part["link"]["busy"] > 0    # the queue of three was used
    assert remote["axes"] == local["axes"]
