"""granflow.rsf: the contract, bad models, results (frame, dict, report, plot), protocols."""

import json
import math

import numpy as np
import pytest

import granflow as gf
from granflow import rsf


@pytest.fixture(scope="module")
def contract():
    model = rsf.RateState(
        mu0=0.6,
        a=0.005,
        v_ref=1.0,
        stiffness=1e-3,
        states=[rsf.State(b=0.01, Dc=10.0, law="aging")],
    )
    protocol = gf.Protocol([gf.Velocity(1.0, 10.0), gf.Velocity(10.0, 30.0)])
    return model, rsf.simulate(model, protocol, t_eval=np.arange(0.0, 41.0))


def test_the_contract_of_the_issue(contract):
    _, res = contract
    np.testing.assert_array_equal(res.t, np.arange(0.0, 41.0))
    assert res.friction.shape == res.velocity.shape == res.slip.shape == (41,)
    assert res.states.shape == (1, 41)
    # steady state at 1 m/s until the step, then the direct effect, then towards mu_ss(10)
    np.testing.assert_allclose(res.friction[:11], 0.6, rtol=1e-12)
    np.testing.assert_allclose(res.velocity[:11], 1.0, rtol=1e-9)
    assert res.friction[11] > 0.6
    assert res.slip[10] == pytest.approx(10.0, rel=1e-9)
    assert res.success and res.events_of("peak")


@pytest.mark.parametrize(
    ("build", "name"),
    [
        (lambda: rsf.State(b=0.01, Dc=-1.0), "Dc"),
        (lambda: rsf.State(b=0.01, Dc=1.0, law="dieterich"), "law"),
        (lambda: rsf.State(b=math.nan, Dc=1.0), "b"),
        (lambda: rsf.State(b=math.inf, Dc=1.0), "b"),
        (lambda: rsf.State(b=0.01, Dc=1.0, law="nagata"), "c"),
        (lambda: rsf.State(b=0.01, Dc=1.0, law="aging", c=1.0), "c"),
        (lambda: rsf.RateState(0.6, math.nan, 1.0, 1e-3, [rsf.State(0.01, 1.0)]), "a"),
        (lambda: rsf.RateState(0.6, math.inf, 1.0, 1e-3, [rsf.State(0.01, 1.0)]), "a"),
        (lambda: rsf.RateState(0.6, -0.01, 1.0, 1e-3, [rsf.State(0.01, 1.0)]), "a"),
        (lambda: rsf.RateState(0.6, 0.01, 0.0, 1e-3, [rsf.State(0.01, 1.0)]), "v_ref"),
        (lambda: rsf.RateState(0.6, 0.01, 1.0, -1.0, [rsf.State(0.01, 1.0)]), "stiffness"),
        (lambda: rsf.RateState(0.6, 0.01, 1.0, 1e-3, []), "states"),
        (lambda: rsf.RateState(0.6, 0.01, 1.0, 1e-3, [0.01]), "states"),
        (
            lambda: rsf.RateState(0.6, 0.01, 1.0, 1e-3, [rsf.State(0.01, 1.0)], -1.0),
            "radiation_damping",
        ),
    ],
)
def test_bad_models_name_the_argument(build, name):
    with pytest.raises(gf.InvalidParameterError, match=name):
        build()


def test_bad_simulations_name_the_argument():
    model = rsf.RateState(0.6, 0.005, 1.0, None, [rsf.State(0.01, 10.0)])
    with pytest.raises(gf.InvalidParameterError, match="stiffness"):
        rsf.simulate(model, [gf.Velocity(1.0, 1.0), gf.Hold(1.0)])
    with pytest.raises(gf.InvalidProtocolError, match="velocity histories"):
        rsf.simulate(model, [gf.Force(1.0, 1.0)])
    with pytest.raises(gf.InvalidParameterError, match="t_eval"):
        rsf.simulate(model, [gf.Velocity(1.0, 1.0)], t_eval=[0.0, 2.0])
    with pytest.raises(gf.InvalidParameterError, match="initial_states"):
        rsf.simulate(model, [gf.Velocity(1.0, 1.0)], initial_states=[1.0, 2.0])
    with pytest.raises(gf.InvalidParameterError, match="model"):
        rsf.simulate("aging", [gf.Velocity(1.0, 1.0)])
    with pytest.raises(gf.InvalidParameterError, match="method"):
        rsf.simulate(model, [gf.Velocity(1.0, 1.0)], method="lsoda")
    spring = rsf.RateState(0.6, 0.005, 1.0, 1e-3, [rsf.State(0.01, 10.0)])
    with pytest.raises(gf.InvalidParameterError, match="initial_velocity"):
        rsf.simulate(spring, [gf.Hold(1.0), gf.Velocity(1.0, 1.0)])


def test_the_inputs_are_not_modified():
    model = rsf.RateState(0.6, 0.005, 1.0, 1e-3, [rsf.State(0.01, 10.0)])
    t_eval = np.linspace(0.0, 20.0, 5)
    initial = np.array([12.0])
    rsf.simulate(model, [gf.Velocity(1.0, 20.0)], t_eval=t_eval, initial_states=initial)
    np.testing.assert_array_equal(t_eval, np.linspace(0.0, 20.0, 5))
    assert initial[0] == 12.0


def test_slide_hold_slide_with_a_table_runs_on_protocol_segments():
    model = rsf.RateState(0.6, 0.005, 1.0, 1e-2, [rsf.State(0.01, 10.0, "slip")])
    protocol = gf.Protocol(
        [
            gf.VelocitySteps([1.0, 3.0], 20.0),
            gf.Hold(50.0),
            gf.VelocityTable([0.0, 10.0], [0.0, 2.0]),
        ]
    )
    result = rsf.simulate(model, protocol)
    assert result.success
    assert set(result.segment.tolist()) == {0, 1, 2}
    hold = result.segment == 1
    np.testing.assert_array_equal(result.load_point_velocity[hold][1:], 0.0)
    assert np.all(np.diff(result.velocity[hold]) < 0)  # the slider creeps to a halt
    assert result.velocity[hold][-1] < 0.01


def test_results_round_trip_through_json_and_frame(contract, tmp_path):
    _, res = contract
    again = type(res).from_dict(json.loads(json.dumps(res.to_dict())))
    for name in ("t", "slip", "velocity", "friction", "states", "load_point_velocity", "segment"):
        np.testing.assert_array_equal(getattr(again, name), getattr(res, name))
    assert again.events == res.events
    assert again.model == res.model
    frame = res.to_frame()
    assert list(frame.columns) == [
        "t",
        "slip",
        "velocity",
        "friction",
        "load_point_velocity",
        "theta_1",
        "segment",
    ]
    assert frame.attrs["units"]["theta_1"] == "s"
    report = res.report()
    assert "aging: b = 0.01" in report and "peak" in report
    assert "1 states" in repr(res)


def test_plot_draws_friction_and_steady_state(contract):
    matplotlib = pytest.importorskip("matplotlib")
    matplotlib.use("Agg")
    _, res = contract
    ax = res.plot()
    assert len(ax.lines) == 2
    np.testing.assert_array_equal(ax.lines[0].get_ydata(), res.friction)


def test_repeated_calls_give_identical_arrays(contract):
    model, res = contract
    protocol = gf.Protocol([gf.Velocity(1.0, 10.0), gf.Velocity(10.0, 30.0)])
    again = rsf.simulate(model, protocol, t_eval=np.arange(0.0, 41.0))
    np.testing.assert_array_equal(again.friction, res.friction)
    np.testing.assert_array_equal(again.velocity, res.velocity)
