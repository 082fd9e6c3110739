"""forecast_peak on start-ups cut before their peak; the truth from gf.peak (brentq on the
nullcline, tested against 40-digit values in tests/model)."""

import numpy as np
import pytest

import granflow as gf
from granflow.errors import InvalidDataError
from granflow.forecast import Prior

PARAMS = gf.Params(a=3.3e-3, alpha=5.0e4, Fd=11.0e-3, x0=0.3e-6)
VELOCITY = 0.86e-6
NOISE = 3e-5


def startup(seed, fraction=0.7, params=PARAMS):
    pk = gf.peak(params, velocity=VELOCITY)
    t = np.arange(1.0, fraction * pk.time, 0.25)
    rng = np.random.default_rng(seed)
    return t, gf.friction_time(t, params, VELOCITY) + NOISE * rng.standard_normal(t.size)


def test_a_start_up_cut_at_70_percent_brackets_its_peak_in_most_seeds():
    pk = gf.peak(PARAMS, velocity=VELOCITY)
    covered = 0
    for seed in range(10):
        fc = gf.forecast_peak(startup(seed), velocity=VELOCITY, until=0.7 * pk.time)
        covered += fc.force_interval[0] <= pk.force <= fc.force_interval[1]
        assert abs(fc.force - pk.force) < 0.02 * pk.force
        assert abs(fc.time - pk.time) < 0.3 * pk.time
    assert covered >= 8


def test_the_campaign_prior_narrows_the_peak_interval():
    """Material constants at the precision of an Amontons fit over a campaign (mu_a +- 0.5 %,
    mu_d +- 0.1 %, alpha +- 0.2 %; their values drawn about the truth by those errors) halve
    the 90 % interval of a cut at 70 % at least, and it still holds the truth; a previous
    run's Fd alone narrows it less (x0, a and alpha stay free)."""
    pk = gf.peak(PARAMS, velocity=VELOCITY)
    rng = np.random.default_rng(11)
    stderr = (3.1e-4, 2.2e-4, 83.0)
    drawn = [
        (m + s * rng.standard_normal(), s) for m, s in zip((0.06, 0.2, 5e4), stderr, strict=True)
    ]
    prior = Prior.from_material(*drawn, normal_load=0.055)
    t, force = startup(1)
    alone = gf.forecast_peak((t, force), velocity=VELOCITY)
    helped = gf.forecast_peak((t, force), velocity=VELOCITY, prior=prior)
    width = helped.force_interval[1] - helped.force_interval[0]
    assert 2.0 * width <= alone.force_interval[1] - alone.force_interval[0]
    assert helped.force_interval[0] <= pk.force <= helped.force_interval[1]
    assert helped.prior == prior.to_dict()
    only_fd = gf.forecast_peak((t, force), velocity=VELOCITY, prior=Prior(Fd=(11e-3, 1e-5)))
    assert width < only_fd.force_interval[1] - only_fd.force_interval[0]


def test_a_run_gives_its_velocity():
    t, force = startup(2)
    run = gf.Run(
        t=t,
        slip=VELOCITY * t,
        velocity=np.full(t.size, VELOCITY),
        force=force,
        meta={"velocity": VELOCITY},
    )
    fc = gf.forecast_peak(run)
    assert fc.velocity == VELOCITY
    back = gf.PeakForecast.from_dict(fc.to_dict())
    assert back.force_interval == fc.force_interval and back.params == fc.params
    assert "Peak forecast" in fc.report()


def test_bad_input_gets_a_clear_error():
    t, force = startup(3)
    with pytest.raises(InvalidDataError, match="velocity"):
        gf.forecast_peak((t, force))
    with pytest.raises(InvalidDataError, match="too short"):
        gf.forecast_peak((t[:5], force[:5]), velocity=VELOCITY)
    with pytest.raises(InvalidDataError, match="force must be finite"):
        gf.forecast_peak((t, np.where(t > 3, np.inf, force)), velocity=VELOCITY)
