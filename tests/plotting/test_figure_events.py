"""Every figure shows the event it exists to show inside its axes (issue 28, point 3, 4, 10,
12): Fig. 3c's runaway after the switch, Fig. 3a's failure at the peak with the grey
rate-controlled F(t) and its sub-µm creep inset, the forecast's band, the stability map's
cells against its analytic boundary, the creep points beside their fits."""

import matplotlib
import numpy as np
import pytest

matplotlib.use("Agg")
import matplotlib.pyplot as plt

import granflow as gf
from granflow.plotting import plot_creep, plot_stress_ramp, plot_switch
from granflow.plotting.forecast import plot_forecast
from granflow.plotting.simulation import plot_stability_map

V = 0.86e-6
P = gf.Params.from_time_domain(a=3.31e-3, k=0.036, t0=0.23, Fd=10e-3, velocity=V)


@pytest.fixture(autouse=True)
def _close():
    yield
    plt.close("all")


def _inside(value, limits):
    low, high = sorted(limits)
    return low <= value <= high


def test_fig3c_shows_the_runaway_after_the_switch():
    protocol = gf.Protocol([gf.Velocity(V, 80.0), gf.SwitchToForce(10.0, factor=1.01)])
    run = gf.simulate(P, protocol, method="dynamic").to_run()
    slip_ax, force_ax = plot_switch(run, P)
    assert _inside(80.0, slip_ax.get_xlim())
    after = run.t > 80.0
    assert np.ptp(run.slip[after]) > 0.3 * run.slip[run.t <= 80.0].max()  # it runs away
    low, high = slip_ax.get_ylim()
    shown = (run.slip[after] * 1e6 >= low) & (run.slip[after] * 1e6 <= high)
    assert shown.all(), "the runaway leaves the slip axis"
    assert _inside(run.force.max() * 1e3, force_ax.get_ylim())


def test_fig3a_fails_at_the_peak_of_the_grey_rate_controlled_curve():
    rate = 0.05e-3
    result = gf.simulate(P, gf.Protocol([gf.ForceRamp(rate=rate, duration=400.0)]), points=800)
    record = result.to_run()
    # the record goes on after the failure: the layer runs away, 50 µm a second
    after = result.failure.time + np.arange(1.0, 6.0)
    run = gf.Run(
        np.concatenate([record.t, after]),
        np.concatenate([record.slip, record.slip[-1] + 50e-6 * np.arange(1.0, 6.0)]),
        np.concatenate([record.velocity, np.full(5, 50e-6)]),
        np.concatenate([record.force, rate * after]),
        "stress",
    )
    slip_ax, force_ax = plot_stress_ramp(run, P, velocity=V)
    top = gf.peak(P, velocity=V)
    (grey,) = [line for line in force_ax.get_lines() if "under rate control" in line.get_label()]
    assert "0.86 µm/s" in grey.get_label()
    assert np.max(grey.get_ydata()) == pytest.approx(top.force * 1e3, rel=1e-3)
    assert _inside(top.time, (grey.get_xdata()[0], grey.get_xdata()[-1]))
    assert _inside(top.force * 1e3, force_ax.get_ylim())
    assert _inside(result.failure.time, slip_ax.get_xlim())
    (inset,) = force_ax.child_axes
    assert inset.get_ylim()[1] < 2.0  # µm: the sub-µm creep, not the main panel again
    window = run.t <= inset.get_xlim()[1]
    assert np.count_nonzero(window) > 20 and run.slip[window].max() * 1e6 <= inset.get_ylim()[1]


def test_the_forecast_band_is_visible_on_its_time_axis():
    cuts = np.array([80.0, 100.0, 120.0, 140.0])
    observed = 204.0
    band = np.array([0.4, 0.3, 0.1, 0.05])  # s: narrow against a 400 s record
    running = gf.forecast.ForecastSeries(
        cuts=cuts,
        methods={
            "model": {"time": observed + 0 * cuts, "low": observed - band, "high": observed + band}
        },
        observed=observed,
        level=0.9,
    )
    ax = plot_forecast(running)
    low, high = ax.get_ylim()
    assert _inside(observed, (low, high))
    assert 2 * band[0] > 0.2 * (high - low)  # the widest band fills a fifth of the axis
    legend = [t.get_text() for t in ax.get_legend().get_texts()]
    assert not any("voight" in t for t in legend)
    assert not [t.get_text() for t in ax.texts if "axis" in t.get_text()]  # nothing left out


def test_a_baseline_that_leaves_the_forecast_axis_is_said_to():
    """The axis keeps to half the observed time either side, so that Voight's law far above
    does not squash the model's band; the figure says where it went (it once just left)."""
    cuts = np.array([80.0, 100.0, 120.0])
    observed = 204.0
    model = {
        "time": observed + 0 * cuts,
        "low": observed - 2 + 0 * cuts,
        "high": observed + 2 + 0 * cuts,
    }
    voight = {"time": np.array([900.0, 500.0, 250.0]), "low": np.array([600.0, 400.0, 230.0]),
              "high": np.array([1500.0, 700.0, 280.0])}  # fmt: skip
    running = gf.forecast.ForecastSeries(
        cuts=cuts, methods={"model": model, "voight": voight}, observed=observed, level=0.9
    )
    ax = plot_forecast(running)
    assert ax.get_ylim()[1] < 1500.0
    notes = [t.get_text() for t in ax.texts]
    assert any("Voight's law above the axis (up to 1500 s)" in note for note in notes), notes
    assert not any("model" in note for note in notes)


def test_the_stability_map_cells_agree_with_its_boundary():
    t_peak = gf.peak(P, velocity=V).time
    points = np.linspace(0.25 * t_peak, 4.0 * t_peak, 48)
    ratios = np.linspace(0.97, 1.09, 31)
    found = gf.stability_map(P, points, ratios, velocity=V, hold=60.0, jobs=1, progress=False)
    ax = plot_stability_map(found)
    (boundary,) = [line for line in ax.get_lines() if line.get_label() == "boundary (analytic)"]
    grid, ratio = boundary.get_xdata(), boundary.get_ydata()
    step = ratios[1] - ratios[0]
    disagree = 0
    for i, t in enumerate(points):
        limit = float(np.interp(t, grid, ratio))
        for j, r in enumerate(ratios):
            if abs(r - limit) <= step:  # the boundary crosses this cell
                continue
            disagree += bool(found.failed[i, j]) != (r > limit)
    assert disagree == 0
    assert all(_inside(r, ax.get_ylim()) for r in ratio[ratio <= ratios.max()])


def test_creep_points_are_not_hidden_under_their_fits():
    t = np.arange(0.0, 1800.0, 1.0)
    slip = 0.05e-6 * np.log1p(t / 5.0) + np.random.default_rng(0).normal(0, 2e-9, t.size)
    run = gf.Run(t, slip, np.full(t.size, np.nan), np.full(t.size, 9e-3), "stress")
    ax = plot_creep([run], [gf.fit_creep(t, slip)], log_time=True)
    points, fit = ax.get_lines()
    assert points.get_markersize() >= 3.5 and fit.get_linewidth() <= 1.0


def test_fig3c_before_the_peak_keeps_the_whole_overshoot_on_its_axis():
    protocol = gf.Protocol([gf.Velocity(V, 10.0), gf.SwitchToForce(60.0, factor=1.01)])
    run = gf.simulate(P, protocol).to_run()
    _, force_ax = plot_switch(run, P)
    (grey,) = [line for line in force_ax.get_lines() if line.get_label() == "rate control (model)"]
    assert np.max(grey.get_ydata()) <= force_ax.get_ylim()[1]  # the peak is not clipped
