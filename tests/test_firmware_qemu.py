"""What only the firmware shows, in QEMU: a feed override mid-move, and the wait for the indexer."""

import time

import pytest

from retrofit.config import load_machine
from retrofit.link import Ack, StatusFlags
from tests.conformance.rawlink import RawLink
from tests.conformance.targets import QemuTarget, build_firmware, missing_tools

pytestmark = pytest.mark.skipif(bool(missing_tools()), reason="the firmware needs avr-gcc, make and "
                                "qemu-system-avr: apt-get install gcc-avr avr-libc binutils-avr "
                                "qemu-system-misc")
F = StatusFlags


@pytest.fixture(scope="module")
def qemu():
    with QemuTarget(build_firmware()) as target:
        yield target


@pytest.fixture
def link(qemu):
    raw = RawLink(qemu.url, load_machine("mitic-lathe"))
    raw.sync_both()
    raw.send("STOP")
    raw.send("INIT")
    raw.wait_idle()
    yield raw
    raw.send("STOP")
    raw.close()


def x_speed(link, seconds: float) -> float:
    """Steps per second of X over ``seconds`` of wall time."""
    x0, t0 = link.position()["X"], time.monotonic()
    time.sleep(seconds)
    return (link.position()["X"] - x0) / (time.monotonic() - t0)


def test_ffdr_changes_the_speed_of_the_move_that_is_running(link):
    assert link.send("FMOV X39") == Ack()                  # 3900 steps at 1500 mm/min
    time.sleep(0.4)
    fast = x_speed(link, 0.4)
    assert link.send("FFDR F15") == Ack()                  # a hundredth: 25 steps/s
    time.sleep(1.5)                                        # the braking
    slow = x_speed(link, 1.0)
    # QEMU's timers run a little late (by the host's latency), so rates are checked loosely.
    assert fast > 1200 and 0 < slow < fast / 5, (fast, slow)
    assert link.status().flags & F.MOVING


def test_an_istp_move_waits_for_the_indexer_start_pulse(link):
    for text in ("ISTP", "PFDR F0.5", "PMOV X1"):          # 0.5 mm per spindle revolution
        assert link.send(text) == Ack()
    time.sleep(0.3)
    st = link.status()
    assert st.flags & F.MOVING and st.flags & F.INDEXER    # no SIND, no ICLK: it waits
    assert link.position() == {"X": 0, "Z": 0}
    assert link.send("STOP") == Ack()
    assert not link.status().flags & F.MOVING
