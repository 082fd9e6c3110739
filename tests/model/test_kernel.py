"""The Eq. 3 point kernel against 40-digit arithmetic, and the below-x0 option."""

import math

import mpmath as mp
import numpy as np
import pytest

import granflow as gf
from granflow.model import kernel

mp.mp.dps = 40

A, ALPHA, FD, X0 = 3.31e-3, 4.186e4, 10e-3, 1.978e-7
NAMES = ("a", "alpha", "Fd", "x0", "F_init")


def reference(z, a, alpha, Fd, x0, F_init=None):
    """Eq. 3 at 40 digits; the paper's initial condition when F_init is None."""
    a, alpha, Fd, x0, z = (mp.mpf(v) for v in (a, alpha, Fd, x0, z))
    s, s0 = alpha * z, alpha * x0
    aging = a * mp.exp(-s) * (mp.ei(s) - mp.ei(s0))
    if F_init is None:
        return aging + Fd * (1 - mp.exp(-s))
    return Fd + (mp.mpf(F_init) - Fd) * mp.exp(-(s - s0)) + aging


def reference_scaled(s, s0, a, Fd, F_init=None):
    """Eq. 3 at 40 digits from the scaled arguments themselves (s = alpha z, s0 = alpha x0 as
    rounded to doubles): next to s0, the rounding of alpha z alone moves F by more than
    1e-13, whatever the formula."""
    s, s0, a, Fd = (mp.mpf(v) for v in (s, s0, a, Fd))
    aging = a * mp.exp(-s) * (mp.ei(s) - mp.ei(s0))
    if F_init is None:
        return aging + Fd * (1 - mp.exp(-s))
    return Fd + (mp.mpf(F_init) - Fd) * mp.exp(-(s - s0)) + aging


def point(z, F_init=None, held=False, params=(A, ALPHA, FD, X0)):
    a, alpha, Fd, x0 = params
    start = kernel.curve_start(alpha, x0)
    s = alpha * z
    paper = F_init is None
    offset = 0.0 if paper else F_init - Fd
    return kernel.point(z, s, math.exp(start[0] - s), a, alpha, Fd, x0, offset, paper, held, start)


SLIPS = [2.5e-7, 1e-6, 5e-6, 2.1e-5, 1e-4, 1e-3, 0.05]


@pytest.mark.parametrize("F_init", [None, 7e-3])
@pytest.mark.parametrize("z", SLIPS)
def test_point_value_matches_mpmath(z, F_init):
    value = point(z, F_init)[0]
    expected = reference(z, A, ALPHA, FD, X0, F_init)
    assert abs(value - float(expected)) <= 1e-14 * abs(float(expected))


@pytest.mark.parametrize("F_init", [None, 7e-3])
@pytest.mark.parametrize("z", SLIPS)
def test_point_derivatives_match_mpmath(z, F_init):
    got = point(z, F_init)
    base = {"a": A, "alpha": ALPHA, "Fd": FD, "x0": X0, "F_init": F_init}
    names = NAMES[:4] if F_init is None else NAMES
    for k, name in enumerate(names, start=1):

        def model(value, name=name):
            values = dict(base, **{name: value})
            return reference(
                z, values["a"], values["alpha"], values["Fd"], values["x0"], values["F_init"]
            )

        expected = float(mp.diff(model, mp.mpf(base[name])))
        assert got[k] == pytest.approx(expected, rel=1e-9, abs=1e-25), name
    if F_init is None:
        assert got[5] == 0.0


@pytest.mark.parametrize("F_init", [None, 7e-3])
def test_held_point_is_the_initial_state_and_its_derivatives(F_init):
    held = point(0.5 * X0, F_init, held=True)
    assert held[0] == pytest.approx(float(reference(X0, A, ALPHA, FD, X0, F_init)), rel=1e-14)
    base = {"a": A, "alpha": ALPHA, "Fd": FD, "x0": X0, "F_init": F_init}
    names = NAMES[:4] if F_init is None else NAMES
    for k, name in enumerate(names, start=1):

        def initial(value, name=name):
            values = dict(base, **{name: value})
            if values["F_init"] is not None:
                return mp.mpf(values["F_init"])
            return mp.mpf(values["Fd"]) * (1 - mp.exp(-mp.mpf(values["alpha"]) * values["x0"]))

        expected = float(mp.diff(initial, mp.mpf(base[name])))
        assert held[k] == pytest.approx(expected, rel=1e-9, abs=1e-25), name


def test_general_value_matches_mpmath_and_friction_slip():
    for z in SLIPS:
        value = kernel.general_value(z, A, ALPHA, FD, X0, 8e-3)
        expected = float(reference(z, A, ALPHA, FD, X0, 8e-3))
        assert abs(value - expected) <= 1e-14 * abs(expected)
        assert value == pytest.approx(
            gf.friction_slip(z, gf.Params(A, ALPHA, FD, X0), F_init=8e-3), rel=1e-14
        )


def fused_grid(x0, alpha, rng):
    """Slips over every region of the SIMD pass for the initial state x0: s <= 1e-3, the power
    series (next to s0 and far from it), the tables, the large-s fit, in shuffled order,
    with runs of sorted points (blocks within one piece of the table)."""
    s0 = alpha * x0
    scattered = np.concatenate(
        [
            s0 * (1.0 + np.geomspace(1e-9, 1.0, 40)),
            np.geomspace(max(2 * s0, 1e-4), 0.5, 30),
            np.geomspace(0.5, 700.0, 50),
            s0 + np.geomspace(1e-9, 2.0, 20),
        ]
    )
    scattered = scattered[scattered > s0]
    sorted_run = np.linspace(max(2.0, 1.01 * s0), max(2.0, 1.01 * s0) + 0.01, 300)
    return np.concatenate([rng.permutation(scattered), sorted_run]) / alpha


@pytest.mark.parametrize("F_init", [None, 7e-3])
@pytest.mark.parametrize("x0", [X0, 1e-9, 2e-5])  # s0 = 8.3e-3, 4.2e-5 and 0.84
def test_fused_values_match_mpmath_in_every_region(x0, F_init):
    rng = np.random.default_rng(1)
    z = fused_grid(x0, ALPHA, rng)
    paper = F_init is None
    offset = 0.0 if paper else F_init - FD
    out = np.empty_like(z)
    bad = kernel.eq3_values(z, 1.0, x0, x0, A, ALPHA, FD, x0, offset, paper, False, out)
    assert bad == -1
    checked = np.concatenate([np.arange(0, z.size, 3), np.arange(z.size - 300, z.size, 50)])
    for i in checked:
        expected = float(reference_scaled(ALPHA * (1.0 * z[i]), ALPHA * x0, A, FD, F_init))
        assert abs(out[i] - expected) <= 1e-13 * abs(expected), (z[i] * ALPHA, x0)


def test_fused_values_in_the_time_domain_hold_and_report_the_first_bad_point():
    velocity = 0.86e-6
    t0 = X0 / velocity
    t = np.array([0.5 * t0, t0, 3 * t0, 10.0, 100.0])
    out = np.empty_like(t)
    bad = kernel.eq3_values(t, velocity, -math.inf, t0, A, ALPHA, FD, X0, 0.0, True, True, out)
    assert bad == -1
    assert out[0] == out[1] == gf.initial_force(gf.Params(A, ALPHA, FD, X0))
    for i in (2, 3, 4):
        expected = float(reference(t[i] * velocity, A, ALPHA, FD, X0))
        assert out[i] == pytest.approx(expected, rel=1e-13)
    t_bad = np.array([10.0, math.nan, 0.1 * t0, 20.0])
    lowest = t0 * (1 - 1e-12)
    assert (
        kernel.eq3_values(t_bad, velocity, lowest, t0, A, ALPHA, FD, X0, 0.0, True, False, out) == 1
    )
    t_low = np.array([10.0, 0.1 * t0])
    assert (
        kernel.eq3_values(t_low, velocity, lowest, t0, A, ALPHA, FD, X0, 0.0, True, False, out) == 1
    )


def test_scalar_path_is_the_fused_pass_at_one_point():
    velocity = 0.86e-6
    t0 = X0 / velocity
    t = np.array([0.5 * t0, t0, 1.001 * t0, 3 * t0, 10.0, 1e4])
    out = np.empty_like(t)
    for paper, offset in ((True, 0.0), (False, -2e-3)):
        args = (velocity, -math.inf, t0, A, ALPHA, FD, X0, offset, paper, True)
        kernel.eq3_values(t, *args, out)
        for i, ti in enumerate(t):
            assert kernel.eq3_scalar(ti, *args) == pytest.approx(out[i], rel=1e-14)
    lowest = t0 * (1 - 1e-12)
    for bad in (math.nan, math.inf, 0.5 * t0):
        args = (velocity, lowest, t0, A, ALPHA, FD, X0, 0.0, True, False)
        assert math.isnan(kernel.eq3_scalar(bad, *args))


def test_default_scalar_path_of_the_model_functions():
    """friction_time / friction_slip on a float (kernel.eq3_default) against 40-digit mpmath,
    and the same errors as the array path where the fast path gives way."""
    p = gf.Params(A, ALPHA, FD, X0)
    velocity = 0.86e-6
    t0 = X0 / velocity
    for t in (t0, t0 * (1 - 1e-13), 1.001 * t0, 3 * t0, 37.5, 1e4, 1e7):
        expected = float(reference(max(t, t0) * velocity, A, ALPHA, FD, X0))
        assert gf.friction_time(t, p, velocity) == pytest.approx(expected, rel=1e-13)
        assert gf.friction_slip(t * velocity, p) == pytest.approx(expected, rel=1e-13)
        assert type(gf.friction_time(t, p, velocity)) is float
    with pytest.raises(gf.InvalidParameterError, match="below the initial state"):
        gf.friction_time(0.5 * t0, p, velocity)
    with pytest.raises(gf.InvalidParameterError, match="below the initial state"):
        gf.friction_slip(0.5 * X0, p)
    with pytest.raises(gf.InvalidParameterError, match="finite"):
        gf.friction_time(math.nan, p, velocity)
    for bad in (0.0, -velocity, math.nan, math.inf):
        with pytest.raises(gf.InvalidParameterError, match="velocity"):
            gf.friction_time(37.5, p, bad)
    with pytest.raises(gf.InvalidParameterError, match="params"):
        gf.friction_time(37.5, (A, ALPHA, FD, X0), velocity)


def test_normal_equations_match_the_jacobian_loop():
    rng = np.random.default_rng(0)
    z = np.concatenate([[0.5 * X0, X0], np.geomspace(1.0001 * X0, 1e-3, 1000)])
    y = rng.normal(0.01, 1e-3, z.size)
    w = rng.uniform(0.5, 2.0, z.size)
    F, J = np.empty(z.size), np.empty((z.size, 5))
    kernel.jacobian_loop(z, A, ALPHA, FD, X0, 0.0, True, True, F, J)
    jtj, jtr = np.empty((4, 4)), np.empty(4)
    cost = kernel.normal_equations(z, y, w, A, ALPHA, FD, X0, jtj, jtr)
    r = w * (F - y)
    Jw = J[:, :4] * w[:, None]
    assert cost == pytest.approx(float(r @ r), rel=1e-13)
    np.testing.assert_allclose(jtr, Jw.T @ r, rtol=1e-10)
    np.testing.assert_allclose(jtj, Jw.T @ Jw, rtol=1e-12)
    assert F[0] == F[1] == gf.initial_force(gf.Params(A, ALPHA, FD, X0))


def test_below_option_of_the_model_functions():
    p = gf.Params(A, ALPHA, FD, X0)
    x = np.array([0.1 * X0, 0.9 * X0, X0, 2e-5])
    with pytest.raises(gf.InvalidParameterError, match="below the initial state"):
        gf.friction_slip(x, p)
    held = gf.friction_slip(x, p, below="hold")
    assert held[0] == held[1] == gf.initial_force(p)
    assert held[3] == gf.friction_slip(2e-5, p)
    assert gf.friction_slip(x, p, F_init=7e-3, below="hold")[0] == 7e-3
    v = 0.86e-6
    assert gf.friction_time(x / v, p, v, below="hold")[1] == gf.initial_force(p)
    jac = gf.friction_slip_jacobian(x, p, below="hold")
    assert jac["a"][0] == 0.0 and jac["Fd"][0] == pytest.approx(-math.expm1(-ALPHA * X0))
    with pytest.raises(gf.InvalidParameterError, match="below the initial state"):
        gf.friction_slip_jacobian(x, p)
    with pytest.raises(gf.InvalidParameterError, match="below must be 'raise' or 'hold'"):
        gf.friction_slip(x, p, below="clip")
