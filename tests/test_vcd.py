"""vcd://: read back with a VCD reader, the wires carry exactly the step and direction edges of the frames."""

from dataclasses import replace
from decimal import Decimal
from pathlib import Path

import numpy as np
import pytest
from vcdvcd import VCDVCD

from retrofit.cli import main
from retrofit.demo import circle_targets
from retrofit.errors import OutputError
from retrofit.machine.config import load_machine
from retrofit.motion.errorloop import PositionErrorLoop
from retrofit.outputs import open_output
from retrofit.outputs.record import load_recording
from retrofit.outputs.vcd import tick_timescale


def edges_of(frames, bit: int) -> list[tuple[int, int]]:
    """(tick, level) at tick 0 and at every change of one port bit."""
    levels = (frames.per_tick() >> bit) & 1
    at = [0] + (np.flatnonzero(np.diff(levels)) + 1).tolist()
    return [(t, int(levels[t])) for t in at]


def vcd_edges(vcd, name: str, units_per_tick: int) -> list[tuple[int, int]]:
    tv = vcd[name].tv
    assert all(t % units_per_tick == 0 for t, _ in tv), "every change on a tick boundary"
    return [(t // units_per_tick, int(v)) for t, v in tv]


def write_vcd(machine, frames, path):
    with open_output(f"vcd://{path}", machine) as out:
        out.write(frames)
    return out


@pytest.mark.parametrize("invert", [False, True], ids=["plain", "inverted-X-step"])
def test_vcd_holds_exactly_the_edges_of_the_port_frames(tmp_path, invert):
    machine = load_machine("chivu-lathe")
    if invert:
        axes = tuple(replace(a, invert_step=True) if a.name == "X" else a for a in machine.axes)
        machine = replace(machine, axes=axes)
    frames = PositionErrorLoop(machine).run(circle_targets(machine, 3.0, 24)).frames
    out = write_vcd(machine, frames, tmp_path / "run.vcd")
    vcd = VCDVCD(str(tmp_path / "run.vcd"))
    assert sorted(vcd.signals) == ["chivu_lathe.X.dir", "chivu_lathe.X.step", "chivu_lathe.Z.dir",
                                   "chivu_lathe.Z.step", "chivu_lathe.out0", "chivu_lathe.out1"]
    for axis in machine.axes:
        for kind, bit in (("step", axis.step_bit), ("dir", axis.dir_bit)):
            got = vcd_edges(vcd, f"chivu_lathe.{axis.name}.{kind}", out.units_per_tick)
            assert got == edges_of(frames, bit), f"{axis.name}.{kind}"
    assert vcd.endtime == frames.end_tick * out.units_per_tick
    if invert:
        assert vcd["chivu_lathe.X.step"].tv[0] == (0, "1"), "an inverted step pin rests at 5 V"


def test_timescale_is_the_tick_or_the_largest_vcd_unit_dividing_it(tmp_path):
    machine = replace(load_machine("chivu-lathe"), tick_us=100.0)
    frames = PositionErrorLoop(machine).run(circle_targets(machine, 1.0, 8)).frames
    out = write_vcd(machine, frames, tmp_path / "t.vcd")
    vcd = VCDVCD(str(tmp_path / "t.vcd"))
    assert (vcd.timescale["magnitude"], vcd.timescale["unit"]) == (Decimal(100), "us")
    assert out.units_per_tick == 1 and vcd.endtime == frames.end_tick


@pytest.mark.parametrize("tick_us, expected", [
    (100, ("100 us", 1)), (50, ("10 us", 5)), (10, ("10 us", 1)), (1000, ("1 ms", 1)),
    (12.5, ("100 ns", 125)), (250, ("10 us", 25)),
], ids=["100us", "50us", "10us", "1ms", "12.5us", "250us"])
def test_tick_timescale(tick_us, expected):
    assert tick_timescale(tick_us) == expected


def test_vcd_needs_a_file():
    with pytest.raises(OutputError, match=r"a file is needed; expected vcd://FILE.vcd"):
        open_output("vcd://", load_machine("chivu-lathe")).open()


def test_several_outputs_at_once_from_the_command_line(tmp_path, capsys):
    vcd, rec = tmp_path / "out.vcd", tmp_path / "out.bin"
    code = main(["demo", "circle", "--radius", "2", "--points", "20", "--output", "sim://",
                 "--output", f"vcd://{vcd}", "--output", f"parport+record://{rec}?paced=0"])
    assert code == 0
    machine = load_machine("chivu-lathe")
    frames = PositionErrorLoop(machine).run(circle_targets(machine, 2.0, 20)).frames
    assert load_recording(rec) == frames
    read = VCDVCD(str(vcd))
    z_step = machine.axis("Z").step_bit
    assert vcd_edges(read, "chivu_lathe.Z.step", 5) == edges_of(frames, z_step)


def pyvcd_text(machine, frames, path):
    """The file pyvcd writes when given every change itself (the writer's reference)."""
    from retrofit.outputs.vcd import VcdOutput
    out = open_output(f"vcd://{path}", machine)
    out.open()
    for tick, value in zip(frames.ticks.tolist(), frames.values.tolist()):
        VcdOutput._write_pyvcd(out, tick, value)
    out.end_tick = frames.end_tick
    out.close()
    return Path(path).read_text()


@pytest.mark.parametrize("seed", range(6))
def test_compiled_vcd_writer_writes_what_pyvcd_writes(tmp_path, seed):
    import numpy as np

    from retrofit.frames import PortFrames
    machine = load_machine("engraver" if seed % 2 else "chivu-lathe")
    rng = np.random.default_rng(seed)
    n = 3000
    ticks = np.cumsum(rng.integers(1, 400, n)) - (0 if seed < 3 else -17)
    ticks[0] = 0 if seed < 3 else ticks[0]
    values = rng.integers(0, 1 << (2 * len(machine.axes)), n).astype(np.uint8)
    keep = np.concatenate(([True], values[1:] != values[:-1]))
    frames = PortFrames(ticks[keep], values[keep], int(ticks[-1]) + 9)
    expected = pyvcd_text(machine, frames, tmp_path / "ref.vcd")
    with open_output(f"vcd://{tmp_path / 'run.vcd'}", machine) as out:
        for lo in range(0, len(frames), 701):             # in chunks, as a streamed run writes
            hi = min(lo + 701, len(frames))
            end = int(frames.ticks[hi]) if hi < len(frames) else frames.end_tick
            out.write(PortFrames(frames.ticks[lo:hi], frames.values[lo:hi], end))
    assert (tmp_path / "run.vcd").read_text() == expected
