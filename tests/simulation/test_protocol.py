"""Protocol segments: validation at the door, pieces, YAML round trips."""

import math

import pytest

import granflow as gf
from granflow.simulation.protocol import ForcePiece, RatePiece


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


def test_protocol_needs_segments():
    with pytest.raises(gf.InvalidProtocolError, match="at least one segment"):
        gf.Protocol([])
    with pytest.raises(gf.InvalidProtocolError, match="segment 2 must be a granflow segment"):
        gf.Protocol([gf.Hold(1.0), "hold"])
    with pytest.raises(gf.InvalidProtocolError, match="list of segments"):
        gf.Protocol(3)


def test_protocol_summary_properties():
    protocol = gf.Protocol(
        [
            gf.Velocity(0.86e-6, 80.0),
            gf.Hold(10.0),
            gf.VelocitySteps([1e-6, 3e-6], 5.0),
            gf.ForceRamp(rate=1e-4, duration=20.0),
        ]
    )
    assert protocol.duration == 120.0
    assert protocol.max_velocity == 3e-6
    assert protocol.first_velocity == 0.86e-6
    assert len(protocol) == 4
    assert isinstance(protocol[1], gf.Hold)
    assert "4 segments" in repr(protocol)
    assert gf.Protocol([gf.Force(1e-3, 1.0)]).first_velocity is None
    assert gf.Protocol(gf.Hold(2.0)).duration == 2.0


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


def _example():
    return gf.Protocol(
        [
            gf.Velocity(0.86e-6, 80.0),
            gf.Hold(30.0, reset=True),
            gf.VelocitySteps([1e-6, 2e-6], 5.0),
            gf.VelocityTable([0.0, 1.0], [0.0, 1e-6]),
            gf.Force(5e-3, 10.0),
            gf.ForceRamp(rate=5e-5, duration=100.0),
            gf.ForceSteps([6e-3, 8e-3], 20.0),
            gf.ForceTable([0.0, 5.0], [8e-3, 9e-3]),
            gf.SwitchToForce(60.0, factor=1.01, ramp=2.0),
        ]
    )


def test_yaml_round_trip_keeps_every_segment(tmp_path):
    protocol = _example()
    assert gf.Protocol.from_yaml(protocol.to_yaml()).segments == protocol.segments
    path = tmp_path / "protocol.yaml"
    protocol.dump(path)
    assert gf.Protocol.load(path).segments == protocol.segments
    assert gf.Protocol.from_dict(protocol.to_dict()).segments == protocol.segments


def test_yaml_accepts_units_and_the_short_form():
    text = """
segments:
  - velocity: {velocity: 0.86 um/s, duration: 80 s}
  - hold: {duration: 2 min}
  - force_ramp: {rate: 0.05 mN/s, duration: 400}
  - force_steps: {levels: [2 mN, 4 mN], step_duration: 20 s}
  - switch_to_force: {duration: 60 s, factor: 1.01}
"""
    protocol = gf.Protocol.from_yaml(text)
    assert protocol[0].velocity == pytest.approx(0.86e-6, rel=1e-12)
    assert protocol[0].duration == 80.0
    assert protocol[1] == gf.Hold(120.0)
    assert protocol[2].rate == pytest.approx(5e-5, rel=1e-12)
    assert protocol[3].levels == pytest.approx((2e-3, 4e-3), rel=1e-12)
    assert protocol[4] == gf.SwitchToForce(60.0, factor=1.01)
    assert gf.Protocol.from_dict([{"type": "hold", "duration": 1.0}])[0] == gf.Hold(1.0)


@pytest.mark.parametrize(
    ("text", "words"),
    [
        ("segments:\n  - force: {duration: 10}\n", r"segment 1 \(force\).*level is missing"),
        ("segments:\n  - velocity: {velocity: .nan, duration: 1}\n", "velocity must be finite"),
        ("segments:\n  - hold: {duration: -3 s}\n", "duration must be positive"),
        ("segments:\n  - creep: {duration: 3}\n", "unknown segment type 'creep'"),
        ("segments:\n  - hold: {duration: 3, speed: 2}\n", "unknown option"),
        ("segments:\n  - hold: {duration: 3 kg}\n", "cannot read"),
        ("segments: 3\n", "must be a list"),
        ("steps: []\n", "needs a 'segments' list"),
        ("segments: [\n", "not valid YAML"),
        ("segments:\n  - {hold: {duration: 1}, force: {level: 1}}\n", "give the segment as"),
    ],
)
def test_bad_yaml_names_the_source_and_the_segment(text, words):
    with pytest.raises(gf.InvalidProtocolError, match=words) as info:
        gf.Protocol.from_yaml(text, source="exp.yaml")
    assert str(info.value).startswith("exp.yaml: ")


def test_load_names_a_missing_file(tmp_path):
    with pytest.raises(gf.InvalidProtocolError, match="cannot read the protocol"):
        gf.Protocol.load(tmp_path / "missing.yaml")
