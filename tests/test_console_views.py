"""What the console's views compute from a run (no browser): steps decoded from the port frames,
pulse windows, the timeline's velocity, the measured feed of a move; its API's errors."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from retrofit.console.runreport import measured_feed
from retrofit.console.server import Console, command_list
from retrofit.console.views import PulseIndex, axis_steps, timeline
from retrofit.errors import RetrofitError
from retrofit.gcode.program import compile_program
from retrofit.machine.config import load_machine
from retrofit.run.program import execute, plan_compiled
from retrofit.run.runner import deliver

LONG_MOVE = "G21 G90\nG0 X5 Z1\nG1 Z-19 F150\nG0 X10\n"


@pytest.fixture(scope="module")
def lathe():
    return load_machine("chivu-lathe")


@pytest.fixture(scope="module")
def long_move(lathe):
    program, plan = plan_compiled(compile_program(LONG_MOVE, lathe, "long.ngc"), lathe)
    log = execute(plan)
    return log, deliver(log, ["sim://"])


def test_steps_decoded_from_the_frames_are_the_motors_steps(lathe, long_move):
    log, sim = long_move
    steps = axis_steps(log.frames, lathe)
    for i, axis in enumerate(lathe.axes):
        assert len(steps[i].ticks) == log.steps_emitted[axis.name]
        assert steps[i].at(np.array([log.frames.end_tick]))[0] == sim.motor_steps[i]


def test_pulse_window_shows_single_pulses_of_the_machines_width(lathe, long_move):
    log, _ = long_move
    index = PulseIndex(log.frames, lathe)
    rise = int(axis_steps(log.frames, lathe)[1].ticks[100])          # the 101st Z step
    window = index.window(rise - 50, rise + 200)
    z_step = window["levels"][window["lines"].index("Z step")]
    ticks = window["ticks"]
    start = ticks.index(rise)
    assert z_step[start] == 1 and z_step[start - 1] == 0
    end = next(t for t, level in zip(ticks[start:], z_step[start:]) if level == 0)
    assert end - rise == lathe.axis("Z").pulse_high_ticks


def test_a_whole_run_window_counts_every_edge_of_every_line(lathe, long_move):
    log, _ = long_move
    window = PulseIndex(log.frames, lathe).window(0, log.frames.end_tick, limit=1000)
    assert "bands" in window and len(window["bands"]["counts"][0]) == 500
    for name, counts in zip(window["lines"], window["bands"]["counts"]):
        if name.endswith("step"):
            assert sum(counts) == 2 * log.steps_emitted[name.split()[0]]       # rising and falling


def test_timeline_velocity_holds_the_programmed_feed_mid_move(lathe, long_move):
    log, sim = long_move
    steps = axis_steps(log.frames, lathe)
    start, end = (w.reached_tick for w in log.waypoints[:2])
    mid = (start + end) // 2
    span = int(1.0 / lathe.tick_s)
    tl = timeline(steps, lathe, mid - span, mid + span, points=50)
    v = np.array(tl["axes"]["Z"]["velocity_mm_min"][5:-5])
    assert np.median(v) == pytest.approx(-150, rel=0.02)
    assert measured_feed(steps, lathe, start, end) == pytest.approx(150, rel=0.005)


def test_velocity_and_acceleration_are_smooth_means_over_a_stated_window(lathe, long_move):
    """At a constant feed every sample of the velocity is the feed (not a step more or less in
    a window), the acceleration 0; the window is stated."""
    log, _ = long_move
    steps = axis_steps(log.frames, lathe)
    start, end = (w.reached_tick for w in log.waypoints[:2])
    mid, span = (start + end) // 2, int(2.0 / lathe.tick_s)
    tl = timeline(steps, lathe, mid - span, mid + span, points=400)
    assert tl["window_s"] == pytest.approx(0.05)
    z = tl["axes"]["Z"]
    assert np.allclose(z["velocity_mm_min"], -150, rtol=0.01)
    assert np.abs(z["accel_mm_s2"]).max() < 1.0            # the axis accelerates at up to 500 mm/s²


def test_command_list_errors_name_the_file_and_line():
    assert [str(c) for c in command_list("FMOV X5 Z1\n# a comment\nTOOL T2\n", "t.cmds").commands] == \
        ["FMOV X5 Z1", "TOOL T2"]
    with pytest.raises(RetrofitError, match=r"^t\.cmds:2: "):
        command_list("FMOV X5\nFMOVE X3\n", "t.cmds")


def test_console_refuses_a_run_without_a_program(lathe):
    with pytest.raises(RetrofitError, match="no program open"):
        Console(lathe).start()


def test_api_answers_bad_input_with_one_line_naming_the_line(lathe):
    from console_kit import Served
    served = Served(Console(lathe))
    try:
        served.take_control()
        status, answer = served.call("POST", "/api/open", {"name": "bad.ngc", "text": "G0 X1\nG1 Z-2 Q7\n"})
        assert status == 400
        assert answer["error"].startswith("bad.ngc:2:") and "\n" not in answer["error"]
    finally:
        served.close()


def test_console_command_rejects_a_bad_listen_address():
    proc = subprocess.run([sys.executable, "-m", "retrofit.cli", "console", "--listen", "localhost:http"],
                          capture_output=True, text=True, timeout=60)
    assert proc.returncode == 2
    assert proc.stderr.strip() == ("retrofit: error: --listen 'localhost:http': expected HOST:PORT with a "
                                   "port 0..65535, e.g. 127.0.0.1:8080")
