"""Eq. 3, its peak and its limits against independent references (SPEC §4, mpmath, solve_ivp)."""

import math

import mpmath as mp
import numpy as np
import pytest
from conftest import PAPER_SETS, PAPER_VELOCITY, paper_params
from scipy.integrate import solve_ivp

import granflow as gf

mp.mp.dps = 40

# SPEC §4: blue set, Fd = 10 mN, v = 0.86 µm/s, paper initial condition (40-digit values)
SPEC_CURVE = {
    1.0: 5.135709584784229e-3,
    10.0: 1.262797803698962e-2,
    24.0: 1.378268331975076e-2,
    100.0: 1.145552112389554e-2,
    1000.0: 1.009465370486166e-2,
    1e7: 1.000000919446998e-2,
}
SPEC_PEAK_TIME = 24.30497780674322
SPEC_PEAK_FORCE = 1.378294706440486e-2


def reference_friction(x, params, F_init=None):
    """Eq. 3 in slip with mpmath at 40 digits."""
    a, alpha, Fd, x0 = (mp.mpf(v) for v in (params.a, params.alpha, params.Fd, params.x0))
    s, s0 = alpha * mp.mpf(float(x)), alpha * x0
    aging = a * mp.exp(-s) * (mp.ei(s) - mp.ei(s0))
    if F_init is None:
        return aging + Fd * (1 - mp.exp(-s))
    return Fd + (mp.mpf(F_init) - Fd) * mp.exp(-(s - s0)) + aging


@pytest.mark.parametrize(("time", "force"), SPEC_CURVE.items())
def test_spec_reference_values(blue, time, force):
    assert gf.friction_time(time, blue, PAPER_VELOCITY) == pytest.approx(force, rel=1e-12)


def test_spec_peak(blue):
    top = gf.peak(blue, velocity=PAPER_VELOCITY)
    assert top.time == pytest.approx(SPEC_PEAK_TIME, rel=1e-10)
    assert top.force == pytest.approx(SPEC_PEAK_FORCE, rel=1e-10)
    assert top.slip == pytest.approx(20.90228e-6, rel=1e-6)
    # the peak is the maximum of the closed form, and satisfies a/x = alpha (F - Fd)
    assert gf.friction_slip(top.slip, blue) == pytest.approx(top.force, rel=1e-14)
    around = gf.friction_slip(top.slip * np.array([0.999, 1.001]), blue)
    assert np.all(around < top.force)


def test_peak_without_velocity_has_no_time(blue):
    top = gf.peak(blue)
    assert top.time is None and top.velocity is None
    assert top.to_dict()["force"] == top.force


# α·x over [1e-12, 1e8] on a log grid, x0 from 1e-8·x to 0.5·x
_SLIP_CASES = [(s, r) for s in np.geomspace(1e-12, 1e8, 41) for r in (1e-8, 1e-4, 0.01, 0.2, 0.5)]


@pytest.mark.parametrize(("s", "ratio"), _SLIP_CASES)
def test_friction_slip_matches_mpmath_over_the_domain(s, ratio):
    alpha = 4.0e4
    params = gf.Params(a=3e-3, alpha=alpha, Fd=1e-2, x0=ratio * s / alpha)
    x = s / alpha
    ref = reference_friction(x, params)
    assert float(abs((gf.friction_slip(x, params) - ref) / ref)) < 1e-12


@pytest.mark.parametrize("s", [1e-9, 1e-3, 0.5, 2.0, 40.0, 1e4])
def test_friction_slip_is_finite_and_continuous_as_x0_approaches_x(s):
    alpha = 4.0e4
    x = s / alpha
    gaps = np.geomspace(1e-15, 0.5, 80)
    values = [gf.friction_slip(x, gf.Params(3e-3, alpha, 1e-2, x * (1 - g))) for g in gaps]
    assert np.all(np.isfinite(values))
    # F(x) -> F(x0) = Fd (1 - e^{-s}) as x0 -> x, with no jump along the way
    limit = 1e-2 * -math.expm1(-s)
    assert values[0] == pytest.approx(limit, rel=1e-12, abs=1e-17)
    for gap, value in zip(gaps, values, strict=True):
        params = gf.Params(3e-3, alpha, 1e-2, x * (1 - gap))
        assert abs(value - float(reference_friction(x, params))) < 1e-15


@pytest.mark.parametrize("F_init", [0.0, 4e-3, 12e-3, 30e-3])
def test_general_initial_condition_matches_mpmath(blue, F_init):
    x = np.geomspace(blue.x0, 1e-3, 50)
    got = gf.friction_slip(x, blue, F_init=F_init)
    ref = np.array([float(reference_friction(v, blue, F_init)) for v in x])
    np.testing.assert_allclose(got, ref, rtol=1e-12, atol=1e-17)
    assert got[0] == F_init


def _ode_solution(params, velocity, times, F_init=None):
    t0 = params.t0(velocity)
    start = gf.initial_force(params, F_init=F_init)
    solution = solve_ivp(
        lambda t, F: gf.rhs_time(t, F, params, velocity),
        (t0, times[-1]),
        [start],
        t_eval=times,
        method="DOP853",
        rtol=1e-11,
        atol=1e-18,
    )
    assert solution.success
    return solution.y[0]


@pytest.mark.parametrize("name", sorted(PAPER_SETS))
@pytest.mark.parametrize("Fd", [0.0, 5e-3, 20e-3])
def test_closed_form_matches_ode_integration(name, Fd):
    params = paper_params(name, Fd=Fd)
    times = np.geomspace(params.t0(PAPER_VELOCITY) * 1.001, 2000.0, 60)
    expected = _ode_solution(params, PAPER_VELOCITY, times)
    np.testing.assert_allclose(gf.friction_time(times, params, PAPER_VELOCITY), expected, rtol=1e-8)


def test_closed_form_matches_ode_with_general_initial_condition():
    params = gf.Params(a=1e-3, alpha=1e5, Fd=5e-3, x0=1e-7)
    velocity = 1e-5
    times = np.geomspace(params.t0(velocity) * 1.01, 10.0, 40)
    expected = _ode_solution(params, velocity, times, F_init=9e-3)
    got = gf.friction_time(times, params, velocity, F_init=9e-3)
    np.testing.assert_allclose(got, expected, rtol=1e-8)


def test_no_peak_is_reported_not_invented(blue):
    nullcline = blue.Fd + blue.a / (blue.alpha * blue.x0)
    assert gf.has_peak(blue)
    assert not gf.has_peak(blue, F_init=nullcline * 1.01)
    with pytest.raises(gf.NoPeakError, match="no peak"):
        gf.peak(blue, F_init=nullcline * 1.01)
    with pytest.raises(gf.NoPeakError, match="a = 0"):
        gf.peak(blue.replace(a=0.0))
    # just below the nullcline the peak exists and sits right after x0
    top = gf.peak(blue, F_init=nullcline * 0.999)
    assert top.slip > blue.x0
    assert top.force == pytest.approx(blue.Fd + blue.a / (blue.alpha * top.slip), rel=1e-14)


def test_general_initial_condition_peak_is_the_maximum():
    params = gf.Params(a=2e-3, alpha=5e4, Fd=8e-3, x0=1e-6)
    top = gf.peak(params, F_init=12e-3)
    x = np.linspace(params.x0, 20 * top.slip, 20001)
    curve = gf.friction_slip(x, params, F_init=12e-3)
    assert curve.max() <= top.force * (1 + 1e-14)
    assert x[np.argmax(curve)] == pytest.approx(top.slip, rel=2e-3)


def test_pure_aging_limit():
    # alpha x << 1: F = F_init + a ln(x/x0) + O(alpha x)
    params = gf.Params(a=3e-3, alpha=1e-6, Fd=1e-2, x0=1e-7)
    x = np.geomspace(1e-7, 1e-3, 20)
    aging = gf.friction_aging(x, params, F_init=2e-3)
    np.testing.assert_allclose(gf.friction_slip(x, params, F_init=2e-3), aging, rtol=1e-8)
    # the paper's initial condition tends to zero with alpha: pure logarithmic growth from 0
    np.testing.assert_allclose(
        gf.friction_aging(x, params), 3e-3 * np.log(x / 1e-7) + 1e-2 * -np.expm1(-1e-13), rtol=1e-12
    )


def test_large_slip_asymptote(blue):
    x = np.geomspace(1e-2, 1e2, 9)  # alpha x from 4e2 to 4e6
    excess = gf.friction_slip(x, blue) - gf.friction_asymptote(x, blue)
    # next term of the asymptotic series: a / (alpha x)^2
    np.testing.assert_allclose(excess, blue.a / (blue.alpha * x) ** 2, rtol=5e-3)
    assert gf.steady_state(blue) == blue.Fd


def test_rhs_vanishes_at_the_peak(blue):
    top = gf.peak(blue)
    assert abs(gf.rhs_slip(top.slip, top.force, blue)) < 1e-12 * blue.a / top.slip


@pytest.mark.parametrize("F_init", [None, 7e-3])
def test_jacobian_matches_mpmath_derivatives(blue, F_init):
    x = np.array([5e-7, 5e-6, 2.1e-5, 1e-4, 1e-3])
    jac = gf.friction_slip_jacobian(x, blue, F_init=F_init)
    names = ["a", "alpha", "Fd", "x0"] + ([] if F_init is None else ["F_init"])
    assert list(jac) == names
    base = {"a": blue.a, "alpha": blue.alpha, "Fd": blue.Fd, "x0": blue.x0, "F_init": F_init}
    for name in names:
        for i, xi in enumerate(x):

            def model(value, name=name, xi=xi):
                values = dict(base, **{name: value})
                a, alpha, Fd, x0 = (mp.mpf(values[k]) for k in ("a", "alpha", "Fd", "x0"))
                s, s0 = alpha * mp.mpf(xi), alpha * x0
                aging = a * mp.exp(-s) * (mp.ei(s) - mp.ei(s0))
                if values["F_init"] is None:
                    return aging + Fd * (1 - mp.exp(-s))
                return Fd + (mp.mpf(values["F_init"]) - Fd) * mp.exp(-(s - s0)) + aging

            expected = mp.diff(model, mp.mpf(base[name]))
            assert float(jac[name][i]) == pytest.approx(float(expected), rel=1e-9, abs=1e-25)


@pytest.mark.parametrize(
    ("call", "match"),
    [
        (lambda p: gf.friction_slip(p.x0 / 2, p), "below the initial state"),
        (lambda p: gf.friction_slip([1e-6, np.nan], p), "x must be finite"),
        (lambda p: gf.friction_time([1.0, np.inf], p, 1e-6), "t must be finite"),
        (lambda p: gf.friction_time(0.1, p, PAPER_VELOCITY), "t must not lie below"),
        (lambda p: gf.friction_time(1.0, p, -1e-6), "velocity must be positive"),
        (lambda p: gf.friction_slip(1e-6, p, F_init=-1.0), "F_init must be non-negative"),
        (lambda p: gf.friction_slip("abc", p), "x: cannot read 'abc' as a quantity in m"),
        (lambda p: gf.friction_slip(1e-6, "params"), "params must be a granflow.Params"),
        (lambda p: gf.friction_slip([[1e-6], [1e-5, 2e-5]], p), "x must be an array"),
    ],
)
def test_bad_input_names_the_argument(blue, call, match):
    with pytest.raises(gf.InvalidParameterError, match=match) as info:
        call(blue)
    assert isinstance(info.value, gf.GranflowError)
    assert isinstance(info.value, ValueError)


def test_start_of_curve_is_accepted_despite_round_off(blue):
    t0 = blue.t0(PAPER_VELOCITY)
    assert gf.friction_time(t0, blue, PAPER_VELOCITY) == pytest.approx(
        gf.initial_force(blue), rel=1e-12
    )


def test_shapes_and_inputs_are_preserved(blue):
    x = np.array([[1e-6, 2e-6], [3e-6, 4e-6]])
    before = x.copy()
    out = gf.friction_slip(x, blue)
    assert out.shape == (2, 2)
    assert np.array_equal(x, before)
    assert isinstance(gf.friction_slip(1e-6, blue), float)
    assert gf.friction_slip(np.array([]), blue).shape == (0,)


def test_threaded_evaluation_equals_serial(blue):
    from granflow import _threads

    t = np.linspace(blue.t0(PAPER_VELOCITY), 3000.0, 3 * _threads.MIN_CHUNK + 17)
    threads = _threads.get_num_threads()
    try:
        _threads.set_num_threads(3)
        threaded = gf.friction_time(t, blue, PAPER_VELOCITY)
        t[-5] = np.nan  # a bad point in the last chunk is found and named
        with pytest.raises(gf.InvalidParameterError, match=f"at index {t.size - 5}"):
            gf.friction_time(t, blue, PAPER_VELOCITY)
        _threads.set_num_threads(1)
        t[-5] = t[-6] + 1e-3
        serial = gf.friction_time(t, blue, PAPER_VELOCITY)
    finally:
        _threads.set_num_threads(threads)
    assert np.array_equal(threaded[:-5], serial[:-5])
    with pytest.raises(ValueError, match="at least 1"):
        _threads.set_num_threads(0)
