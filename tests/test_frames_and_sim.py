"""Port frames through the pin map, and the simulator reading them like a driver would."""

from dataclasses import replace

import numpy as np

from retrofit.frames import PinMap, PortFrames
from retrofit.machine.config import load_machine
from retrofit.sim import SimMachine

from tests.helpers import run_targets


def test_paper_bit_map_b0_to_b3():
    pins = PinMap(load_machine("chivu-lathe"))           # axes X, Z
    # X step (b2) and Z direction right (b1)
    assert pins.byte([1, 0], [-1, 1]) == 0b0110
    assert pins.byte([0, 1], [1, -1]) == 0b1001


def test_inverted_pins_flip_on_the_wire_and_the_machine_still_moves_right():
    m = load_machine("chivu-lathe")
    inverted = replace(m, axes=(replace(m.axes[0], invert_step=True, invert_dir=True), m.axes[1]))
    pins = PinMap(inverted)
    assert pins.byte([0, 0], [-1, -1]) == 0b1100          # idle X step line sits high
    log_a, sim_a = run_targets(m, [(10, -7)])
    log_b, sim_b = run_targets(inverted, [(10, -7)])
    assert not np.array_equal(log_a.frames.values, log_b.frames.values)
    assert sim_a.motor_steps == sim_b.motor_steps == [10 + 4, -7]   # X took up its clearance turning +


def test_byte_written_once_per_tick_all_bits_together():
    log, _ = run_targets(load_machine("chivu-lathe"), [(3, 3)])
    per_tick = log.frames.per_tick()
    assert len(per_tick) == log.frames.end_tick
    # both step bits rise in the same frame when both axes start together
    x_step = (per_tick >> 2) & 1
    z_step = per_tick & 1
    assert np.array_equal(np.flatnonzero(np.diff(x_step.astype(int)) == 1),
                          np.flatnonzero(np.diff(z_step.astype(int)) == 1))
    assert PortFrames.from_per_tick(per_tick) == log.frames


def test_sim_flags_short_pulses_and_direction_at_the_edge():
    m = load_machine("chivu-lathe")                      # needs high 2, low 2, set-up 1, hold 1
    z_step, z_dir = 1, 2
    ticks = [0, 5, 6, 7, 8, 20, 22]
    values = [0, z_step, 0, z_step | z_dir, z_dir, z_step, 0]
    sim = SimMachine(m)
    sim.feed(PortFrames(ticks, values, 30))
    kinds = [(v.tick, v.kind) for v in sim.violations]
    assert (6, "pulse_high") in kinds                     # 1 tick high
    assert (7, "pulse_low") in kinds                      # 1 tick low
    assert (7, "dir_setup") in kinds                      # direction changed with the edge
    assert (20, "dir_setup") in kinds                     # direction dropped with the next edge
    assert sim.motor_steps[1] == -1 + 1 - 1               # dir low at tick 5, high at 7, low at 20
    held = replace(m, axes=(m.axes[0], replace(m.axes[1], dir_hold_ticks=3)))
    sim = SimMachine(held)
    sim.feed(PortFrames([0, 4, 6], [z_dir, z_dir | z_step, 0], 12))
    assert [(v.tick, v.kind) for v in sim.violations] == [(6, "dir_hold")]   # dropped 2 ticks after the edge


def test_sim_reports_leaving_the_travel():
    m = load_machine("chivu-lathe")
    small = replace(m, axes=(replace(m.axes[0], max_mm=0.1), m.axes[1]))
    _, sim = run_targets(small, [(8, 0)])               # 0.2 mm > 0.1 mm
    assert [v.kind for v in sim.violations] == ["travel"]
