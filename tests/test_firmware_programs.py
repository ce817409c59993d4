"""Whole programs through ``retrofit run --output serial+socket://`` on the firmware in simavr.

The firmware runs on simavr's cycle-exact ATmega2560 (``retrofit.firmware.sim.Harness``, the
engine of ``retrofit firmware sim``), its AVR time as fast as simavr goes; the host is
``retrofit run`` itself. Where the carriages went is read from the step pins (the harness's log,
decoded by the driver model of ``sim://``), never from the firmware's own counters; the oracle
is the same program on ``sim://``.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from retrofit.cli import main
from retrofit.controller.program import run_commands
from retrofit.gcode import compile_program
from retrofit.machine.config import load_machine
from retrofit.sim import SimMachine

from tests.conformance.targets import missing_tools

pytestmark = pytest.mark.skipif(bool(missing_tools()), reason="the firmware needs avr-gcc, make "
                                "and libsimavr: apt-get install gcc-avr avr-libc libsimavr-dev")
fs = pytest.importorskip("retrofit.firmware.sim")

TOOL_CYCLE = "G21 G90\nT3 M6\nM3 S1000\nG0 X10 Y10\nG1 Z-5 F200\nT5 M6\nG0 X5 Y5\nT0 M6\nM2\n"
THREAD = ("G18 G21 G90\nG0 X12 Z3\nS300 M3\n"
          "G76 P1.5 Z-6 I-0.5 J0.3 K0.92 R2 Q0 H1\nG0 X20\nM5\nM2\n")
THREAD_RPM = 300


def run_report(prog: str, machine: str, output: str, name: str) -> dict:
    assert main(["run", prog, "--machine", machine, "--output", output, "--progress", "off",
                 "--report", f"{name}.json"]) == 0
    with open(f"{name}.json") as fh:
        return json.load(fh)


def on_firmware(prog: str, machine, spindle_rpm: float = 0.0):
    """``retrofit run`` of ``prog`` against the firmware; (the run's report, the pin log)."""
    harness = fs.Harness(fs.build(machine.name), machine, listen="127.0.0.1:0", speed=0,
                         spindle_rpm=spindle_rpm).start()
    try:
        remote = run_report(prog, machine.name, f"serial+socket://{harness.address}?wait_s=600",
                            "remote")
    finally:
        log = harness.stop()
    return remote, log


def pin_positions(log, machine, axis: str) -> tuple[np.ndarray, np.ndarray]:
    """(rise cycles, motor position after each step) of one axis, counted on its pins."""
    rises, _, dirs = fs.step_times(log, machine, axis)
    positive = dirs.astype(bool) ^ bool(machine.axis(axis).invert_dir)
    return rises, np.cumsum(np.where(positive, 1, -1))


def rests(rises: np.ndarray, position: np.ndarray, gap_cycles: int) -> list[int]:
    """The positions an axis stood still at for longer than ``gap_cycles`` between steps."""
    ends = np.flatnonzero(np.diff(rises) > gap_cycles)
    return [int(position[i]) for i in ends] + [int(position[-1])]


def check_same_end(local: dict, remote: dict, report: dict, machine) -> None:
    """The firmware ends where sim:// ends: RDPS, the carriages on the pins, no violation."""
    part = remote["remote"][0]
    expected = {name: machine.axis(name).to_steps(ax["target_mm"]) for name, ax in local["axes"].items()}
    assert part["position_steps"] == expected
    assert "ERROR" not in part["status"] and "STOPPED" not in part["status"]
    for name, ax in local["axes"].items():
        step_mm = 1 / machine.axis(name).steps_per_mm
        assert report["carriage_mm"][name] == pytest.approx(ax["carriage_mm"], abs=step_mm * 1.01), name
    assert local["violations"] == [] and report["violations"] == []


@pytest.mark.slow
def test_the_mill_tool_change_cycle_on_the_firmware_ends_where_sim_ends(tmp_path, monkeypatch):
    """T3 M6, moves, T5 M6, T0 M6 on tul-mill: the carousel homes, turns to pocket 3, back, to
    pocket 5 and home again; X, Y, Z and the carousel end where the sim:// run ends them."""
    monkeypatch.chdir(tmp_path)
    machine = load_machine("tul-mill")
    (tmp_path / "cycle.ngc").write_text(TOOL_CYCLE)
    local = run_report("cycle.ngc", machine.name, "sim://", "local")
    for record in tmp_path.glob("tul-mill.*"):
        record.unlink()                            # the second run starts with an empty spindle too
    remote, log = on_firmware("cycle.ngc", machine)
    check_same_end(local, remote, fs.report(log, machine), machine)
    atc = machine.parts["atc"]
    spm = machine.axis("E").steps_per_mm
    pockets = [round((atc.atc_offset + n) * spm) for n in (3, 5)]      # 992 and 1312 steps
    stops = [p for p in rests(*pin_positions(log, machine, "E"), fs.F_CPU // 50)
             if p >= atc.atc_offset * spm]           # not the homing's stops near the switch
    # pick T3, put T3 back, pick T5, put T5 back: the carousel rests at these pockets in turn
    assert stops == [pockets[0], pockets[0], pockets[1], pockets[1]]
    x, y = (rests(*pin_positions(log, machine, a), fs.F_CPU // 50) for a in "XY")
    assert round(atc.x1 * 100) in x and round(atc.y_point_b * 100) in y     # in the pocket


def helix_phase(steps: np.ndarray, revolutions: np.ndarray, per_rev: float) -> np.ndarray:
    """Carriage steps plus steps-a-revolution times the spindle angle: constant on one helix
    (defined modulo ``per_rev``; brought near 0 here)."""
    phi = steps + per_rev * revolutions
    return (phi + per_rev / 2) % per_rev - per_rev / 2


def cutting_passes(steps: np.ndarray, negative: np.ndarray, below: float) -> list[np.ndarray]:
    """Indices of each run of steps towards -Z (a pass), only where the carriage is ``below``."""
    down = np.flatnonzero(negative)
    return [g[steps[g] < below] for g in np.split(down, np.flatnonzero(np.diff(down) > 1) + 1)]


@pytest.mark.slow
def test_a_g76_thread_on_the_firmware_cuts_the_helix_sim_cuts(tmp_path, monkeypatch):
    """G76 on mitic-lathe, 11 passes at 300 rpm: on the firmware every step of every pass lies
    within one step of the helix the sim:// run cuts (Z steps against the spindle angle), and
    every step of each pass's lead-in within one step of sim://'s."""
    monkeypatch.chdir(tmp_path)
    machine = load_machine("mitic-lathe")
    (tmp_path / "g76.ngc").write_text(THREAD)
    z = machine.axis("Z")
    per_rev = 1.5 * z.steps_per_mm                                    # 120 Z steps a turn
    below = (3.0 - 2.5) * z.steps_per_mm                               # past every lead-in
    local = run_report("g76.ngc", machine.name, "sim://", "local")
    remote, log = on_firmware("g76.ngc", machine, spindle_rpm=THREAD_RPM)
    check_same_end(local, remote, fs.report(log, machine), machine)

    sim = SimMachine(machine)                       # sim://'s helix: carriage against the angle
    run_commands(list(compile_program(THREAD, machine, "g76.ngc").commands), machine, sim=sim)
    trace = sim.traces["Z"]
    ticks, motor = np.asarray(trace.ticks), np.asarray(trace.motor_steps)
    carriage = np.asarray(trace.carriage_mm) * z.steps_per_mm
    passes = cutting_passes(carriage, np.diff(motor, prepend=0) < 0, below)
    ref = np.concatenate([helix_phase(carriage[g], sim.spindle.revolutions_at(ticks[g]), per_rev)
                          for g in passes])
    assert len(passes) == 11 and np.ptp(ref) < 0.5

    rises, position = pin_positions(log, machine, "Z")                 # the firmware's, on its pins
    counts = machine.parts["spindle"].encoder_counts_per_rev
    iclk = np.array([c for c, port, bit, level in log.inputs if (port, bit, level) == ("D", 0, 1)])
    negative = np.diff(position, prepend=0) < 0
    fw_passes = cutting_passes(position, negative, below)   # the nut rests on its - face: carriage
    assert [len(g) for g in fw_passes] == [len(g) for g in passes]
    for g in fw_passes:
        angle = (np.searchsorted(iclk, rises[g], side="right") - 1) / counts   # index at count 0
        phi = helix_phase(position[g], angle, per_rev)
        assert np.abs(phi - np.median(ref)).max() <= 1.0

    # the lead-ins too: step by step, each whole pass against sim://'s (a lead-in lags the
    # helix by up to ~5 steps here), after its backlash take-up, which the clock times
    everything = float("inf")
    sim_whole = cutting_passes(carriage, np.diff(motor, prepend=0) < 0, everything)
    fw_whole = cutting_passes(position, negative, everything)
    takeup = round(z.backlash_mm * z.steps_per_mm)                   # 2 steps on each reversal
    assert [len(g) for g in fw_whole] == [len(g) for g in sim_whole]
    lead_dev = []
    for g, h in zip(sim_whole, fw_whole):
        ref_whole = helix_phase(carriage[g], sim.spindle.revolutions_at(ticks[g]), per_rev)
        angle = (np.searchsorted(iclk, rises[h], side="right") - 1) / counts
        phi = helix_phase(position[h], angle, per_rev)
        assert np.abs(phi - ref_whole)[takeup:].max() <= 1.0
        lead_dev.append(np.abs(ref_whole[takeup:] - np.median(ref)).max())
    assert min(lead_dev) > 2                                          # each pass leads in
