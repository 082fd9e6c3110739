"""The compiled integrator (granflow.simulation.ode): both methods against closed forms, event
location against a root finder, and bounded work."""

import math

import numpy as np
import pytest
from scipy.optimize import brentq

from granflow.simulation import equations as eq
from granflow.simulation import ode


def _rigid_aging(v, Dc):
    p = np.zeros(eq.STATE_BASE + 4)
    p[eq.RSF_A], p[eq.RSF_V_REF], p[eq.RSF_START], p[eq.N_STATES] = 0.01, 1.0, v, 1
    p[eq.STATE_BASE : eq.STATE_BASE + 4] = (0.01, Dc, eq.LAWS["aging"], 0.0)
    return p


def _solve(
    method,
    kind,
    p,
    t,
    y,
    t_end,
    rtol,
    atol,
    out_t,
    *,
    directions=None,
    terminal=None,
    max_evaluations=10**8,
    land=False,
):
    n = y.size
    out_y = np.full((out_t.size, n), np.nan)
    counters = ode.new_counters()
    directions = np.zeros(eq.EVENTS, np.int64) if directions is None else directions
    terminal = np.zeros(eq.EVENTS, np.bool_) if terminal is None else terminal
    status, t_reached, _ = ode.solve(
        method,
        kind,
        p,
        t,
        y,
        t_end,
        rtol,
        atol,
        0.0,
        max_evaluations,
        directions,
        terminal,
        out_t,
        out_y,
        land,
        np.empty(0),
        np.empty((0, n)),
        np.empty(0),
        np.empty((0, n)),
        np.empty(0, np.int64),
        counters,
    )
    return status, t_reached, out_y, counters


@pytest.mark.parametrize("method", [ode.RODAS4, ode.DOP853])
@pytest.mark.parametrize("land", [False, True])
def test_both_methods_follow_the_closed_form(method, land):
    v, Dc = 2.0, 3.0
    t = np.linspace(0.0, 10.0, 11)
    y = np.array([0.0, 0.0, 0.0])
    status, reached, out, counters = _solve(
        method,
        eq.RATE_STATE,
        _rigid_aging(v, Dc),
        0.0,
        y,
        10.0,
        1e-12,
        np.full(3, 1e-15),
        t,
        land=land,
    )
    assert status == ode.DONE and reached == 10.0
    exact = (1 - np.exp(-v * t / Dc)) * Dc / v
    # landing on the outputs gives them the steps' accuracy (Rodas4 interpolates cubically)
    np.testing.assert_allclose(out[:, 1], exact, rtol=1e-12 if land else 1e-9, atol=1e-15)
    assert y[1] == pytest.approx(exact[-1], rel=1e-12)
    assert counters[ode.COUNT_STEPS] > 0


def test_rodas4_converges_at_fourth_order():
    errors, steps = [], []
    for rtol in (1e-6, 1e-8, 1e-10):
        y = np.array([0.0, 0.0, 0.0])
        _, _, _, counters = _solve(
            ode.RODAS4,
            eq.RATE_STATE,
            _rigid_aging(2.0, 3.0),
            0.0,
            y,
            10.0,
            rtol,
            np.full(3, 1e-20),
            np.empty(0),
        )
        errors.append(abs(y[1] - (1 - math.exp(-20.0 / 3.0)) * 1.5))
        steps.append(counters[ode.COUNT_STEPS])
    order = math.log(errors[0] / errors[2]) / math.log(steps[2] / steps[0])
    assert 3.0 < order < 6.0


def test_an_event_is_located_where_the_root_finder_puts_it():
    """The stuck slider on the time clock under a force ramp: F = F_s + a ln(tau / tau_s);
    it unsticks where the force reaches F + c v_stop."""
    p = np.zeros(eq.SLIDER_PARAMETERS)
    p[eq.A], p[eq.ALPHA], p[eq.FD], p[eq.MASS], p[eq.DAMPING] = 3.31e-3, 4e4, 10e-3, 0.05, 0.5
    p[eq.TIME_CLOCK], p[eq.TAU_SHIFT], p[eq.T_START] = 1.0, 0.23, 0.0
    p[eq.START], p[eq.SLOPE], p[eq.V_FAIL], p[eq.V_STOP] = 1e-3, 1e-3, 1e-3, 1e-15
    F_s = 2e-3
    y = np.array([2e-7, 0.0, F_s, 0.0])
    directions = np.array([0, 0, 1], np.int64)
    terminal = np.ones(eq.EVENTS, np.bool_)
    status, when, _, counters = _solve(
        ode.DOP853,
        eq.STUCK,
        p,
        0.0,
        y,
        100.0,
        1e-10,
        np.array([1e-16, 1e-18, 1e-16, 1.0]),
        np.empty(0),
        directions=directions,
        terminal=terminal,
    )
    assert status == ode.EVENT and counters[ode.COUNT_FIRED] == 2

    def margin(t):
        return 1e-3 + 1e-3 * t - (F_s + 3.31e-3 * math.log((t + 0.23) / 0.23)) - 0.5e-15

    expected = brentq(margin, 0.0, 100.0, xtol=1e-15, rtol=1e-15)
    assert when == pytest.approx(expected, rel=1e-9)
    assert y[2] == pytest.approx(F_s + 3.31e-3 * math.log((expected + 0.23) / 0.23), rel=1e-9)


def test_work_is_bounded_by_evaluations():
    y = np.array([0.0, 0.0, 0.0])
    status, reached, _, counters = _solve(
        ode.RODAS4,
        eq.RATE_STATE,
        _rigid_aging(2.0, 3.0),
        0.0,
        y,
        10.0,
        1e-12,
        np.full(3, 1e-15),
        np.empty(0),
        max_evaluations=100,
    )
    assert status == ode.WORK_EXCEEDED and reached < 10.0
    assert 100 < counters[ode.COUNT_EVALUATIONS] < 200
