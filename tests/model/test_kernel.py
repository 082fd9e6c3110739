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
        assert value == gf.friction_slip(z, gf.Params(A, ALPHA, FD, X0), F_init=8e-3)


def test_normal_equations_match_the_jacobian_loop():
    rng = np.random.default_rng(0)
    z = np.concatenate([[0.5 * X0, X0], np.geomspace(2 * X0, 1e-3, 200)])
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
