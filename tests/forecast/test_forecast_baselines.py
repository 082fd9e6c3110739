"""The baselines on records whose answer is known by hand, the running forecast, the figure
and the command."""

import math

import numpy as np
import pytest

import granflow as gf
from granflow.cli import main
from granflow.forecast.baselines import inverse_velocity_forecast, voight_forecast
from granflow.forecast.running import running_forecast
from granflow.forecast.synthetic import ramp_record
from granflow.io.writer import write_trios

FAILURE = 100.0


def voight_slip(alpha, t):
    """Slip whose rate is v = (t_f - t)^(-1/(alpha - 1)) (Voight's law with A chosen so),
    integrated by hand: for alpha = 2, slip = -ln(1 - t/t_f); for alpha = 3,
    slip = 2 (sqrt(t_f) - sqrt(t_f - t))."""
    if alpha == 2:
        return -np.log1p(-t / FAILURE)
    return 2.0 * (np.sqrt(FAILURE) - np.sqrt(FAILURE - t))


def test_inverse_velocity_dates_a_linear_inverse_velocity_record():
    t = np.arange(0.0, 80.0, 0.5)
    fc = inverse_velocity_forecast(t, voight_slip(2, t), window=5)
    assert fc.time == pytest.approx(FAILURE, rel=0.01)
    assert fc.exponent == 2.0


def test_voight_recovers_alpha_three():
    t = np.arange(0.0, 80.0, 0.5)
    fc = voight_forecast(t, voight_slip(3, t), window=5)
    assert fc.time == pytest.approx(FAILURE, rel=0.02)
    assert fc.exponent == pytest.approx(3.0, rel=0.05)


def test_a_slowing_record_gets_no_date():
    t = np.arange(0.0, 100.0)
    fc = inverse_velocity_forecast(t, np.log1p(t))
    assert fc.time is None and not fc.approaching
    assert math.isnan(fc.time_interval[0])
    assert "no failure forecast" in fc.report()


@pytest.fixture(scope="module")
def running():
    params = gf.Params(a=3.3e-3, alpha=5e4, Fd=11e-3, x0=0.3e-6)
    t, slip, force, failure = ramp_record(params, 0.065e-3, noise=5e-9, seed=4)
    return running_forecast(t, slip, force, cuts=[0.6 * failure, 0.9 * failure], observed=failure)


def test_the_running_forecast_converges_on_the_observed_failure(running):
    model = running.methods["model"]
    errors = np.abs(model["time"] - running.observed)
    assert errors[-1] < errors[0] or errors[-1] < 0.02 * running.observed
    assert model["low"][-1] <= running.observed <= model["high"][-1]
    assert len(running.rows()) == 6
    back = gf.forecast.ForecastSeries.from_dict(running.to_dict())
    np.testing.assert_array_equal(back.cuts, running.cuts)
    np.testing.assert_array_equal(back.methods["voight"]["high"], running.methods["voight"]["high"])
    assert "Forecast series" in running.report()


def test_plot_forecast_draws_each_method_and_the_failure(running):
    pytest.importorskip("matplotlib")
    import matplotlib

    matplotlib.use("Agg")
    from granflow.plotting import plot_forecast

    ax = plot_forecast(running)
    labels = [line.get_label() for line in ax.get_lines()]
    methods = {label.split(",")[0] for label in labels}
    names = {"model (Eq. 2)", "inverse velocity (Fukuzono)", "Voight's law", "observed failure"}
    assert names <= methods  # each method by its name, with its band's level
    assert all("90% band" in label for label in labels if label != "observed failure")


def test_the_forecast_command_forecasts_a_csv_ramp(tmp_path, capsys):
    params = gf.Params(a=3.3e-3, alpha=5e4, Fd=11e-3, x0=0.3e-6)
    t, slip, force, failure = ramp_record(params, 0.065e-3, noise=5e-9, seed=5)
    run = gf.Run(t=t, slip=slip, velocity=np.gradient(slip, t), force=force, control="stress")
    path = tmp_path / "ramp.txt"
    write_trios(path, [run])
    code = main(["forecast", str(path), "--until", f"{0.9 * failure:.3f}s"])
    out = capsys.readouterr().out
    assert code == 0, out
    assert "Failure forecast" in out and "t_f =" in out
