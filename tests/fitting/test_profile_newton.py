"""The profile's Newton search: the envelope theorem's slope of a conditional minimum, and
ends found from hints that match those of the secant search and of an independent root.

The reference is independent of the engine: each conditional minimum by SciPy's
``least_squares`` on the same residuals with the profiled parameter pinned, the ends by
``brentq`` on those minima."""

import math

import numpy as np
import pytest
from scipy.optimize import brentq, least_squares

from granflow.fitting.engine import Curve, GlobalParameter, Model, Problem
from granflow.fitting.profile import profile_scan

TARGETS = (1.2815515655446004, 1.6448536269514722)  # the normal's 90 % and 95 % quantiles


def _decay(x, amplitude, rate, offset):
    return amplitude * np.exp(-rate * x) + offset


def _decay_jacobian(x, amplitude, rate, offset):
    e = np.exp(-rate * x)
    return _decay(x, amplitude, rate, offset), np.column_stack(
        [e, -amplitude * x * e, np.ones_like(x)]
    )


DECAY = Model(("amplitude", "rate", "offset"), _decay, _decay_jacobian, log=(False, True, False))
NOISE = 0.02


def _solved(seed):
    """A decaying signal with noise ``NOISE``, its problem built about its best fit (the
    weights 1/NOISE: chi-square in variance units), and that fit's chi-square."""
    rng = np.random.default_rng(seed)
    x = np.linspace(0.0, 3.0, 60)
    y = _decay(x, 2.0, 1.3, 0.4) + rng.normal(0.0, NOISE, x.size)
    start = least_squares(lambda p: (_decay(x, *p) - y) / NOISE, (1.0, 1.0, 0.0)).x
    parameters = [
        GlobalParameter("amplitude", start[0], log=False),
        GlobalParameter("rate", start[1], log=True),
        GlobalParameter("offset", start[2], log=False),
    ]
    curve = Curve(x, y, np.full(x.size, 1.0 / NOISE), ((0, 1.0), (1, 1.0), (2, 1.0)))
    problem = Problem([curve], parameters, DECAY)
    u, chisqr, *_ = problem.lm(problem.internal(start), max_iter=200, rtol=1e-15)
    return x, y, problem, problem.values(u), chisqr


def _conditional(x, y, rate, start):
    """SciPy's least chi-square over (amplitude, offset) at ``rate``: (chi-square, argmin)."""
    found = least_squares(
        lambda p: (_decay(x, p[0], rate, p[1]) - y) / NOISE,
        start,
        xtol=1e-15,
        ftol=1e-15,
        gtol=1e-15,
    )
    return 2.0 * found.cost, found.x


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_the_envelope_slope_is_the_derivative_of_the_conditional_minimum(seed):
    """gauss_newton(envelope=True) with the rate pinned returns d(min chi-square)/du (u the
    rate's log coordinate) from its last pass, which SciPy's conditional minima on either
    side give by central differences; and the others' response as Gauss-Newton's model has
    it, -H_oo^-1 H_op with H = J^T J, J here by central differences of the residuals."""
    x, y, problem, values, _ = _solved(seed)
    rate = problem.parameters[1]
    scales = np.array([problem.parameters[i].scale for i in (0, 2)])
    for offset in (-0.05, 0.03, 0.08):
        u = rate.to_internal(values[1]) + offset
        start = np.array([problem.parameters[i].to_internal(values[i]) for i in (0, 2)])
        _, minimum, slopes, response = problem.gauss_newton(
            start, [0, 2], {1: u}, 1e-12, max_steps=20, envelope=True
        )
        assert minimum is not None
        h = 1e-5
        plus = _conditional(x, y, rate.from_internal(u + h), values[[0, 2]])
        minus = _conditional(x, y, rate.from_internal(u - h), values[[0, 2]])
        slope = (plus[0] - minus[0]) / (2 * h)
        assert slopes[0] == pytest.approx(slope, rel=1e-6)
        # the others' response in their own coordinates (linear: value / scale)
        here = _conditional(x, y, rate.from_internal(u), values[[0, 2]])
        internal = np.array([here[1][0] / scales[0], u, here[1][1] / scales[1]])

        def residuals(v):
            amplitude, offset = v[0] * scales[0], v[2] * scales[1]
            return (_decay(x, amplitude, rate.from_internal(v[1]), offset) - y) / NOISE

        jacobian = np.column_stack(
            [(residuals(internal + e) - residuals(internal - e)) / 2e-6 for e in np.eye(3) * 1e-6]
        )
        H = jacobian.T @ jacobian
        expected = -np.linalg.solve(H[np.ix_([0, 2], [0, 2])], H[[0, 2], 1])
        np.testing.assert_allclose(response[:, 0], expected, rtol=1e-6)
        assert minimum == pytest.approx(here[0], rel=1e-12)


def _counted(problem):
    """A list that grows by one at each conditional minimum ``problem`` solves."""
    calls, original = [], problem.gauss_newton

    def counted(*args, **options):
        calls.append(1)
        return original(*args, **options)

    problem.gauss_newton = counted
    return calls


def _true_ends(x, y, problem, values, chisqr):
    """The rate's profile ends in u at each target height, by brentq on SciPy's minima."""
    rate = problem.parameters[1]
    u_hat = rate.to_internal(values[1])

    def height(u):
        return math.sqrt(
            max(_conditional(x, y, rate.from_internal(u), values[[0, 2]])[0] - chisqr, 0)
        )

    ends = {}
    for side in (-1, 1):
        ends[side] = [
            brentq(
                lambda u, t=t: height(u) - t, u_hat + side * 1e-6, u_hat + side * 1.0, xtol=1e-14
            )
            for t in TARGETS
        ]
    return ends, height


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_newton_ends_from_hints_are_the_profiles_own(seed):
    """From hints off the true ends by 3 % of their distance to the optimum (a record grown
    by a few points), the Newton search ends each target on its first conditional minimum
    (4 for 4 ends) where the secant search needs more, at the same ends: the signed root
    there within 1e-4 of its target, as the secant's, by the independent profile; the
    point it adds at each end is the profile's there (its height the target's, to 1e-4)."""
    x, y, problem, values, chisqr = _solved(seed)
    ends, height = _true_ends(x, y, problem, values, chisqr)
    u_hat = problem.parameters[1].to_internal(values[1])
    hints = {side: [u_hat + 1.03 * (e - u_hat) for e in ends[side]] for side in ends}
    options = dict(variance=1.0, check=True, tolerance=1e-4, precision=1e-4, hints=hints)
    solved = _counted(problem)
    newton = profile_scan(problem, values, 1, chisqr, TARGETS, 0.05, newton=True, **options)
    newton_minima = len(solved)
    secant = profile_scan(problem, values, 1, chisqr, TARGETS, 0.05, **options)
    assert newton_minima == 4 and len(solved) - newton_minima == len(secant.points) == 8
    assert len(newton.points) == 8  # the four evaluated and the four ends
    for side in (-1, 1):
        for k, target in enumerate(TARGETS):
            for scan in (newton, secant):
                assert scan.reached[side][k]
                assert height(scan.ends[side][k]) == pytest.approx(target, abs=1e-4)
    for point in newton.points:
        assert math.sqrt(point.delta) == pytest.approx(height(point.u), abs=1e-4)
    # the offsets a next scan starts from: how far the others stood off the linear response
    assert all(offset is not None and offset.shape == (2,) for offset in newton.end_offsets[1])


def test_newton_without_hints_is_the_secant_search():
    """Without hints the Newton search steps where the secant would not end early; its ends
    agree with the secant's and the independent ones to the precision."""
    x, y, problem, values, chisqr = _solved(4)
    ends, height = _true_ends(x, y, problem, values, chisqr)
    options = dict(variance=1.0, check=True, tolerance=1e-4, precision=1e-4)
    newton = profile_scan(problem, values, 1, chisqr, TARGETS, 0.05, newton=True, **options)
    for side in (-1, 1):
        for k, target in enumerate(TARGETS):
            assert height(newton.ends[side][k]) == pytest.approx(target, abs=1e-4)
            assert newton.ends[side][k] == pytest.approx(ends[side][k], abs=1e-3)


@pytest.mark.parametrize(("factor", "gap"), [(0.8, None), (2.0, None), (1.0, 1e-4), (1.0, 1e-6)])
def test_newton_reaches_every_end_from_poor_hints(factor, gap):
    """Hints short of the ends, twice as far, or the second target's a hair past the first
    end (so that its first step is tiny): every end is still reached, within 1e-4 of its
    target by the independent profile, the steps widening where Newton's root lies beyond
    them."""
    x, y, problem, values, chisqr = _solved(5)
    ends, height = _true_ends(x, y, problem, values, chisqr)
    u_hat = problem.parameters[1].to_internal(values[1])
    if gap is None:
        hints = {side: [u_hat + factor * (e - u_hat) for e in ends[side]] for side in ends}
    else:
        hints = {side: [ends[side][0], ends[side][0] + side * gap] for side in ends}
    options = dict(variance=1.0, check=True, tolerance=1e-4, precision=1e-4, damped=True)
    scan = profile_scan(
        problem, values, 1, chisqr, TARGETS, 0.05, newton=True, hints=hints, **options
    )
    for side in (-1, 1):
        for k, target in enumerate(TARGETS):
            assert scan.reached[side][k]
            assert height(scan.ends[side][k]) == pytest.approx(target, abs=1e-4)


def test_a_newton_end_stays_inside_the_parameters_bound():
    """An upper bound on the rate just inside the profile's upper end: the search ends at
    the bound, not reached, as the secant search does; no point lies beyond it."""
    x, y, problem, values, chisqr = _solved(1)
    ends, _ = _true_ends(x, y, problem, values, chisqr)
    rate = problem.parameters[1]
    rate.upper = rate.from_internal(ends[1][1] - 5e-6)
    hints = {side: [e + side * 0.03 * abs(e) for e in ends[side]] for side in ends}
    options = dict(variance=1.0, check=True, tolerance=1e-4, precision=1e-4, hints=hints)
    scan = profile_scan(problem, values, 1, chisqr, TARGETS, 0.05, newton=True, **options)
    assert scan.reached[1][0] and not scan.reached[1][1]
    assert max(point.u for point in scan.points) <= rate.internal_bounds()[1] + 1e-15
