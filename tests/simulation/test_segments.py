"""Protocol segments: validation at the door and their pieces."""

import math

import pytest

import granflow as gf
from granflow.simulation.segments import ForcePiece, RatePiece


def test_invalid_protocol_error_is_both_granflow_and_value_error():
    assert issubclass(gf.InvalidProtocolError, gf.GranflowError)
    assert issubclass(gf.InvalidProtocolError, ValueError)


@pytest.mark.parametrize(
    ("make", "words"),
    [
        (lambda: gf.Velocity(0.86e-6, -1.0), "duration must be positive"),
        (lambda: gf.Velocity(-1e-6, 10.0), "velocity must be positive"),
        (lambda: gf.Velocity(math.nan, 10.0), "velocity must be finite"),
        (lambda: gf.Velocity(0.86e-6), "duration is missing"),
        (lambda: gf.Hold(-5.0), "duration must be positive"),
        (lambda: gf.Hold(5.0, reset="yes"), "reset must be true or false"),
        (lambda: gf.Force(duration=10.0), "level is missing"),
        (lambda: gf.Force(-1e-3, 10.0), "level must be non-negative"),
        (lambda: gf.Force(math.inf, 10.0), "level must be finite"),
        (lambda: gf.ForceRamp(rate=math.nan, duration=10.0), "rate must be finite"),
        (lambda: gf.ForceRamp(rate=-1e-3, duration=10.0, start=5e-3), "below zero"),
        (lambda: gf.ForceSteps([1e-3, math.nan], 10.0), "must be finite"),
        (lambda: gf.ForceSteps([], 10.0), "non-empty"),
        (lambda: gf.ForceSteps([1e-3], 0.0), "step_duration must be positive"),
        (lambda: gf.SwitchToForce(10.0), "exactly one of factor"),
        (lambda: gf.SwitchToForce(10.0, factor=1.1, level=1e-3), "exactly one of factor"),
        (lambda: gf.SwitchToForce(10.0, factor=-1.0), "factor must be positive"),
        (lambda: gf.SwitchToForce(10.0, factor=1.1, ramp=20.0), "ramp must not exceed"),
        (lambda: gf.VelocityTable([0.0, 2.0, 1.0], [1e-6, 1e-6, 1e-6]), "times must increase"),
        (lambda: gf.VelocityTable([1.0, 2.0], [1e-6, 1e-6]), "first time must be 0"),
        (lambda: gf.VelocityTable([0.0, 2.0], [1e-6]), "same length"),
        (lambda: gf.ForceTable([0.0, 1.0], [1e-3, -1e-3]), "non-negative"),
        (lambda: gf.VelocitySteps("fast", 1.0), "list of numbers"),
    ],
)
def test_bad_segments_are_rejected_with_a_clear_message(make, words):
    with pytest.raises(gf.InvalidProtocolError, match=words):
        make()


def test_segments_expand_into_pieces():
    assert gf.Velocity(1e-6, 3.0).pieces() == [RatePiece(1e-6, 1e-6, 3.0)]
    assert gf.Hold(4.0, reset=True).pieces() == [RatePiece(0.0, 0.0, 4.0, hold=True, reset=True)]
    table = gf.VelocityTable([0.0, 1.0, 3.0], [0.0, 2e-6, 1e-6])
    assert table.pieces() == [RatePiece(0.0, 2e-6, 1.0), RatePiece(2e-6, 1e-6, 2.0)]
    assert table.duration == 3.0
    ramp = gf.ForceRamp(rate=2e-3, duration=5.0)
    assert ramp.pieces(current=1e-3) == [ForcePiece(1e-3, 11e-3, 5.0)]
    assert gf.ForceRamp(rate=2e-3, duration=5.0, start=0.0).pieces(1e-3)[0].start == 0.0
    switch = gf.SwitchToForce(10.0, factor=1.5, ramp=4.0)
    assert switch.pieces(2e-3) == [ForcePiece(2e-3, 3e-3, 4.0), ForcePiece(3e-3, 3e-3, 6.0)]
    assert gf.SwitchToForce(10.0, level=5e-3).pieces(2e-3) == [ForcePiece(5e-3, 5e-3, 10.0)]
    steps = gf.ForceSteps([1e-3, 2e-3], 3.0)
    assert steps.duration == 6.0
    assert [piece.rate for piece in steps.pieces(0.0)] == [0.0, 0.0]


def test_a_ramp_from_the_current_force_may_not_go_negative():
    with pytest.raises(gf.InvalidProtocolError, match="below zero"):
        gf.ForceRamp(rate=-1e-3, duration=10.0).pieces(current=2e-3)
