"""The scaled exponential-integral kernel against 40-digit arithmetic (mpmath)."""

import mpmath as mp
import numpy as np
import pytest

from granflow.model.special import scaled_ei, scaled_ei_diff

mp.mp.dps = 40


def reference_scaled_ei(x):
    x = mp.mpf(float(x))
    return mp.exp(-x) * mp.ei(x)


def reference_scaled_diff(x, x0):
    x, x0 = mp.mpf(float(x)), mp.mpf(float(x0))
    return mp.exp(-x) * (mp.ei(x) - mp.ei(x0))


def relative_error(got, ref):
    return float(abs((mp.mpf(float(got)) - ref) / ref))


# A log grid over the whole domain, plus points next to every region boundary and the zero of Ei
GRID = np.concatenate(
    [
        np.geomspace(1e-12, 1e8, 241),
        [0.5 * (1 - 1e-15), 0.5, 64 * (1 - 1e-15), 64.0, 1.0, 2.0, 32.0],
        0.3725074107813666 + np.array([-0.02, -0.0101, -0.0099, -1e-5, -1e-9, 1e-12, 1e-7, 0.0099]),
    ]
)


@pytest.mark.parametrize("x", GRID)
def test_scaled_ei_matches_mpmath(x):
    assert relative_error(scaled_ei(x), reference_scaled_ei(x)) < 1e-12


def test_scaled_ei_vectorised_equals_scalar():
    values = scaled_ei(GRID.reshape(-1, 1))
    assert values.shape == (GRID.size, 1)
    assert np.array_equal(values[:, 0], [scaled_ei(x) for x in GRID])


@pytest.mark.parametrize("x", np.geomspace(1e-12, 1e8, 31))
@pytest.mark.parametrize("ratio", [1e-8, 1e-5, 1e-3, 0.05, 0.3, 0.5])
def test_scaled_diff_matches_mpmath(x, ratio):
    x0 = ratio * x
    assert relative_error(scaled_ei_diff(x, x0), reference_scaled_diff(x, x0)) < 1e-12


@pytest.mark.parametrize("x", [1e-9, 0.01, 0.37, 0.9, 3.0, 50.0, 700.0, 1e5, 1e8])
def test_scaled_diff_close_to_x_is_accurate_and_continuous(x):
    # As x0 approaches x the difference goes to zero: absolute accuracy, and no jump where the
    # evaluation switches from subtraction to quadrature (|x - x0| = min(1, x/2)).
    gaps = np.concatenate([np.geomspace(1e-14, 0.999, 60), [1.0, 1.001]]) * min(1.0, x / 2)
    x0 = x - gaps
    got = scaled_ei_diff(x, x0)
    scale = float(abs(reference_scaled_ei(x))) + 1.0 / x
    for value, start in zip(got, x0, strict=True):
        ref = reference_scaled_diff(x, start)
        assert abs(mp.mpf(float(value)) - ref) <= 1e-14 * scale + 1e-12 * abs(ref)
    assert np.all(np.isfinite(got))
    assert np.all(np.diff(got[::-1]) <= 0)  # monotone: smaller gap, smaller difference


def test_extreme_arguments_are_finite():
    x = np.array([5e-324, 1e-300, 1e-12, 709.0, 710.0, 1e8, 1e300, np.finfo(float).max])
    values = scaled_ei(x)
    assert np.all(np.isfinite(values))
    assert scaled_ei_diff(1e300, 1e-300) > 0
    assert scaled_ei(np.inf) == 0.0


def test_invalid_arguments_give_nan():
    assert np.isnan(scaled_ei(0.0))
    assert np.isnan(scaled_ei(-1.0))
    assert np.isnan(scaled_ei(np.nan))


def test_diff_is_antisymmetric_in_the_unscaled_sense():
    # e^-x (Ei(x) - Ei(x0)) = -e^-(x-x0) * e^-x0 (Ei(x0) - Ei(x))
    x, x0 = 3.0, 1.2
    assert scaled_ei_diff(x, x0) == pytest.approx(
        -np.exp(-(x - x0)) * scaled_ei_diff(x0, x), rel=1e-14
    )


def test_simd_exp_log_and_log1p_match_mpmath():
    import numba

    from granflow.model.special import simd_exp, simd_log, simd_log1p

    @numba.njit
    def apply(x):
        out = np.empty((3, x.size))
        for i in range(x.size):
            out[0, i] = simd_exp(x[i])
            out[1, i] = simd_log(abs(x[i]) + 1e-300)
            out[2, i] = simd_log1p(x[i] / 800.0)
        return out

    rng = np.random.default_rng(3)
    x = np.concatenate([rng.uniform(-708.0, 709.0, 300), [-1e-12, 0.0, 1e-15, 1e-8, -0.3]])
    exp, log, log1p = apply(x)
    for i, value in enumerate(x):
        assert exp[i] == pytest.approx(float(mp.exp(value)), rel=3e-16, abs=0.0)
        expected_log = float(mp.log(abs(mp.mpf(value)) + mp.mpf(1e-300)))
        assert log[i] == pytest.approx(expected_log, rel=3e-16, abs=3e-16)
        assert log1p[i] == pytest.approx(float(mp.log1p(mp.mpf(value) / 800)), rel=3e-16)
    assert apply(np.array([-800.0]))[0, 0] == 0.0
