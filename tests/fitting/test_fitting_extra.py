"""Creep fits, model comparison and batch fits."""

import json
import math

import numpy as np
import pytest
from scipy.optimize import curve_fit

import granflow
from granflow import InvalidDataError, Params, friction_slip


def test_creep_fit_recovers_parameters_and_matches_curve_fit_covariance():
    t = np.linspace(0.0, 600.0, 601)
    rng = np.random.default_rng(3)
    slip = 1.5e-6 * np.log1p(t / 8.0) + rng.normal(0, 2e-8, t.size)
    result = granflow.fit_creep(t, slip)
    assert result.success
    for name, value in (("B", 1.5e-6), ("tau_c", 8.0)):
        low, high = result.ci95[name]
        assert low <= value <= high
    # independent: scipy's curve_fit (started at the truth) gives the same optimum and errors
    popt, pcov = curve_fit(lambda t_, B, tau: B * np.log1p(t_ / tau), t, slip, p0=(1.5e-6, 8.0))
    assert result.params["B"] == pytest.approx(popt[0], rel=1e-6)
    assert result.params["tau_c"] == pytest.approx(popt[1], rel=1e-6)
    assert result.stderr["B"] == pytest.approx(math.sqrt(pcov[0, 0]), rel=1e-3)
    assert result.stderr["tau_c"] == pytest.approx(math.sqrt(pcov[1, 1]), rel=1e-3)
    assert "tau_c" in result.report()
    json.dumps(result.to_dict())


def test_creep_rejects_bad_data():
    with pytest.raises(InvalidDataError, match="no creep"):
        granflow.fit_creep(np.arange(10.0), np.ones(10))
    with pytest.raises(InvalidDataError, match="at least 4"):
        granflow.fit_creep([0.0, 1.0], [0.0, 1.0])
    with pytest.raises(InvalidDataError, match="finite"):
        granflow.fit_creep([0.0, 1.0, 2.0, np.nan], [0.0, 1.0, 2.0, 3.0])


def test_compare_models_prefers_eq3_on_eq3_data():
    p = Params(3.3e-3, 4.2e4, 10e-3, 2e-7)
    x = np.linspace(3e-7, 5e-4, 1000)
    y = friction_slip(x, p) + np.random.default_rng(0).normal(0, 5e-5, x.size)
    table = granflow.compare_models((x, y))
    assert table.best_aic == "eq3" and table.best_bic == "eq3"
    rows = {r["model"]: r for r in table.rows}
    assert rows["eq3"]["delta_aic"] == 0.0
    assert rows["exponential"]["delta_aic"] > 100
    assert table.to_frame().loc["eq3", "nfree"] == 4
    json.dumps(table.to_dict())
    assert "best by AIC: eq3" in table.report()


def test_compare_models_on_an_exponential_approach():
    x = np.linspace(1e-7, 5e-4, 800)
    y = 10e-3 - 8e-3 * np.exp(-2e4 * x) + np.random.default_rng(1).normal(0, 5e-5, x.size)
    table = granflow.compare_models((x, y))
    rows = {r["model"]: r for r in table.rows}
    assert table.best_bic == "exponential"
    assert rows["eq3"]["aic"] is None and "overshoot" in rows["eq3"]["message"]
    fitted = table.fits["exponential"]
    assert fitted.params["alpha"] == pytest.approx(2e4, rel=0.02)


def test_compare_models_on_pure_aging():
    x = np.geomspace(1e-7, 1e-4, 400)
    y = 3e-3 * np.log(x / 5e-8) + np.random.default_rng(2).normal(0, 5e-5, x.size)
    table = granflow.compare_models((x, y))
    assert table.best_bic == "log_aging"
    assert table.fits["log_aging"].params["a"] == pytest.approx(3e-3, rel=0.01)


def test_fit_many_in_processes_keeps_order_and_reports_failures():
    x = np.linspace(1e-6, 5e-4, 400)
    curves = [(x, friction_slip(x, Params(3e-3, 4e4, Fd, 2e-7))) for Fd in (6e-3, 8e-3, 12e-3)]
    curves.insert(1, (x, np.full(x.size, 1e-3)))  # flat: no overshoot
    results = granflow.fit_many(curves, jobs=2, errors="return")
    assert isinstance(results[1], granflow.FitError)
    assert [round(r.params["Fd"] * 1e3, 6) for r in results if not isinstance(r, Exception)] == [
        6.0,
        8.0,
        12.0,
    ]
    with pytest.raises(granflow.FitError, match="dataset 1"):
        granflow.fit_many(curves, jobs=1)
    serial = granflow.fit_many(curves[:1], jobs=1, profile=False)
    assert serial[0].ci_method["x0"] == "wald"
