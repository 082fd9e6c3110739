"""compare_models with the rate-and-state families: each family wins (by AIC) on data it
generated, the nested models get likelihood-ratio tests, and the real records are ranked."""

import json

import numpy as np
import pytest
from conftest import shared_data

import granflow as gf
from granflow import rsf
from granflow.fitting.rsf_compare import residual_pattern

V1, V2 = 1e-6, 1e-5


def steps(law, b, seed):
    model = rsf.RateState(0.6, 0.008, V1, 2000.0, [rsf.State(b, 20e-6, law)])
    protocol = gf.Protocol([gf.Velocity(V1, 40.0), gf.Velocity(V2, 40.0)])
    t = np.arange(0.0, 80.0001, 0.1)
    mu = rsf.simulate(model, protocol, t_eval=t).friction
    return t, mu + np.random.default_rng(seed).normal(0, 3e-4, t.size), protocol


@pytest.mark.parametrize(
    ("law", "b", "winner"),
    [("aging", 0.012, "rsf_aging"), ("slip", 0.012, "rsf_slip"), ("aging", 0.0, "eq2_direct")],
)
def test_each_family_wins_on_its_own_velocity_steps(law, b, winner):
    """b = 0 is the paper's law with the direct effect: rate-and-state fits it as well, with
    two parameters more, so AIC prefers the paper's law by about 4."""
    t, mu, protocol = steps(law, b, seed=7)
    comparison = gf.compare_models((t, mu), protocol=protocol)
    assert comparison.best_aic == winner, comparison.report()
    rows = {row["model"]: row for row in comparison.rows}
    assert rows["eq2_direct"]["lr_test"]["against"] == "eq2"
    assert rows["rsf_aging"]["lr_test"]["df"] == 2
    if winner == "eq2_direct":
        # nested and no better: the likelihood ratio finds nothing
        assert rows["rsf_aging"]["lr_test"]["p_value"] > 0.05
    else:
        assert rows[winner]["lr_test"]["p_value"] < 1e-10


def test_eq3_wins_on_its_own_startup_against_rate_and_state():
    params = gf.Params.from_time_domain(a=3.31e-3, k=0.036, t0=0.23, Fd=10e-3, velocity=0.86e-6)
    x = np.linspace(3e-7, 5e-4, 300)
    y = gf.friction_slip(x, params) + np.random.default_rng(0).normal(0, 5e-5, x.size)
    comparison = gf.compare_models((x, y), rate_and_state=True, velocity=0.86e-6)
    rows = {row["model"]: row for row in comparison.rows}
    assert comparison.best_aic == "eq3"
    # the rate-and-state laws were fitted (a step from slow sliding), not left out
    assert rows["rsf_aging"]["aic"] is not None and rows["rsf_slip"]["aic"] is not None
    assert rows["rsf_aging"]["nfree"] == 6  # a, b, Dc, k, mu0 and the slow velocity
    again = gf.ModelComparison.from_dict(json.loads(json.dumps(comparison.to_dict())))
    assert again == comparison


def test_residual_patterns():
    rng = np.random.default_rng(1)
    white = residual_pattern(rng.normal(size=2000))
    assert abs(white["lag1"]) < 0.1 and abs(white["runs_z"]) < 3.5
    drift = residual_pattern(np.sin(np.linspace(0, 6, 2000)) + 0.1 * rng.normal(size=2000))
    assert drift["lag1"] > 0.5 and drift["runs_z"] < -10


@pytest.mark.parametrize(
    "name", ["velstep3_TR2_exp013_sepiolite.txt", "velstep4_BRAVA_expb819_basalt.txt"]
)
def test_the_real_records_prefer_rate_and_state(name):
    """On both records the slip law has the smallest AIC and the paper's law, with or
    without the direct effect, is far behind; the likelihood-ratio tests, with n divided by
    the residuals' correlation time, still reject the direct effect alone (p < 1e-3)."""
    record = rsf.read_velocity_steps(shared_data("rate-state-velocity-steps", name))
    comparison = gf.compare_models(record, correlated_noise=True)
    rows = {row["model"]: row for row in comparison.rows}
    assert comparison.best_aic == "rsf_slip"
    assert rows["rsf_aging"]["delta_aic"] > 10
    assert rows["eq2_direct"]["delta_aic"] > 1000 and rows["eq2"]["delta_aic"] > 1000
    assert rows["rsf_slip"]["lr_test"]["p_value"] < 1e-3
