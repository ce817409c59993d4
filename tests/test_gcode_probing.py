"""G38.2-G38.5 on the simulated tul-mill: the probing move stops where the tool meets the setter's
beam, the stop point lands in #5061.., and the program goes on from there.

The oracle is the machine file: a tool hanging ``length`` below the gauge line (``[tools.sim]``)
meets the beam's top edge ``beam_top_z_mm`` when Z = top + length (Z+ is up, the tool hangs
below the gauge line), and meets its near side coming along +Y when Y = beam_y - beam_width/2 - diameter/2.
"""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from retrofit.atc.prober import SimProber
from retrofit.atc.settings import tools_of
from retrofit.commands import FMov, PMov
from retrofit.errors import GcodeError
from retrofit.gcode import compile_program
from retrofit.machine.config import load_machine

MILL = load_machine("tul-mill")
BEAM = MILL.parts["setter"]
SIM_TOOLS = tools_of(MILL).sim
STEP_MM = 0.01                          # 100 steps/mm on X, Y, Z


def compile_probing(text: str, spindle_tool: int = 0):
    return compile_program(text, MILL, "probe.ngc", probe=SimProber(MILL, spindle_tool))


def debug_values(program) -> list[list[float]]:
    return [[float(v) for v in text.split()] for _, _, kind, text in program.messages if kind == "DEBUG"]


def over_the_beam(tool: int) -> str:
    return f"T{tool}\nG0 Z{BEAM.approach_z_mm:g}\nG0 X{BEAM.beam_x_mm:g} Y{BEAM.beam_y_mm:g}\n"


@pytest.mark.parametrize("tool", [1, 3, 8], ids=["T1-reference", "T3", "T8-short"])
def test_g38_2_stops_where_the_tip_meets_the_beam_within_one_step(tool):
    expected_z = BEAM.beam_top_z_mm + SIM_TOOLS[tool].length_mm
    program = compile_probing(over_the_beam(tool) + f"G38.2 Z{BEAM.lowest_z_mm:g} F60\n"
                              "(debug, #5061 #5062 #5063 #5070)\nM2\n")
    x, y, z, ok = debug_values(program)[0]
    assert ok == 1.0
    assert (x, y) == (BEAM.beam_x_mm, BEAM.beam_y_mm)
    assert abs(z - expected_z) <= STEP_MM
    # the probing move is compiled as a feed move to where it stopped, on the line of the G38.2
    moves = [(c, line) for c, line in zip(program.commands, program.lines) if isinstance(c, PMov)]
    assert moves[-1][1] == 4 and dict(moves[-1][0].axes)["Z"] == pytest.approx(z)


def test_g38_2_along_y_meets_the_near_side_of_the_beam():
    t = 3
    below_top = BEAM.beam_top_z_mm + SIM_TOOLS[t].length_mm - 1.0      # tip 1 mm into the beam
    start_y = BEAM.beam_y_mm - 6.0
    program = compile_probing(f"T{t}\nG0 Z{BEAM.approach_z_mm:g}\nG0 X{BEAM.beam_x_mm:g} Y{start_y:g}\n"
                              f"G0 Z{below_top:g}\nG38.2 Y{BEAM.beam_y_mm:g} F60\n(debug, #5062)\nM2\n")
    expected_y = BEAM.beam_y_mm - BEAM.beam_width_mm / 2 - SIM_TOOLS[t].diameter_mm / 2
    assert abs(debug_values(program)[0][0] - expected_y) <= STEP_MM


def test_the_program_goes_on_from_the_trip_point_in_the_new_coordinates():
    program = compile_probing(over_the_beam(1) + "G38.2 Z-45 F60\nG10 L20 P1 Z0\n"
                              "G0 Z5\nG1 X20 Y20 F300\n(debug, #5420 #5421 #5422)\nM2\n")
    trip = BEAM.beam_top_z_mm + SIM_TOOLS[1].length_mm
    after = [c for c, line in zip(program.commands, program.lines) if line >= 6 and isinstance(c, (FMov, PMov))]
    assert abs(dict(after[0].axes)["Z"] - (trip + 5)) <= STEP_MM           # machine Z, 5 mm above
    assert dict(after[1].axes)["Z"] == dict(after[0].axes)["Z"]
    assert debug_values(program)[0] == [20.0, 20.0, 5.0]                  # program coordinates


def test_g38_4_backs_off_until_the_beam_clears_and_g38_3_may_miss():
    program = compile_probing(over_the_beam(1) + "G38.2 Z-45 F60\n(debug, #5063 #5070)\n"
                              "G38.4 Z-25 F30\n(debug, #5063 #5070)\n"
                              "G38.3 Z-10\n(debug, #5063 #5070)\nM2\n")
    trip = BEAM.beam_top_z_mm + SIM_TOOLS[1].length_mm
    (down, ok1), (up, ok2), (miss, ok3) = debug_values(program)
    assert ok1 == ok2 == 1.0 and ok3 == 0.0
    assert 0 < up - down <= STEP_MM + 1e-9 and abs(down - trip) <= STEP_MM
    assert miss == -10.0                             # no contact: the move ran to its end
    assert dict(program.commands[-1].axes)["Z"] == -10.0


def test_g38_2_without_contact_names_the_line():
    with pytest.raises(GcodeError, match=r"probe.ngc:4: G38.2: the move to Z-10 finished without "
                                         r"making contact"):
        compile_probing(over_the_beam(1) + "G38.2 Z-10 F60\nM2\n")


def test_probing_from_a_tripped_beam_is_refused():
    with pytest.raises(GcodeError, match=r"probe.ngc:5: G38.3: the probe is already tripped"):
        compile_probing(over_the_beam(1) + "G38.2 Z-45 F60\nG38.3 Z-44\nM2\n")
    with pytest.raises(GcodeError, match=r"probe.ngc:4: G38.5: the probe is not tripped"):
        compile_probing(over_the_beam(1) + "G38.5 Z-20 F60\nM2\n")


@pytest.mark.parametrize("line, rule", [
    ("G93 G38.2 Z-45 F1", "cannot probe in inverse time feed mode"),
    ("G38.2 Z-18 F60", "start point too close to probe point"),
    ("G38.2 Z-60 F60", "Z -60.000 mm is outside the soft limits"),
], ids=["inverse-time", "no-move", "soft-limit"])
def test_probing_rules_as_linuxcnc(line, rule):
    with pytest.raises(GcodeError, match=f"probe.ngc:4: .*{rule}"):
        compile_probing(over_the_beam(1) + line + "\nM2\n")


def test_a_machine_without_a_probe_input_refuses_with_the_line():
    with pytest.raises(GcodeError, match=r"p.ngc:2: G38.2: machine chivu-lathe has no probe input"):
        compile_program("G0 X10\nG38.2 X0 F100\n", load_machine("chivu-lathe"), "p.ngc")
    with pytest.raises(GcodeError, match=r"p.ngc:1: G38.3: probing needs the machine .* no prober"):
        compile_program("G38.3 Z-40 F100\n", MILL, "p.ngc")


def retrofit_cli(*args, cwd):
    return subprocess.run([sys.executable, "-m", "retrofit.cli", *args], capture_output=True,
                          text=True, cwd=cwd, timeout=120)


def test_retrofit_run_probes_on_the_simulated_mill_and_refuses_a_real_port(tmp_path):
    (tmp_path / "probe.ngc").write_text(over_the_beam(1) + "G38.2 Z-45 F60\nG10 L20 P1 Z0\n"
                                        "G0 Z5\nG0 X20 Y20\nM2\n")
    proc = retrofit_cli("run", "probe.ngc", "--machine", "tul-mill", "--report", "r.json", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr + proc.stdout
    axes = json.loads((tmp_path / "r.json").read_text())["axes"]
    trip = BEAM.beam_top_z_mm + SIM_TOOLS[1].length_mm
    assert abs(axes["Z"]["carriage_mm"] - (trip + 5)) <= STEP_MM
    assert axes["X"]["carriage_mm"] == pytest.approx(20.0, abs=STEP_MM)
    real = retrofit_cli("run", "probe.ngc", "--machine", "tul-mill", "--output",
                        "parport:///dev/null", cwd=tmp_path)
    assert real.returncode == 2
    assert "probe results come from the simulated machine" in real.stderr
