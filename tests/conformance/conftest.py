"""Fixtures of the conformance suite: each test runs on ``retrofit mcu`` and on the firmware."""

import pytest

from retrofit.machine.config import load_machine

from tests.conformance.rawlink import RawLink
from tests.conformance.targets import MACHINE, TARGETS, McuTarget, SimavrTarget, build_firmware, missing_tools


@pytest.fixture(scope="session")
def firmware_elf():
    """firmware.elf, built once a session; skipped (with the reason) without the AVR tools."""
    missing = missing_tools()
    if missing:
        pytest.skip(f"the firmware needs {', '.join(missing)}: apt-get install gcc-avr avr-libc "
                    "binutils-avr libsimavr-dev")
    return build_firmware()


def start(name: str, request):
    if name == "mcu":
        return McuTarget()
    request.getfixturevalue("firmware_elf")
    return SimavrTarget()


@pytest.fixture(scope="module", params=TARGETS)
def device(request):
    """One device process per module and target, killed at the end."""
    target = start(request.param, request)
    yield target
    target.close()


@pytest.fixture
def fresh(request):
    """A device just powered up (nothing synchronised yet), killed after the test."""
    target = start(request.param, request)
    yield target
    target.close()


@pytest.fixture(scope="session")
def machine():
    return load_machine(MACHINE)


@pytest.fixture
def link(device, machine):
    """A new connection to the module's device: both channels synchronised, INIT done, idle."""
    raw = RawLink(device.url, machine)
    raw.sync_both()
    raw.send("STOP")
    raw.send("INIT")
    raw.wait_idle()
    yield raw
    raw.close()
