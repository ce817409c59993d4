"""Lab 02's logic-analyser part: the capture shipped with the lab (a sigrok session file) matches,
edge by edge, the VCD the reference solution writes; a pulse one tick wider or a lost direction
change is found and named."""

import shutil
from pathlib import Path

import pytest

from retrofit.lab.core import find_lab, load_module, run_lab

LAB = find_lab(Path(__file__).resolve().parent.parent / "labs", "02")
pytestmark = pytest.mark.skipif(shutil.which("sigrok-cli") is None, reason="sigrok-cli is not installed")


@pytest.fixture(scope="module")
def written(tmp_path_factory):
    out = tmp_path_factory.mktemp("lab02")
    run_lab(LAB, solution=True, out_dir=out)
    return out / "lathe_steps.vcd"


def compare(vcd):
    tool = load_module(LAB.path / "sigrok_compare.py")
    return {m.signal: m for m in tool.compare(tool.RECORDED, vcd)}


def test_recorded_capture_matches_the_vcd_the_lab_writes(written):
    matches = compare(written)
    assert {name: (m.channel, m.lab_edges, m.ok) for name, m in matches.items()} == {
        "X.step": ("D2", 28, True), "X.dir": ("D3", 2, True), "Z.step": ("D0", 24, True), "Z.dir": ("D1", 2, True),
        "out0": ("D4", 0, True), "out1": ("D5", 0, True)}     # the lathe's spare outputs, quiet
    assert all(m.captured_edges == m.lab_edges and m.worst_s <= 10e-6 for m in matches.values())


def test_a_pulse_one_tick_wider_is_found(written, tmp_path):
    lines = written.read_text(encoding="utf-8").splitlines()
    at = lines.index("#20")                 # X and Z step fall at 20 (10 us units); X's now at 25
    lines[at + 1:at + 3] = ["0#", "#25", "0!"]
    bad = tmp_path / "wide.vcd"
    bad.write_text("\n".join(lines) + "\n", encoding="utf-8")
    matches = compare(bad)
    assert not matches["X.step"].ok and matches["X.step"].worst_s == pytest.approx(50e-6)
    assert matches["Z.step"].ok and matches["X.dir"].ok


def test_a_lost_direction_change_is_found(written, tmp_path):
    bad = tmp_path / "nodir.vcd"
    bad.write_text(written.read_text(encoding="utf-8").replace('\n1"\n', "\n"), encoding="utf-8")
    matches = compare(bad)
    assert not matches["X.dir"].ok and matches["X.dir"].lab_edges == 0 \
        and matches["X.dir"].captured_edges == 2 and matches["X.step"].ok
