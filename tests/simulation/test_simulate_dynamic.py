"""method="dynamic": inertia, damping, a machine spring and the direct effect, checked
against the quasi-static answers where the two must agree and against the physics where
they must differ."""

import subprocess
import sys

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import granflow as gf
from granflow.simulation.driver import DEFAULT_DAMPING, DEFAULT_MASS

V = 0.86e-6
RAMP_RATE = 0.05e-3


@pytest.fixture(scope="module")
def blue():
    return gf.Params.from_time_domain(a=3.31e-3, k=0.036, t0=0.23, Fd=10e-3, velocity=V)


def _switch(duration, factor=1.01, hold=60.0, ramp=0.0):
    return gf.Protocol([gf.Velocity(V, duration), gf.SwitchToForce(hold, factor=factor, ramp=ramp)])


def test_default_mass_is_an_mcr_motor_at_the_contact_radius():
    assert pytest.approx(1e-5 / gf.Annulus.paper().mean_radius ** 2) == DEFAULT_MASS
    assert pytest.approx(0.0533, rel=1e-3) == DEFAULT_MASS


@pytest.fixture(scope="module")
def ramps(blue):
    protocol = gf.Protocol([gf.ForceRamp(rate=RAMP_RATE, duration=400.0)])
    return gf.simulate(blue, protocol), gf.simulate(blue, protocol, method="dynamic")


def test_slow_stress_ramp_fails_near_the_peak(blue, ramps):
    quasistatic, dynamic = ramps
    top = gf.peak(blue).force
    assert quasistatic.failure.force == pytest.approx(top, rel=1e-6)
    assert dynamic.success and dynamic.failed
    assert dynamic.failure.force == pytest.approx(top, rel=1e-2)
    assert dynamic.failure.force >= top  # the runaway needs a force above the peak
    assert dynamic.failure.time > quasistatic.failure.time  # failure takes a finite time
    assert np.max(dynamic.velocity) >= dynamic.options["v_fail"]


def test_slip_at_ninety_percent_of_the_peak_agrees(blue, ramps):
    level = 0.9 * gf.peak(blue).force

    def slip_at(result):
        rising = result.t < result.failure.time - 1.0
        return np.interp(level, result.force[rising], result.slip[rising])

    quasistatic, dynamic = ramps
    assert slip_at(quasistatic) - blue.x0 > 0
    assert slip_at(dynamic) == pytest.approx(slip_at(quasistatic), rel=1e-3)


def test_switch_after_the_peak_fails_dynamically(blue):
    result = gf.simulate(blue, _switch(80.0), method="dynamic")
    assert result.failed
    assert 80.0 < result.failure.time < 90.0
    assert result.failure.slip > 80.0 * V


@pytest.fixture(scope="module")
def step_slips(blue):
    """Slip to the stop after a 1 % force step at t = 10 s: (quasi-static, {damping: dynamic})."""
    start = 10.0 * V  # the record clock: slip v t since the start of shear
    quasistatic = gf.simulate(blue, _switch(10.0)).events_of("stop")[0].slip - start
    dynamic = {}
    for damping in (None, 0.0, DEFAULT_DAMPING, 2.0, 8.0, 100.0):
        result = gf.simulate(blue, _switch(10.0), method="dynamic", damping=damping)
        assert not result.failed
        dynamic[damping] = result.events_of("stop")[0].slip - start
    return quasistatic, dynamic


def test_a_sudden_step_overshoots_the_quasistatic_stop(step_slips):
    quasistatic, dynamic = step_slips
    assert 0.3e-6 < quasistatic < 0.7e-6
    ratio = dynamic[None] / quasistatic  # the default, lightly damped drive
    assert 1.0 < ratio < 2.0


def test_the_overshoot_fades_as_damping_makes_the_motion_overdamped(step_slips):
    quasistatic, dynamic = step_slips
    ratios = [dynamic[d] / quasistatic for d in (0.0, DEFAULT_DAMPING, 2.0, 8.0, 100.0)]
    assert ratios[0] > ratios[1] > ratios[2] > ratios[3] - 1e-6  # less overshoot, down to ...
    # undamped: about twice (a little more, since the rising branch is concave)
    assert ratios[0] == pytest.approx(2.0, abs=0.05)
    assert ratios[-2] == pytest.approx(1.0, abs=1e-3)  # ... none: critically damped
    assert ratios[-1] == pytest.approx(1.0, abs=1e-3)


def test_a_slow_switch_agrees_with_the_quasistatic_stop(blue):
    start = 10.0 * V  # the record clock: slip v t since the start of shear
    quasistatic = gf.simulate(blue, _switch(10.0, hold=400.0))
    dynamic = gf.simulate(blue, _switch(10.0, hold=400.0, ramp=300.0), method="dynamic")
    assert dynamic.velocity[-1] == 0.0
    assert dynamic.slip[-1] - start == pytest.approx(quasistatic.slip[-1] - start, rel=1e-3)


def test_rigid_drive_makes_rate_control_identical(blue):
    protocol = gf.Protocol([gf.Velocity(V, 100.0), gf.Hold(10.0), gf.Velocity(2 * V, 10.0)])
    quasistatic = gf.simulate(blue, protocol)
    dynamic = gf.simulate(blue, protocol, method="dynamic")
    np.testing.assert_array_equal(quasistatic.force, dynamic.force)


def test_a_stiff_machine_follows_the_closed_form(blue):
    damping = 20.0
    result = gf.simulate(
        blue, gf.Protocol([gf.Velocity(V, 20.0)]), method="dynamic", stiffness=1e5, damping=damping
    )
    assert result.success
    sliding = result.t > 5.0
    expected = gf.friction_slip(result.slip[sliding], blue)
    resisted = result.force[sliding] - damping * result.velocity[sliding]
    np.testing.assert_allclose(resisted, expected, rtol=1e-5)
    # the spring stretches by force / K: the layer lags the drive by that much
    lag = V * result.t[-1] - result.displacement[-1]
    assert lag == pytest.approx(result.force[-1] / 1e5, rel=1e-3)


def test_a_soft_machine_sticks_and_slips_after_the_peak(blue):
    """K below the steepest fall of F(x) (about 26 N/m here): a slip instability."""
    fast = 10e-6  # the curve F(x) does not depend on the rate; a faster drive is quicker
    result = gf.simulate(
        blue, gf.Protocol([gf.Velocity(fast, 150.0)]), method="dynamic", stiffness=20.0
    )
    assert result.success and not result.failed
    kinds = [event.kind for event in result.events]
    assert kinds[:3] == ["slide", "stop", "slide"]
    stop = result.events_of("stop")[0]
    assert stop.slip > gf.peak(blue).slip  # the instability lies on the falling branch
    assert np.max(result.velocity) > 10 * fast  # the slip runs ahead of the drive


def test_time_clock_dynamic_switch_fails_where_the_quasistatic_one_does(blue):
    for method in ("quasistatic", "dynamic"):
        result = gf.simulate(blue, _switch(10.0), clock="time", method=method)
        assert result.failed, method


def test_direct_effect_creeps_dynamically(blue):
    sigma = 0.98 * gf.friction_time(5.0 + blue.t0(V), blue, V)
    protocol = gf.Protocol([gf.Velocity(V, 5.0), gf.Force(sigma, 100.0)])
    result = gf.simulate(blue, protocol, method="dynamic", direct_effect=0.05e-3)
    assert result.success and not result.failed
    creep = result.segment == 1
    assert np.all(np.diff(result.displacement[creep]) >= 0)
    assert result.displacement[-1] > 5.0 * V
    quasistatic = gf.simulate(blue, protocol, direct_effect=0.05e-3)
    assert result.displacement[-1] == pytest.approx(quasistatic.displacement[-1], rel=1e-2)


@pytest.mark.parametrize(
    ("limit", "words"),
    [
        ({"max_evaluations": 50}, "max_evaluations"),
        ({"max_transitions": 1}, "max_transitions"),
    ],
)
def test_bounded_work_returns_an_unsuccessful_result(blue, limit, words):
    protocol = gf.Protocol([gf.ForceSteps([2e-3, 4e-3, 6e-3], 1.0)])
    result = gf.simulate(blue, protocol, method="dynamic", **limit)
    assert not result.success
    assert words in result.message
    assert result.segments[-1].outcome == "aborted"
    assert len(result.t) == len(result.force)


def test_wall_time_does_not_bound_the_dynamic_method(blue):
    """Work is bounded by evaluations and transitions only: max_wall changes nothing."""
    protocol = gf.Protocol([gf.ForceSteps([2e-3, 4e-3, 6e-3], 1.0)])
    bounded = gf.simulate(blue, protocol, method="dynamic", max_wall=1e-6)
    free = gf.simulate(blue, protocol, method="dynamic")
    assert bounded.success
    for name in ("t", "slip", "velocity", "force", "state"):
        np.testing.assert_array_equal(getattr(bounded, name), getattr(free, name))


@pytest.mark.parametrize("damping", [None, 0.0])
def test_failure_time_matches_a_tight_radau_reference(blue, damping):
    """A start-up to 20 s, then a 0.05 mN/s ramp from there to failure, against solve_ivp
    (Radau, rtol 1e-12) on the same equations written here."""
    switch = 20.0
    protocol = gf.Protocol([gf.Velocity(V, switch), gf.ForceRamp(rate=RAMP_RATE, duration=60.0)])
    result = gf.simulate(blue, protocol, method="dynamic", damping=damping)
    assert [event.kind for event in result.events] == ["failure"]  # no stick on the way
    c, m, v_fail = result.options["damping"], result.options["mass"], result.options["v_fail"]
    x_s = V * switch  # the one clock: slip V t since shearing started at t = 0
    F_s = gf.friction_slip(x_s, blue)

    def rhs(t, y):
        x, v, F = y
        sigma = F_s + RAMP_RATE * (t - switch)
        return [v, (sigma - F - c * v) / m, v * (blue.a / x - blue.alpha * (F - blue.Fd))]

    def failure(t, y):
        return y[1] - v_fail

    failure.terminal, failure.direction = True, 1
    reference = solve_ivp(
        rhs,
        (switch, switch + 60.0),
        [x_s, V, F_s],
        method="Radau",
        rtol=1e-12,
        atol=[1e-20, 1e-22, 1e-18],
        events=failure,
    )
    assert result.failure.time == pytest.approx(reference.t_events[0][0], rel=1e-6)
    assert result.failure.slip == pytest.approx(reference.y_events[0][0][0], rel=1e-6)


def _busy_cores(count):
    """Processes that keep ``count`` cores busy until they are ended."""
    return [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(count)]


def test_runs_are_bit_identical_on_a_quiet_and_a_loaded_machine(blue):
    protocols = [
        gf.Protocol([gf.ForceRamp(rate=RAMP_RATE, duration=400.0)]),
        gf.Protocol([gf.Velocity(V, 10.0), gf.SwitchToForce(60.0, factor=1.01)]),
    ]
    runs = [{"damping": 0.0}, {}, {"clock": "time"}, {"direct_effect": 0.05e-3}]

    def all_runs():
        return [
            gf.simulate(blue, protocol, method="dynamic", **options)
            for protocol in protocols
            for options in runs
        ]

    quiet = all_runs()
    workers = _busy_cores(2)
    try:
        loaded = all_runs()
    finally:
        for worker in workers:
            worker.kill()
            worker.wait()
    for first, second in zip(quiet, loaded, strict=True):
        assert first.success == second.success and first.message == second.message
        assert first.events == second.events
        for name in ("t", "slip", "velocity", "force", "state", "age", "displacement"):
            np.testing.assert_array_equal(getattr(first, name), getattr(second, name))
