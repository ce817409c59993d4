"""Bring-up on a board: the host waits out the bootloader and reads the firmware's start line;
switches are debounced; a hung main loop stops the steppers and the watchdog restarts the board.

The pin-level tests run the firmware in simavr for a fixed number of cycles (the harness plays
the bootloader, glitches a switch input, hangs the main loop) and measure in AVR cycles."""

from __future__ import annotations

import numpy as np
import pytest

from retrofit.commands import FMov
from retrofit.errors import LinkError, OutputError
from retrofit.link import StatusFlags
from retrofit.machine.config import load_machine
from retrofit.outputs import open_output
from retrofit.outputs.serial import BANNER, Banner

from tests.conformance.targets import SimavrTarget, build_firmware, missing_tools
from tests.test_firmware_sim import Script, replies

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
    assert remote["banner"] == {"machine": "mitic-lathe", "link": 3, "reset": "external"}


def test_without_the_wait_the_bootloader_swallows_the_first_frames():
    build_firmware()
    machine = load_machine("mitic-lathe")
    with SimavrTarget("mitic-lathe", "--boot-ms", "3000") as target:
        out = open_output(f"{target.output_url}?boot_ms=300", machine)
        with pytest.raises(OutputError, match="no answer to SYNC within 0.3 s"):
            out.open()


def test_a_firmware_built_for_another_machine_is_refused_by_its_banner():
    build_firmware("tul-mill")
    with SimavrTarget("tul-mill", "--boot-ms", "300") as target:
        out = open_output(f"{target.output_url}?boot_ms=4000", load_machine("mitic-lathe"))
        with pytest.raises(OutputError, match="built for machine 'tul-mill', the run is for "
                                              "'mitic-lathe'"):
            out.open()
        out.close()


def test_the_start_line_is_found_among_noise_and_another_link_version_is_refused():
    line = b"\x00\xff\r\nretrofit firmware machine=tul-mill link=2 reset=brown-out\r\n\x7e\x01"
    banner = Banner.find(line)
    assert banner == Banner("tul-mill", 2, "brown-out")
    with pytest.raises(LinkError, match="speaks link version 2; this host speaks 3"):
        banner.check("tul-mill", "serial:///dev/ttyACM0")
    assert Banner.find(b"retrofit firmware machine=tul-mill link=2 reset=power") is None  # unfinished


# -- measured on the pins: the harness runs the firmware for a fixed number of cycles ----------

S = 16_000_000                                   # AVR cycles a second
fs = pytest.importorskip("retrofit.firmware.sim")


@pytest.fixture(scope="module")
def lathe():
    machine = load_machine("mitic-lathe")
    return machine, fs.build(machine.name)


def banners(log) -> list[tuple[int, str]]:
    """(cycle of its first byte, reset cause) of each start line the firmware sent."""
    data, out = log.answer_bytes(), []
    for found in BANNER.finditer(data):
        out.append((log.uart[found.start()][0], found[3].decode()))
    return out


def test_the_firmware_starts_after_the_bootloader_and_says_so_first():
    machine = load_machine("mitic-lathe")
    elf = fs.build(machine.name)
    log = fs.Harness(elf, machine, cycles=int(0.2 * S), boot_ms=100).run()
    assert [cause for _, cause in banners(log)] == ["external"]      # the DTR reset's bootloader
    first_pin = min(changes[0][0] for changes in log.ports.values())
    assert first_pin >= int(0.1 * S) and banners(log)[0][0] > first_pin
    assert log.answer_bytes().startswith(b"\r\nretrofit firmware machine=mitic-lathe link=3 ")
    log = fs.Harness(elf, machine, cycles=int(0.05 * S)).run()
    assert [cause for _, cause in banners(log)] == ["power-on"]


def en_high(log, machine, axis: str) -> np.ndarray:
    """Cycles at which the axis's driver ENABLE pin went high (driver off)."""
    port, bit = fs.ENABLE_PINS[fs.sockets(machine)[axis]]
    cycles, levels = log.pin(port, bit)
    prev = np.concatenate(([0], levels[:-1]))                # low (on) from power-up
    return cycles[(levels == 1) & (prev == 0)]


@pytest.mark.parametrize("interrupts_off", [False, True], ids=["loop-hangs", "loop-hangs-cli"])
def test_a_hung_main_loop_stops_the_steppers_and_the_watchdog_restarts_the_board(lathe,
                                                                                   interrupts_off):
    """FMOV X30 with the spindle on; at 0.3 s the main loop hangs. With the interrupts on, the
    clock's interrupt sees no turn of the loop for 50 ms: the steps end, every driver is disabled
    (ENABLE high), the spindle's PWM stops, and the watchdog resets the board 16 ms later. With
    the interrupts off nothing steps from the hang on and the watchdog resets it at 120 ms."""
    machine, elf = lathe
    script = (Script(machine).at(3_100_000, "SPIN S1000 D1").at(3_200_000, "FMOV X30"))
    stall = int(0.3 * S)
    log = fs.Harness(elf, machine, script=script.items, cycles=int(0.6 * S),
                     stall=(stall, interrupts_off)).run()
    assert stall <= log.stalled_at < stall + 1000
    rises, _, _ = fs.step_times(log, machine, "X")
    assert (rises < stall).sum() > 100                         # it was moving
    restart = [c for c, cause in banners(log) if cause == "watchdog"]
    assert [cause for _, cause in banners(log)] == ["power-on", "watchdog"]
    pwm, level = log.pin("W", 4)
    if interrupts_off:
        assert rises.max() < log.stalled_at + 16 * 30          # nothing after the hang
        assert 0.115 * S < restart[0] - log.stalled_at < 0.14 * S
        return
    # the stall guard: 50 ms of the clock without a turn of the loop, counted from its last
    # turn, which came up to a turn (well under 1 ms) before the hang
    guard = en_high(log, machine, "X")[0]
    assert 0.048 * S < guard - log.stalled_at < 0.051 * S
    period = np.diff(rises[-3:]).max()                 # the last step: within a period before
    for axis in "XZ":                          # drivers off before the next step would come
        off = en_high(log, machine, axis)
        assert len(off) == 1 and 0 < off[0] - rises.max() < period, axis
    assert 0 < restart[0] - off[0] < 0.02 * S                  # the watchdog's 15 ms
    assert not level[(pwm > off[0]) & (pwm < restart[0])].any()   # D10 held low
    assert level[(pwm > stall - 0.05 * S) & (pwm < stall)].any()  # the PWM ran before


def plsx_glitches(lathe, glitches):
    """FMOV X12 towards PLSX with the switch input driven high as ``glitches`` (start, cycles);
    (the final status, the final position, the X step rises)."""
    machine, elf = lathe
    script = Script(machine).at(3_200_000, "FMOV X12").at(int(0.9 * S), "RDST")
    script.at(int(0.9 * S), "RDPS")
    log = fs.Harness(elf, machine, script=script.items, cycles=int(0.95 * S),
                     glitches=[("XMAX", at, n, 1) for at, n in glitches]).run()
    status, position = replies(log, machine)[-2:]
    return status, dict(position.steps), fs.step_times(log, machine, "X")[0]


def test_a_switch_bounce_shorter_than_the_debounce_does_not_stop_a_move(lathe):
    ms = S // 1000
    bounce = [(int(0.3 * S) + k * 1.6 * ms, 0.6 * ms) for k in range(6)]   # 0.6 ms every 1.6 ms
    status, position, _ = plsx_glitches(lathe, bounce + [(int(0.4 * S), 1.9 * ms)])
    assert not status.flags & StatusFlags.ERROR
    assert position["X"] == 1200                                # the whole move


def test_a_switch_closed_for_three_samples_stops_the_move_three_ms_later(lathe):
    ms, start = S // 1000, int(0.35 * S)
    status, position, rises = plsx_glitches(lathe, [(start, 3 * ms)])
    assert status.flags & StatusFlags.ERROR                     # a limit switch while moving
    assert position["X"] < 1200
    last = rises.max() - start                                  # 2-3 ms: three 1 ms samples
    assert 2 * ms < last < 3 * ms + 400 * 16                    # (+ one step at 2500 steps/s)
