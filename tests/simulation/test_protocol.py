"""Protocols: sequences of segments, their summaries, YAML round trips with units."""

import pytest

import granflow as gf
from granflow.model import protocol as protocol_module
from granflow.model.units import QUANTITIES
from granflow.simulation.segments import SEGMENT_TYPES


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


def test_every_field_with_a_unit_has_a_quantity_in_the_one_unit_table():
    """The fields YAML may give with a unit are exactly the segments' physical fields."""
    physical = {
        item
        for cls in SEGMENT_TYPES.values()
        for item in cls.__dataclass_fields__
        if item != "reset"
    }
    assert set(protocol_module._FIELD_QUANTITIES) == physical
    assert set(protocol_module._FIELD_QUANTITIES.values()) <= set(QUANTITIES)


def test_yaml_units_of_every_field_convert_to_si():
    """Hand conversions: 1.5 min = 90 s, 2 mN = 2e-3 N, 300 ms = 0.3 s, 1 mN/min = 1e-3/60 N/s."""
    text = """
segments:
  - velocity_steps: {velocities: [1 um/s, 2 um/s], step_duration: 1.5 min}
  - velocity_table: {time: [0 s, 300 ms], velocity: [0 um/s, 2 um/s]}
  - force_table: {time: [0 s, 1 min], force: [1 mN, 2 mN]}
  - force_ramp: {rate: 1 mN/min, duration: 10 s, start: 2 mN}
  - force_steps: {levels: [3 mN], step_duration: 1 s}
  - force: {level: 500 uN, duration: 1 s}
  - switch_to_force: {duration: 1 min, level: 4 mN, ramp: 500 ms}
"""
    steps, table, force_table, ramp, force_steps, force, switch = gf.Protocol.from_yaml(text)
    assert steps.velocities == pytest.approx((1e-6, 2e-6), rel=1e-12)
    assert steps.step_duration == pytest.approx(90.0, rel=1e-12)
    assert table.time == pytest.approx((0.0, 0.3), rel=1e-12)
    assert table.velocity == pytest.approx((0.0, 2e-6), rel=1e-12)
    assert force_table.time == pytest.approx((0.0, 60.0), rel=1e-12)
    assert force_table.force == pytest.approx((1e-3, 2e-3), rel=1e-12)
    assert ramp.rate == pytest.approx(1e-3 / 60.0, rel=1e-12)
    assert ramp.start == pytest.approx(2e-3, rel=1e-12)
    assert force_steps.levels == pytest.approx((3e-3,), rel=1e-12)
    assert force.level == pytest.approx(5e-4, rel=1e-12)
    assert switch.level == pytest.approx(4e-3, rel=1e-12)
    assert switch.ramp == pytest.approx(0.5, rel=1e-12)
    assert switch.duration == pytest.approx(60.0, rel=1e-12)
