"""The result types: frozen, exported, and rebuilt by from_dict from their to_dict."""

import dataclasses
import json
import math

import numpy as np
import pytest

import granflow as gf
from granflow.simulation.results import ARRAYS, Event, SegmentRecord, SimulationResult

V = 0.86e-6  # m/s, the paper's velocity
RAMP_RATE = 0.05e-3  # N/s


def _switch(duration, factor=1.01, hold=60.0):
    return gf.Protocol([gf.Velocity(V, duration), gf.SwitchToForce(hold, factor=factor)])


def assert_same_result(rebuilt, result):
    """Every field equal: arrays element by element (inf and NaN included), the rest by ==."""
    assert type(rebuilt) is SimulationResult
    for name in ARRAYS:
        expected = getattr(result, name)
        got = getattr(rebuilt, name)
        assert got.dtype == expected.dtype, name
        np.testing.assert_array_equal(got, expected, err_msg=name)
    for item in dataclasses.fields(SimulationResult):
        if item.name not in ARRAYS:
            assert getattr(rebuilt, item.name) == getattr(result, item.name), item.name


def test_result_is_frozen_with_read_only_arrays(blue):
    result = gf.simulate(blue, _switch(10.0))
    with pytest.raises(dataclasses.FrozenInstanceError):
        result.failed = True
    with pytest.raises(ValueError, match="read-only"):
        result.force[0] = 1.0
    lengths = {len(getattr(result, name)) for name in ("t", "slip", "velocity", "force", "state")}
    assert len(lengths) == 1
    assert np.all(np.diff(result.t) >= 0)


def test_result_exports(blue):
    result = gf.simulate(blue, _switch(80.0))
    frame = result.to_frame()
    assert list(frame.columns) == [
        "t",
        "slip",
        "velocity",
        "force",
        "state",
        "age",
        "displacement",
        "segment",
    ]
    assert frame.attrs["events"][-1]["kind"] == "failure"
    text = json.dumps(result.to_dict())
    assert '"failure"' in text
    report = result.report()
    assert "[[Events]]" in report and "failure" in report and "quasistatic" in report
    run = result.to_run()
    assert isinstance(run, gf.Run) and run.control == "stress"
    assert len(run) == np.count_nonzero(np.diff(result.t, append=np.inf))  # one per instant
    assert np.all(np.diff(run.t) > 0)
    assert "failed" in repr(result)


@pytest.mark.parametrize(
    ("protocol", "options"),
    [
        (gf.Protocol([gf.ForceRamp(rate=RAMP_RATE, duration=400.0)]), {}),  # inf velocity
        (_switch(10.0), {"clock": "time"}),
        (_switch(10.0, hold=5.0), {"method": "dynamic", "stiffness": 5000.0}),
        (_switch(5.0, factor=0.98, hold=20.0), {"direct_effect": 0.05e-3}),
        (
            gf.Protocol([gf.Velocity(V, 20.0), gf.Hold(5.0, reset=True), gf.Velocity(V, 5.0)]),
            {"points": 20},
        ),
    ],
)
def test_from_dict_inverts_to_dict_through_json(blue, protocol, options):
    result = gf.simulate(blue, protocol, **options)
    text = json.dumps(result.to_dict(), allow_nan=False)
    rebuilt = SimulationResult.from_dict(json.loads(text))
    assert_same_result(rebuilt, result)
    assert rebuilt.to_dict() == result.to_dict()
    assert rebuilt.report() == result.report()
    assert repr(rebuilt) == repr(result)


def test_from_dict_reads_the_failure_velocity_back_as_infinite(blue):
    result = gf.simulate(blue, gf.Protocol([gf.ForceRamp(rate=RAMP_RATE, duration=400.0)]))
    data = result.to_dict()
    assert data["velocity"][-1] is None
    assert SimulationResult.from_dict(data).velocity[-1] == math.inf
    assert SimulationResult.from_dict(data).failure == result.failure


def test_rebuilt_direct_effect_is_the_option_object(blue):
    result = gf.simulate(blue, _switch(5.0, factor=0.98, hold=5.0), direct_effect=0.05e-3)
    rebuilt = SimulationResult.from_dict(result.to_dict())
    assert rebuilt.options["direct_effect"] == gf.DirectEffect(0.05e-3, V)


def test_events_and_segment_records_round_trip():
    event = Event("stop", 1.5, 2e-6, 3e-3, 3e-3, 1, "the layer sticks")
    assert Event.from_dict(event.to_dict()) == event
    record = SegmentRecord(0, "velocity", "rate", 0.0, 10.0, 1e-6, 9.6e-6, 0.0, 8e-3, "completed")
    assert SegmentRecord.from_dict(record.to_dict()) == record
    assert gf.DirectEffect.from_dict(gf.DirectEffect(1e-4).to_dict()) == gf.DirectEffect(1e-4)
