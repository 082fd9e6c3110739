"""A creeping run that cannot go on: it ends with a result that says why, never with an
internal error from NumPy or SciPy."""

import numpy as np

import granflow as gf
from granflow.simulation import ForceSteps, Protocol

PARAMS = gf.Params(a=6e-3, alpha=5e4, Fd=6e-3, x0=3e-7)
STEPS = Protocol([ForceSteps(levels=(5e-3, 1e-2, 1.5e-2, 2e-2), step_duration=30.0)])


def test_a_run_aborted_before_its_first_sample_returns_where_it_stood():
    """A creep so stiff (A = 1 uN) that the first step exhausts the evaluation budget: the
    run ends aborted with the budget named, and its arrays hold the one point it stood at
    (before: NumPy's 'need at least one array to concatenate')."""
    effect = gf.DirectEffect(amplitude=1e-6, velocity=1e-6)
    result = gf.simulate(PARAMS, STEPS, direct_effect=effect, points=50, max_evaluations=20_000)
    assert not result.success and not result.failed
    assert "max_evaluations" in result.message and "segment 1" in result.message
    assert result.t.tolist() == [0.0]
    assert result.segments[0].outcome == "aborted"


def test_a_creep_velocity_past_float_range_aborts_with_its_reason(monkeypatch):
    """The calibration study's creeping staircase of seed 370726, first draw: a step far
    above the friction on A = 0.16 mN sends the creep velocity past float range and the
    integrated state to infinity, where no failure event can be read. The run ends aborted,
    saying so and when, and the study draws the record again (before: SciPy's 'All
    components of the initial state y0 must be finite' at the next segment, an error)."""
    import granflow.simulation as simulation
    from granflow.forecast.calibration import draw

    results = []
    simulate = simulation.simulate

    def recorded(*arguments, **options):
        results.append(simulate(*arguments, **options))
        return results[-1]

    monkeypatch.setattr(simulation, "simulate", recorded)
    case = draw(370726, "creep steps")
    first = results[0]
    assert not first.success and not first.failed
    assert "left float range near t = 410.2" in first.message
    assert np.all(np.isfinite(first.t)) and np.all(np.isfinite(first.slip))
    assert case.redraws == len(results) - 1 >= 1
    assert results[-1].failed and case.failure == results[-1].failure.time
