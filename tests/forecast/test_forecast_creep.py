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
    creep_slip,
    ramp_history,
    steps_history,
)
from granflow.forecast.creep_failure import creep_failure_time, velocity_for_failure
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


# a layer whose strength stands only 1.35 A above Fd: past the peak F never falls far enough
# for the run-away to be quick, so the force's own rise decides when it fails
WEAK = gf.Params(a=1.14066e-3, alpha=9.6007e4, Fd=9.85869e-3, x0=2.94739e-7)
WEAK_EFFECT = gf.DirectEffect(amplitude=2.15709e-4, velocity=3.22787e-7)


def _ode_failure(params, effect, pieces):
    """The first time the velocity dx/dt = 2 v_ref sinh(sigma(t)/A) exp(-F(x)/A) passes
    1 mm/s past the peak: SciPy's LSODA with an event, piece by piece of the force history
    (``(start, end, sigma(t))``, so that no step's jump is integrated across), F(x) from
    granflow's Eq. 3 along the slip (independent of the forecast's grid, quadrature and
    root search)."""
    from scipy.integrate import solve_ivp

    top = peak(params)
    y = [params.x0 * (1.0 + 1e-9)]
    for start, end, force_of in pieces:

        def rate(t, y, force_of=force_of):
            x = max(y[0], params.x0 * (1.0 + 1e-12))
            friction = float(gf.friction_slip(np.array([x]), params)[0])
            return [
                2.0
                * effect.velocity
                * math.sinh(force_of(t) / effect.amplitude)
                * math.exp(-friction / effect.amplitude)
            ]

        def passed(t, y, rate=rate):
            return rate(t, y)[0] - 1e-3 if y[0] > top.slip else -1.0

        passed.terminal, passed.direction = True, 1
        if passed(start, y) >= 0:
            return start
        found = solve_ivp(
            rate,
            (start, end),
            y,
            method="LSODA",
            rtol=1e-10,
            atol=1e-16,
            events=passed,
            max_step=(end - start) / 400.0,
        )
        if found.t_events[0].size:
            return float(found.t_events[0][0])
        y = [found.y[0, -1]]
    return math.inf


def test_a_weak_layer_fails_when_the_ode_says_and_not_at_the_grids_end():
    """The run-away of a layer 1.35 A above Fd lasts seconds (F falls as a / (alpha x)
    towards Fd past the peak): the failure is the first passage of the joint condition on
    force and slip. Holding the force at one value, as the forecast did, put it 2.8 s
    (1.8 %) early; the ODE says 153.874 s."""
    top = peak(WEAK)
    rate = top.force / 134.6767
    history = ramp_history(0.0, rate)
    curve = creep_curve(WEAK, WEAK_EFFECT.amplitude, top.slip, top.force)
    failure = creep_failure_time(curve, WEAK_EFFECT.velocity, history)
    expected = _ode_failure(WEAK, WEAK_EFFECT, [(0.0, 400.0, lambda t: rate * t)])
    assert failure == pytest.approx(expected, rel=1e-6)
    back = velocity_for_failure(curve, history, failure)
    assert back == pytest.approx(WEAK_EFFECT.velocity, rel=1e-6)


def test_a_weak_layer_on_a_staircase_fails_as_its_force_steps_up():
    """The same layer under steps of a tenth of F_peak, the tenth 0.1 A above it: it
    creeps past the peak there and on the next step, too slowly to fail, and fails as the
    twelfth begins (an ODE integrated step by step says so); where the force was held, it
    failed when the slip left the grid, two steps early."""
    top = peak(WEAK)
    levels = top.force * np.arange(1, 31) / 9.98
    curve = creep_curve(WEAK, WEAK_EFFECT.amplitude, top.slip, top.force)
    history = steps_history(11.0 * np.arange(1, levels.size), levels)
    failure = creep_failure_time(curve, WEAK_EFFECT.velocity, history)
    steps = [
        (11.0 * k, 11.0 * (k + 1), lambda t, level=level: level) for k, level in enumerate(levels)
    ]
    expected = _ode_failure(WEAK, WEAK_EFFECT, steps)
    assert failure == pytest.approx(expected, rel=1e-6)
    assert failure == pytest.approx(11.0 * 11, abs=1e-3)
