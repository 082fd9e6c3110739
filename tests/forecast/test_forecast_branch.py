"""The compiled inversion of the rising branch (granflow.forecast.branch.branch_values), which
every quasi-static forecast evaluates tens of times: its slip against brentq on
friction_slip (independent of it), its Jacobian against central differences, over
parameters a factor 3 about SPEC §4's values, dense and sparse forces, up to a millionth
below the peak and past it."""

import numpy as np
import pytest
from scipy.optimize import brentq

import granflow as gf
from granflow.forecast.branch import branch_values

CENTRE = (3.31e-3, 4.19e4, 10e-3, 0.198e-6)


def _params(rng):
    return gf.Params(*(v * 3.0 ** rng.uniform(-1.0, 1.0) for v in CENTRE))


def reference_slip(force, params):
    """x - x0 [m] under the running maximum of ``force`` [N]: brentq on friction_slip to
    rounding (its default xtol, 2e-12 m, is a hundredth of these slips)."""
    held = np.maximum.accumulate(force)
    top = gf.peak(params)
    start = gf.friction_slip(params.x0, params)

    def root(h):
        if h <= start:
            return params.x0
        return brentq(
            lambda z: gf.friction_slip(z, params) - h,
            params.x0,
            top.slip,
            xtol=1e-30,
            rtol=1e-15,
        )

    return np.array([root(h) for h in held]) - params.x0


def _solve(base, params, error=None, nuisance=None):
    """(slip [m], jacobian) of the branch under ``base + error @ nuisance``, in Eq. 3's own
    parameters (a, alpha, Fd, x0), then the nuisance coordinates."""
    top = gf.peak(params)
    error = np.zeros((base.size, 0)) if error is None else np.ascontiguousarray(error)
    nuisance = np.zeros(0) if nuisance is None else np.asarray(nuisance, dtype=float)
    slip = np.empty(base.size)
    jacobian = np.empty((base.size, 4 + error.shape[1]))
    branch_values(
        np.ascontiguousarray(base, dtype=float),
        error,
        nuisance,
        (params.a, params.alpha, params.Fd, params.x0),
        (top.force, top.slip),
        np.eye(4),
        slip,
        jacobian,
    )
    return slip, jacobian


@pytest.mark.parametrize("size", [15, 400, 5000])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_branch_slip_is_the_independent_root(size, seed):
    """Forces rising to a millionth below the peak, in order and with drops (a held force
    is the running maximum): the slip equals brentq's root to 1e-12 of the peak's slip."""
    rng = np.random.default_rng(seed)
    params = _params(rng)
    top = gf.peak(params)
    rising = np.sort(rng.uniform(0.0, 1.0 - 1e-6, size)) * top.force
    rising[-1] = (1.0 - 1e-6) * top.force
    force = rising * np.where(rng.uniform(size=size) < 0.2, 0.7, 1.0)  # some drops
    slip, _ = _solve(force, params)
    expected = reference_slip(force, params)
    np.testing.assert_allclose(slip, expected, rtol=0, atol=1e-12 * (top.slip - params.x0))


def test_past_the_peak_the_slip_is_the_penalty_and_points_back():
    """A held force at or above F_peak (a nuisance shifted far) gives the peak's slip plus a
    steep linear penalty whose derivative points back in F_peak's direction."""
    params = gf.Params(*CENTRE)
    top = gf.peak(params)
    force = np.array([0.5, 0.9, 1.0, 1.01]) * top.force
    slip, jacobian = _solve(force, params)
    assert slip[2] == pytest.approx(top.slip - params.x0, rel=1e-12)
    assert slip[3] > slip[2]
    assert jacobian[3, 0] < 0 and np.all(jacobian[3, 1:4] == 0)


@pytest.mark.parametrize("seed", [3, 4])
def test_the_branch_jacobian_is_the_slip_s_derivative(seed):
    """The Jacobian in (a, alpha, Fd, x0) and the nuisance coordinates against central
    differences of the slip itself (steps of 1e-6 of each value)."""
    rng = np.random.default_rng(seed)
    params = _params(rng)
    top = gf.peak(params)
    base = np.linspace(0.2, 0.97, 300) * top.force
    error = rng.standard_normal((base.size, 2)) * 1e-3 * top.force
    nuisance = np.array([0.3, -0.2])
    _, jacobian = _solve(base, params, error, nuisance)
    values = np.array([params.a, params.alpha, params.Fd, params.x0, *nuisance])
    for j in range(values.size):
        step = 1e-6 * (abs(values[j]) if j < 4 else 1.0)
        up, down = values.copy(), values.copy()
        up[j] += step
        down[j] -= step

        def slip_at(v):
            p = gf.Params(*v[:4])
            x, _ = _solve(base, p, error, v[4:])
            return x + p.x0  # x itself: the slip counts from x0

        numeric = (slip_at(up) - slip_at(down)) / (2 * step)
        analytic = jacobian[:, j] + (1.0 if j == 3 else 0.0)
        scale = np.max(np.abs(numeric)) + 1e-300
        np.testing.assert_allclose(analytic, numeric, rtol=0, atol=2e-5 * scale)
