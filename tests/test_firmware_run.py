"""``retrofit run`` of the lathe example on the firmware, running for real in QEMU (serial+socket://).

QEMU's timers run in real time, so this takes as long as the part takes on the machine: about
two and a half minutes.
"""

import json

import pytest

from retrofit.cli import main
from retrofit.config import load_machine
from tests.conformance.targets import QemuTarget, build_firmware, missing_tools

pytestmark = pytest.mark.skipif(bool(missing_tools()), reason="the firmware needs avr-gcc, make and "
                                "qemu-system-avr: apt-get install gcc-avr avr-libc binutils-avr "
                                "qemu-system-misc")


def report_of(tmp_path, output: str, name: str) -> dict:
    path = tmp_path / f"{name}.json"
    assert main(["run", "lathe-profile.ngc", "--machine", "mitic-lathe", "--output", output,
                 "--progress", "off", "--report", str(path)]) == 0
    return json.loads(path.read_text())


@pytest.mark.slow
def test_the_lathe_example_on_the_firmware_ends_where_it_ends_on_sim(tmp_path):
    machine = load_machine("mitic-lathe")
    local = report_of(tmp_path, "sim://", "local")
    with QemuTarget(build_firmware()) as qemu:
        remote = report_of(tmp_path, f"{qemu.output_url}?wait_s=900", "remote")
    part = remote["remote"][0]
    expected = {name: machine.axis(name).to_steps(ax["target_mm"]) for name, ax in local["axes"].items()}
    assert part["position_steps"] == expected == {"X": 3000, "Z": 800}
    assert part["status"] == []                   # no ERROR, STOPPED, MOVING; spindle, coolant off
    assert part["link"]["naks"] == 0 and part["link"]["busy"] > 0    # the queue of three was used
    assert remote["axes"] == local["axes"]
