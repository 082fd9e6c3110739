"""Figures in the manner of the paper (Fig. 2a-c, 3a-c) and save_figure, on realistic inputs:
simulated stress runs, fits of noisy synthetic curves, failed fits, NaN, missing columns."""

import dataclasses
import math
import os
import re
import struct

import matplotlib
import numpy as np
import pytest
from scipy.optimize import brentq

matplotlib.use("Agg")
import matplotlib.pyplot as plt
from matplotlib.collections import PolyCollection
from matplotlib.container import ErrorbarContainer

import granflow as gf
from granflow import plotting
from granflow.plotting import (
    plot_amontons,
    plot_collapse,
    plot_creep,
    plot_startup,
    plot_stress_ramp,
    plot_switch,
    save_figure,
)

V = 0.86e-6  # m/s
NOISE = 0.03e-3  # N
RAMP_RATE = 0.05e-3  # N/s
#: SPEC §4, blue set with Fd = 10 mN (40-digit reference values)
F_PEAK_MN = 13.78294706440486
X_PEAK_UM = 20.90228


@pytest.fixture(autouse=True)
def _close_figures():
    yield
    plt.close("all")


@pytest.fixture(scope="module")
def blue():
    return gf.Params.from_time_domain(a=3.31e-3, k=0.036, t0=0.23, Fd=10e-3, velocity=V)


def startup_run(params, seed, *, velocity=V, points=400, load=0.05, name=None):
    """Eq. 3 sampled at 1 point per V-second, the fits' convention (slip x = v t, t >= t0)."""
    t = np.arange(1.0, points + 1.0) * (V / velocity)
    force = gf.friction_slip(velocity * t, params)
    force = force + np.random.default_rng(seed).normal(0.0, NOISE, t.size)
    meta = {"name": name or f"run {seed}", "velocity": velocity, "normal_load": load}
    return gf.Run(t, velocity * t, np.full(t.size, velocity), force, meta=meta)


@pytest.fixture(scope="module")
def startup():
    sets = ((3.31e-3, 0.036, 0.23), (2.99e-3, 0.051, 0.39), (2.67e-3, 0.058, 0.55))
    runs = [
        startup_run(gf.Params.from_time_domain(a, k, t0, 10e-3, V), seed=i)
        for i, (a, k, t0) in enumerate(sets)
    ]
    return runs, [gf.fit(run, profile=False) for run in runs]


def _run_with_runaway(result, rate=None, seed=0):
    """A simulated force-controlled run, continued after failure by a runaway slip (as a
    rheometer records it) and with measurement noise on the slip."""
    t, slip, force = result.t[:-1], result.displacement[:-1], result.force[:-1]
    extra = np.arange(t[-1] + 1.0, t[-1] + 15.0)
    runaway = slip[-1] + 20e-6 * np.expm1((extra - t[-1]) / 3.0)
    extra_force = RAMP_RATE * extra if rate else np.full(extra.size, force[-1])
    t, slip = np.r_[t, extra], np.r_[slip, runaway]
    slip = slip + np.random.default_rng(seed).normal(0.0, 0.02e-6, slip.size)
    velocity = np.r_[result.velocity[:-1], np.gradient(runaway, extra)]
    return gf.Run(t, slip, velocity, np.r_[force, extra_force], control="stress")


@pytest.fixture(scope="module")
def ramp(blue):
    result = gf.simulate(blue, gf.Protocol([gf.ForceRamp(rate=RAMP_RATE, duration=400.0)]))
    return _run_with_runaway(result, rate=RAMP_RATE)


@pytest.fixture(scope="module")
def switch_fails(blue):
    protocol = gf.Protocol([gf.Velocity(V, 80.0), gf.SwitchToForce(30.0, factor=1.01)])
    return _run_with_runaway(gf.simulate(blue, protocol))


@pytest.fixture(scope="module")
def creep():
    runs, fits = [], []
    for seed, (slip_scale, tau, level) in enumerate(
        ((0.08e-6, 20.0, 9e-3), (0.25e-6, 10.0, 12e-3))
    ):
        t = np.arange(0.0, 3600.0, 10.0)
        noise = np.random.default_rng(seed).normal(0.0, 0.005e-6, t.size)
        slip = slip_scale * np.log1p(t / tau) + noise
        runs.append(gf.Run(t, slip, np.full(t.size, np.nan), np.full(t.size, level), "stress"))
        fits.append(gf.fit_creep(t, slip))
    return runs, fits


def _legend_texts(ax):
    return [text.get_text() for text in ax.get_legend().get_texts()]


# -- Fig. 2a ---------------------------------------------------------------------------------


def test_startup_draws_data_fits_and_residuals_with_units(startup):
    runs, fits = startup
    ax = plot_startup(runs, fits)
    residual_ax = ax.figure.axes[1]
    assert ax.get_ylabel() == "friction force F [mN]"
    assert residual_ax.get_xlabel() == "time t [s]"
    assert residual_ax.get_ylabel() == "residual [mN]"
    assert len(ax.get_lines()) == 2 * len(runs)  # points and fit per run
    assert len(residual_ax.get_lines()) == len(runs) + 1  # residuals and the zero line
    # each fit line (a slip-domain fit, mapped to time) lies on its noisy data
    for run, line in zip(runs, ax.get_lines()[1::2], strict=True):
        model = np.interp(run.t, line.get_xdata(), line.get_ydata())
        late = run.t > 5.0
        assert np.max(np.abs(model[late] - run.force[late] * 1e3)) < 5 * NOISE * 1e3
    assert all("αv =" in text for text in _legend_texts(ax))
    # every a with the same three digits: "3.30" beside "3.31", never "3.3"
    amplitudes = [re.search(r"a = ([\d.]+) mN", text).group(1) for text in _legend_texts(ax)]
    assert all(len(value.replace(".", "").lstrip("0")) == 3 for value in amplitudes)


def test_a_fit_label_keeps_its_trailing_zero():
    from types import SimpleNamespace

    from granflow.plotting.paper import _fit_label

    fit = SimpleNamespace(
        velocity=V, domain="slip", params={"a": 3.3e-3, "alpha": 0.05 / V, "x0": 0.4 * V}
    )
    assert _fit_label(None, fit) == "a = 3.30 mN, αv = 0.050 1/s, t₀ = 0.40 s"


def test_startup_time_domain_fit_is_drawn_against_time(startup):
    run = startup[0][0]
    fit = gf.fit(run, domain="time", profile=False)
    ax = plot_startup(run, fit)
    line = ax.get_lines()[1]
    model = np.interp(run.t[5:], line.get_xdata(), line.get_ydata())
    assert np.max(np.abs(model - run.force[5:] * 1e3)) < 5 * NOISE * 1e3


def test_startup_with_missing_and_failed_fits_draws_data_only(startup):
    runs, fits = startup
    failed = dataclasses.replace(fits[2], success=False)
    ax = plot_startup(runs, [fits[0], None, failed])
    assert len(ax.get_lines()) == len(runs) + 1
    texts = _legend_texts(ax)
    assert "(no fit)" in texts[1] and "fit failed" in texts[2]
    assert len(ax.figure.axes[1].get_lines()) == 2


def test_startup_single_run_with_nan_rows_on_given_axes(startup):
    run, fit = startup[0][0], startup[1][0]
    force = run.force.copy()
    force[[3, 50, 51]] = np.nan
    gappy = gf.Run(run.t, run.slip, run.velocity, force, meta=dict(run.meta))
    _, ax = plt.subplots()
    assert plot_startup(gappy, fit, ax=ax) is ax
    assert ax.get_xlabel() == "time t [s]"
    assert len(ax.get_lines()[0].get_xdata()) == len(run) - 3


def test_startup_rejects_bad_arguments(startup):
    run = startup[0][0]
    cases = [
        (("not runs", None), "runs must be"),
        (([], None), "runs is empty"),
        ((run, [None, None]), "fits has 2 entries for 1 run"),
        (([run, 3.0], None), r"runs\[1\] must be a granflow.Run"),
        ((run, ["fit"]), r"fits\[0\] must be a FitResult"),
    ]
    for arguments, match in cases:
        with pytest.raises(gf.InvalidParameterError, match=match):
            plot_startup(*arguments)


def test_startup_rejects_a_non_axes(startup):
    with pytest.raises(gf.InvalidParameterError, match="residual_ax must be a matplotlib Axes"):
        plot_startup(startup[0][0], None, residual_ax="below")


# -- Fig. 2b and 2c --------------------------------------------------------------------------


@pytest.fixture(scope="module")
def collapse(blue):
    runs = []
    for i, velocity in enumerate((0.3e-6, 0.86e-6, 3e-6)):
        for j in range(2):
            params = blue.replace(x0=blue.x0 * (1.0 + 0.6 * j))
            runs.append(startup_run(params, seed=10 + 2 * i + j, velocity=velocity, points=300))
    return gf.velocity_collapse(runs)


def test_collapse_has_an_inset_of_the_short_slips(collapse):
    ax = plot_collapse(collapse)
    assert ax.get_xlabel() == "slip x [µm]" and ax.get_ylabel() == "friction force F [mN]"
    assert len(ax.get_lines()) == 2 * 6
    (inset,) = ax.child_axes
    peaks = [gf.peak(gf.Params(**dict(p))).slip for p in collapse.shared.run_params]
    assert inset.get_xlim()[1] == pytest.approx(1.5 * max(peaks) * 1e6)
    assert 1.2 * X_PEAK_UM < inset.get_xlim()[1] < 2.5 * X_PEAK_UM
    assert len(inset.get_lines()) == 2 * 6
    labels = _legend_texts(ax)
    assert labels[:3] == ["0.3 µm/s", "0.86 µm/s", "3 µm/s"]
    assert "collapse" in ax.get_legend().get_title().get_text()


def test_collapse_without_inset_and_bad_input(collapse):
    assert plot_collapse(collapse, inset=False).child_axes == []
    with pytest.raises(
        gf.InvalidParameterError, match=r"result must be a granflow\.CollapseResult"
    ):
        plot_collapse(collapse.shared)


@pytest.fixture(scope="module")
def amontons():
    constants = gf.MaterialConstants(mu_a=0.06, mu_d=0.2, alpha=4.2e4)
    runs = []
    for i, load in enumerate((0.03, 0.06, 0.09)):
        for repeat in range(3):
            params = constants.params_at(load, x0=(1.5 + repeat) * 1e-7)
            runs.append(startup_run(params, seed=40 + 3 * i + repeat, load=load, points=300))
    return gf.fit_amontons(runs)


def test_amontons_error_bars_and_lines_through_the_origin(amontons):
    axes = plot_amontons(amontons)
    assert [ax.get_ylabel() for ax in axes] == [
        "$a$ [mN]",
        r"$\alpha v$ [1/s]",
        r"$F_\mathrm{d}$ [mN]",
    ]
    assert all(ax.get_xlabel() == r"normal load $F_\mathrm{N}$ [mN]" for ax in axes)
    for ax, key, scale in zip(axes, ("a", "alpha_v", "Fd"), (1e3, 1.0, 1e3), strict=True):
        (container,) = [c for c in ax.containers if isinstance(c, ErrorbarContainer)]
        assert container.has_yerr
        (bars,) = container.lines[2]
        half_lengths = [abs(seg[1, 1] - seg[0, 1]) / 2 for seg in bars.get_segments()]
        expected = [row[key][1] * scale for row in amontons.per_load]
        np.testing.assert_allclose(half_lengths, expected, rtol=1e-9)
        assert any(isinstance(c, PolyCollection) for c in ax.collections)  # the ± band
    for ax, key in ((axes[0], "a"), (axes[2], "Fd")):
        line = ax.get_lines()[-1]
        x, y = line.get_xdata(), line.get_ydata()
        assert y[0] == 0.0 and x[0] == 0.0
        assert y[-1] / x[-1] == pytest.approx(amontons.lines[key][0], rel=1e-12)
    # the joint alpha times the one velocity, as a level
    level = axes[1].get_lines()[-1].get_ydata()
    assert level[0] == pytest.approx(amontons.joint.params["alpha"] * V, rel=1e-12)
    assert abs(level[0] - 4.2e4 * V) < 0.05 * 4.2e4 * V


def test_amontons_with_one_repeat_per_load_and_bad_axes(amontons):
    constants = gf.MaterialConstants(mu_a=0.06, mu_d=0.2, alpha=4.2e4)
    runs = [
        startup_run(constants.params_at(load, 2e-7), seed=7, load=load) for load in (0.03, 0.08)
    ]
    single = gf.fit_amontons(runs)
    axes = plot_amontons(single)
    assert len(axes) == 3 and axes[0].get_ylim()[1] > 0
    _, (first, second) = plt.subplots(1, 2)
    with pytest.raises(gf.InvalidParameterError, match="three Axes"):
        plot_amontons(amontons, axes=[first, second])
    with pytest.raises(gf.InvalidParameterError, match="AmontonsResult"):
        plot_amontons({"per_load": []})


# -- Fig. 3a ---------------------------------------------------------------------------------


def test_stress_ramp_with_the_rate_controlled_peak(ramp, blue):
    slip_ax, force_ax = plot_stress_ramp(ramp, blue)
    assert slip_ax.get_ylabel() == "slip δ [µm]"
    assert force_ax.get_ylabel() == "force F [mN]"
    assert slip_ax.get_xlabel() == "time t [s]"
    peak_line, failure_line = force_ax.get_lines()[1:3]
    assert peak_line.get_ydata()[0] == pytest.approx(F_PEAK_MN, rel=1e-9)
    # a linear ramp from zero reaches F_peak at F_peak / rate
    assert failure_line.get_xdata()[0] == pytest.approx(F_PEAK_MN * 1e-3 / RAMP_RATE, rel=1e-3)
    _, model = slip_ax.get_lines()
    assert np.nanmax(model.get_ydata()) == pytest.approx(X_PEAK_UM - blue.x0 * 1e6, rel=0.01)
    # the quasi-static slip is the simulated one before failure
    before = ramp.t < 270.0
    np.testing.assert_allclose(
        np.interp(ramp.t[before], model.get_xdata(), model.get_ydata()),
        ramp.slip[before] * 1e6,
        atol=0.1,
    )
    (inset,) = force_ax.child_axes
    # the inset magnifies the sub-µm creep long before the failure (the paper's inset)
    assert inset.get_ylim()[1] == pytest.approx(1.15, rel=1e-6)  # µm: up to 1 µm of slip
    reached = ramp.t[np.argmax(ramp.slip >= 1e-6)]
    assert inset.get_xlim()[1] == pytest.approx(reached)
    assert inset.get_xlim()[1] < 0.5 * failure_line.get_xdata()[0]
    assert r"$F_\mathrm{peak}$ = 13.8 mN" in " ".join(_legend_texts(slip_ax))


def test_stress_ramp_without_params_finds_the_runaway_for_the_inset(ramp):
    slip_ax, force_ax = plot_stress_ramp(ramp)
    assert len(force_ax.get_lines()) == 1 and len(slip_ax.get_lines()) == 1
    (inset,) = force_ax.child_axes
    assert inset.get_xlim()[1] == pytest.approx(ramp.t[np.argmax(ramp.slip >= 1e-6)])
    assert plot_stress_ramp(ramp, inset=False)[1].child_axes == []


def test_stress_ramp_without_a_slip_column(ramp, blue):
    no_slip = gf.Run(ramp.t, np.full(len(ramp), np.nan), ramp.velocity, ramp.force, "stress")
    slip_ax, force_ax = plot_stress_ramp(no_slip, blue)
    assert slip_ax.get_ylabel() == "slip δ [µm]"
    assert "no slip recorded" in [text.get_text() for text in force_ax.texts]
    assert len(force_ax.get_lines()) == 3  # imposed force, F_peak, predicted failure
    with pytest.raises(gf.InvalidParameterError, match=r"run must be a granflow\.Run"):
        plot_stress_ramp([ramp])
    with pytest.raises(gf.InvalidParameterError, match=r"params must be a granflow\.Params"):
        plot_stress_ramp(ramp, {"a": 1.0})


# -- Fig. 3b ---------------------------------------------------------------------------------


def test_creep_curves_with_fits_labelled_by_force(creep):
    runs, fits = creep
    ax = plot_creep(runs, fits)
    assert ax.get_xlabel() == "time t [s]" and ax.get_ylabel() == "creep slip δ [µm]"
    assert len(ax.get_lines()) == 4
    texts = _legend_texts(ax)
    assert texts[0].startswith("F = 9 mN") and texts[1].startswith("F = 12 mN")
    fit_line = ax.get_lines()[3]
    assert fit_line.get_ydata()[-1] == pytest.approx(0.25 * math.log1p(3590.0 / 10.0), rel=0.02)


def test_creep_without_fits_with_a_failed_fit_and_the_inset(creep, blue):
    runs, fits = creep
    assert len(plot_creep(runs).get_lines()) == 2
    failed = dataclasses.replace(fits[1], success=False)
    ax = plot_creep(runs, [fits[0], failed], params=blue, log_time=True)
    assert len(ax.get_lines()) == 3 and ax.get_xscale() == "log"
    (inset,) = ax.child_axes
    levels = sorted(line.get_ydata()[0] for line in inset.get_lines()[1:])
    assert levels == pytest.approx([9.0, 10.0, 12.0])  # the two creep forces and F_d [mN]
    assert "fit failed" in _legend_texts(ax)[1]


def test_creep_run_without_slip_and_bad_fits(creep, startup):
    runs, fits = creep
    blank = gf.Run(runs[0].t, np.full(len(runs[0]), np.nan), runs[0].velocity, runs[0].force)
    ax = plot_creep([blank, runs[1]], [None, fits[1]])
    assert "(no slip recorded)" in _legend_texts(ax)[0]
    with pytest.raises(gf.InvalidParameterError, match=r"fits\[0\] must be a CurveFitResult"):
        plot_creep(runs[0], [startup[1][0]])


# -- Fig. 3c ---------------------------------------------------------------------------------


def _switch_line(force_ax):
    (line,) = [line for line in force_ax.get_lines() if line.get_label().startswith("switch")]
    return line


def test_switch_after_the_peak_fails(switch_fails, blue):
    slip_ax, force_ax = plot_switch(switch_fails, blue)
    assert slip_ax.get_ylabel() == "slip δ [µm]" and force_ax.get_ylabel() == "force F [mN]"
    line = _switch_line(force_ax)
    assert line.get_xdata()[0] == pytest.approx(80.0)  # found from the velocity
    assert "model: fails" in line.get_label()
    model = [line for line in force_ax.get_lines() if line.get_label() == "rate control (model)"]
    (curve,) = model
    assert np.max(curve.get_ydata()) == pytest.approx(F_PEAK_MN, rel=1e-4)


def test_switch_before_the_peak_stops_where_the_friction_reaches_the_force(blue):
    protocol = gf.Protocol([gf.Velocity(V, 10.0), gf.SwitchToForce(30.0, factor=1.01)])
    run = gf.simulate(blue, protocol).to_run()
    slip_ax, force_ax = plot_switch(run, blue)
    assert "model: stops" in _switch_line(force_ax).get_label()
    (stop,) = [line for line in slip_ax.get_lines() if line.get_label() == "stop slip (model)"]
    at_switch = float(np.interp(10.0, run.t, run.slip))
    sigma = float(np.median(run.force[run.t > 10.0]))
    x_stop = brentq(lambda x: gf.friction_slip(x, blue) - sigma, at_switch, 20e-6)
    assert stop.get_ydata()[0] == pytest.approx(x_stop * 1e6, rel=1e-4)


def test_switch_time_from_argument_or_metadata(switch_fails):
    run = gf.Run(
        switch_fails.t,
        switch_fails.slip,
        np.full(len(switch_fails), np.nan),  # no velocity: the slip rate is used
        switch_fails.force,
        "stress",
    )
    # found from the slip rate over 2 % of the duration
    assert _switch_line(plot_switch(run)[1]).get_xdata()[0] == pytest.approx(80.0, abs=2.0)
    tagged = gf.Run(run.t, run.slip, run.velocity, run.force, "stress", {"switch_time": 79.0})
    assert _switch_line(plot_switch(tagged)[1]).get_xdata()[0] == 79.0
    assert _switch_line(plot_switch(tagged, switch_time=50)[1]).get_xdata()[0] == 50.0
    with pytest.raises(gf.InvalidParameterError, match="switch_time"):
        plot_switch(run, switch_time="late")


def test_switch_is_not_marked_on_a_run_that_stays_at_its_velocity(startup):
    slip_ax, force_ax = plot_switch(startup[0][0])
    labels = [line.get_label() for line in force_ax.get_lines()]
    assert labels == ["force"] and len(slip_ax.get_lines()) == 1


# -- saving and the package ------------------------------------------------------------------


def test_save_figure_writes_png_and_svg(tmp_path, switch_fails):
    axes = plot_switch(switch_fails)
    figure = axes[0].figure
    paths = save_figure(figure, tmp_path / "figures", "switch")
    assert set(paths) == {"png", "svg"}
    png, svg = paths["png"].read_bytes(), paths["svg"].read_bytes()
    assert png.startswith(b"\x89PNG") and len(png) > 10_000
    width, height = struct.unpack(">II", png[16:24])
    assert (width, height) == tuple(round(150 * s) for s in figure.get_size_inches())
    assert b"<svg" in svg[:1000] and len(svg) > 10_000
    umask = os.umask(0o022)
    os.umask(umask)
    assert paths["png"].stat().st_mode & 0o777 == 0o666 & ~umask
    again = save_figure(axes, tmp_path / "figures", "switch")  # the axes stand for the figure
    assert again["png"].read_bytes() == png  # no date, no layout drift between saves
    assert sorted(p.name for p in (tmp_path / "figures").iterdir()) == ["switch.png", "switch.svg"]
    assert plt.fignum_exists(figure.number)


@pytest.mark.parametrize(
    ("figure", "stem", "match"),
    [("figure", "ok", "figure must be"), (None, "a/b", "stem"), (None, "", "stem")],
)
def test_save_figure_rejects_bad_arguments(tmp_path, figure, stem, match):
    figure = plt.figure() if figure is None else figure
    with pytest.raises(gf.InvalidParameterError, match=match):
        save_figure(figure, tmp_path, stem)


def test_the_figures_are_exported_by_granflow_plotting():
    for name in ("plot_startup", "plot_stress_ramp", "plot_creep", "plot_switch", "save_figure"):
        assert name in plotting.__all__ and callable(getattr(plotting, name))
