"""The console and ``retrofit run`` share one run: the same program on the same machine ends at the
same carriage positions after the same steps and machine time, with the same violations at the
same lines (the changer's magazine checked in both), the same tool changes, and probing (G38) on
the simulated machine in both."""

from __future__ import annotations

import time
from types import SimpleNamespace

import pytest

from retrofit.console.server import Console
from retrofit.machine.config import load_machine
from retrofit.run.program import STAGE_WEIGHTS, pause_tick, read_program, run_program
from retrofit.run.progress import silent

#: the spindle drives into the magazine where no pocket stands (the carousel at home)
INTO_THE_MAGAZINE = "G21 G90\nG0 X23 Y28 Z-45\nG1 Y44 F800\nG0 Y10\nM30\n"
#: a change to T3 by the carousel, then a cut
CHANGE = "G21 G90\nG0 X10 Y10 Z-5\nT3\nG1 X20 Y5 Z-10 F300\nM30\n"
#: the tool's length measured on the setter (G38.2), then a move to the measured height
PROBE = "G21 G90\nG0 Z-18\nG0 X8 Y8\nG38.2 Z-45 F60\nG0 Z[#5063 + 2]\nM30\n"


def by_cli(text: str, name: str, machine, tool: int) -> dict:
    opts = SimpleNamespace(backlash_comp=True, reference=False, controller=False, urls=["sim://"],
                           keep_frames=True, keep_commands=True, before_outputs=None)
    from retrofit.console.tools import SpindleTools
    from retrofit.machine.tooltable import ToolTable
    table = ToolTable.load(SpindleTools(machine, []).table_path)
    return run_program(text, name, machine, opts, silent(STAGE_WEIGHTS), tool_table=table,
                       spindle_tool=tool).report


def by_console(text: str, name: str, machine) -> tuple[dict, int]:
    console = Console(machine)
    try:
        tool = console.tools.tool()
        console.open(name=name, text=text)
        console.start(0)
        end = time.monotonic() + 120
        while console.state()["state"] not in ("done", "error") and time.monotonic() < end:
            time.sleep(0.05)
        assert console.state()["state"] == "done", console.state()
        return console.report(), tool
    finally:
        console.close()


def seen(report: dict) -> dict:
    return {"axes": {k: (v["carriage_mm"], v["steps"]) for k, v in report["axes"].items()},
            "ticks": report["ticks"], "violations": [(v["kind"], v["axis"], v["line"]) for v in report["violations"]]}


@pytest.mark.parametrize("program,machine", [pytest.param("lathe-profile.ngc", "chivu-lathe", marks=pytest.mark.slow), (INTO_THE_MAGAZINE, "tul-mill"),
                                             pytest.param(CHANGE, "tul-mill", marks=pytest.mark.slow),
                                             (PROBE, "tul-mill")],
                         ids=["lathe-profile", "into-the-magazine", "carousel-change", "g38-probe"])
def test_the_console_runs_what_retrofit_run_runs(program, machine, tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_STATE_HOME", str(tmp_path))     # a spindle record of this test's own
    m = load_machine(machine)
    if program is PROBE:                                     # T1 in the spindle: it breaks the beam
        from retrofit.console.tools import SpindleTools
        SpindleTools(m, []).store.save(1)
    text, name = read_program(program) if program.endswith(".ngc") else (program, "job.ngc")
    console, tool = by_console(text, name, m)
    cli = by_cli(text, name, m, tool)
    assert seen(console) == seen(cli)
    if program is INTO_THE_MAGAZINE:
        assert seen(console)["violations"] == [("pocket_misaligned", "ATC", 3)]
    if program is PROBE:
        assert console["axes"]["Z"]["carriage_mm"] == pytest.approx(-52.0 + 20.0 + 2.0, abs=0.011)   # T1 is 20 mm
    if program is CHANGE:
        changes = [e["text"] for e in console["events"] if e["kind"] == "tool change"]
        assert changes == [f"tool change T{tool} -> T3 by the changer (condition 1)"] == \
            [c["says"] for c in cli["tool"]["changes"]]


@pytest.mark.parametrize("text", ["G21 G90\nG0 X10\nM62 P0\nG1 Z-5 F300\nM63 P0\nM30\n",
                                  "G21 G90\nG0 X10\nM66 P0 L3 Q2\nG1 Z-5 F300\nM30\n"], ids=["m62", "m66"])
def test_digital_outputs_and_input_waits_are_refused_not_skipped(text, tmp_path, monkeypatch):
    """The console's controller makes no M62-M66 (retrofit run writes them in the port byte): the
    console refuses such a program, naming its line, instead of running it without them."""
    monkeypatch.setenv("XDG_STATE_HOME", str(tmp_path))
    from retrofit.errors import GcodeError
    console = Console(load_machine("chivu-lathe"))
    try:
        with pytest.raises(GcodeError, match=r"^io\.ngc:3: .*M62-M66"):
            console.open(name="io.ngc", text=text)
        assert console.program is None
        with pytest.raises(GcodeError, match=r'^MDI "M62 P0": .*M62-M66'):
            console.act("mdi", text="M62 P0")
    finally:
        console.close()


def test_a_pause_stops_the_axes_in_both(tmp_path, monkeypatch):
    """M0 and a manual change (T2 M6): retrofit run brings the axes to rest before each pause, as
    the console's run does (it blended through a pause before: a real output stopped at speed).
    The steps are the same, tick for tick, up to the first pause; after each pause the console's
    controller starts again once its last pulse has ended, a few ticks later."""
    monkeypatch.setenv("XDG_STATE_HOME", str(tmp_path))
    from retrofit.console.views import axis_steps
    machine = load_machine("chivu-lathe")
    text = "G21 G90\nG0 X5 Z1\nG1 Z-10 F300\nM0\nG1 X10 Z-12\nT2 M6\nG0 Z2\nM30\n"
    console = Console(machine)
    try:
        console.open(name="job.ngc", text=text)
        console.start(0)
        end = time.monotonic() + 120
        while console.state()["state"] != "done" and time.monotonic() < end:
            if console.state().get("dialog"):
                console.act("answer")
            time.sleep(0.02)
        steered = [s.ticks for s in axis_steps(console.frames(), machine)]
        in_console = console.report()
    finally:
        console.close()
    opts = SimpleNamespace(backlash_comp=True, reference=False, controller=False, urls=["sim://"],
                           keep_frames=True, keep_commands=True, before_outputs=None)
    run = run_program(text, "job.ngc", machine, opts, silent(STAGE_WEIGHTS))
    planned = [s.ticks for s in axis_steps(run.log.frames, machine)]
    first_pause = pause_tick(run, run.expanded.pauses[0].index)
    for a, b in zip(steered, planned):
        assert len(a) == len(b)
        assert list(a[a <= first_pause]) == list(b[b <= first_pause])       # the same up to M0
        late = a - b
        assert 0 <= late.min() and late.max() <= 2 * 5                      # 4 ticks a pause on this lathe
    assert seen(in_console)["axes"] == seen(run.report)["axes"]
