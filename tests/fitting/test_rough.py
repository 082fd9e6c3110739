"""A rough likelihood (``Problem(rough=True)``, a creeping layer's): Levenberg-Marquardt with
its best curve on the box's face, and a profile's end search across a cliff.

The references are independent of the engine: SciPy's bounded ``least_squares`` for the
optimum on a face, and the cliff's crossing solved by hand."""

import math

import numpy as np
import pytest
from scipy.optimize import least_squares

from granflow.fitting.engine import Curve, GlobalParameter, Model, Problem
from granflow.fitting.profile_search import search_side


def _decay_and_slopes(x, amplitude, rate, offset):
    """amplitude exp(-rate x) + offset and its derivatives by the three."""
    e = np.exp(-rate * x)
    return amplitude * e + offset, np.column_stack([e, -amplitude * x * e, np.ones_like(x)])


def _decay(x, amplitude, rate, offset):
    return _decay_and_slopes(x, amplitude, rate, offset)[0]


DECAY = Model(("amplitude", "rate", "offset"), _decay, _decay_and_slopes, log=(False, True, False))


def _problem(seed, floor, rough):
    """A decay whose offset (true 0.4) is held above ``floor`` by its bound, the weights
    1/noise."""
    rng = np.random.default_rng(seed)
    x = np.linspace(0.0, 3.0, 80)
    noise = 0.01
    y = _decay(x, 2.0, 1.3, 0.4) + rng.normal(0.0, noise, x.size)
    parameters = [
        GlobalParameter("amplitude", 1.0, log=False, lower=0.0, upper=10.0),
        GlobalParameter("rate", 0.5, log=True, lower=1e-3, upper=1e3),
        GlobalParameter("offset", floor + 0.3, log=False, lower=floor, upper=5.0),
    ]
    curve = Curve(z=x, y=y, w=np.full(x.size, 1.0 / noise), links=((0, 1.0), (1, 1.0), (2, 1.0)))
    return Problem([curve], parameters, model=DECAY, rough=rough), x, y, noise


@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize("floor", [0.5, 0.7])
def test_levenberg_marquardt_reaches_an_optimum_on_the_box_face(seed, floor):
    """The offset's bound lies above the truth, so the best curve has it on the bound and
    the gradient pushes out of the box: the rough problem's Levenberg-Marquardt reaches
    SciPy's bounded optimum (chi-square to 1e-9 relative, the others to 1e-6)."""
    problem, x, y, noise = _problem(seed, floor, rough=True)
    u, chisqr, converged, _, _ = problem.lm(problem.internal(), max_iter=200, rtol=1e-14)
    values = problem.values(u)

    def residuals(p):
        return (_decay(x, *p) - y) / noise

    reference = least_squares(
        residuals,
        [1.0, 0.5, floor + 0.3],
        bounds=([0.0, 1e-3, floor], [10.0, 1e3, 5.0]),
        xtol=1e-15,
        ftol=1e-15,
        gtol=1e-15,
    )
    assert reference.x[2] == pytest.approx(floor)  # the optimum lies on the face
    assert converged
    assert chisqr == pytest.approx(2.0 * reference.cost, rel=1e-9)
    assert values[2] == pytest.approx(floor, abs=1e-12)
    np.testing.assert_allclose(values[:2], reference.x[:2], rtol=1e-6)


def test_the_coordinates_a_bound_holds():
    """A rough problem's step leaves still exactly the coordinates at a bound whose gradient
    (J^T r: the step goes against it) points out of the box; a smooth problem's moves all."""
    rough, *_ = _problem(3, 0.5, rough=True)
    smooth, *_ = _problem(3, 0.5, rough=False)
    bounds = np.array([[0.0, -10.0, 0.0], [1.0, 10.0, 1.0]])
    u = np.array([0.0, 0.3, 1.0])  # the first at its lower bound, the last at its upper
    for g, held in (
        ([1.0, 1.0, -1.0], [True, False, True]),  # both pushed out of the box
        ([-1.0, 1.0, 1.0], [False, False, False]),  # both pulled back in
        ([1.0, -1.0, 1.0], [True, False, False]),
    ):
        moving = rough._moving(u, np.array(g), bounds)
        assert moving.tolist() == [not h for h in held]
        assert smooth._moving(u, np.array(g), bounds).all()


class _Cliff:
    """A conditional minimum in variance units that is flat to ``edge`` and then climbs a
    cliff of slope ``steep``: sqrt(delta) crosses 1.645 at ``edge + (1.645**2 - flat) /
    steep``, by hand."""

    class _Parameter:
        def internal_bounds(self):
            return -50.0, 50.0

    def __init__(self, rough, edge=1.0, flat=0.01, steep=1e4, wall=math.inf):
        self.problem = type("P", (), {"rough": rough})()
        self.parameter = self._Parameter()
        self.u_hat, self.u_others_hat, self.others = 0.0, np.zeros(0), []
        self.curvature, self.newton, self.last = flat, False, None
        self.edge, self.flat, self.steep, self.wall = edge, flat, steep, wall

    def delta(self, u):
        if u <= self.edge:
            return self.flat * u * u
        if u >= self.wall:
            return math.inf  # no curve there (a conditional fit that found none)
        return self.flat * self.edge**2 + self.steep * (u - self.edge)

    def __call__(self, u, u_others, u_last, height=math.inf):
        return self.delta(u), u_others

    def point(self, u, delta, u_others):
        return (u, delta)

    def offset(self, u, u_others):
        return None


def test_a_rough_profile_finds_the_end_at_a_cliff():
    """Flat to u = 1, then a cliff: the crossing of 1.645 lies 2.7e-4 past the cliff's foot.
    The secant through the last two points stalls on the flat side (regula falsi's
    one-sided steps) and ends there; a rough problem's search keeps the bracket, halves it
    where regula falsi stalls, and ends at the crossing."""
    target = 1.6448536269514722
    cliff = _Cliff(rough=True)
    crossing = cliff.edge + (target**2 - cliff.flat * cliff.edge**2) / cliff.steep
    record = []
    ends, reached, _ = search_side(cliff, 1, (target,), 0.3, record, precision=2e-3)
    assert reached == [True]
    # to a thousandth of the end's distance from the optimum (at a cliff the signed root's
    # precision asks the impossible: it climbs 1.6 over 3e-4)
    assert abs(ends[0] - crossing) <= 1e-3 * crossing
    assert ends[0] >= cliff.edge  # never read on the flat side
    stalled, reached, _ = search_side(_Cliff(rough=False), 1, (target,), 0.3, [])
    assert stalled[0] < cliff.edge - 0.01 and reached == [False]  # what the bracket is for


@pytest.mark.parametrize("step", [0.015, 0.3, 2.0])
@pytest.mark.parametrize("wall", [math.inf, 1.001, 1.5])
def test_a_rough_profile_ends_inside_its_bracket(step, wall):
    """From any first step, small (the 24 steps run out before the bracket is a thousandth
    wide) or large (past an infinite wall beyond the cliff), the end lies in the bracket
    around the crossing, on the cliff and not on its flat side, and the target is reached."""
    target = 1.6448536269514722
    cliff = _Cliff(rough=True, wall=wall)
    crossing = cliff.edge + (target**2 - cliff.flat * cliff.edge**2) / cliff.steep
    ends, reached, _ = search_side(cliff, 1, (target,), step, [], precision=2e-3)
    assert reached == [True]
    assert cliff.edge <= ends[0] <= min(wall, crossing + 0.05)
