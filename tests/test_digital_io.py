"""M62-M66: spare outputs and inputs named in ``[io]``, against rs274's canonical calls, hand
computed ticks in the port frames and the VCD, the simulated inputs' waits, and the refusals."""

from __future__ import annotations

import re
from pathlib import Path
from types import SimpleNamespace

import pytest

from retrofit.commands import Cool, Dout, FMov, PMov, Spin, Tool, Wait, parse_command
from retrofit.errors import ConfigError, GcodeError, OutputError
from retrofit.gcode import compile_program, load_program
from retrofit.machine.config import load_machine
from retrofit.machine.tooltable import ToolTable
from retrofit.run.program import STAGE_WEIGHTS, run_program
from retrofit.run.progress import silent

HERE = Path(__file__).resolve().parent / "gcode"
RS274_MILL = load_machine(HERE / "rs274-mill.toml")
_CALL = re.compile(r"^\s*\d+ N\S* +([A-Z_]+)\((.*)\)\s*$")
_CANON_DOUT = {"SET_MOTION_OUTPUT_BIT": 62, "CLEAR_MOTION_OUTPUT_BIT": 63,
               "SET_AUX_OUTPUT_BIT": 64, "CLEAR_AUX_OUTPUT_BIT": 65}
_CANON_OTHER = {"STRAIGHT_FEED": "move", "STRAIGHT_TRAVERSE": "move", "CHANGE_TOOL": "tool",
                "START_SPINDLE_CLOCKWISE": "spindle", "FLOOD_ON": "coolant", "FLOOD_OFF": "coolant"}


def _collapse(tokens):
    return [t for k, t in enumerate(tokens) if not (t == "move" and k and tokens[k - 1] == "move")]


def rs274_sequence(stem: str) -> list:
    """rs274's output calls, moves, tool changes, spindle starts and coolant in order."""
    text = (HERE / "golden" / "programs" / f"{stem}.canon").read_text()
    assert text.startswith("# rs274 exit 0")
    out = []
    for line in text.splitlines()[1:]:
        m = _CALL.match(line)
        if m and m.group(1) in _CANON_DOUT:
            out.append((_CANON_DOUT[m.group(1)], int(m.group(2))))
        elif m and m.group(1) in _CANON_OTHER:
            out.append(_CANON_OTHER[m.group(1)])
        elif m and m.group(1) == "PROGRAM_END":
            break
    return _collapse(out)


def retrofit_sequence(program) -> list:
    out = []
    for cmd in program.commands:
        if isinstance(cmd, Dout):
            out.append((cmd.code, cmd.output))
        elif isinstance(cmd, (FMov, PMov)):
            out.append("move")
        elif isinstance(cmd, Tool):
            out.append("tool")
        elif isinstance(cmd, Spin) and cmd.direction:
            out.append("spindle")
        elif isinstance(cmd, Cool):
            out.append("coolant")
    return _collapse(out)


@pytest.mark.parametrize("stem", ["hand-io-outputs", "hand-io-order", "hand-io-p-rounding"])
def test_outputs_come_in_rs274s_order_between_the_moves(stem):
    program = load_program(HERE / "programs" / f"{stem}.ngc", RS274_MILL,
                           tool_table=ToolTable.load(HERE / "tool.tbl"))
    assert retrofit_sequence(program) == rs274_sequence(stem)


def test_commands_read_back_from_their_text():
    for text in ("DOUT M62 P1", "DOUT M65 P0", "WAIT P0 L3 Q2.5", "WAIT P1 L0 Q0"):
        assert str(parse_command(text)) == text


# -- a lathe on the parallel port: outputs on data pins 6 and 7 (bits 4 and 5) ---------------------
LATHE_IO = """
[io]
out0 = 6
out1 = 7
in0 = 12
in1 = 13
[io.sim]
in0 = [2.0]
"""


def lathe(tmp_path, io_text=LATHE_IO, name="lathe.toml"):
    base = (Path(load_machine("chivu-lathe").source).read_text())
    base = base[:base.index("[io]")] + base[base.index("# The physical machine the simulator"):]
    path = tmp_path / name
    path.write_text(base + io_text)
    return load_machine(path)


def run(machine, text, urls=("sim://",)):
    opts = SimpleNamespace(backlash_comp=True, reference=False, controller=False, urls=list(urls))
    return run_program(text, "io.ngc", machine, opts, silent(STAGE_WEIGHTS))


#: X 0 -> 10 at 600 mm/min (10 mm/s) with X's 200 mm/s2 and its 0.10 mm of backlash taken up
#: (the nut starts on its negative face): 10.1 mm, 1.01 s at speed + 0.05 s of ramps
MOVE_S = 10.1 / 10.0 + 10.0 / 200.0
TICK_S = 50e-6


def test_outputs_are_bits_of_the_port_byte_at_the_hand_computed_ticks(tmp_path):
    machine = lathe(tmp_path)
    r = run(machine, "G21 G90\nM62 P0\nG1 X10 F600\nM64 P1\nG4 P0.5\nM63 P0\nG1 X0\nM65 P1\nM2\n",
            ("sim://", f"vcd://{tmp_path / 'io.vcd'}"))
    frames = r.log.frames
    out0, out1 = 1 << 4, 1 << 5
    first_end = round(MOVE_S / TICK_S)                      # 21000
    second_start = first_end + round(0.5 / TICK_S)          # after the dwell
    end = second_start + first_end
    assert frames.value_at(0) & out0 and not frames.value_at(0) & out1
    assert not frames.value_at(first_end - 1) & out1
    assert frames.value_at(first_end) & out1 and frames.value_at(second_start - 1) & out0
    assert not frames.value_at(second_start) & out0        # M63 as the next move starts
    assert frames.value_at(end - 1) & out1 and not frames.value_at(end) & out1
    vcd = (tmp_path / "io.vcd").read_text()
    assert "out0 = bit 4 pin 6" in vcd and "$var wire 1 % out0 $end" in vcd
    changes = [(c["tick"], c["output"], c["level"], c["line"]) for c in r.report["io"]["outputs"]]
    assert changes == [(0, 0, 1, 2), (first_end, 1, 1, 4), (second_start, 0, 0, 6), (end, 1, 0, 8)]
    assert r.report["violations"] == []


def test_m66_waits_for_the_scripted_edge_and_leaves_5399(tmp_path):
    machine = lathe(tmp_path)        # input 0 rises at 2.0 s of the run
    text = ("G21 G90\nG1 X10 F600\nM66 P0 L1 Q5\n#1=#5399\nM66 P1 L3 Q0.25\n#2=#5399\n"
            "M66 P0 L0\n#3=#5399\nG1 X[#1+#2+#3]\nM2\n")
    program = compile_program(text, machine)
    assert [str(c) for c in program.commands if isinstance(c, Wait)] == [
        "WAIT P0 L1 Q5", "WAIT P1 L3 Q0.25", "WAIT P0 L0 Q0"]
    assert program.commands[-1].position()["X"] == pytest.approx(1.0 - 1.0 + 1.0)
    r = run(machine, text)
    waits = r.report["io"]["waits"]
    assert waits[0]["waited_s"] == pytest.approx(2.0 - MOVE_S) and waits[0]["value"] == 1.0
    assert waits[1]["waited_s"] == pytest.approx(0.25) and waits[1]["timed_out"]
    assert waits[2]["waited_s"] == 0.0 and waits[2]["value"] == 1.0
    # the last move X10 -> X1 starts when the waits are over: 2.0 s + 0.25 s
    assert r.log.waypoints[-1].reached_tick == round((2.25 + (9.1 / 10 + 10 / 200)) / TICK_S)


def test_m66_rising_edge_already_past_times_out(tmp_path):
    machine = lathe(tmp_path, LATHE_IO.replace("[2.0]", "[0.5]"))
    program = compile_program("G1 X10 F600\nM66 P0 L1 Q1\nG1 X[#5399]\nM2\n", machine)
    assert program.commands[-1].position()["X"] == -1.0          # timed out: #5399 = -1


@pytest.mark.parametrize("text, words", [
    ("G0 X1\nM64 P2\n", ["io.ngc:2", "M64 P2", "out0..out1"]),
    ("G0 X1\nM66 P2 L0\n", ["io.ngc:2", "M66 P2", "in0..in1"]),
    ("G0 X1\nM66 P0 L5 Q1\n", ["io.ngc:2", "L5", "wait mode"]),
    ("G0 X1\nM66 E0 L0\n", ["io.ngc:2", "analog"]),
    ("G0 X1\nM66 P0 L3\n", ["io.ngc:2", "timeout"]),
    ("G0 X1\nM67 E0 Q1\n", ["io.ngc:2", "M67", "analog outputs"]),
    ("G0 X1\nG71 Q100 D1\n", ["io.ngc:2", "G71 Q100", "no o100 sub"]),
])
def test_refusals_name_the_line_and_the_rule(tmp_path, text, words):
    with pytest.raises(GcodeError) as exc:
        compile_program(text, lathe(tmp_path), file="io.ngc")
    for word in words:
        assert word in str(exc.value)


def test_a_machine_without_io_refuses_m62_with_its_line():
    with pytest.raises(GcodeError) as exc:
        compile_program("G0 X1\nM62 P0\nG0 X2\n", load_machine("engraver"), file="p.ngc")
    assert "p.ngc:2" in str(exc.value) and "names no digital output pins" in str(exc.value)


def test_the_serial_link_refuses_before_anything_is_sent(tmp_path):
    machine = lathe(tmp_path)
    with pytest.raises(OutputError) as exc:
        run(machine, "G0 X1\nM64 P0\nG0 X2\nM2\n", ("serial:///dev/null-nothing",))
    assert "DOUT M64 P0" in str(exc.value) and "serial link does not carry" in str(exc.value)


@pytest.mark.parametrize("io_text, words", [
    ("[io]\nout0 = 4\n", ["[io] out0 = 4", "already used by X.step"]),
    ("[io]\nout0 = 12\n", ["[io] out0 = 12", "data pin"]),
    ("[io]\nin0 = 6\n", ["[io] in0 = 6", "status pin"]),
    ("[io]\nout0 = 6\nout2 = 7\n", ["[io] out2", "unknown key"]),
    ("[io]\nin0 = 12\n[io.sim]\nin0 = [2.0, 1.0]\n", ["[io.sim] in0", "increase"]),
    ("[io]\nin0 = 12\n[io.sim]\nin1 = [1.0]\n", ["[io.sim] in1", "unknown key"]),
])
def test_machine_file_io_errors_name_file_section_and_key(tmp_path, io_text, words):
    with pytest.raises(ConfigError) as exc:
        lathe(tmp_path, io_text)
    for word in ["lathe.toml", *words]:
        assert word in str(exc.value)


def test_shipped_lathe_declares_its_spare_pins():
    io = load_machine("chivu-lathe").parts["io"]
    assert io.outputs == (6, 7) and io.inputs == (12, 13)
