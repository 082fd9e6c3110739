"""The failure forecast of a creeping layer (the direct effect): the closed-form slip against
granflow.simulate's ODE integration, the forecast on simulated records, bad input."""

import math

import numpy as np
import pytest

import granflow as gf
from granflow.errors import InvalidDataError
from granflow.forecast.creep import (
    History,
    creep_curve,
    creep_failure_time,
    creep_slip,
    ramp_history,
    steps_history,
    velocity_for_failure,
)
from granflow.forecast.synthetic import creep_ramp_record, creep_staircase_record
from granflow.model.friction import peak
from granflow.simulation import ForceRamp, ForceSteps, Protocol

PARAMS = gf.Params(a=3.3e-3, alpha=5e4, Fd=11e-3, x0=0.3e-6)
PEAK = peak(PARAMS)
AMPLITUDE, VELOCITY = 1e-4, 1e-7
EFFECT = gf.DirectEffect(amplitude=AMPLITUDE, velocity=VELOCITY)


def _simulated(protocol, points):
    result = gf.simulate(PARAMS, protocol, direct_effect=EFFECT, points=points, rtol=1e-11)
    assert result.failed
    return result


@pytest.mark.parametrize("amplitude", [2e-5, 1e-4])
def test_ramp_slip_and_failure_match_the_simulator(amplitude):
    rate = PEAK.force / 200.0
    effect = gf.DirectEffect(amplitude=amplitude, velocity=VELOCITY)
    protocol = Protocol([ForceRamp(rate=rate, duration=400.0, start=0.0)])
    result = gf.simulate(PARAMS, protocol, direct_effect=effect, points=4000, rtol=1e-11)
    curve = creep_curve(PARAMS, amplitude, PEAK.slip, PEAK.force)
    history = ramp_history(0.0, rate)
    x = creep_slip(result.t, curve, VELOCITY, history)
    below = result.displacement < 0.99 * (PEAK.slip - PARAMS.x0)
    # the simulator's slip (LSODA, rtol 1e-11) to a tenth of a nanometre over ~20 um
    assert np.max(np.abs(x - PARAMS.x0 - result.displacement)[below]) < 5e-10
    # the failure: the velocity passing 1 mm/s (the simulator's event) to 0.2 ms
    failure = creep_failure_time(curve, VELOCITY, history)
    assert failure == pytest.approx(result.failure.time, abs=2e-4)


def test_staircase_fails_inside_a_step_as_the_simulator_says():
    levels = PEAK.force * np.arange(1, 15) / 11.5
    protocol = Protocol([ForceSteps(levels=tuple(levels), step_duration=17.0)])
    result = _simulated(protocol, 400)
    curve = creep_curve(PARAMS, AMPLITUDE, PEAK.slip, PEAK.force)
    history = steps_history(17.0 * np.arange(1, levels.size), levels)
    x = creep_slip(result.t, curve, VELOCITY, history)
    below = result.displacement < 0.99 * (PEAK.slip - PARAMS.x0)
    assert np.max(np.abs(x - PARAMS.x0 - result.displacement)[below]) < 5e-10
    failure = creep_failure_time(curve, VELOCITY, history)
    assert failure == pytest.approx(result.failure.time, abs=2e-4)
    # inside a step (0.28 s into the one that passes F_peak), not at its start as in the
    # quasi-static model
    assert 0.1 < failure % 17.0 < 16.9
    # v_ref back from the failure time in closed form
    assert velocity_for_failure(curve, history, failure) == pytest.approx(VELOCITY, rel=1e-6)


def test_static_fatigue_below_the_peak():
    """A constant force below F_peak breaks a creeping layer after a delay."""
    level = PEAK.force - 3 * AMPLITUDE
    protocol = Protocol(
        [ForceRamp(rate=level / 5.0, duration=5.0, start=0.0), gf.Force(level, 5000.0)]
    )
    result = _simulated(protocol, 2000)
    curve = creep_curve(PARAMS, AMPLITUDE, PEAK.slip, PEAK.force)
    history = History(np.array([0.0, 5.0]), np.array([0.0, level]), np.array([level / 5.0, 0.0]))
    assert creep_failure_time(curve, VELOCITY, history) == pytest.approx(
        result.failure.time, rel=1e-4
    )


@pytest.mark.parametrize(("protocol", "seed"), [("ramp", 5), ("ramp", 6), ("steps", 5)], ids=str)
def test_forecast_covers_the_simulated_failure(protocol, seed):
    if protocol == "ramp":
        t, slip, force, truth = creep_ramp_record(
            PARAMS, PEAK.force / 200.0, EFFECT, noise=2e-9, force_noise=3e-5, seed=seed
        )
    else:
        t, slip, force, truth = creep_staircase_record(
            PARAMS, PEAK.force / 11.5, 17.0, EFFECT, noise=2e-9, force_noise=3e-5, seed=seed
        )
    ff = gf.forecast_failure(t, slip, force, until=0.75 * truth, direct_effect=True)
    assert ff.method == "model (creep)"
    assert ff.time_interval[0] <= truth <= ff.time_interval[1]
    assert ff.force_interval[0] <= PEAK.force <= ff.force_interval[1]
    assert ff.time_interval[1] - ff.time_interval[0] < 0.1 * truth
    assert ff.params["A"] == pytest.approx(AMPLITUDE, rel=0.5)


def test_fixed_amplitude_is_used():
    t, slip, force, truth = creep_ramp_record(
        PARAMS, PEAK.force / 200.0, EFFECT, noise=2e-9, force_noise=3e-5, seed=7
    )
    ff = gf.forecast_failure(
        t, slip, force, until=0.75 * truth, direct_effect=gf.DirectEffect(AMPLITUDE)
    )
    assert ff.params["A"] == AMPLITUDE
    assert ff.time_interval[0] <= truth <= ff.time_interval[1]


@pytest.mark.parametrize(
    ("value", "words"),
    [
        (gf.DirectEffect(1e-4, velocity=1e-7), "velocity"),
        (-1e-4, "positive"),
        (math.nan, "positive"),
        ("yes", "direct_effect must be"),
        (False, "direct_effect must be"),
    ],
)
def test_bad_direct_effect_is_named(value, words):
    t = np.arange(30.0)
    with pytest.raises(InvalidDataError, match=words):
        gf.forecast_failure(t, 1e-8 * t, 1e-4 * t, direct_effect=value)


def test_bad_record_is_rejected_with_creep():
    t = np.arange(30.0)
    slip = 1e-8 * t
    slip[3] = math.nan
    with pytest.raises(InvalidDataError, match="slip must be finite"):
        gf.forecast_failure(t, slip, 1e-4 * t, direct_effect=True)


def test_no_date_without_slip():
    t = np.arange(60.0)
    rng = np.random.default_rng(0)
    ff = gf.forecast_failure(t, 1e-9 * rng.standard_normal(t.size), 1e-4 * t, direct_effect=True)
    assert ff.time is None
    assert "no sign" in ff.message


def test_default_stays_quasi_static():
    from granflow.forecast.synthetic import ramp_record

    t, slip, force, truth = ramp_record(PARAMS, PEAK.force / 200.0, noise=2e-9, seed=1)
    default = gf.forecast_failure(t, slip, force, until=0.9 * truth)
    explicit = gf.forecast_failure(t, slip, force, until=0.9 * truth, direct_effect=None)
    assert default.method == "model"
    assert "A" not in default.params
    assert default.time == explicit.time
    assert default.time_interval == explicit.time_interval


def test_the_forecast_command_takes_the_direct_effect(tmp_path, capsys):
    """``granflow forecast FILE --direct-effect [A]``: a creeping ramp in a TRIOS export,
    forecast with A fitted and with A held; the printed date is the API's."""
    from granflow.cli import main
    from granflow.io.writer import write_trios

    t, slip, force, truth = creep_ramp_record(
        PARAMS, PEAK.force / 200.0, EFFECT, noise=2e-9, force_noise=3e-5, seed=7
    )
    run = gf.Run(t=t, slip=slip, velocity=np.gradient(slip, t), force=force, control="stress")
    path = tmp_path / "creeping_ramp.txt"
    write_trios(path, [run])
    (read,) = gf.read_runs(path)
    until = 0.75 * truth
    for flag, held in ((["--direct-effect"], True), (["--direct-effect", "0.1mN"], AMPLITUDE)):
        code = main(["forecast", str(path), "--until", f"{until:.6f}s", *flag])
        out = capsys.readouterr().out
        assert code == 0, out
        ff = gf.forecast_failure(read.t, read.slip, read.force, until=until, direct_effect=held)
        assert ff.method == "model (creep)" and ff.time_interval[0] <= truth <= ff.time_interval[1]
        assert f"{ff.time:.4g}" in out, out
    assert main(["forecast", str(path), "--direct-effect", "0.1"]) == 2  # no unit
    assert "--direct-effect" in capsys.readouterr().err
