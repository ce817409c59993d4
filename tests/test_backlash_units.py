"""backlash/ on its own: the compensator's shift on a reversal and the dead band's carriage, step by
step, against positions worked by hand."""

from __future__ import annotations

import pytest

from retrofit.backlash import BacklashCompensator, DeadBand


@pytest.mark.parametrize("clearance, position, direction, expected", [
    (3, 100, +1, 97),          # turning positive: the clearance is taken off the position
    (3, 100, -1, 103),         # turning negative: it is added
    (0, 100, +1, 100),
    (7, -20, -1, -13),
])
def test_a_reversal_shifts_the_position_by_the_clearance(clearance, position, direction, expected):
    assert BacklashCompensator(clearance).on_reversal(position, direction) == expected


def test_a_disabled_compensator_leaves_the_position_alone():
    comp = BacklashCompensator(5, enabled=False)
    assert comp.clearance == 0
    assert comp.on_reversal(40, +1) == 40 and comp.on_reversal(40, -1) == 40


def test_a_negative_clearance_is_refused_and_says_what_is_accepted():
    with pytest.raises(ValueError, match=r"clearance must be >= 0 steps, not -1"):
        BacklashCompensator(-1)


def test_the_dead_band_lags_the_carriage_when_moving_positive_and_holds_it_on_reversal():
    band = DeadBand(2.5)
    carriage = [band.move_motor(d) for d in (+1, +1, +1, +1, -1, -1, -1, -1)]
    # motor: 1 2 3 4 3 2 1 0; the screw takes up 2.5 steps of play each way before the nut moves
    assert carriage == [0.0, 0.0, 0.5, 1.5, 1.5, 1.5, 1.0, 0.0]
    assert band.motor == 0 and band.carriage == 0.0


def test_the_dead_band_starts_engaged_on_the_negative_face():
    band = DeadBand(2.0, motor=5)
    assert band.carriage == 5.0
    assert band.move_motor(-1) == 4.0          # moving negative: the carriage follows at once
    assert band.move_motor(+1) == 4.0          # the first positive step only opens the gap


def test_a_zero_dead_band_is_a_rigid_screw():
    band = DeadBand(0.0)
    moves = (+1, +1, -1, +1, -1, -1, -1)
    assert [band.move_motor(d) for d in moves] == [1, 2, 1, 2, 1, 0, -1]


def test_a_negative_dead_band_is_refused():
    with pytest.raises(ValueError, match=r"dead band must be >= 0, not -0.1"):
        DeadBand(-0.1)
