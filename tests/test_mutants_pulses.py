"""The controller's output stage (``motion.pulses``) tick by tick, against timings worked by hand:
a step deferred by the period, a reversal held by the direction's hold and set-up times, the
following error, and what STOP leaves of the requests."""

from __future__ import annotations

from dataclasses import replace

from retrofit.machine.config import load_machine
from retrofit.motion.pulses import PulseShaper

#: X pulses 2 ticks high and 3 low (a period of 5), its direction held 2 ticks after a rise and
#: set up 1 tick before one
LATHE = load_machine("chivu-lathe")
MACHINE = replace(LATHE, axes=(replace(LATHE.axes[0], pulse_high_ticks=2, pulse_low_ticks=3, dir_setup_ticks=1,
                                       dir_hold_ticks=2), LATHE.axes[1]))


def run(shaper, ticks, hint=lambda axis: 0):
    """X's (step bit, direction) on each frame 0..ticks-1, the shaper asked after each frame."""
    return run_from(shaper, 0, ticks, hint)


def test_a_step_waits_for_the_period_and_a_reversal_for_the_hold_then_the_set_up():
    shaper = PulseShaper(MACHINE)
    for due, direction in ((1, -1), (2, -1), (8, +1)):
        shaper.request(0, due, direction)
    assert shaper.requested() == (3, 0) and shaper.heading(0) == -1 and shaper.next_due() == 1
    frames = run(shaper, 16)
    # rises on 1 (as wanted), 6 (one period later), 11: the turn could come on 8 (2 ticks after the
    # rise on 6) and the step a period after 6, at 11, which is after the set-up
    assert [t for t, (s, _) in enumerate(frames) if s] == [1, 2, 6, 7, 11, 12]
    assert [d for _, d in frames] == [-1] * 8 + [1] * 8
    assert shaper.rises[0] == [1, 6, 11] and shaper.motor == [-1, 0]
    assert shaper.lag() == 0 and not shaper.pending and shaper.next_due() is None and shaper.heading(0) == 0
    assert not shaper.busy and shaper.still()


def test_the_following_error_counts_steps_wanted_but_not_yet_risen():
    shaper = PulseShaper(MACHINE)
    for due in (1, 2, 3, 4):
        shaper.request(0, due, -1)
    run(shaper, 20)
    # rises 1, 6, 11, 16: by tick 6 four steps were wanted and only two had risen
    assert shaper.rises[0] == [1, 6, 11, 16] and shaper.lag() == 2
    assert PulseShaper(MACHINE).lag() == 0


def test_a_set_up_time_defers_the_first_step_after_a_turn():
    timing = dict(pulse_high_ticks=1, pulse_low_ticks=1, dir_setup_ticks=3, dir_hold_ticks=0)
    shaper = PulseShaper(replace(LATHE, axes=(replace(LATHE.axes[0], **timing), LATHE.axes[1])))
    shaper.request(0, 1, +1)
    frames = run(shaper, 6)
    assert [d for _, d in frames] == [-1, 1, 1, 1, 1, 1]        # turned for frame 1
    assert shaper.rises[0] == [4]                                 # 3 ticks after the turn


def test_stop_drops_the_requests_not_started_and_lets_the_pulse_under_way_finish():
    shaper = PulseShaper(MACHINE)
    for due in (1, 2, 3):
        shaper.request(0, due, -1)
    shaper.request(1, 5, +1)
    frames = run(shaper, 2)                                       # X's first pulse rises on 1
    shaper.clear()
    assert not shaper.pending and shaper.requested() == (1, 0) and shaper.wanted == [[1], []]
    assert shaper.busy and not shaper.still()
    frames += run_from(shaper, 2, 6)
    assert [s for s, _ in frames] == [0, 1, 1, 0, 0, 0, 0, 0]
    assert shaper.motor == [-1, 0] and not shaper.busy and shaper.still()


def test_an_idle_axis_turns_ahead_on_the_hint_and_frames_settle_until_a_step_is_due():
    shaper = PulseShaper(MACHINE)
    assert shaper.settled(0, lambda axis: 0)
    assert not shaper.settled(0, lambda axis: +1 if axis == 0 else 0)      # X would turn
    frames = run(shaper, 3, hint=lambda axis: +1 if axis == 0 else 0)
    assert [d for _, d in frames] == [-1, 1, 1]                              # turned for frame 1
    shaper.request(0, 10, +1)
    assert shaper.settled(3, lambda axis: 0)                      # nothing rises on 3
    shaper.skip(6)                                                # frames 3..8 repeat
    frames = run_from(shaper, 9, 1)                               # after frame 9: X rises on 10
    assert shaper.rises[0] == [10] and not shaper.settled(10, lambda axis: 0)
    frames += run_from(shaper, 10, 3)
    assert [s for s, _ in frames] == [0, 1, 1, 0] and shaper.settled(13, lambda axis: 0)


def run_from(shaper, first, ticks, hint=lambda axis: 0):
    """:func:`run` from frame ``first`` on."""
    out = []
    for tick in range(first, first + ticks):
        steps, dirs = shaper.pins.decode(shaper.frame(tick))
        out.append((steps[0], dirs[0]))
        shaper.shape(tick, hint)
    return out
