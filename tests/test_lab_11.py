"""Lab 11's checks are held to retrofit's controller: the model in labs/11_command_pipeline/checks.py
(written apart from retrofit, so a student's file cannot reach it) gives the controller's queue,
window, entry executing, replies and position on random command streams, event by event, and its
Bresenham points are those of the controller's executor at every cycle."""

import random
from pathlib import Path

import pytest

from retrofit.commands import parse_command
from retrofit.controller import Controller
from retrofit.controller.prepare import LineEntry
from retrofit.lab.core import load_module
from retrofit.link.replies import Busy, Err, Position, Status, StatusFlags
from retrofit.motion.bresenham import BresenhamExecutor, prepare_line
from retrofit.motion.planner import kinematics

CHECKS = load_module(Path(__file__).resolve().parent.parent / "labs" / "11_command_pipeline" / "checks.py")


def model_view(model):
    moves = [e for e in model.prepared if e["kind"] == "move"]
    return {"queue": list(model.queue), "prepared": [e["cmd"] for e in model.prepared],
            "executing": model.executing["cmd"] if model.executing else None,
            "stopped": model.stopped, "error": model.error,
            "ends": [tuple(e["end"]) for e in moves], "starts": [tuple(e["start"]) for e in moves],
            "speeds": [round(kinematics(model.m, tuple(e["start"]), tuple(e["end"]), e["feed"] / 60).v_max_mm_s, 9)
                       for e in moves],
            "offsets": [tuple(e["offset"]) for e in model.prepared if e["kind"] == "pstn"]}


def controller_view(ctl):
    proc = ctl.processor
    lines = [e for e in proc.window if isinstance(e, LineEntry)]
    return {"queue": [str(c) for c in ctl.queue], "prepared": [str(e.cmd) for e in proc.window],
            "executing": str(proc.run.entry.cmd) if proc.run is not None else None,
            "stopped": proc.stopped, "error": proc.error,
            "ends": [tuple(e.end) for e in lines], "starts": [tuple(e.start) for e in lines],
            "speeds": [round(e.kin.v_max_mm_s, 9) for e in lines],
            "offsets": [tuple(e.offsets) for e in proc.window if str(e.cmd).startswith("PSTN")]}


def reply_of(reply, machine):
    """The controller's reply in the model's words."""
    if reply is None:
        return "OK"
    if isinstance(reply, Busy):
        return "BUSY"
    if isinstance(reply, Err):
        return "ERR"
    if isinstance(reply, Status):
        flags = reply.flags
        return {"queued": reply.queued, "queue_full": bool(flags & StatusFlags.QUEUE_FULL),
                "stopped": bool(flags & StatusFlags.STOPPED), "error": bool(flags & StatusFlags.ERROR)}
    assert isinstance(reply, Position)
    steps = dict(reply.steps)
    return [steps[name] for name in machine.axis_names]


def advance_model(model):
    before = model.executing
    for _ in range(10**6):
        model.tick()
        if model.executing is not None and model.executing is not before:
            return
        if model.executing is None and not model.prepared and not model.queue:
            return
    raise AssertionError("the model never moved on")


def advance_controller(ctl):
    proc, before = ctl.processor, ctl.processor.run

    def moved_on():
        return (proc.run is not None and proc.run is not before) or \
            (proc.run is None and not proc.window and not ctl.queue)
    assert ctl._run(10**9, moved_on), "the controller never moved on"


def play(seed, machine, events=120):
    """Random commands and 'until the next entry starts', to both; the first difference or None."""
    rng = random.Random(seed)
    model, ctl = CHECKS.Model(machine), Controller(machine, backlash_comp=False)
    compared = 0
    for k in range(events):
        if rng.random() < 0.6:
            text = str(parse_command(CHECKS._command(rng, machine)))
            want = model.submit(text)
            want = "OK" if want is None else want
            got = reply_of(ctl.submit(parse_command(text)), machine)
            if isinstance(want, dict):
                want = {key: want[key] for key in got}
            if isinstance(want, list) and not (ctl.idle and not ctl.processor.error and not ctl.processor.stopped):
                want = got = "position while moving or after a halt: the motor lags the cycles by a pulse"
            compared += isinstance(want, list)
            event = text
        else:
            advance_model(model)
            advance_controller(ctl)
            want = got = None
            event = "until the next entry starts"
        if want != got or model_view(model) != controller_view(ctl):
            return (f"seed {seed}, event {k} ({event}): reply {want} != {got}\n"
                    f"{model_view(model)}\n{controller_view(ctl)}")
    return None


@pytest.mark.parametrize("name", list(CHECKS.MACHINES))
def test_the_checks_model_is_the_controller_on_random_streams(name):
    machine = CHECKS.MACHINES[name]()
    differences = [d for d in (play(seed, machine) for seed in range(8)) if d]
    assert not differences, differences[0]


def test_the_checks_bresenham_is_the_controllers():
    rng = random.Random(3)
    for _ in range(300):
        start = [rng.randint(-50, 50) for _ in range(rng.randint(1, 4))]
        end = [s + rng.choice([0, rng.randint(-60, 60)]) for s in start]
        executor = BresenhamExecutor(prepare_line(tuple(start), tuple(end)))
        assert CHECKS._point(start, end, 0) == start
        for cycle in range(1, executor.move.n + 1):
            executor.step()
            assert CHECKS._point(start, end, cycle) == list(executor.position), (start, end, cycle)


def test_the_checks_reach_no_module_a_student_file_can_import():
    """The checks' model is their own: they import retrofit only for machines and messages."""
    text = (Path(CHECKS.__file__)).read_text(encoding="utf-8")
    imports = {line.split()[1] for line in text.splitlines() if line.startswith(("import ", "from "))}
    assert imports <= {"random", "dataclasses", "pytest", "retrofit.machine.config", "retrofit.lab.core"}, imports
