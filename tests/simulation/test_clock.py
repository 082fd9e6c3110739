"""The one-clock rule: a simulated start-up, its record, its events, the peak and the fit on
one clock (issue 12, item 1), and the work bounded by counting, not by the wall clock."""

import json

import numpy as np
import pytest
from scipy.optimize import brentq

import granflow as gf
from granflow.simulation.results import Origin, SimulationResult

V = 0.86e-6  # m/s, the paper's velocity
FD = 10e-3  # N

#: SPEC §4, Fig. 2a: a [N], alpha v [1/s], t0 [s] at 0.86 um/s (Fd = 10 mN).
FIG_2A = {
    "blue": (3.31e-3, 0.036, 0.23),
    "gray": (2.99e-3, 0.051, 0.39),
    "black": (2.67e-3, 0.058, 0.55),
}


def _cases():
    cases = [
        pytest.param(gf.Params.from_time_domain(a, k, t0, FD, V), V, 600.0, id=name)
        for name, (a, k, t0) in FIG_2A.items()
    ]
    # a fast drive on a strong, quickly rejuvenating layer; a slow drive on a weak one
    cases.append(
        pytest.param(gf.Params(12e-3, 2.5e5, 40e-3, 0.05e-6), 5e-6, 60.0, id="fast-strong")
    )
    cases.append(pytest.param(gf.Params(0.8e-3, 1.5e4, 3e-3, 1.2e-6), 0.2e-6, 4000.0, id="slow"))
    return cases


@pytest.fixture(scope="module")
def blue():
    return gf.Params.from_time_domain(a=3.31e-3, k=0.036, t0=0.23, Fd=FD, velocity=V)


@pytest.mark.parametrize(("params", "velocity", "duration"), _cases())
def test_fit_of_a_simulated_startup_needs_no_shift(params, velocity, duration):
    """Acceptance: fit(simulate(...).to_run()) recovers a, alpha, Fd, x0 (asked: 1e-6
    relative; it does to about 1e-15), the fitted curve simulated again matches the curve the
    data sample to 1e-9 relative, and peak().time is the simulated peak event's time."""
    protocol = [gf.Velocity(velocity, duration)]
    result = gf.simulate(params, protocol, points=600)
    run = result.to_run()
    t0 = params.x0 / velocity
    assert run.t[0] == pytest.approx(t0, rel=1e-15) and run.slip[0] == params.x0
    # the record samples Eq. 3 in the paper's form at its own time: t is the model's t
    np.testing.assert_allclose(run.force, gf.friction_time(run.t, params, velocity), rtol=1e-13)
    fitted = gf.fit(run).to_params()
    for name in ("a", "alpha", "Fd", "x0"):
        assert getattr(fitted, name) == pytest.approx(getattr(params, name), rel=1e-6), name
    again = gf.simulate(fitted, protocol, points=600)
    np.testing.assert_allclose(
        again.force, gf.friction_time(again.t, params, velocity), rtol=1e-9, atol=0
    )
    (event,) = result.events_of("peak")
    top = gf.peak(params, velocity=velocity)
    # the event's time comes from brentq at 4 eps on the slip, the peak's from its slip / v
    assert event.time == pytest.approx(top.time, rel=1e-13)
    assert result.force.max() == pytest.approx(top.force, rel=1e-14)
    assert result.t[np.argmax(result.force)] == event.time


def test_a_time_domain_fit_reads_the_record_as_the_paper_does(blue):
    run = gf.simulate(blue, [gf.Velocity(V, 600.0)], points=600).to_run()
    fitted = gf.fit(run, domain="time")
    assert fitted.params["k"] == pytest.approx(0.036, rel=1e-6)
    assert fitted.params["t0"] == pytest.approx(0.23, rel=1e-6)


def test_a_startup_states_its_origin_and_the_run_carries_it(blue):
    result = gf.simulate(blue, [gf.Velocity(V, 100.0)])
    assert result.origin == Origin("shear", 0.0, blue.t0(V), 0.0)
    assert "start of shear at t = 0 s; the model takes over at t = 0.23 s" in result.report()
    meta = result.to_run().meta
    assert meta["origin"] == "shear" and meta["shear_start"] == 0.0
    assert meta["model_start"] == blue.t0(V) and meta["slip_offset"] == 0.0


def test_force_control_from_rest_starts_at_zero_with_the_slip_offset_x0(blue):
    result = gf.simulate(blue, [gf.ForceRamp(rate=0.05e-3, duration=400.0)])
    assert result.t[0] == 0.0 and result.displacement[0] == 0.0
    np.testing.assert_allclose(result.slip, blue.x0 + result.displacement, rtol=1e-14)
    assert result.origin == Origin("rest", None, 0.0, blue.x0)
    run = result.to_run()
    assert run.meta["origin"] == "rest" and run.meta["slip_offset"] == blue.x0
    assert "shear_start" not in run.meta
    shifted = result.to_run(origin="model")
    kept = result.instants()  # one row per instant, as a record
    np.testing.assert_allclose(shifted.slip, result.slip[kept], rtol=1e-15)
    np.testing.assert_allclose(shifted.t, result.t[kept] + result.options["t0"], rtol=1e-15)
    assert shifted.meta["origin"] == "model"


def test_the_switch_happens_at_the_record_time_of_the_protocol(blue):
    """The paper's switch at t = 80 s is record time: slip 80 v since the start of shear."""
    protocol = [gf.Velocity(V, 80.0), gf.SwitchToForce(60.0, factor=1.01)]
    result = gf.simulate(blue, protocol)
    first = result.segments[0]
    assert first.start_time == 0.0 and first.end_time == 80.0
    assert first.end_slip == pytest.approx(80.0 * V, rel=1e-14)
    assert first.end_force == pytest.approx(gf.friction_time(80.0, blue, V), rel=1e-12)
    assert result.failed and result.failure.time == 80.0
    run = result.to_run()
    assert run.control == "stress" and run.meta["origin"] == "shear"
    switched = (result.segment == 1)[result.instants()]
    assert np.all(run.t[switched] == 80.0)  # quasi-statically the failure comes at once
    assert run.force[switched][-1] == result.failure.force


def test_a_rest_before_the_startup_delays_the_start_of_shear(blue):
    """Slip clock: the rest changes nothing, the start-up enters the model t0 after it ends;
    the record's time then starts 10 s before the shear, and to_run(origin="model") is the
    explicit offset that fit needs."""
    protocol = [gf.Hold(10.0), gf.Velocity(V, 300.0)]
    result = gf.simulate(blue, protocol, points=400)
    assert result.origin == Origin("shear", 10.0, 10.0 + blue.t0(V), 0.0)
    sliding = result.segment == 1
    assert result.t[sliding][0] == pytest.approx(10.0 + blue.t0(V), rel=1e-15)
    assert result.displacement[sliding][0] == blue.x0
    (event,) = result.events_of("peak")
    assert event.time == pytest.approx(10.0 + gf.peak(blue, velocity=V).time, rel=1e-13)
    shifted = result.to_run(origin="model").select(sliding)
    assert shifted.meta["time_shift"] == -10.0
    fitted = gf.fit(shifted).to_params()
    assert fitted.x0 == pytest.approx(blue.x0, rel=1e-6)
    assert fitted.alpha == pytest.approx(blue.alpha, rel=1e-6)


def test_a_rest_before_the_startup_ages_the_layer_on_the_time_clock(blue):
    """Time clock: the rest ages the prepared layer from t = 0 (age t0), so the model
    describes it from there (from rest) and the start-up begins at 10 s without an entry."""
    result = gf.simulate(blue, [gf.Hold(10.0), gf.Velocity(V, 50.0)], clock="time")
    t0 = result.options["t0"]
    assert result.origin == Origin("rest", None, 0.0, blue.x0)
    sliding = result.segment == 1
    assert result.t[sliding][0] == 10.0 and result.displacement[sliding][0] == 0.0
    assert result.age[sliding][0] == pytest.approx(t0 + 10.0, rel=1e-15)
    aged = gf.initial_force(blue) + blue.a * np.log((t0 + 10.0) / t0)
    assert result.state[sliding][0] == pytest.approx(aged, rel=1e-12)


def test_a_re_prepared_layer_enters_the_model_again(blue):
    protocol = [gf.Velocity(V, 100.0), gf.Hold(60.0, reset=True), gf.Velocity(V, 100.0)]
    result = gf.simulate(blue, protocol)
    second = result.segment == 2
    assert result.t[second][0] == pytest.approx(160.0 + blue.t0(V), rel=1e-15)
    assert result.displacement[second][0] == pytest.approx(100.0 * V + blue.x0, rel=1e-14)
    assert result.slip[second][0] == blue.x0
    first_peak, second_peak = result.events_of("peak")
    assert second_peak.time - 160.0 == pytest.approx(first_peak.time, rel=1e-13)


def test_a_drive_accelerating_from_rest_loads_the_layer_from_rest(blue):
    result = gf.simulate(blue, [gf.VelocityTable([0.0, 10.0, 50.0], [0.0, 2e-6, 2e-6])])
    assert result.origin.kind == "rest" and result.t[0] == 0.0
    np.testing.assert_allclose(result.slip, blue.x0 + result.displacement, rtol=1e-14)


def test_a_startup_shorter_than_t0_is_refused_with_the_reason(blue):
    with pytest.raises(gf.InvalidProtocolError, match=r"segment 1 \(velocity\) ends before"):
        gf.simulate(blue, [gf.Velocity(V, 0.1), gf.Force(5e-3, 10.0)])


def test_velocity_steps_enter_the_model_within_a_later_step(blue):
    """The first step slips less than x0: the entry falls in the second step."""
    steps = gf.VelocitySteps([0.5e-7, 1e-6], 3.0)  # 0.15 um in the first step, x0 = 0.198 um
    result = gf.simulate(blue, [steps])
    entry = 3.0 + (blue.x0 - 3.0 * 0.5e-7) / 1e-6
    assert result.t[0] == pytest.approx(entry, rel=1e-14)
    assert result.displacement[0] == blue.x0 and result.displacement[-1] == pytest.approx(
        3.0 * 0.5e-7 + 3.0 * 1e-6, rel=1e-14
    )


def test_the_dynamic_method_runs_on_the_same_clock(blue):
    """A rigid drive: identical; a stiff machine: its drive, at v t on the record's clock
    (unloaded at t0, where both it and the layer have moved x0), leads the layer by the
    spring's stretch F / K."""
    protocol = [gf.Velocity(V, 60.0)]
    quasistatic = gf.simulate(blue, protocol)
    rigid = gf.simulate(blue, protocol, method="dynamic")
    np.testing.assert_array_equal(rigid.t, quasistatic.t)
    np.testing.assert_array_equal(rigid.force, quasistatic.force)
    assert rigid.origin == quasistatic.origin
    stiffness = 1e5
    spring = gf.simulate(blue, protocol, method="dynamic", stiffness=stiffness, damping=20.0)
    assert spring.t[0] == pytest.approx(blue.t0(V), rel=1e-15)
    assert spring.displacement[0] == blue.x0
    loaded = spring.t > blue.t0(V) + 5.0
    stretch = V * spring.t - spring.displacement
    np.testing.assert_allclose(stretch[loaded], spring.force[loaded] / stiffness, rtol=2e-3)
    np.testing.assert_allclose(
        spring.state, gf.friction_slip(spring.slip, blue), rtol=1e-6
    )  # the layer follows F(x) of its own slip
    assert spring.state.max() == pytest.approx(gf.peak(blue).force, rel=1e-5)


def test_the_origin_and_the_work_survive_json(blue):
    result = gf.simulate(blue, [gf.Hold(5.0), gf.Velocity(V, 30.0)], points=20)
    rebuilt = SimulationResult.from_dict(json.loads(json.dumps(result.to_dict())))
    assert rebuilt.origin == result.origin
    assert dict(rebuilt.work) == dict(result.work)
    assert rebuilt.report() == result.report()


def test_a_record_written_before_the_origin_reads_as_the_old_clock(blue):
    mapping = gf.simulate(blue, [gf.ForceRamp(rate=1e-4, duration=10.0)], points=5).to_dict()
    del mapping["origin"], mapping["work"]
    old = SimulationResult.from_dict(mapping)
    assert old.origin == Origin("rest", None, 0.0, blue.x0)


def test_no_wall_clock_limit_by_default_and_the_work_is_counted(blue):
    protocol = [gf.Velocity(V, 10.0), gf.Force(0.98 * gf.friction_time(10.0, blue, V), 100.0)]
    runs = [gf.simulate(blue, protocol, direct_effect=0.05e-3) for _ in range(2)]
    assert runs[0].options["max_wall"] is None
    assert runs[0].work["evaluations"] > 0
    assert dict(runs[0].work) == dict(runs[1].work)  # counted work: the same on every run
    np.testing.assert_array_equal(runs[0].displacement, runs[1].displacement)
    assert "wall-clock" not in runs[0].report()
    limited = gf.simulate(blue, protocol, direct_effect=0.05e-3, max_wall=3600.0)
    assert "(a wall-clock limit)" in limited.report()


def test_the_time_clock_startup_ages_on_the_record_clock(blue):
    """Time clock, constant velocity: the age is the record's time (preparation at the start
    of shear), so Eq. 3 in time holds with t the record's time."""
    result = gf.simulate(blue, [gf.Velocity(V, 100.0)], clock="time")
    np.testing.assert_allclose(result.age, result.t, rtol=1e-15)
    (event,) = result.events_of("peak")
    assert event.time == pytest.approx(gf.peak(blue, velocity=V).time, rel=1e-12)
    stop = brentq(lambda t: gf.friction_time(t, blue, V) - result.force[-1], 30.0, 100.0)
    assert stop == pytest.approx(100.0, rel=1e-8)
