"""vcd://: read back with a VCD reader, the wires carry exactly the step and direction edges of the frames."""

from dataclasses import replace
from decimal import Decimal

import numpy as np
import pytest
from vcdvcd import VCDVCD

from retrofit.cli import main
from retrofit.config import load_machine
from retrofit.demo import circle_targets
from retrofit.errors import OutputError
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
    assert sorted(vcd.signals) == ["chivu_lathe.X.dir", "chivu_lathe.X.step", "chivu_lathe.Z.dir", "chivu_lathe.Z.step"]
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
