"""Rate-and-state fits of the two real velocity-step records (shared/data), with no guess.

The regression values (aging law, one state, no trend, covariance scaled by the residuals'
correlation time) sit next to the independent checks that justify them: the steady-state
change read off the raw record with medians, the record's own scatter, and what the record
does where the model predicts a constant friction.

The sepiolite record carries an apparatus ripple periodic in load-point displacement (about
86 µm: 430 s at 0.2 µm/s, 43 s at 2 µm/s, read off the raw record below); with it fitted
(``periodic=True``) in a window up to 250 s after the step, its residuals are within 1.5 times
its scatter.
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
        assert not fit.periodicity["significant"]  # no ripple to fit
        return
    assert 3.0 < ratio < 3.8
    # the check of the residuals finds the ripple and says so
    assert fit.periodicity["significant"]
    assert fit.periodicity["wavelength"] == pytest.approx(86.5e-6, rel=0.02)
    assert "consider periodic=True" in fit.report()
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


# ---------------------------------------------------------------- sepiolite, ripple fitted

SEPIOLITE = "velstep3_TR2_exp013_sepiolite.txt"
#: The documented settings: slip law, the ripple fitted (two harmonics), one window from the
#: record's start (all of the steady friction before the step) to 250 s after the step (500
#: µm of load-point slip, 5.7 Dc: the transient is within 0.4 % of its end, and the slow
#: wander of the friction after about 1500 s, which no rate-and-state law describes, stays
#: outside). The start hardly matters, the end does: benchmarks/README.md has the map
#: (within 1.5 times the scatter for every end from 100 to 300 s after the step).
SEPIOLITE_END = 250.0  # s after the step
#: found by rsf.fit with these settings (a, b, Dc [m], stiffness [1/m], wavelength [m])
SEPIOLITE_VALUES = {
    "a": 0.0117568,
    "b": -0.00829592,
    "Dc": 8.76621e-05,
    "stiffness": 2677.08,
    "wavelength": 8.65565e-05,
}


@pytest.fixture(scope="module")
def sepiolite():
    record = rsf.read_velocity_steps(shared_data("rate-state-velocity-steps", SEPIOLITE))
    step = record.step_times[0]
    fit = rsf.fit(
        record,
        law="slip",
        periodic=True,
        windows=[(0.0, step + SEPIOLITE_END)],
        correlated_noise=True,
    )
    return record, fit


def _raw_periods(record):
    """Period [s] of the ripple in the raw friction at each velocity: the highest peak of a
    one-harmonic periodogram against time, the friction less a polynomial trend (linear
    before the step, quadratic after its transient)."""
    from granflow.fitting.rsf_periodic import displacement_periodogram

    t, mu, step = record.t, record.friction, record.step_times[0]
    periods = []
    for inside, degree in ((t < step, 1), (t > step + 200.0, 2)):
        tt, y = t[inside], mu[inside]
        y = y - np.polyval(np.polyfit(tt, y, degree), tt)
        trial = np.linspace(20.0, 800.0, 4000)
        _, power = displacement_periodogram(tt, y, 1, wavelengths=trial)
        periods.append(trial[np.argmax(power)])
    return periods


def test_sepiolite_ripple_is_periodic_in_displacement(sepiolite):
    """Independent of the fit: the ripple's period in time is ten times shorter at ten times
    the speed, one wavelength in load-point displacement; the fit finds that wavelength."""
    record, fit = sepiolite
    v1, v2 = record.velocities
    slow, fast = _raw_periods(record)
    assert slow / fast == pytest.approx(v2 / v1, rel=0.03)
    for wavelength in (slow * v1, fast * v2):
        assert fit.params["wavelength"] == pytest.approx(wavelength, rel=0.02)


def test_sepiolite_with_the_ripple_is_within_one_and_a_half_times_its_scatter(sepiolite):
    record, fit = sepiolite
    assert fit.success, fit.message
    assert fit.harmonics == 2
    for name, value in SEPIOLITE_VALUES.items():
        assert fit.params[name] == pytest.approx(value, rel=2e-3), name
    for key in ("a", "b", "Dc"):
        assert fit.ci_method[key] == "profile"
    # the scatter, independently: the first differences of white noise have twice its variance
    assert fit.noise == pytest.approx(np.std(np.diff(record.friction)) / np.sqrt(2), rel=0.15)
    ratio = fit.residual_rms / fit.noise
    assert ratio <= 1.5
    assert ratio == pytest.approx(1.426, abs=0.01)
    # no ripple left in the residuals
    assert not fit.periodicity["significant"]


def test_sepiolite_a_minus_b_agrees_with_the_measured_steady_state_change(sepiolite):
    """Measured: the mean friction over one ripple wavelength of load-point slip (which
    averages the ripple out) just before the step and at the end of the window, over
    ln(v2 / v1); the wavelength is the raw record's, not the fit's."""
    record, fit = sepiolite
    t, mu, step = record.t, record.friction, record.step_times[0]
    v1, v2 = record.velocities
    slow, fast = _raw_periods(record)
    wavelength = 0.5 * (slow * v1 + fast * v2)
    end = step + SEPIOLITE_END
    before = mu[(t >= step - wavelength / v1) & (t < step)].mean()
    after = mu[(t > end - wavelength / v2) & (t <= end)].mean()
    measured = (after - before) / np.log(v2 / v1)
    assert abs(fit.a_minus_b - measured) < 1.96 * fit.a_minus_b_stderr
    assert fit.a_minus_b == pytest.approx(0.0200527, rel=2e-3)


def test_sepiolite_fit_and_ripple_are_drawn(sepiolite, tmp_path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    _, fit = sepiolite
    top, bottom = fit.plot()
    np.testing.assert_allclose(top.lines[1].get_ydata(), fit.best_fit)
    np.testing.assert_allclose(top.lines[2].get_ydata(), fit.best_fit - fit.ripple)
    np.testing.assert_allclose(bottom.lines[0].get_ydata(), fit.residuals)
    top.figure.savefig(tmp_path / "sepiolite_ripple.png")
    plt.close(top.figure)
