"""The firmware builds with avr-gcc, fits the ATmega2560, and compiles in the machine file's numbers."""

import importlib.util
import re
import shutil
import subprocess

import pytest

from tests.conformance.targets import FIRMWARE, missing_tools

needs_avr = pytest.mark.skipif(bool(missing_tools()), reason="the firmware needs avr-gcc, make and "
                               "libsimavr: apt-get install gcc-avr avr-libc binutils-avr "
                               "libsimavr-dev")


def header_tool():
    spec = importlib.util.spec_from_file_location("machine_header",
                                                  FIRMWARE / "tools" / "machine_header.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_shipped_header_is_what_the_machine_file_gives():
    from retrofit.machine.config import load_machine
    shipped = (FIRMWARE / "machines" / "mitic-lathe.h").read_text()
    assert shipped == header_tool().header(load_machine("mitic-lathe")), (
        "firmware/machines/mitic-lathe.h is out of date: run make -C firmware machine")


def test_the_header_carries_steps_per_mm_switches_and_homing_of_the_lathe():
    text = (FIRMWARE / "machines" / "mitic-lathe.h").read_text()
    assert "#define STEPS_PER_MM        { 100.0f, 80.0f }" in text
    assert "#define AXIS_BITS           { 0, 2 }" in text           # X and Z on the link
    for name, connector, bit in (("NLSX", "XMIN", 2), ("PLSX", "XMAX", 3), ("PLSZ", "ZMAX", 4),
                                 ("PPSX", "YMIN", 5), ("PPSZ", "YMAX", 6)):
        assert re.search(rf"SWITCH\(\d, \d, [+-]1, SW_\w+, {connector}, {bit}\)\s+/\* {name} \*/",
                         text), name
    assert "#define HOME_STEPS          { 4000, 1600 }" in text      # X 40 mm, Z 20 mm
    assert "#define ENCODER_COUNTS_PER_REV 400" in text


def test_the_mills_setter_beam_is_a_probe_input_on_the_next_free_connector():
    """tul-mill's four homing switches take X-min, X-max, Y-min, Y-max: the beam gets Z-min (D18,
    PD3), with no axis and no status bit; the lathe has no setter, so no probe input."""
    from retrofit.machine.config import load_machine
    shipped = (FIRMWARE / "machines" / "tul-mill.h").read_text()
    assert shipped == header_tool().header(load_machine("tul-mill")), (
        "firmware/machines/tul-mill.h is out of date: run make -C firmware machine MACHINE=tul-mill")
    assert re.search(r"SWITCH\(4, 0, \+1, SW_PROBE, ZMIN, -1\)", shipped)
    assert "#define PROBE_SWITCH        4" in shipped and "#define N_SWITCHES          5" in shipped
    lathe = (FIRMWARE / "machines" / "mitic-lathe.h").read_text()
    assert "#define PROBE_SWITCH        255" in lathe and "SW_PROBE" not in lathe


@needs_avr
def test_it_builds_without_warnings_and_fits_the_2560(tmp_path):
    # from scratch, in a copy: a `make clean` of the tree would pull the harness and the ELFs
    # from under the tests that run them meanwhile
    copy = tmp_path / "firmware"
    shutil.copytree(FIRMWARE, copy, ignore=shutil.ignore_patterns("build", "*.elf", "*.hex"))
    out = subprocess.run(["make", "-C", str(copy)], check=True, capture_output=True, text=True)
    assert "warning" not in out.stderr.lower()
    sizes = subprocess.run(["avr-size", str(copy / "firmware.elf")], check=True, capture_output=True,
                           text=True).stdout.splitlines()[1].split()
    text, data, bss = (int(v) for v in sizes[:3])
    flash, ram = text + data, data + bss
    assert flash < 256 * 1024 - 8 * 1024            # the Mega's flash less its bootloader
    assert ram < 8 * 1024 - 1024                    # SRAM, with room left for the stack
    # The look-ahead queue (18 moves) and the segment buffer take most of the RAM; half the
    # 2560's SRAM stays free for the stack (docs/firmware.md lists the figures).
    assert flash < 32 * 1024 and ram < 4 * 1024, (flash, ram)


@needs_avr
def test_make_flash_uploads_through_avrdude_to_the_given_port():
    out = subprocess.run(["make", "-n", "-C", str(FIRMWARE), "flash", "PORT=/dev/ttyACM7"],
                         check=True, capture_output=True, text=True).stdout
    assert re.search(r"avrdude -p atmega2560 -c wiring -P /dev/ttyACM7 -b 115200 -D "
                     r"-U flash:w:firmware.hex:i", out), out
