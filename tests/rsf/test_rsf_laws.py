"""Rate-and-state laws against independent references: solve_ivp at rtol 1e-12, closed forms
at constant velocity, steady states, velocity steps and slide-hold-slide healing."""

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.special import lambertw

import granflow as gf
from granflow import rsf

MU0, A, V_REF, K = 0.6, 0.005, 1.0, 3e-3
STEP = gf.Protocol([gf.Velocity(1.0, 10.0), gf.Velocity(10.0, 40.0)])
T_EVAL = np.linspace(0.0, 50.0, 101)


def reference(states, protocol_pieces, t_eval, *, eta=0.0, stiffness=K, v0=1.0):
    """solve_ivp (Radau, rtol 1e-12) on y = (mu, theta_1 .. theta_n), written from the laws."""
    scales = [2 * Dc if law == "prz" else Dc for _, Dc, law, _ in states]

    def velocity(mu, thetas):
        rest = (
            mu
            - MU0
            - sum(
                b * math.log(V_REF * th / s)
                for (b, *_), th, s in zip(states, thetas, scales, strict=True)
            )
        )
        if eta == 0:
            return V_REF * math.exp(rest / A)
        # a ln(v / v_ref) + eta v = rest  <=>  v = (a / eta) W(eta v_ref / a e^(rest / a))
        return A / eta * lambertw(eta * V_REF / A * math.exp(rest / A)).real

    def load_point(t):
        start = 0.0
        for v, duration in protocol_pieces:
            if t <= start + duration:
                return v
            start += duration
        return protocol_pieces[-1][0]

    def rhs(t, y):
        mu, thetas = y[0], y[1:]
        v = velocity(mu, thetas)
        mu_rate = stiffness * (load_point(t) - v)
        out = [mu_rate]
        for (b, Dc, law, c), th in zip(states, thetas, strict=True):
            if law == "aging":
                out.append(1 - v * th / Dc)
            elif law == "slip":
                out.append(-(v * th / Dc) * math.log(v * th / Dc))
            elif law == "prz":
                out.append(1 - (v * th / (2 * Dc)) ** 2)
            else:
                out.append(1 - v * th / Dc - c / b * th * mu_rate)
        return out

    thetas0 = [s / v0 for s in scales]
    mu_start = MU0 + A * math.log(v0 / V_REF) + eta * v0
    mu_start += sum(
        b * math.log(V_REF * th / s) for (b, *_), th, s in zip(states, thetas0, scales, strict=True)
    )
    y = np.array([mu_start, *thetas0])
    results = []
    start = 0.0
    for _, duration in protocol_pieces:
        inside = t_eval[(t_eval >= start) & (t_eval <= start + duration)]
        if results:
            inside = inside[inside > start]
        sol = solve_ivp(
            rhs,
            (start, start + duration),
            y,
            method="Radau",
            rtol=1e-12,
            atol=1e-15,
            t_eval=inside,
            dense_output=True,
        )
        assert sol.success
        results.append(sol.y)
        y = sol.y[:, -1] if sol.y.shape[1] else sol.sol(start + duration)
        y = sol.sol(start + duration)
        start += duration
    return np.concatenate(results, axis=1)


LAW_CASES = {
    "aging": [(0.01, 10.0, "aging", None)],
    "slip": [(0.01, 10.0, "slip", None)],
    "prz": [(0.01, 10.0, "prz", None)],
    "nagata": [(0.01, 10.0, "nagata", 2.0)],
    "aging+slip": [(0.006, 10.0, "aging", None), (0.004, 3.0, "slip", None)],
}


def _model(states, **extra):
    return rsf.RateState(
        MU0,
        A,
        V_REF,
        extra.pop("stiffness", K),
        [rsf.State(b, Dc, law, c) for b, Dc, law, c in states],
        **extra,
    )


_REFERENCES = {}


@pytest.mark.parametrize("method", ["rodas4", "dop853"])
@pytest.mark.parametrize("case", sorted(LAW_CASES))
def test_each_law_matches_an_independent_solve_ivp_reference(case, method):
    states = LAW_CASES[case]
    result = rsf.simulate(_model(states), STEP, t_eval=T_EVAL, rtol=1e-12, method=method)
    assert result.success
    if case not in _REFERENCES:
        _REFERENCES[case] = reference(states, [(1.0, 10.0), (10.0, 40.0)], T_EVAL)
    expected = _REFERENCES[case]
    np.testing.assert_allclose(result.friction, expected[0], rtol=1e-8, atol=0)
    np.testing.assert_allclose(result.states, expected[1:], rtol=1e-8, atol=0)


def test_radiation_damping_matches_the_reference():
    states = LAW_CASES["aging"]
    result = rsf.simulate(_model(states, radiation_damping=0.002), STEP, t_eval=T_EVAL, rtol=1e-12)
    expected = reference(states, [(1.0, 10.0), (10.0, 40.0)], T_EVAL, eta=0.002)
    np.testing.assert_allclose(result.friction, expected[0], rtol=1e-8, atol=0)
    np.testing.assert_allclose(result.theta, expected[1], rtol=1e-8, atol=0)


@pytest.mark.parametrize("v", [0.3, 2.0])
def test_rigid_aging_from_zero_follows_the_closed_form(v):
    Dc = 3.0
    model = rsf.RateState(MU0, A, V_REF, None, [rsf.State(0.01, Dc, "aging")])
    t = np.linspace(0.0, 20.0, 41)
    result = rsf.simulate(model, [gf.Velocity(v, 20.0)], t_eval=t, initial_states=[0.0], rtol=1e-13)
    exact = (1 - np.exp(-v * t / Dc)) * Dc / v
    np.testing.assert_allclose(result.theta, exact, rtol=1e-12, atol=1e-13 * Dc / v)
    np.testing.assert_allclose(result.slip, v * t, rtol=1e-12, atol=1e-12)
    assert np.all(result.velocity == v)


def test_rigid_slip_and_prz_laws_follow_their_closed_forms():
    v, Dc, theta0 = 2.0, 3.0, 7.0
    t = np.linspace(0.0, 10.0, 21)
    slip = rsf.simulate(
        rsf.RateState(MU0, A, V_REF, None, [rsf.State(0.01, Dc, "slip")]),
        [gf.Velocity(v, 10.0)],
        t_eval=t,
        initial_states=[theta0],
        rtol=1e-13,
    )
    # ln(v theta / Dc) decays as exp(-v t / Dc)
    exact = Dc / v * np.exp(np.log(v * theta0 / Dc) * np.exp(-v * t / Dc))
    np.testing.assert_allclose(slip.theta, exact, rtol=1e-12)
    prz = rsf.simulate(
        rsf.RateState(MU0, A, V_REF, None, [rsf.State(0.01, Dc, "prz")]),
        [gf.Velocity(v, 10.0)],
        t_eval=t,
        initial_states=[0.5],
        rtol=1e-13,
    )
    scale = 2 * Dc / v
    exact = scale * np.tanh(t / scale + np.arctanh(0.5 / scale))
    np.testing.assert_allclose(prz.theta, exact, rtol=1e-12)


@pytest.mark.parametrize("case", sorted(LAW_CASES))
def test_steady_sliding_stays_at_the_steady_state(case):
    model = _model(LAW_CASES[case], radiation_damping=1e-3)
    result = rsf.simulate(
        model, [gf.Velocity(3.0, 50.0)], t_eval=np.linspace(0, 50, 11), rtol=1e-13
    )
    mu_ss = MU0 + (A - model.b) * math.log(3.0 / V_REF) + 1e-3 * 3.0
    np.testing.assert_allclose(result.friction, mu_ss, rtol=1e-12, atol=0)
    assert model.steady_state_friction(3.0) == pytest.approx(mu_ss, rel=1e-15)
    np.testing.assert_allclose(result.velocity, 3.0, rtol=1e-10)


@pytest.mark.parametrize("law", ["aging", "slip", "prz", "nagata"])
def test_a_velocity_step_ends_at_the_new_steady_state(law):
    states = [(0.01, 10.0, law, 2.0 if law == "nagata" else None)]
    model = _model(states, stiffness=3e-3)
    result = rsf.simulate(model, [gf.Velocity(1.0, 10.0), gf.Velocity(10.0, 600.0)])
    assert result.friction[-1] == pytest.approx(MU0 + (A - 0.01) * math.log(10.0), abs=1e-9)
    assert result.velocity[-1] == pytest.approx(10.0, rel=1e-6)
    peak = result.events_of("peak")[0]
    assert peak.time > 10.0 and peak.force > MU0  # the direct effect first


def _healing(law, holds):
    model = rsf.RateState(MU0, A, V_REF, 1e-1, [rsf.State(0.01, 10.0, law)])
    peaks = []
    for hold in holds:
        protocol = [gf.Velocity(1.0, 100.0), gf.Hold(hold), gf.Velocity(1.0, 100.0)]
        result = rsf.simulate(model, protocol)
        peaks.append(max(result.friction[result.t > 100.0 + hold]) - MU0)
    return np.array(peaks)


def test_slide_hold_slide_healing_grows_as_b_ln_hold_for_aging_only():
    holds = np.array([100.0, 1000.0, 10000.0])
    aging = _healing("aging", holds)
    slope = np.diff(aging) / np.diff(np.log(holds))
    np.testing.assert_allclose(slope, 0.01, rtol=0.1)  # b per e-fold of the hold
    slip = _healing("slip", holds)
    assert np.all(np.abs(np.diff(slip) / np.diff(np.log(holds))) < 0.2 * 0.01)
