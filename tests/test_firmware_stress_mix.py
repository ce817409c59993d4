"""The mixed stress run on the firmware in simavr (retrofit.firmware.stress_mix): random moves up to
and above the firmware's ceiling on 1-4 axes, homing and thread passes, RDST polled every 2-20 ms,
garbage and dropped bytes, the host in lockstep with the AVR's time. At every rest RDPS equals the
plan (the commanded moves' sum, the home positions) and so do the step pins at the cycle of the
answer; no RDST says ERROR or STEP_ERROR; the board never restarts.

Oracles: the commanded steps and home positions (summed by the generator, not the firmware), the
step pins (decoded here from the pin log in the main stage; counted by the harness as each byte
leaves in the long run, which logs no pins).
"""

from __future__ import annotations

import dataclasses
import shutil

import pytest

from retrofit.machine.config import load_machine

pytestmark = pytest.mark.skipif(
    shutil.which("avr-gcc") is None or shutil.which("make") is None,
    reason="the firmware needs avr-gcc and make: apt-get install gcc-avr avr-libc make libsimavr-dev")

fs = pytest.importorskip("retrofit.firmware.sim")
mx = pytest.importorskip("retrofit.firmware.stress_mix")

#: the slow stage's long run: chunks of at least CHUNK_S simulated seconds, each a fresh board
#: with seed LONG_SEED * 10 000 + chunk, CHUNKS of them: ten simulated minutes in all, every one
#: in every CI run
LONG_SEED, CHUNKS, CHUNK_S = 1, 120, 5.0


@pytest.fixture(scope="module")
def mix(tmp_path_factory):
    machine = load_machine(mx.MACHINE)
    return machine, fs.build_copy(machine, tmp_path_factory.mktemp("mix"))


def held(run, machine):
    problems = mx.check(run, machine)
    assert not problems, "\n".join(problems[:10])


@pytest.mark.parametrize("seed,spindle_rpm", [(37, 0.0), (52, 480.0)], ids=["spindle-model", "encoder-480rpm"])
def test_moves_homing_and_threads_mixed_end_every_rest_where_the_plan_does(mix, seed, spindle_rpm):
    """Two short seeds, each with moves, a homing and thread passes (with the spindle model in
    the loop, and with an encoder at a fixed speed); bytes dropped from frames at twice the long
    run's rate, so that so short a run surely has its frames refused and sent again."""
    machine, elf = mix
    run = mx.mix_run(elf, machine, seed=seed, parts=4, spindle_rpm=spindle_rpm, drop=0.04)
    kinds = {p.kind for p in run.parts}
    assert kinds == {"moves", "home", "thread"}, kinds
    held(run, machine)
    assert run.garbage_bytes > 0 and run.link["timeouts"] + run.link["naks"] > 0
    # the check is not blind: a home or a thread's end one step off the plan is caught
    for kind in ("home", "thread"):
        part = next(p for p in run.parts if p.kind == kind)
        axis = (part.homed or [a for a in part.end])[0]
        part.end[axis] += 1
        assert any(f"({kind}): RDPS" in p for p in mx.check(run, machine)), kind
        part.end[axis] -= 1
    # the harness's own counts, which the long run checks instead of the pin log, are the pins'
    positions = [c for c, r in mx.answer_cycles(run.log, machine) if type(r).__name__ == "Position"]
    assert mx.counts_at(run, machine, positions) == mx.pins_at(run, machine, positions)
    counted = dataclasses.replace(run, log=dataclasses.replace(run.log, ports={}))
    assert not mx.check(counted, machine)
    y = [a.name for a in fs.firmware_axes(machine)].index("Y")      # (never homed)
    counted.sent = [(c, b, tuple(n + (k == y and c == positions[-1]) for k, n in enumerate(counts)))
                    for c, b, counts in run.sent]       # one step more on Y at the last RDPS
    assert any("the pins" in p for p in mx.check(counted, machine))


def test_the_board_that_restarted_with_the_encoder_turning_holds(mix):
    """The long run's board 116 (seed 10 116, the encoder at a fixed 492 rpm) restarted 3.3
    simulated seconds in: a three-axis line at 1:0.99:0.89 ran at 40 000 events/s, the step
    interrupt took 92 % of the CPU and the encoder's, counting for no line, 5 % more; the main
    loop, planning a short move, did not turn for 50 ms and the stall guard reset the board.
    Now the encoder's interrupt is off outside a thread and such a line is held to the sum of
    steps a second: its first 3.5 simulated seconds end every rest where the plan does."""
    machine, elf = mix
    seed = LONG_SEED * 10_000 + 116
    run = mx.mix_run(elf, machine, seed=seed, parts=60, min_s=3.5, spindle_rpm=492.0, pins=False)
    assert mx.simulated_s(run) >= 3.5
    held(run, machine)


@pytest.mark.slow
@pytest.mark.parametrize("chunk", range(CHUNKS))
def test_ten_simulated_minutes_of_mixed_stress(mix, chunk):
    """One of CHUNKS fresh boards, at least CHUNK_S simulated seconds each: moves up to 60 kHz
    asked, homing, threads (the encoder's speed drawn per chunk); no pin log, the harness's
    counts checked."""
    machine, elf = mix
    seed = LONG_SEED * 10_000 + chunk
    rpm = 0.0 if chunk % 2 else 200.0 + (seed * 37) % 400
    run = mx.mix_run(elf, machine, seed=seed, parts=60, min_s=CHUNK_S, spindle_rpm=rpm, pins=False)
    held(run, machine)
    assert mx.simulated_s(run) >= CHUNK_S


@pytest.mark.parametrize("rate", [40_000, 100_000])
def test_a_homing_seek_asked_above_what_the_slow_tick_keeps_ends_on_its_switch(mix, rate):
    """Z seeks its switch 5 000 steps away at a fast feed of ``rate`` steps/s (100 000: the
    machine's rapid) with RDST every 2 ms. A line that watches a switch is stepped by the slow
    tick; before, 40 000 crashed the board (interrupts nested without end) and 100 000 (clamped to
    47 500) stopped it 147 steps into the seek, interrupts off for 1.5 ms. Now (clamped to
    20 000): one start line, RDPS the home position, the carriage at its switch within the
    latch's resolution."""
    from retrofit.link import QUEUED

    from tests.test_firmware_sim import Script, replies
    machine, elf = mix
    end = 2_000_000 + int(5_000 / 20_000 * fs.F_CPU) + 16_000_000
    script = Script(machine).at(1_500_000, f"FFDR F{rate * 60 / 1000:.3f}").at(2_000_000, "ZMOV Z")
    for t in range(2_000_000, end - 1_000_000, 32_000):
        script.at(t, "RDST")
    script.at(end - 500_000, "RDPS", QUEUED)
    log = fs.Harness(elf, machine, script=script.items, cycles=end, start_steps={"Z": 45_000}).run()
    assert log.answer_bytes().count(b"retrofit firmware") == 1
    position = [r for r in replies(log, machine) if type(r).__name__ == "Position"][-1]
    assert dict(position.steps)["Z"] == 50_000
    z = dict(zip([a.name for a in fs.firmware_axes(machine)], log.steps))["Z"]
    assert abs(z - 50_000) <= mx.latch_steps(machine, "Z")
