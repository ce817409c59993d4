"""`retrofit run` fails safe: an exception in the run, SIGHUP (the terminal closed) and SIGTERM stop the
machine and leave the port's last byte safe (every data pin at rest: step bits low, the digital
outputs off), then the files are complete or absent and the exit code says what happened (128 + the
signal's number)."""

import os
import re
import signal
import subprocess
import sys
import threading
from pathlib import Path

import numpy as np
import pytest

from retrofit.cli import main
from retrofit.machine.config import load_machine

ROOT = Path(__file__).resolve().parents[1]
LATHE = load_machine("chivu-lathe")
# from the machine file: step pins 4 (X) and 2 (Z) are data bits 2 and 0, direction pins 5 and 3
# bits 3 and 1; the spare outputs of [io], pins 6 and 7, bits 4 and 5
STEP_BITS = 0b000101
DIR_BITS = 0b001010
OUTPUT_BITS = 0b110000


def test_the_bits_named_here_are_the_machine_files():
    assert sum(1 << a.step_bit for a in LATHE.axes) == STEP_BITS
    assert sum(1 << a.dir_bit for a in LATHE.axes) == DIR_BITS
    assert sum(1 << (pin - 2) for pin in LATHE.parts["io"].outputs) == OUTPUT_BITS


def program(path: Path, moves: int = 6) -> Path:
    """Back and forth on both axes with the coolant output (M64 P0) on: steps and an output high."""
    lines = ["G21 G90", "M64 P0"] + [f"G1 X{4 if i % 2 else 0} Z{-6 if i % 2 else 0} F600"
                                     for i in range(moves)] + ["M65 P0", "M2"]
    path.write_text("\n".join(lines) + "\n")
    return path


def recording(path: Path) -> np.ndarray:
    return np.fromfile(path, dtype=np.uint8)


def assert_safe_end(data: np.ndarray) -> None:
    """The port moved (steps, directions, the output on) and its last byte is safe: every data
    pin at rest, which on this machine (no pin inverted) is 0 V on all eight."""
    assert (data & STEP_BITS).any() and (data & DIR_BITS).any() and (data & OUTPUT_BITS).any()
    assert data[-1] == 0, f"last byte {data[-1]:#010b}"


def fail_after_a_step_pulse(monkeypatch, error: BaseException) -> dict:
    """The recorded port raises ``error`` on the first write that would end a step pulse after the
    50th write: the port holds a step bit high when the run fails."""
    from retrofit.outputs import record
    original = record.RecordPort.write
    state = {"failed": False}

    def failing(self, tick, value):
        if not state["failed"] and self.writes > 50 and self.held & STEP_BITS and not value & STEP_BITS:
            state["failed"] = True
            raise error
        original(self, tick, value)
    monkeypatch.setattr(record.RecordPort, "write", failing)
    return state


RUN = ["--machine", "chivu-lathe", "--output", "parport+record://rec.bin?paced=0&engine=python",
       "--output", "sim://", "--report", "r.json", "--progress", "off"]


def test_an_exception_inside_a_run_ends_with_the_safe_byte_last(tmp_path, monkeypatch, capsys):
    """The port refuses a write just after a step pulse went high (a failing port): the run stops,
    the byte after it on the recorded port is the safe one, the report is not written."""
    from retrofit.errors import OutputError
    state = fail_after_a_step_pulse(monkeypatch, OutputError("port write refused (the cable is out)"))
    monkeypatch.chdir(tmp_path)
    code = main(["run", str(program(tmp_path / "p.ngc")), *RUN])
    err = capsys.readouterr().err
    assert state["failed"] and code == 2 and "the cable is out" in err
    data = recording(tmp_path / "rec.bin")
    assert data[-2] & STEP_BITS                                           # held high when it failed
    assert_safe_end(data)
    assert not (tmp_path / "r.json").exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["p.ngc", "rec.bin"]    # no temporary left


def test_a_bug_inside_a_run_still_ends_with_the_safe_byte_last(tmp_path, monkeypatch):
    """Not an error retrofit knows (a RuntimeError, a bug): the port is made safe before the
    exception goes on."""
    fail_after_a_step_pulse(monkeypatch, RuntimeError("a bug"))
    monkeypatch.chdir(tmp_path)
    with pytest.raises(RuntimeError, match="a bug"):
        main(["run", str(program(tmp_path / "p.ngc")), *RUN])
    data = recording(tmp_path / "rec.bin")
    assert data[-2] & STEP_BITS
    assert_safe_end(data)


#: the progress bar shows every step it takes (tqdm's own settings), so a test can wait for one
EVERY_STEP = {"TQDM_MINITERS": "1", "TQDM_MININTERVAL": "0"}


def test_an_error_in_the_block_drops_the_enable_and_rests_inverted_step_pins(tmp_path):
    """A machine whose X step pin is inverted (it rests at 5 V) and whose drivers are enabled by
    pin 14 at 0 V: an error while the port holds a step pulse leaves the X step pin at 5 V, the
    Z step pin at 0 V, and pin 14 at 5 V (drivers off)."""
    from retrofit.frames import PortFrames
    from retrofit.outputs import open_output
    text = (Path(LATHE.source).read_text().replace("step_pin = 4 ", "step_pin = 4\ninvert_step = true ")
            + '\n[parport]\nenable_pin = 14\nenable_level = "low"\n')
    (tmp_path / "lathe.toml").write_text(text)
    machine = load_machine(tmp_path / "lathe.toml")
    assert [a.invert_step for a in machine.axes] == [True, False]
    out = open_output(f"parport+record://{tmp_path / 'r.bin'}?paced=0", machine)
    pulse = 0b001011                     # X step at 0 V (its pulse), Z step at 5 V, X dir at 5 V
    with pytest.raises(RuntimeError):
        with out:
            rec = out.recording
            assert rec.control_register & 0b10            # pin 14 at 0 V: drivers on
            out.write(PortFrames([0, 3], [0b001100, pulse], 5))
            raise RuntimeError("the run fails")
    data = rec.buffer
    assert data[3] == pulse and data[-1] == 0b000100       # X step at rest (5 V), all else 0 V
    assert not rec.control_register & 0b10                # pin 14 at 5 V: drivers off
    assert len(data) == 5                                 # the safe byte, at once after the pulse


def wait_for(proc, pattern: str, ceiling_s: float = 50.0) -> list[str]:
    """Read the process's standard error until ``pattern`` shows; all it writes is kept in the list."""
    seen, found = [], threading.Event()

    def read():
        while chunk := os.read(proc.stderr.fileno(), 4096):
            seen.append(chunk.decode(errors="replace"))
            if re.search(pattern, "".join(seen)):
                found.set()
        found.set()
    threading.Thread(target=read, daemon=True).start()
    assert found.wait(ceiling_s), "".join(seen)
    return seen


@pytest.mark.parametrize("signum", [signal.SIGHUP, signal.SIGTERM, signal.SIGINT],
                         ids=["SIGHUP", "SIGTERM", "SIGINT"])
def test_a_signal_mid_run_leaves_the_port_safe_and_the_files_complete_or_absent(tmp_path, signum):
    moves = 6
    prog = program(tmp_path / "p.ngc", moves)
    # paced at 200 us a tick (4 times slower than the machine's 50 us): 14 s of port writes, the
    # first twelfth of which (89 %) is written after about a second
    url = "parport+record://rec.bin?tick_us=200&force=1"
    proc = subprocess.Popen([sys.executable, "-m", "retrofit.cli", "run", str(prog), "--machine", "chivu-lathe",
                             "--output", url, "--output", "vcd://w.vcd", "--report", "r.json", "--plot", "p.png",
                             "--progress", "on"],
                            cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            env=dict(os.environ, PYTHONPATH=str(ROOT), MPLBACKEND="Agg", **EVERY_STEP))
    try:
        seen = wait_for(proc, r"\b(89|9\d)%")          # past 88 %: the port is being written
        proc.send_signal(signum)
        proc.wait(timeout=60)
    finally:
        proc.kill()
    err = "".join(seen)
    assert proc.returncode == 128 + signum, err           # 130 for SIGINT (Ctrl-C)
    said = "interrupted" if signum == signal.SIGINT else f"stopped by {signal.Signals(signum).name}"
    assert f"retrofit: {said}; not written: " in err and "Traceback" not in err
    for lost in ("w.vcd", "r.json", "p.png"):
        assert lost in err.split("not written: ")[1] and not (tmp_path / lost).exists()
    data = recording(tmp_path / "rec.bin")
    assert_safe_end(data)
    full = moves * 6 / 10 / LATHE.tick_s                 # moves of 6 mm at 10 mm/s, in ticks
    assert len(data) < full                               # it was stopped mid-run
    assert sorted(p.name for p in tmp_path.iterdir()) == ["p.ngc", "rec.bin"]    # no temporary left
