"""`retrofit fpga build`: the pulse engine through Yosys and nextpnr-ice40 (YoWASP) for the
iCEBreaker; resources and the maximum clock printed, the bitstream written in the build folder."""

import os
import re
import subprocess
import sys

import pytest


@pytest.mark.slow
def test_build_for_the_icebreaker_prints_resources_and_a_clock_it_meets(tmp_path):
    proc = subprocess.run([sys.executable, "-m", "retrofit.cli", "fpga", "build", "--board", "icebreaker",
                           "--build-dir", str(tmp_path / "build")], capture_output=True, text=True, cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr[-2000:]
    luts, ffs, ram = (int(n) for n in re.search(r"LUTs (\d+), flip-flops (\d+), RAM blocks (\d+)", proc.stdout).groups())
    fmax, clock = (float(x) for x in re.search(r"maximum clock ([\d.]+) MHz \(meets ([\d.]+) MHz\)", proc.stdout).groups())
    assert 0 < luts < 1000 and ffs > 0 and ram == 6          # one FIFO of 25-bit records per axis: 2 blocks each
    assert fmax >= clock
    bitstream = tmp_path / "build" / "pulse_engine.bin"
    assert bitstream.stat().st_size > 100_000                # an iCE40UP5K image
    assert str(bitstream) in proc.stdout


def test_an_unknown_board_is_refused_naming_the_known_ones(tmp_path):
    proc = subprocess.run([sys.executable, "-m", "retrofit.cli", "fpga", "build", "--board", "ulx3s"],
                          capture_output=True, text=True, cwd=tmp_path)
    assert proc.returncode == 2 and "unknown board 'ulx3s'; known: icebreaker" in proc.stderr


@pytest.mark.slow
@pytest.mark.skipif(not os.environ.get("RETROFIT_FPGA_BUILD_DI"), reason="a second place and route (about "
                    "a minute): RETROFIT_FPGA_BUILD_DI=1 runs it")
def test_the_digital_integration_variant_builds_and_meets_its_clock(tmp_path):
    proc = subprocess.run([sys.executable, "-m", "retrofit.cli", "fpga", "build", "--variant", "di",
                           "--build-dir", str(tmp_path / "build")], capture_output=True, text=True, cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert "digital-integration engine" in proc.stdout
    luts, ram = (int(n) for n in re.search(r"LUTs (\d+), flip-flops \d+, RAM blocks (\d+)", proc.stdout).groups())
    fmax, clock = (float(x) for x in re.search(r"maximum clock ([\d.]+) MHz \(meets ([\d.]+) MHz\)", proc.stdout).groups())
    assert luts > 0 and ram > 6 and fmax >= clock                 # three FIFOs of wider records
    assert (tmp_path / "build" / "di_engine.bin").stat().st_size > 100_000
