"""Rate-and-state fits of the two real velocity-step records (shared/data), with no guess.

The regression values (aging law, one state, no trend, covariance scaled by the residuals'
correlation time) sit next to the independent checks that justify them: the steady-state
change read off the raw record with medians, the record's own scatter, and what the record
does where the model predicts a constant friction.
"""

import numpy as np
import pytest
from conftest import shared_data

from granflow import rsf

RECORDS = {
    # name: (a, b, Dc [m], stiffness [1/m]) found by rsf.fit, aging law
    "velstep3_TR2_exp013_sepiolite.txt": (0.0135802, -0.00663449, 6.41116e-05, 2114.35),
    "velstep4_BRAVA_expb819_basalt.txt": (0.00948196, 0.00907845, 5.8638e-06, 5091.05),
}


@pytest.fixture(scope="module", params=list(RECORDS))
def fitted(request):
    path = shared_data("rate-state-velocity-steps", request.param)
    record = rsf.read_velocity_steps(path)
    return request.param, record, rsf.fit(record, law="aging", correlated_noise=True)


def _measured_a_minus_b(record):
    """Delta mu_ss / ln(v2 / v1) from the raw record: the median friction over the second half
    of the time after the step minus that over the second half before it."""
    t, mu = record.t, record.friction
    step = record.step_times[0]
    before = (t < step) & (t >= 0.5 * step)
    after = t >= step + 0.5 * (t[-1] - step)
    v1, v2 = record.velocities
    return (np.median(mu[after]) - np.median(mu[before])) / np.log(v2 / v1)


def test_the_fit_converges_with_no_guess_and_matches_its_regression_values(fitted):
    name, _, fit = fitted
    assert fit.success, fit.message
    a, b, Dc, k = RECORDS[name]
    assert fit.params["a"] == pytest.approx(a, rel=2e-3)
    assert fit.params["b"] == pytest.approx(b, rel=2e-3)
    assert fit.params["Dc"] == pytest.approx(Dc, rel=2e-3)
    assert fit.params["stiffness"] == pytest.approx(k, rel=2e-3)
    for key in ("a", "b", "Dc"):
        low, high = fit.ci95[key]
        assert low < fit.params[key] < high and fit.ci_method[key] == "profile"


def test_a_minus_b_agrees_with_the_measured_steady_state_change(fitted):
    _, record, fit = fitted
    measured = _measured_a_minus_b(record)
    assert abs(fit.a_minus_b - measured) < 1.96 * fit.a_minus_b_stderr


def test_the_residuals_against_the_records_own_scatter(fitted):
    """Basalt: the residual RMS is within 1.5 times the high-frequency scatter. Sepiolite: it
    is not (3.4 times): the record wanders by about 1e-3 over hundreds of seconds, already
    before the step, where every rate-and-state model predicts a constant friction (the
    record's spread about its mean there is 2.3 times the scatter); there the fit's residuals
    are as small as a constant's can be."""
    name, record, fit = fitted
    ratio = fit.residual_rms / fit.noise
    if "basalt" in name:
        assert ratio < 1.5
        return
    assert 3.0 < ratio < 3.8
    before = record.t < record.step_times[0]
    spread = np.std(record.friction[before])
    assert spread > 2 * fit.noise  # the wander is in the data
    assert np.sqrt(np.mean(fit.residuals[before] ** 2)) == pytest.approx(spread, rel=0.01)


def test_the_fit_and_its_residuals_are_drawn(fitted, tmp_path):
    import matplotlib

    matplotlib.use("Agg")
    name, record, fit = fitted
    top, bottom = fit.plot()
    drawn = top.lines[1].get_ydata()
    np.testing.assert_allclose(drawn, fit.best_fit)
    np.testing.assert_allclose(bottom.lines[0].get_ydata(), record.friction - fit.best_fit)
    top.figure.savefig(tmp_path / f"{name}.png")
    import matplotlib.pyplot as plt

    plt.close(top.figure)


def test_the_section_for_the_report(tmp_path):
    import json

    from granflow.analysis.velocity_steps import is_velocity_step_file, velocity_step_section

    path = shared_data("rate-state-velocity-steps", "velstep4_BRAVA_expb819_basalt.txt")
    assert is_velocity_step_file(path)
    not_steps = tmp_path / "other.csv"
    not_steps.write_text("time [s],force [mN]\n0,1\n")
    assert not is_velocity_step_file(not_steps)
    section = velocity_step_section([path, not_steps], tmp_path / "out")
    json.dumps(section)  # plain data
    (entry,) = section["model_comparison"]
    assert entry["label"] == path.name and entry["best_aic"] == "rsf_slip"
    (figure,) = section["figures"]
    assert (tmp_path / "out" / figure["png"]).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    table = section["fits"][path.name]
    assert {row["name"] for row in table["parameters"]} >= {"a", "b", "Dc", "stiffness"}
    assert len(section["problems"]) == 1 and "other.csv" in section["problems"][0]
