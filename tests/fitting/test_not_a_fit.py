"""Fits that are not fits, and data a fit cannot square (issue 31, points 5 and 8): the
result says success=False with a sentence why, or a GranflowError names the reason; never
success=True on nonsense, never an OverflowError."""

import numpy as np
import pytest
from conftest import paper_params, shared_data

import granflow
from granflow.errors import GranflowError

VELOCITY = 0.86e-6


def _curve(points=600, scale=1.0, seed=0):
    params = paper_params("blue")
    t = np.linspace(0.5, 600.0, points)
    force = granflow.friction_time(t, params, VELOCITY)
    noise = np.random.default_rng(seed).normal(0.0, 3e-5, points)
    return t * VELOCITY, (force + noise) * scale


def _quiet_fit(*args, **kwargs):
    with pytest.warns(granflow.ConvergenceWarning):
        return granflow.fit(*args, **kwargs)


def test_a_stress_relaxation_interval_is_not_a_fit():
    # the Rheoplus export's relaxation intervals: the force decays, there is no start-up
    export = shared_data("instrument-exports", "rheoplus-en-utf8-stress-relaxation.txt")
    run = granflow.read_runs(export)[3]
    result = _quiet_fit(run, domain="time", velocity=VELOCITY)
    assert result.rsquared < 0
    assert result.success is False
    assert "not a fit of these data" in result.message
    assert "R-squared" in result.message and "not determined by the data" in result.message


def test_a_real_shear_export_with_a_parameter_of_a_million_percent_is_not_a_fit():
    export = shared_data("instrument-exports", "rheocompass-en-utf16-shear.txt")
    (run,) = granflow.read_runs(export)
    result = _quiet_fit(run, domain="time", velocity=VELOCITY)
    relative = {n: result.stderr[n] / abs(result.params[n]) for n in result.names}
    assert max(relative.values()) > 100  # the fit reports +-1.8e6 %
    assert result.success is False and "not determined by the data" in result.message


def test_a_parameter_on_its_search_bound_is_not_a_fit():
    x, force = _curve()
    result = _quiet_fit((x, force), bounds={"alpha": (1e3, 3e4)})  # truth 4.19e4 outside
    assert result.at_bound["alpha"] and result.success is False
    assert "bound of its search range" in result.message


def test_a_good_fit_stays_a_success():
    x, force = _curve()
    result = granflow.fit((x, force))
    assert result.success and result.rsquared > 0.99 and "not a fit" not in result.message


@pytest.mark.parametrize("scale", [1e300, 1e200, 1e120])
def test_forces_beyond_what_a_fit_can_square_are_refused_by_name(scale):
    x, force = _curve(scale=scale)
    with pytest.raises(granflow.InvalidDataError, match=r"force\[\d+\] = .* is beyond"):
        granflow.fit((x, force))


def test_a_rheocompass_export_cut_at_three_quarters_ends_in_a_result_or_a_granflow_error(
    tmp_path,
):
    export = shared_data("instrument-exports", "rheocompass-en-utf16-shear.txt")
    raw = export.read_bytes()
    cut = tmp_path / "cut.txt"
    cut.write_bytes(raw[: 3 * len(raw) // 4])
    (run,) = granflow.read_runs(cut)
    assert any("cut short" in problem for problem in run.problems)
    try:
        with pytest.warns(granflow.ConvergenceWarning):
            result = granflow.fit(run, domain="time", velocity=VELOCITY)
    except GranflowError:
        return
    assert result.success is False  # a profile that walks off to an infinite end


def test_the_internal_coordinate_past_exps_range_is_an_infinite_value():
    from granflow.fitting.engine import GlobalParameter

    parameter = GlobalParameter("k", 2.0, log=True)
    assert parameter.from_internal(800.0) == np.inf
    assert parameter.derivative(800.0) == np.inf
    assert parameter.from_internal(np.log(3.0)) == pytest.approx(6.0, rel=1e-15)
