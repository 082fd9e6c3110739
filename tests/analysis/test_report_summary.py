"""The report's verdicts and predictions in a physicist's words: the Amontons test, the fit
against the plateau noise, the preparation spread with a, α and F_d held, Fig. 2a's choice,
the display of predictions, and the stability map's analytic boundary."""

import json
import math
from types import SimpleNamespace

import numpy as np
import pytest

import granflow as gf
from granflow._format import display_text
from granflow.analysis.joint import (
    Startup,
    figure_preparations,
    goodness_of_fit,
    plateau_noise,
    preparation_of,
    preparation_spreads,
)
from granflow.analysis.prediction_results import RampComparison
from granflow.analysis.report_stress import ramp_view
from granflow.analysis.runs import StartupData
from granflow.fitting.amontons_test import amontons_test

A, ALPHA, FD, V = 3.3e-3, 5.0e4, 11e-3, 0.86e-6


def _run(x0, seed, *, noise=3e-5, bump=0.0, state="protocol", label=None):
    """A rate-controlled start-up of Eq. 3 with Gaussian force noise (and an optional bump
    the model cannot follow)."""
    params = gf.Params(A, ALPHA, FD, x0)
    t = np.arange(1.0, 401.0)
    slip = V * t
    force = gf.friction_slip(slip, params)
    force = force + bump * np.exp(-(((slip - 150e-6) / 20e-6) ** 2))
    force = force + np.random.default_rng(seed).normal(0.0, noise, t.size)
    meta = {"normal_load": 0.055, "velocity": V, "preparation": label or f"p{seed}"}
    if state:
        meta["preparation_state"] = state
    return gf.Run(t, slip, np.full(t.size, V), force, meta=meta)


def _startup(run, name):
    fit = gf.fit((run.slip, run.force), profile=False)
    entry = SimpleNamespace(name=name, run=run, result=SimpleNamespace(fit=fit))
    data = StartupData(run.slip, run.force, "slip", 0, V, 0)
    return Startup(entry=entry, data=data)


# --------------------------------------------------------------------------- Amontons


def test_amontons_test_by_hand():
    # a/F_N = 1, 2, 3 (error 1 each, no repeat count): weighted mean 2, chi2 = 2 with 2 d.o.f.,
    # whose survival function is exp(-chi2 / 2)
    rows = [
        {
            "normal_load": load,
            "a": [ratio * load, load],
            "Fd": [0.2 * load, 1e-3 * load],
            "alpha": [5e4, 100.0],
        }
        for load, ratio in ((0.02, 1.0), (0.05, 2.0), (0.1, 3.0))
    ]
    test = amontons_test(rows)
    a, fd, alpha = test.relations
    assert a.name == "a ∝ F_N" and a.mean == pytest.approx(2.0) and a.df == 2
    assert a.statistic == pytest.approx(2.0) and a.p_value == pytest.approx(math.exp(-1.0))
    assert fd.statistic == pytest.approx(0.0, abs=1e-20) and fd.p_value == pytest.approx(1.0)
    assert alpha.p_value == pytest.approx(1.0)
    # one verdict: the smallest p times three relations (Bonferroni), its χ² the statistic
    assert test.statistic == a.statistic and test.df == 2
    assert test.p_value == pytest.approx(min(1.0, 3 * math.exp(-1.0)))
    assert test.holds and test.loads == 3
    assert type(test).from_dict(json.loads(json.dumps(test.to_dict()))) == test
    rows[2]["Fd"] = [0.3 * 0.1, 1e-3 * 0.1]  # F_d/F_N 0.3 at the largest load: 100 errors off
    assert not amontons_test(rows).holds
    assert amontons_test(rows[:2]) is None  # two loads: nothing to test


def test_student_t_makes_few_repeats_less_damning():
    rows = [
        {
            "normal_load": load,
            "a": [0.06 * load * (1 + d), 0.06 * load * 0.01],
            "Fd": [0.2 * load, 1e-3],
            "alpha": [5e4, 100.0],
            "repeats": 3,
        }
        for load, d in ((0.02, 0.0), (0.05, 0.03), (0.1, -0.03))
    ]
    with_t = amontons_test(rows).relations[0].statistic
    for row in rows:
        row["repeats"] = None
    without = amontons_test(rows).relations[0].statistic
    assert with_t < without  # a 3-sigma t deviate with 2 d.o.f. is a smaller normal deviate


# --------------------------------------------------------------------------- goodness of fit


def test_plateau_noise_recovers_the_noise():
    rng = np.random.default_rng(3)
    x = np.linspace(0.0, 1.0, 4000)
    force = 0.01 + 0.002 * np.exp(-3 * x) + rng.normal(0.0, 3e-5, x.size)
    assert plateau_noise(force) == pytest.approx(3e-5, rel=0.05)
    assert math.isnan(plateau_noise(force[:12]))


def test_goodness_of_fit_tells_noise_from_a_missed_curve():
    good = [_startup(_run(x0, seed), f"good{seed}") for seed, x0 in enumerate((2e-7, 4e-7))]
    bad = _startup(_run(3e-7, 7, bump=4e-4), "bump")
    result = goodness_of_fit([*good, bad])
    for name in ("good0", "good1"):
        assert 0.75 < result.runs[name].chi2 < 1.3
        assert result.runs[name].noise == pytest.approx(3e-5, rel=0.2)
    assert result.runs["bump"].chi2 > 2.0
    assert list(result.poor) == ["bump"]
    assert goodness_of_fit([]) is None


# --------------------------------------------------------------------------- preparations


def test_spread_over_repeats_with_a_alpha_fd_held():
    truth = (2.0e-7, 3.5e-7, 5.0e-7)
    startups = [_startup(_run(x0, seed), f"r{seed}") for seed, x0 in enumerate(truth)]
    other = _startup(_run(3e-7, 9, state="other"), "alone")
    rows, notes = preparation_spreads([*startups, other])
    assert notes.errors == ()
    (row,) = rows  # "other" has one repeat: no spread
    assert row.conditions["preparation"] == "protocol"
    held = row.conditions["held"]
    np.testing.assert_allclose(held["x0"], truth, rtol=0.03)
    assert held["a"][0] == pytest.approx(A, rel=0.01)
    assert held["alpha"][0] == pytest.approx(ALPHA, rel=0.02)
    assert held["Fd"][0] == pytest.approx(FD, rel=1e-3)
    assert held["x0_spread"]["relative"] == pytest.approx(
        np.std(truth, ddof=1) / np.mean(truth), rel=0.05
    )


def test_without_a_state_the_preparation_label_groups():
    run = _run(2e-7, 1, state=None, label="batch-1")
    startup = _startup(run, "x")
    assert preparation_of(startup) == "batch-1"
    assert preparation_of(_startup(_run(2e-7, 1), "y")) == "protocol"


def test_fig2a_shows_the_three_most_different_x0():
    values = (3e-7, 2e-7, 4.5e-7, 3.2e-7, 2.6e-7, 3.9e-7, 2.2e-7)
    startups = [_startup(_run(x0, seed), f"r{seed}") for seed, x0 in enumerate(values)]
    rows, _ = preparation_spreads(startups)
    chosen = figure_preparations(startups, rows)
    x0 = sorted(s.fit.params["x0"] for s in chosen)
    assert len(chosen) == 3
    assert x0[0] == pytest.approx(2e-7, rel=0.05) and x0[2] == pytest.approx(4.5e-7, rel=0.05)
    assert x0[1] == pytest.approx(3e-7, rel=0.05)  # the median of the seven
    # no repeats named: the three most different x0 of the representative load and velocity
    assert len(figure_preparations(startups, ())) == 3


# --------------------------------------------------------------------------- predictions


def test_si_messages_in_display_units():
    text = "failure at t = 80 s, slip = 6.88e-05 m, force = 0.01267863 N: exceeds 0.01243683 N"
    assert display_text(text) == (
        "failure at t = 80.00 s, slip = 68.80 µm, force = 12.68 mN: exceeds 12.44 mN"
    )


def test_ramp_comparison_reads_as_physics():
    row = RampComparison(
        run="ramp#1",
        normal_load=0.055,
        observed={"failure_force": 0.01328, "failure_time": 204.0, "failure_slip": 2e-5},
        criterion="velocity above 10 x the reference",
        predicted_force=0.01362,
        predicted_time=209.7,
        F_peak_stderr=3e-4,
        F_peak_spread=2e-4,
        z=-0.8549,
        consistent=True,
    )
    (view,) = ramp_view(SimpleNamespace(analyses=SimpleNamespace(stress_ramp=(row,))))
    rows = {row["quantity"]: row for row in view["rows"]}
    force = rows["failure force F_f [mN]"]
    assert (force["observed"], force["predicted"]) == ("13.28", "13.62")
    assert force["difference"] == "−0.340 mN (−2.5 %)"  # observed − predicted, signed
    assert rows["failure time t_f [s]"]["difference"] == "−5.70 s (−2.7 %)"
    assert view["width"] == pytest.approx(math.hypot(3e-4, 2e-4)) and view["consistent"]


# --------------------------------------------------------------------------- stability map


def test_stability_boundary_separates_the_simulated_outcomes():
    import matplotlib.pyplot as plt

    from granflow.plotting import plot_stability_map

    params = gf.Params(A, ALPHA, FD, 3e-7)
    top = gf.peak(params)
    times = np.linspace(3.0, 60.0, 7)
    ratios = np.array([0.99, 1.01, 1.03, 1.06, 1.1])
    smap = gf.stability_map(params, times, ratios, velocity=V)
    ax = plot_stability_map(smap)
    (boundary,) = [line for line in ax.get_lines() if line.get_label() == "boundary (analytic)"]
    for i, t in enumerate(times):
        limit = np.interp(t, boundary.get_xdata(), boundary.get_ydata())
        for j, ratio in enumerate(ratios):
            if abs(ratio - limit) < 0.005:
                continue  # on the line: either outcome
            expected = "failure" if ratio > limit else "stop"
            assert smap.outcome[i, j] == expected, (t, ratio, limit)
    (marker,) = [line for line in ax.get_lines() if line.get_label().startswith("peak")]
    t_peak = np.interp(top.slip, smap.switch_slip, smap.switch_points)
    assert marker.get_xdata()[0] == pytest.approx(t_peak)
    plt.close(ax.figure)
