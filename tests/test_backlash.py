"""Backlash compensation against a simulated screw with a real dead band."""

from hypothesis import given, settings
from hypothesis import strategies as st

from tests.helpers import lathe, run_targets

positions = st.tuples(st.integers(-40, 40), st.integers(-50, 50))   # steps of X, Z


@settings(max_examples=60)
@given(st.lists(positions, min_size=2, max_size=10))
def test_compensated_carriage_reaches_every_target(targets):
    machine = lathe(dead_band_equals_comp=True)
    log, sim = run_targets(machine, targets)
    for w in log.waypoints:
        state = sim.state_at(w.reached_tick)
        for i, axis in enumerate(machine.axes):
            error_steps = abs(state[axis.name][1] - axis.to_mm(w.steps[i])) * axis.steps_per_mm
            assert error_steps <= 1.0 + 1e-9, (axis.name, w, error_steps)
    assert sim.violations == []


@settings(max_examples=60)
@given(st.lists(positions, min_size=2, max_size=10))
def test_without_compensation_each_reversal_shows_the_dead_band(targets):
    machine = lathe(dead_band_equals_comp=True)
    log, sim = run_targets(machine, targets, backlash_comp=False)
    for i, axis in enumerate(machine.axes):
        band = machine.sim.dead_band_mm[axis.name]
        prev_target, prev_dir, prev_error, prev_len = 0, 0, 0.0, 0
        for w in log.waypoints:
            move = w.steps[i] - prev_target
            error = axis.to_mm(w.steps[i]) - sim.state_at(w.reached_tick)[axis.name][1]
            direction = (move > 0) - (move < 0)
            full = band * axis.steps_per_mm
            if direction and prev_dir and direction != prev_dir and abs(move) >= full and prev_len >= full:
                # the carriage lags by the whole dead band after a turn to +, and catches up after a turn to -
                assert abs(abs(error - prev_error) - band) < 1e-9, (axis.name, w, error, prev_error)
            if direction:
                prev_dir, prev_len = direction, abs(move)
            prev_target, prev_error = w.steps[i], error


def test_compensation_switch_changes_only_the_carriage_error():
    machine = lathe(dead_band_equals_comp=True)
    targets = [(40, 50), (-40, -50), (40, 50)]
    on_log, on_sim = run_targets(machine, targets, True)
    off_log, off_sim = run_targets(machine, targets, False)
    assert on_sim.carriage_mm("X") == 1.0 and on_sim.carriage_mm("Z") == 1.0
    assert off_sim.carriage_mm("X") == 1.0 - 0.10 and round(off_sim.carriage_mm("Z"), 9) == 1.0 - 0.08
    assert on_log.steps_emitted["X"] > off_log.steps_emitted["X"]       # the extra steps of the clearance
