"""Identities and limits of the model as hypothesis property tests."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import granflow as gf

SETTINGS = settings(max_examples=60, deadline=None)


def log_uniform(low, high):
    return st.floats(np.log10(low), np.log10(high)).map(lambda e: 10.0**e)


params_strategy = st.builds(
    gf.Params,
    a=log_uniform(1e-5, 1e-1),
    alpha=log_uniform(1e2, 1e7),
    Fd=log_uniform(1e-4, 1.0),
    x0=log_uniform(1e-10, 1e-5),
)


@SETTINGS
@given(params_strategy)
def test_peak_satisfies_the_nullcline_identity(params):
    top = gf.peak(params)
    assert top.force == pytest.approx(params.Fd + params.a / (params.alpha * top.slip), rel=1e-14)
    assert gf.friction_slip(top.slip, params) == pytest.approx(top.force, rel=1e-12)
    assert top.force > params.Fd
    assert top.slip > params.x0


@SETTINGS
@given(params_strategy, log_uniform(1e2, 1e7))
def test_friction_tends_to_fd_from_above(params, s):
    top = gf.peak(params)
    x = max(s / params.alpha, 2 * top.slip)
    force = gf.friction_slip(np.array([x, 2 * x]), params)
    assert np.all(force > params.Fd)
    assert force[1] < force[0]  # still falling towards Fd
    excess = force - params.Fd
    assert excess[0] < 2.0 * params.a / (params.alpha * x) + params.Fd * np.exp(-params.alpha * x)


@SETTINGS
@given(params_strategy, log_uniform(1e-9, 1e-2), st.floats(1.0, 1e4))
def test_rate_independence(params, velocity, factor):
    # friction_time(t, p, v) is friction_slip(v t, p): the transient depends on slip only.
    # The two round the slip differently (a few ulp), which moves F by (dF/d ln x) * 1e-16,
    # about a * 1e-16 near x0: far above F itself when F(x0) = Fd alpha x0 << a (a = 0.1 N,
    # Fd = 1 N, alpha x0 = 1e-4 differ by 1.4e-13 relative, 1.4e-16 a absolute)
    times = params.t0(velocity) * np.array([1.0, factor, factor**1.5])
    np.testing.assert_allclose(
        gf.friction_time(times, params, velocity),
        gf.friction_slip(velocity * times, params),
        rtol=1e-13,
        atol=1e-15 * params.a,
    )
    # and two velocities give the same force at the same slip; v t is rounded differently at
    # the two velocities, which moves F by up to (dF/d ln x) * 1e-16 ~ a * 1e-16 near x0
    other = 10 * velocity
    np.testing.assert_allclose(
        gf.friction_time(times / 10, params, other),
        gf.friction_time(times, params, velocity),
        rtol=1e-12,
        atol=1e-14 * params.a,
    )


@SETTINGS
@given(
    st.floats(0.01, 0.2),
    st.floats(0.05, 0.6),
    log_uniform(1e3, 1e6),
    log_uniform(1e-8, 1e-6),
    log_uniform(0.01, 0.2),
    st.floats(1.5, 6.0),
)
def test_amontons_scaling(mu_a, mu_d, alpha, x0, load, ratio):
    material = gf.MaterialConstants(mu_a=mu_a, mu_d=mu_d, alpha=alpha)
    light = material.params_at(load, x0)
    heavy = material.params_at(ratio * load, x0)
    assert heavy.a == pytest.approx(ratio * light.a, rel=1e-14)
    assert heavy.Fd == pytest.approx(ratio * light.Fd, rel=1e-14)
    assert heavy.alpha == light.alpha
    # Eq. 3 is linear in (a, Fd) at fixed alpha: the whole curve and its peak scale with load
    x = np.geomspace(x0, 1e3 / alpha, 25)
    np.testing.assert_allclose(
        gf.friction_slip(x, heavy), ratio * gf.friction_slip(x, light), rtol=1e-12
    )
    assert gf.peak(heavy).slip == pytest.approx(gf.peak(light).slip, rel=1e-12)
    back = heavy.to_material(ratio * load)
    assert back.mu_a == pytest.approx(mu_a, rel=1e-14)
    assert back.mu_d == pytest.approx(mu_d, rel=1e-14)
