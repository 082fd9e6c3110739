"""Joint fits: tied parameters, velocity collapse with its likelihood-ratio test, Amontons."""

import json

import numpy as np
import pytest

import granflow
from granflow import MaterialConstants, Params, friction_slip

NOISE = 0.05e-3
VELOCITIES = (0.3e-6, 0.86e-6, 2.5e-6)


def slip_run(params, seed, points=1500, last_slip=5e-4):
    x = np.linspace(params.x0, last_slip, points)
    return x, friction_slip(x, params) + np.random.default_rng(seed).normal(0, NOISE, points)


def campaign(alphas, seed):
    """Two repeats at each velocity; x0 differs between repeats (preparation)."""
    runs, velocities = [], []
    for i, (velocity, alpha) in enumerate(zip(VELOCITIES, alphas, strict=True)):
        for repeat, x0 in enumerate((2e-7, 3.2e-7)):
            params = Params(a=3.1e-3, alpha=alpha, Fd=10e-3, x0=x0)
            runs.append(slip_run(params, seed=100 * seed + 10 * i + repeat))
            velocities.append(velocity)
    return runs, velocities


def test_joint_fit_recovers_shared_parameters_within_intervals():
    truths = [Params(3.1e-3, 5e4, 10e-3, x0) for x0 in (1.5e-7, 2.5e-7, 4e-7)]
    runs = [slip_run(p, seed=i) for i, p in enumerate(truths)]
    joint = granflow.fit_joint(runs)
    assert joint.success
    assert joint.names == ("a", "alpha", "Fd", "x0_0", "x0_1", "x0_2")
    for name, value in (("a", 3.1e-3), ("alpha", 5e4), ("Fd", 10e-3)):
        low, high = joint.ci95[name]
        assert low <= value <= high, name
    for i, p in enumerate(truths):
        low, high = joint.ci95[f"x0_{i}"]
        assert low <= p.x0 <= high
        assert joint.run_params[i]["x0"] == joint.params[f"x0_{i}"]
    # the joint interval of a shared parameter is narrower than each single-run interval
    assert all(joint.stderr["alpha"] < f.stderr["alpha"] for f in joint.individual)
    json.dumps(joint.to_dict())
    assert "alpha" in joint.report()


def test_joint_fit_with_fixed_and_unknown_names():
    truths = [Params(3.1e-3, 5e4, 10e-3, x0) for x0 in (1.5e-7, 2.5e-7)]
    runs = [slip_run(p, seed=i, points=800) for i, p in enumerate(truths)]
    joint = granflow.fit_joint(runs, fixed={"Fd": 10e-3})
    assert joint.params["Fd"] == 10e-3 and joint.stderr["Fd"] == 0.0
    with pytest.raises(granflow.InvalidParameterError, match="missing: x0"):
        granflow.fit_joint(runs, per_run=())
    with pytest.raises(granflow.InvalidParameterError, match="unknown parameter"):
        granflow.fit_joint(runs, fixed={"x0_9": 1e-7})


def test_velocity_collapse_is_not_rejected_when_alpha_is_constant():
    runs, velocities = campaign((5e4, 5e4, 5e4), seed=1)
    result = granflow.velocity_collapse(runs, velocities)
    assert result.df == 4
    assert result.collapses and result.p_value > 0.05
    low, high = result.shared.ci95["alpha"]
    assert low <= 5e4 <= high
    assert "collapse" in result.report()
    json.dumps(result.to_dict())


def test_velocity_collapse_is_rejected_when_alpha_depends_on_velocity():
    runs, velocities = campaign((4e4, 5e4, 6e4), seed=2)
    result = granflow.velocity_collapse(runs, velocities)
    assert not result.collapses and result.p_value < 1e-6
    for i, alpha in enumerate((4e4, 5e4, 6e4)):
        low, high = result.per_velocity.ci95[f"alpha_v{i}"]
        assert low <= alpha <= high


def test_collapse_test_false_rejection_rate_is_near_five_percent():
    """Under the null the p-value is uniform: over 20 campaigns at most 4 rejections."""
    rejections = 0
    for seed in range(20):
        runs, velocities = campaign((5e4, 5e4, 5e4), seed=50 + seed)
        runs = [(x[::3], f[::3]) for x, f in runs]
        rejections += not granflow.velocity_collapse(runs, velocities).collapses
    assert rejections <= 4


def test_amontons_recovers_material_constants():
    constants = MaterialConstants(mu_a=0.06, mu_d=0.2, alpha=5e4)
    runs, loads = [], []
    for i, load in enumerate((0.03, 0.06, 0.09)):
        for repeat in range(3):
            params = constants.params_at(load, x0=(1.5 + repeat) * 1e-7)
            runs.append(slip_run(params, seed=10 * i + repeat, points=800))
            loads.append(load)
    result = granflow.fit_amontons(runs, loads, velocities=[0.86e-6] * len(runs))
    joint = result.joint
    for name, value in (("mu_a", 0.06), ("mu_d", 0.2), ("alpha", 5e4)):
        low, high = joint.ci95[name]
        assert low <= value <= high, name
    assert len(result.per_load) == 3
    row = result.per_load[1]
    assert row["repeats"] == 3 and row["normal_load"] == 0.06
    assert row["Fd"][0] == pytest.approx(0.012, rel=1e-3)
    assert row["alpha_v"][0] == pytest.approx(5e4 * 0.86e-6, rel=0.02)
    slope, error = result.lines["Fd"]
    assert abs(slope - 0.2) < 4 * error
    slope, error = result.lines["a"]
    assert abs(slope - 0.06) < 4 * error
    assert "F_N" in result.report()
    low, high = result.lines_ci95["Fd"]
    assert low < 0.2 < high and high - low > 2 * 1.96 * result.lines["Fd"][1]
    # the result carries its test of the law (the contract of issue 28), in the JSON too
    test = result.test
    assert test is not None and test.loads == 3
    assert [r.name for r in test.relations] == ["a ∝ F_N", "F_d ∝ F_N", "α independent of F_N"]
    worst = min(test.relations, key=lambda r: r.p_value)
    assert test.statistic == worst.statistic and test.df == worst.df
    assert test.p_value == pytest.approx(min(1.0, 3 * worst.p_value))
    assert test.holds == (test.p_value >= 0.05)
    assert result.to_dict()["test"]["p_value"] == test.p_value
    assert "[[Test of the law: " in result.report()
    assert granflow.AmontonsResult.from_dict(json.loads(json.dumps(result.to_dict()))) == result


def test_the_amontons_test_rejects_the_law_about_as_often_as_its_level_when_it_holds():
    """20 campaigns made by Amontons' law (3 loads, 4 repeats, x0 drawn per repeat): the
    test (Bonferroni over its three relations, at 5 %) rejects at most a few."""
    constants = MaterialConstants(mu_a=0.06, mu_d=0.2, alpha=5e4)
    rng = np.random.default_rng(7)
    rejected = 0
    for seed in range(20):
        runs, loads = [], []
        for i, load in enumerate((0.03, 0.06, 0.09)):
            for repeat in range(4):
                params = constants.params_at(load, x0=rng.uniform(1.5e-7, 4.5e-7))
                runs.append(slip_run(params, seed=700 + 40 * seed + 10 * i + repeat, points=300))
                loads.append(load)
        rejected += not granflow.fit_amontons(runs, loads).test.holds
    assert rejected <= 3
    # and a law that fails is seen: F_d/F_N rising by half from the least to the largest load
    runs, loads = [], []
    for i, load in enumerate((0.03, 0.06, 0.09)):
        for repeat in range(4):
            params = MaterialConstants(0.06, 0.2 * (1 + 0.25 * i), 5e4).params_at(
                load, x0=rng.uniform(1.5e-7, 4.5e-7)
            )
            runs.append(slip_run(params, seed=900 + 10 * i + repeat, points=300))
            loads.append(load)
    test = granflow.fit_amontons(runs, loads).test
    assert not test.holds and min(test.relations, key=lambda r: r.p_value).name == "F_d ∝ F_N"


def test_amontons_lines_by_hand():
    """The slope through the origin over every run, its error from the scatter about the line
    and its Student-t interval, against a hand computation with numpy and scipy.stats."""
    from scipy import stats

    from granflow.fitting.joint import _line_through_origin

    loads = np.array([0.03, 0.03, 0.06, 0.06, 0.09])
    values = np.array([0.0061, 0.0059, 0.0118, 0.0123, 0.0181])
    (slope, error), (low, high) = _line_through_origin(loads, values)
    # least squares without intercept: the one-parameter normal equation, by hand
    expected = float(loads @ values / (loads @ loads))
    residuals = values - expected * loads
    expected_error = np.sqrt(residuals @ residuals / 4 / (loads @ loads))
    assert slope == pytest.approx(expected, rel=1e-14)
    assert error == pytest.approx(expected_error, rel=1e-12)
    half = 2.7764451051977987 * expected_error  # t(0.975, 4), tabulated
    assert (low, high) == pytest.approx((expected - half, expected + half), rel=1e-12)
    assert stats.t.ppf(0.975, 4) == pytest.approx(2.7764451051977987, rel=1e-12)


@pytest.mark.slow
def test_amontons_line_intervals_hold_the_truth_with_three_repeats():
    """Over 100 seeds with 3 repeats per load, the 95 % intervals of mu_a and mu_d (the lines'
    ci95) hold the truth in 90-98 % of the seeds (inverse-variance weights from 3 repeats
    gave 75-78 %)."""
    constants = MaterialConstants(mu_a=0.06, mu_d=0.2, alpha=5e4)
    seeds, held = 100, {"a": 0, "Fd": 0}
    for seed in range(seeds):
        rng = np.random.default_rng(1000 + seed)
        runs, loads = [], []
        for load in (0.03, 0.06, 0.09):
            for _ in range(3):
                params = constants.params_at(load, x0=rng.uniform(1.5e-7, 4e-7))
                x = np.linspace(params.x0, 5e-4, 400)
                runs.append((x, friction_slip(x, params) + rng.normal(0, NOISE, x.size)))
                loads.append(load)
        result = granflow.fit_amontons(runs, loads)
        for key, truth in (("a", constants.mu_a), ("Fd", constants.mu_d)):
            low, high = result.lines_ci95[key]
            held[key] += low <= truth <= high
            error = result.lines[key][1]
            assert high - low == pytest.approx(2 * 2.306004135033371 * error, rel=1e-9)
    for key, count in held.items():
        assert 0.90 <= count / seeds <= 0.98, (key, count)


def test_preparation_spread():
    fits = []
    x0s = (1.5e-7, 2e-7, 3e-7, 4.5e-7)
    for i, x0 in enumerate(x0s):
        fits.append(granflow.fit(slip_run(Params(3.1e-3, 5e4, 10e-3, x0), seed=i, points=800)))
    spread = granflow.preparation_spread(fits)
    assert spread.repeats == 4
    assert spread.start["mean"] == pytest.approx(np.mean(x0s), rel=0.05)
    assert spread.Fd["relative"] < 0.01
    # a larger x0 (older initial state) gives a smaller overshoot in this model
    peaks = [granflow.peak(Params(3.1e-3, 5e4, 10e-3, x0)).force for x0 in x0s]
    assert np.sign(spread.correlation) == np.sign(np.corrcoef(x0s, peaks)[0, 1])
    assert "repeats" in spread.report()


def test_collapse_and_amontons_plots():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from granflow.plotting import plot_amontons, plot_collapse

    runs, velocities = campaign((5e4, 5e4, 5e4), seed=3)
    runs = [(x[::4], f[::4]) for x, f in runs]
    ax = plot_collapse(granflow.velocity_collapse(runs, velocities))
    assert ax.get_xlabel() == "slip x [µm]"
    assert "collapse" in ax.get_legend().get_title().get_text()
    assert len(ax.get_lines()) == 2 * len(runs)
    constants = MaterialConstants(mu_a=0.06, mu_d=0.2, alpha=5e4)
    amontons_runs, loads = [], []
    for i, load in enumerate((0.03, 0.06)):
        for repeat in range(2):
            params = constants.params_at(load, x0=(1.5 + repeat) * 1e-7)
            amontons_runs.append(slip_run(params, seed=40 + 10 * i + repeat, points=400))
            loads.append(load)
    axes = plot_amontons(granflow.fit_amontons(amontons_runs, loads))
    assert [a.get_ylabel() for a in axes] == ["$a$ [mN]", r"$\alpha$ [1/m]", r"$F_\mathrm{d}$ [mN]"]
    plt.close("all")
