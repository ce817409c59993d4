"""The run read ahead: the interpreter runs only as far as asked, the planner plans batch by
batch, and the stream takes the moves as they come -- the same plan, frames and report as a
program read whole."""

import json
import subprocess
import sys

import numpy as np
import pytest
from test_stream_reversal import lathe, x_dir_turns

from retrofit.errors import GcodeError
from retrofit.gcode import compile_program
from retrofit.gcode.readahead import ReadAhead
from retrofit.machine.config import load_machine
from retrofit.motion.fast import execute_fast
from retrofit.motion.planarrays import PlanArrays
from retrofit.motion.planblocks import BlockPlanner, plan_in_blocks
from retrofit.motion.planner import plan_program
from retrofit.motion.stream import stream_blocks

FIELDS = PlanArrays.__dataclass_fields__



@pytest.fixture(autouse=True)
def reading_ahead(monkeypatch):
    """Reading ahead is the default (RETROFIT_READ_AHEAD=0 turns it off), here and in the runs
    these tests start."""
    monkeypatch.delenv("RETROFIT_READ_AHEAD", raising=False)

def job(moves: int = 400) -> str:
    """An engraving-like job: plunge, a zigzag of short moves with arcs and dwells, retract."""
    out = ["G21 G90 F2400", "G0 X10 Y10 Z2", "G1 Z-0.5"]
    for i in range(moves):
        out.append(f"G1 X{10 + (i * 7) % 13 * 0.3:.2f} Y{10 + (i * 5) % 11 * 0.3:.2f}")
        if i % 97 == 0:
            out += ["G0 X12 Y12", "G2 X14 Y12 I1 J0", "G4 P0.05"]
    return "\n".join(out + ["G0 Z2", "M2"]) + "\n"


@pytest.mark.parametrize("size", [5, 64, 1000], ids=["blocks-of-5", "blocks-of-64", "one-block"])
def test_a_plan_made_batch_by_batch_is_the_whole_plan_move_for_move(size):
    machine = load_machine("engraver")
    commands = compile_program(job(), machine).commands
    whole = plan_program(commands, machine)
    arrays, end_s = plan_in_blocks(commands, machine, True, size)
    for name in FIELDS:
        assert np.array_equal(getattr(arrays, name), getattr(whole.arrays(), name)), name
    assert end_s == whole.end_s


def test_a_reversal_planned_in_blocks_streams_the_fast_paths_frames_bit_for_bit():
    """Plunge, passes, retract on the lathe with backlash and a slow driver, the plan handed on
    a few moves at a time: X turns where the fast path turns it, every frame the same."""
    machine = lathe(lookahead=3)
    text = "G21 G90 F600\nG1 X-0.5\n" + "".join(f"G1 Z{-1.0 - i:g}\n" for i in range(30)) + "G1 X0\nM2\n"
    commands = compile_program(text, machine).commands
    fast = execute_fast(plan_program(commands, machine)).frames
    planner = BlockPlanner(machine)

    def blocks():
        for lo in range(0, len(commands), 4):
            planner.add(commands[lo:lo + 4])
            got = planner.planned(final=lo + 4 >= len(commands))
            if got is not None:
                yield got[0], (got[1] if lo + 4 >= len(commands) else None)
    chunks = list(stream_blocks(machine, (0, 0), blocks(), window_steps=60))
    assert len(chunks) > 5                                    # taken window by window
    ticks = np.concatenate([c.ticks for c in chunks])
    values = np.concatenate([c.values for c in chunks])
    assert np.array_equal(ticks, fast.ticks) and np.array_equal(values, fast.values)
    assert chunks[-1].end_tick == fast.end_tick
    assert x_dir_turns(machine, fast)[-1] > 0


def test_the_interpreter_runs_only_as_far_as_the_first_batch_needs():
    text = "G21 G90 F3000\n" + "".join(f"G1 X{i % 2 * 0.05:.2f} Y{i % 40 * 0.05:.2f}\n"
                                       for i in range(30_000)) + "M2\n"
    reader = ReadAhead(text, load_machine("engraver"), "long.ngc")
    batches = reader.batches(size=500)
    commands, lines, _ = next(batches)                        # a small first batch (a run of
    assert len(commands) >= 256 and max(lines) < 600          # plain lines is taken whole)
    assert reader.interpreter.steps < 600                     # 29 400 lines not run yet
    second = next(batches)[0]
    assert len(second) >= 500 and reader.interpreter.steps < 1500
    rest = sum(len(b[0]) for b in batches)
    assert len(commands) + len(second) + rest == len(compile_program(text, load_machine("engraver")).commands)


def test_a_late_error_names_its_line_when_read_ahead():
    text = "G21 G90 F3000\n" + "G1 X1\nG1 X2\n" * 2000 + "G1 X[1/0]\n"
    reader = ReadAhead(text, load_machine("engraver"), "late.ngc")
    with pytest.raises(Exception, match=r"^late.ngc:4002: "):
        for _ in reader.batches(size=100):
            pass


def run_cli(tmp_path, program: str, name: str) -> dict:
    path = tmp_path / name
    path.write_text(program)
    report = tmp_path / f"{name}.json"
    code = subprocess.run([sys.executable, "-c", "import sys; from retrofit.cli import main; "
                           "sys.exit(main(sys.argv[1:]))", "run", str(path), "--machine", "engraver",
                           "--output", "sim://", "--output", f"vcd://{tmp_path / name}.vcd", "--report",
                           str(report), "--progress", "off"], capture_output=True, text=True, timeout=240)
    assert code.returncode == 0, code.stderr
    return json.loads(report.read_text())


def test_retrofit_run_reads_ahead_and_gives_the_whole_programs_report_and_vcd(tmp_path):
    """The same program with a pause (read ahead) and with a digital output (read whole, M64 is
    timed on the program so far): the motion, the report's axes and the pause line agree."""
    moves = job(300)
    ahead = run_cli(tmp_path, moves.replace("G1 Z-0.5\n", "G1 Z-0.5\nM0\n"), "ahead.ngc")
    assert ahead["pauses"] == [{"line": 4, "says": ahead["pauses"][0]["says"]}]
    from types import SimpleNamespace

    from retrofit.run.program import STAGE_WEIGHTS, Run, run_program
    from retrofit.run.progress import silent
    machine = load_machine("engraver")
    opts = SimpleNamespace(backlash_comp=True, reference=False, controller=False, urls=["sim://"],
                           keep_frames=False, keep_commands=True)       # keeps commands: read whole
    whole = run_program(moves.replace("G1 Z-0.5\n", "G1 Z-0.5\nM0\n"), "ahead.ngc", machine, opts,
                        silent(STAGE_WEIGHTS))
    assert isinstance(whole, Run) and whole.plan is not None
    assert ahead["axes"] == json.loads(json.dumps(whole.report["axes"]))
    assert ahead["ticks"] == whole.report["ticks"]


def test_a_program_timing_an_output_on_the_moves_so_far_is_read_whole():
    """M64 is timed on the program so far: a run that would read ahead reads it whole, and its
    digital output is switched where the whole-program run switches it."""
    from pathlib import Path
    from types import SimpleNamespace

    from retrofit.run.program import STAGE_WEIGHTS, run_program
    from retrofit.run.progress import silent
    machine = load_machine(Path(__file__).parent / "gcode" / "rs274-mill.toml")
    text = "G21 G90 G1 F600\n" + "".join(f"X{i % 9 + 1} Y{i % 4 + 1}\n" for i in range(3000)) + \
        "M64 P1\nG1 X20\nM2\n"
    runs = []
    for keep in (False, True):
        opts = SimpleNamespace(backlash_comp=True, reference=False, controller=False, urls=["sim://"],
                               keep_frames=False, keep_commands=keep)
        runs.append(run_program(text, "io.ngc", machine, opts, silent(STAGE_WEIGHTS)))
    ahead, whole = runs
    from retrofit.run.stream import reads_ahead
    assert reads_ahead(machine, SimpleNamespace(reference=False, controller=False, keep_frames=False,
                                                keep_commands=False), ["sim://"])   # it started so
    assert ahead.plan is not None and ahead.line_of is None          # and read it whole
    assert ahead.io is not None and ahead.io == whole.io
    assert ahead.report["axes"] == whole.report["axes"]


def run_warned(text: str, capsys):
    """A run of ``text`` on the rs274 mill (a feed above its fastest is warned); (run or error,
    stderr)."""
    from pathlib import Path
    from types import SimpleNamespace

    from retrofit.run.program import STAGE_WEIGHTS, run_program
    from retrofit.run.progress import silent
    opts = SimpleNamespace(backlash_comp=True, reference=False, controller=False, urls=["sim://"],
                           keep_frames=False, keep_commands=False)
    try:
        got = run_program(text, "w.ngc", load_machine(Path(__file__).parent / "gcode" / "rs274-mill.toml"),
                          opts, silent(STAGE_WEIGHTS))
    except GcodeError as exc:
        got = exc
    return got, capsys.readouterr().err


WARNED = "w.ngc:1: warning: F90000 is above machine rs274-mill's fastest feed 3000 mm/min"
MOVES = "G21 G90 G1 F90000\n" + "".join(f"X{i % 9 + 1} Y{i % 4 + 1}\n" for i in range(3000))


def test_a_warning_is_printed_as_its_line_is_read_before_a_late_refusal(capsys):
    got, err = run_warned(MOVES + "G1 X[1/0]\nM2\n", capsys)
    assert isinstance(got, GcodeError) and "w.ngc:3002" in str(got)
    assert [line for line in err.splitlines() if "warning" in line][0].startswith(WARNED)


def test_a_program_read_whole_after_reading_ahead_warns_once(capsys, monkeypatch):
    for ahead in ("1", "0"):
        monkeypatch.setenv("RETROFIT_READ_AHEAD", ahead)
        run, err = run_warned(MOVES + "M64 P1\nG1 X20 F100\nM2\n", capsys)   # M64: read whole
        assert run.plan is not None and run.line_of is None
        assert [line[:len(WARNED)] for line in err.splitlines() if "warning" in line] == [WARNED]
