"""simulate(): rate control against the closed form and an ODE solver; the quasi-static
answers under imposed forces; the arguments. (The dynamic method: test_simulate_dynamic; the
result object: test_results.)"""

import math

import numpy as np
import pytest
from scipy.integrate import quad, solve_ivp
from scipy.optimize import brentq

import granflow as gf
from granflow.simulation.driver import DEFAULT_REFERENCE_VELOCITY

V = 0.86e-6  # m/s, the paper's velocity
RAMP_RATE = 0.05e-3  # N/s


@pytest.fixture(scope="module")
def blue():
    """The blue set of SPEC §4 with Fd = 10 mN."""
    return gf.Params.from_time_domain(a=3.31e-3, k=0.036, t0=0.23, Fd=10e-3, velocity=V)


def _switch(duration, factor=1.01, hold=60.0):
    return gf.Protocol([gf.Velocity(V, duration), gf.SwitchToForce(hold, factor=factor)])


# -- rate control -------------------------------------------------------------------------


@pytest.mark.parametrize("clock", ["slip", "time"])
def test_constant_velocity_gives_the_closed_form(blue, clock):
    """On the record's clock: the start-up enters the model at t0 with slip x0 = v t0, and
    from there t, the slip and the age are the model's t, x and t of Eq. 3."""
    result = gf.simulate(blue, gf.Protocol([gf.Velocity(V, 200.0)]), clock=clock)
    t0 = blue.t0(V)
    assert result.t[0] == t0 and result.displacement[0] == blue.x0 and result.t[-1] == 200.0
    np.testing.assert_allclose(result.age, result.t, rtol=1e-15)
    np.testing.assert_allclose(result.slip, V * result.t, rtol=1e-14)
    np.testing.assert_allclose(result.displacement, result.slip, rtol=1e-14)
    closed = gf.friction_time(result.t, blue, V)
    np.testing.assert_allclose(result.force, closed, rtol=1e-8, atol=0)
    np.testing.assert_allclose(result.state, gf.friction_slip(result.slip, blue), rtol=1e-8)
    assert result.success and not result.failed
    assert np.all(result.velocity == V)


def test_constant_velocity_agrees_with_an_ode_solver(blue):
    result = gf.simulate(blue, gf.Protocol([gf.Velocity(V, 200.0)]))
    t0 = blue.t0(V)
    ode = solve_ivp(
        lambda t, F: gf.rhs_time(t, F, blue, V),
        (t0, 200.0),
        [gf.initial_force(blue)],
        method="DOP853",
        rtol=1e-11,
        atol=1e-16,
        t_eval=result.t,
    )
    np.testing.assert_allclose(result.force, ode.y[0], rtol=1e-8)


def test_the_peak_event_is_the_static_yield_point(blue):
    result = gf.simulate(blue, gf.Protocol([gf.Velocity(V, 100.0)]))
    (top,) = result.events_of("peak")
    expected = gf.peak(blue, velocity=V)
    assert top.force == pytest.approx(expected.force, rel=1e-14)
    assert top.slip == pytest.approx(expected.slip, rel=1e-12)
    assert top.time == pytest.approx(expected.time, rel=1e-12)
    assert result.force.max() == pytest.approx(expected.force, rel=1e-14)


def test_slip_clock_transient_depends_on_slip_only(blue):
    """Velocity steps and a velocity table follow one curve F(x) (Fig. 2b)."""
    protocol = gf.Protocol(
        [
            gf.VelocitySteps([0.5e-6, 2e-6, 0.0, 1e-6], 10.0),
            gf.VelocityTable([0.0, 10.0, 20.0], [0.0, 3e-6, 0.5e-6]),
        ]
    )
    result = gf.simulate(blue, protocol)
    np.testing.assert_allclose(result.state, gf.friction_slip(result.slip, blue), rtol=1e-12)
    assert np.all(np.diff(result.displacement) >= 0)
    # slip of the table: the area under the velocity
    assert result.displacement[-1] == pytest.approx(10 * 3.5e-6 + 15e-6 + 17.5e-6, rel=1e-12)


def test_time_clock_under_a_changing_velocity_matches_an_ode_solver(blue):
    table = gf.VelocityTable([0.0, 20.0, 50.0], [0.2e-6, 2e-6, 0.5e-6])
    result = gf.simulate(blue, gf.Protocol([table]), clock="time")
    t0 = blue.t0(table.velocity[0])  # the age where the model takes over
    # the start-up enters the model where it has slipped x0: v0 t + (dv/dt) t^2 / 2 = x0
    accel = (2e-6 - 0.2e-6) / 20.0
    entry = brentq(lambda t: 0.2e-6 * t + 0.5 * accel * t**2 - blue.x0, 0.0, 20.0, xtol=1e-16)
    assert result.t[0] == pytest.approx(entry, rel=1e-12)
    assert result.displacement[0] == pytest.approx(blue.x0, rel=1e-15)

    def velocity(t):
        return np.interp(t, np.array(table.time), np.array(table.velocity))

    ode = solve_ivp(
        lambda t, F: blue.a / (t - entry + t0) - blue.alpha * velocity(t) * (F - blue.Fd),
        (entry, 50.0),
        [gf.initial_force(blue)],
        method="Radau",
        rtol=1e-11,
        atol=1e-16,
        dense_output=True,
    )
    np.testing.assert_allclose(result.state, ode.sol(result.t)[0], rtol=1e-7)


def test_slide_hold_slide_strengthens_with_the_time_clock_only(blue):
    def reload_peak(hold, clock):
        protocol = gf.Protocol([gf.Velocity(V, 100.0), gf.Hold(hold), gf.Velocity(V, 100.0)])
        result = gf.simulate(blue, protocol, clock=clock)
        return result.state[result.segment == 2].max()

    holds = [10.0, 100.0, 1000.0]
    aged = [reload_peak(hold, "time") for hold in holds]
    assert aged[0] < aged[1] < aged[2]
    # the strength after the hold grows as a ln(t_age); the first peak is the largest value
    before = gf.friction_time(100.0, blue, V)
    expected = before + blue.a * math.log((100.0 + holds[2]) / 100.0)
    assert aged[2] == pytest.approx(expected, rel=1e-9)
    slipping = [reload_peak(hold, "slip") for hold in holds]
    assert slipping[0] == slipping[1] == slipping[2] == pytest.approx(before, rel=1e-12)


@pytest.mark.parametrize("clock", ["slip", "time"])
def test_reset_restores_the_first_overshoot_exactly(blue, clock):
    protocol = gf.Protocol(
        [gf.Velocity(V, 100.0), gf.Hold(60.0, reset=True), gf.Velocity(V, 100.0)]
    )
    result = gf.simulate(blue, protocol, clock=clock)
    first, second = result.events_of("peak")
    assert second.force == first.force
    assert second.slip == first.slip
    assert second.time - first.time == pytest.approx(160.0, rel=1e-12)
    np.testing.assert_array_equal(
        result.state[result.segment == 2], result.state[result.segment == 0]
    )
    (reset,) = result.events_of("reset")
    assert reset.slip == blue.x0 and reset.force == 0.0
    assert result.displacement[-1] == pytest.approx(2 * 100.0 * V, rel=1e-12)


def test_the_force_stays_during_a_hold(blue):
    result = gf.simulate(blue, gf.Protocol([gf.Velocity(V, 50.0), gf.Hold(30.0)]), clock="time")
    held = result.force[result.segment == 1]
    assert np.all(held == held[0])
    assert np.all(np.diff(result.state[result.segment == 1]) > 0)  # the strength ages


# -- quasi-static force control, slip clock -------------------------------------------------


def test_stress_ramp_fails_at_the_peak(blue):
    result = gf.simulate(blue, gf.Protocol([gf.ForceRamp(rate=RAMP_RATE, duration=400.0)]))
    top = gf.peak(blue)
    assert result.failed and result.success
    failure = result.failure
    assert failure.kind == "failure"
    assert failure.force == pytest.approx(top.force, rel=1e-6)
    assert failure.slip == pytest.approx(top.slip, rel=1e-9)
    assert failure.time == pytest.approx(top.force / RAMP_RATE, rel=1e-9)
    assert failure.slip - blue.x0 > 0
    # the layer sticks until the force reaches its initial strength, then creeps
    start = gf.initial_force(blue)
    (slide,) = result.events_of("slide")
    assert slide.time == pytest.approx(start / RAMP_RATE, rel=1e-12)
    creeping = (result.t > slide.time) & (result.t < failure.time)
    np.testing.assert_allclose(
        result.state[creeping], gf.friction_slip(result.slip[creeping], blue), rtol=1e-12
    )
    np.testing.assert_allclose(result.force[creeping], RAMP_RATE * result.t[creeping], rtol=1e-9)
    assert result.velocity[-1] == np.inf
    assert np.all(result.velocity[creeping] > 0)


def test_switch_after_the_peak_fails(blue):
    result = gf.simulate(blue, _switch(80.0))
    assert result.failed
    switch_force = gf.friction_time(80.0, blue, V)
    assert result.failure.time == 80.0
    assert result.failure.force == pytest.approx(1.01 * switch_force, rel=1e-12)
    assert result.segments[1].outcome == "failed"


def test_switch_before_the_peak_stops_after_half_a_micrometre(blue):
    result = gf.simulate(blue, _switch(10.0))
    assert not result.failed
    (stop,) = result.events_of("stop")
    switch_slip = 10.0 * V
    sigma = 1.01 * gf.friction_slip(switch_slip, blue)
    assert stop.force == pytest.approx(sigma, rel=1e-15)
    assert gf.friction_slip(stop.slip, blue) == pytest.approx(sigma, rel=1e-6)
    assert 0.3e-6 < stop.slip - switch_slip < 0.7e-6
    assert result.velocity[-1] == 0.0
    assert result.slip[-1] == stop.slip


def test_a_rising_force_after_the_peak_fails_at_once(blue):
    protocol = gf.Protocol([gf.Velocity(V, 80.0), gf.ForceRamp(rate=1e-5, duration=10.0)])
    result = gf.simulate(blue, protocol)
    switch_force = gf.friction_time(80.0, blue, V)
    assert result.failed and result.failure.time == 80.0
    assert result.failure.force == pytest.approx(switch_force, rel=1e-12)
    assert np.all(result.velocity >= 0)


def test_a_lower_force_after_the_switch_stops_at_once(blue):
    result = gf.simulate(blue, _switch(10.0, factor=0.9))
    (stop,) = result.events_of("stop")
    assert stop.time == 10.0 and stop.slip == pytest.approx(10 * V, rel=1e-14)


def test_force_staircase_stops_below_the_peak_and_fails_above(blue):
    top = gf.peak(blue).force
    levels = [2e-3, 6e-3, 10e-3, 13e-3, 13.7e-3, 13.9e-3, 14.5e-3]
    result = gf.simulate(blue, gf.Protocol([gf.ForceSteps(levels, 20.0)]))
    stops = result.events_of("stop")
    assert len(stops) == 5
    for stop, level in zip(stops, levels, strict=False):
        assert gf.friction_slip(stop.slip, blue) == pytest.approx(level, rel=1e-9)
    assert result.failure.force == 13.9e-3 > top
    assert result.failure.time == pytest.approx(100.0)


def test_stop_and_failure_agree_with_root_finding_on_the_closed_form(blue):
    """An independent check: brentq on friction_slip itself."""
    for switch_time, factor in [(5.0, 1.05), (15.0, 1.01), (20.0, 1.002)]:
        result = gf.simulate(blue, _switch(switch_time, factor))
        start = V * switch_time
        sigma = factor * gf.friction_slip(start, blue)
        top = gf.peak(blue)
        if sigma > top.force:
            assert result.failed
            continue
        expected = brentq(
            lambda x, s=sigma: gf.friction_slip(x, blue) - s, start, top.slip, xtol=1e-22
        )
        assert result.events_of("stop")[0].slip == pytest.approx(expected, rel=1e-10)


def test_a_ramp_from_a_too_high_start_cannot_go_negative(blue):
    protocol = gf.Protocol([gf.Force(1e-3, 5.0), gf.ForceRamp(rate=-1e-3, duration=5.0)])
    with pytest.raises(gf.InvalidProtocolError, match="below zero"):
        gf.simulate(blue, protocol)


# -- quasi-static force control, time clock -------------------------------------------------


def test_time_clock_ramp_fails_where_the_force_catches_the_aging_strength(blue):
    """A fresh layer ages as F_init + a ln(tau/t0); the ramp catches it above Fd: failure."""
    result = gf.simulate(
        blue, gf.Protocol([gf.ForceRamp(rate=RAMP_RATE, duration=1000.0)]), clock="time"
    )
    t0 = result.options["t0"]
    assert t0 == pytest.approx(blue.x0 / DEFAULT_REFERENCE_VELOCITY)
    start = gf.initial_force(blue)

    def gap(t):
        return RAMP_RATE * t - start - blue.a * math.log((t + t0) / t0)

    crossing = brentq(gap, blue.a / RAMP_RATE, 1000.0, xtol=1e-13)
    assert result.failed
    assert result.failure.time == pytest.approx(crossing, rel=1e-10)
    assert result.failure.force > blue.Fd
    assert result.failure.slip == blue.x0  # no slip before failure: the layer never crept


def test_time_clock_creep_below_fd_follows_the_derived_velocity(blue):
    """Below Fd the layer creeps with v = (dsigma/dt - a/tau) / (alpha (Fd - sigma))."""
    params = blue.replace(Fd=30e-3)
    rate = 0.5e-3
    result = gf.simulate(
        params, gf.Protocol([gf.ForceRamp(rate=rate, duration=100.0)]), clock="time"
    )
    (slide,) = result.events_of("slide")
    assert result.failed
    assert result.failure.force == pytest.approx(params.Fd, rel=1e-6)
    t0 = result.options["t0"]
    creeping = (result.t > slide.time) & (result.t < result.failure.time - 1.0)

    def velocity(t):
        return (rate - params.a / (t + t0)) / (params.alpha * (params.Fd - rate * t))

    for t, slip in list(zip(result.t[creeping], result.slip[creeping], strict=True))[::25]:
        expected, _ = quad(velocity, slide.time, t, epsabs=0, epsrel=1e-12)
        assert slip - params.x0 == pytest.approx(expected, rel=1e-8, abs=1e-18)


def test_time_clock_step_below_fd_slides_by_rejuvenation(blue):
    params = blue.replace(Fd=30e-3)
    protocol = gf.Protocol([gf.Velocity(V, 10.0), gf.SwitchToForce(10.0, factor=1.2)])
    result = gf.simulate(params, protocol, clock="time")
    switch_force = gf.friction_time(10.0, params, V)
    sigma = 1.2 * switch_force
    (stop,) = result.events_of("stop")
    expected = math.log((params.Fd - switch_force) / (params.Fd - sigma)) / params.alpha
    assert stop.slip - 10.0 * V == pytest.approx(expected, rel=1e-9)
    assert result.velocity[-1] == 0 and not result.failed


# -- direct effect: creep --------------------------------------------------------------------


def test_direct_effect_makes_the_layer_creep_logarithmically(blue):
    startup = gf.Velocity(V, 5.0)
    sigma = 0.98 * gf.friction_time(5.0, blue, V)
    protocol = gf.Protocol([startup, gf.Force(sigma, 1000.0)])
    result = gf.simulate(blue, protocol, direct_effect=0.05e-3)
    assert result.success and not result.failed
    creep = result.segment == 1
    t = result.t[creep] - 5.0
    slip = result.displacement[creep]
    assert np.all(np.diff(slip) >= 0)
    assert np.all(result.velocity[creep][1:] > 0)
    increments = np.diff(np.interp([10.0, 100.0, 1000.0], t, slip))
    assert increments[1] == pytest.approx(increments[0], rel=0.3)  # about B ln(10) per decade


# -- the arguments ------------------------------------------------------------------------


def test_bad_arguments_are_rejected(blue):
    protocol = _switch(10.0)
    with pytest.raises(gf.InvalidParameterError, match="dynamic"):
        gf.simulate(blue, protocol, mass=0.05)
    with pytest.raises(gf.InvalidParameterError, match="clock"):
        gf.simulate(blue, protocol, clock="wall")
    with pytest.raises(gf.InvalidParameterError, match="method"):
        gf.simulate(blue, protocol, method="implicit")
    with pytest.raises(gf.InvalidParameterError, match="params"):
        gf.simulate({"a": 1}, protocol)
    with pytest.raises(gf.InvalidParameterError, match="v_fail"):
        gf.simulate(blue, protocol, v_fail=-1.0)
    with pytest.raises(gf.InvalidParameterError, match="damping"):
        gf.simulate(blue, protocol, method="dynamic", damping=-1.0)
    with pytest.raises(gf.InvalidProtocolError):
        gf.simulate(blue, [gf.Hold(1.0), 3])


def test_a_list_of_segments_is_a_protocol(blue):
    result = gf.simulate(blue, [gf.Velocity(V, 10.0)])
    assert result.protocol.duration == 10.0


def test_default_failure_threshold_is_a_thousand_times_the_velocity(blue):
    assert gf.simulate(blue, _switch(10.0)).options["v_fail"] == pytest.approx(1000 * V)
    ramp = gf.Protocol([gf.ForceRamp(rate=RAMP_RATE, duration=10.0)])
    assert gf.simulate(blue, ramp).options["v_fail"] == pytest.approx(1e-3)
