"""The drawing rules of --plot: rapids dashed, the lathe's stock and part, a magnifying inset that
shows the backlash, axis names once, titles in words."""

from __future__ import annotations

import re
import shutil
import subprocess

import numpy as np
import pytest

from retrofit.demo import circle_targets
from retrofit.gcode import load_program
from retrofit.gcode.program import compile_program
from retrofit.machine.config import load_machine
from retrofit.motion.errorloop import PositionErrorLoop
from retrofit.run.plot import axis_label, run_figure, stock_and_part, toolpath, user_title, worst_error_point
from retrofit.run.program import execute, plan_compiled, resolve_program
from retrofit.run.runner import deliver


@pytest.fixture(scope="module")
def lathe():
    return load_machine("chivu-lathe")


@pytest.fixture(scope="module")
def profile(lathe):
    path = resolve_program("lathe-profile.ngc")
    program = load_program(path, lathe)
    return program, path.read_text()


def part_radius(lathe_shape: dict, z_mm: float) -> float:
    return float(np.interp(z_mm, lathe_shape["part_z"], lathe_shape["part_x"]))


def test_part_outline_is_the_profile_the_program_describes(lathe, profile):
    program, text = profile
    shape = stock_and_part(toolpath(program.commands, lathe), lathe, text)
    # the program's header: bar of 44 mm, 30 mm diameter to Z-27, 42 mm to Z-45, a 1 mm chamfer
    assert shape["radius_mm"] == 22.0
    assert shape["z_mm"][1] == 0.0                        # the faced end
    assert part_radius(shape, -10.0) == pytest.approx(15.0, abs=1e-6)
    assert part_radius(shape, -40.0) == pytest.approx(21.0, abs=1e-6)
    assert part_radius(shape, -0.5) == pytest.approx(14.5, abs=1e-6)    # on the 45 deg chamfer
    assert part_radius(shape, -47.0) == pytest.approx(22.0)             # past the cuts: stock
    assert shape["z_mm"][0] < -45.0


def test_a_lathe_program_that_names_no_stock_gets_none(lathe):
    program = compile_program("G0 X12 Z1\nG1 Z-10 F100\nG0 X20\n", lathe, "bare.ngc")
    assert stock_and_part(toolpath(program.commands, lathe), lathe, "G0 X12 Z1") is None


def test_a_mill_has_no_stock_outline():
    engraver = load_machine("engraver")
    program = load_program(resolve_program("engraving.ngc"), engraver)
    assert stock_and_part(toolpath(program.commands, engraver), engraver) is None


@pytest.mark.skipif(shutil.which("rs274") is None, reason="needs LinuxCNC's rs274")
def test_rapids_are_the_programs_traverses(profile, lathe):
    program, _ = profile
    out = subprocess.run(["rs274", "-g", str(resolve_program("lathe-profile.ngc"))], input="",
                         capture_output=True, text=True, timeout=60).stdout
    segments = toolpath(program.commands, lathe)
    assert sum(s.kind == "rapid" for s in segments) == len(re.findall(r"STRAIGHT_TRAVERSE\(", out))


def test_axes_are_named_once():
    assert axis_label(load_machine("engraver").axis("X")) == "X [mm]"
    assert axis_label(load_machine("chivu-lathe").axis("X")) == "X transversal [mm]"


def lathe_profile_figure(lathe, profile, comp=True):
    program, text = profile
    program, plan = plan_compiled(program, lathe, backlash_comp=comp)
    log = execute(plan)
    sim = deliver(log, ["sim://"])
    title = user_title(lathe, "lathe-profile.ngc", comp)
    return run_figure(log, sim, title, program.commands, text), log, sim


def test_profile_plot_draws_rapids_dashed_and_cuts_solid(lathe, profile):
    import matplotlib.pyplot as plt
    fig, _, _ = lathe_profile_figure(lathe, profile)
    ax = fig.axes[0]
    lines = {line.get_label(): line for line in ax.get_lines()}
    assert lines["rapid (G0)"].get_linestyle() == "--"
    assert lines["cut (G1/G2/G3)"].get_linestyle() == "-"
    legend = [t.get_text() for t in ax.get_legend().get_texts()]
    assert "stock (diameter 44 mm)" in legend and "part left by the cuts" in legend
    assert ax.get_title() == "lathe-profile.ngc on the chivu-lathe, backlash compensation on"
    assert ax.get_xlabel() == "Z longitudinal [mm]" and ax.get_ylabel() == "X transversal [mm]"
    plt.close(fig)


def test_inset_magnifies_the_circles_backlash_only_without_compensation(lathe):
    import matplotlib.pyplot as plt
    worst = {}
    for comp in (True, False):
        log = PositionErrorLoop(lathe, backlash_comp=comp).run(circle_targets(lathe, 15.0, 100))
        sim = deliver(log, ["sim://"])
        worst[comp] = worst_error_point(log, sim, 1, 0)[2]
        fig = run_figure(log, sim, user_title(lathe, "circle", comp))
        main = fig.axes[0]
        inset = main.child_axes[0]
        span = np.diff(inset.get_xlim())[0]
        assert span < np.diff(main.get_xlim())[0] / 10     # magnified at least ten times
        assert f"worst error {worst[comp]:.3f} mm" in inset.get_title()
        plt.close(fig)
    dead_band = max(lathe.sim.dead_band_mm.values())
    assert worst[False] >= dead_band / 2                   # the 0.1 mm of backlash stands out
    assert worst[True] <= 2 * lathe.axis("X").step_mm * np.sqrt(2)


def mill_figure(name: str = "engraving.ngc"):
    engraver = load_machine("engraver")
    path = resolve_program(name)
    program, plan = plan_compiled(load_program(path, engraver), engraver)
    log = execute(plan)
    sim = deliver(log, ["sim://"])
    return run_figure(log, sim, user_title(engraver, name, True), program.commands, path.read_text()), path


def test_a_mill_plot_has_a_side_view_with_its_plunges_marked():
    import matplotlib.pyplot as plt
    fig, path = mill_figure()
    top, side = fig.axes[0], fig.axes[1]
    assert (side.get_xlabel(), side.get_ylabel()) == ("X [mm]", "Z [mm]")
    plunges = len(re.findall(r"^(?:G91 )?G1 Z-", path.read_text(), re.M))
    assert plunges == 5                                   # the program's own "G1 Z-..." lines
    for ax in (top, side):
        marked = [ln for ln in ax.get_lines() if ln.get_label().startswith("plunge / drill point")]
        assert marked and len(marked[0].get_xdata()) == plunges
    zs = [y for ln in side.get_lines() if ln.get_label() == "cut (G1/G2/G3)" for y in ln.get_ydata() if y == y]
    assert min(zs) == pytest.approx(-0.3) and max(zs) == pytest.approx(2.0)   # cut 0.3 mm deep, from Z2
    assert top.child_axes == []                           # no error to see: no inset
    assert top.get_title() == "engraving.ngc on the engraver"     # no backlash: none named
    plt.close(fig)


def test_the_inset_names_the_summarys_worst_error(lathe, profile):
    import matplotlib.pyplot as plt

    from retrofit.run.report import build_report
    fig, log, sim = lathe_profile_figure(lathe, profile, comp=False)
    worst = max(ax["max_carriage_error_mm"] for ax in build_report(log, sim)["axes"].values())
    assert f"worst error {worst:.3f} mm" in fig.axes[0].child_axes[0].get_title()
    plt.close(fig)
