"""A fit says how many points it left out, and why."""

import json

import numpy as np
import pytest

import granflow
from granflow.fitting.curves import prepare

PARAMS = granflow.Params(3e-3, 4e4, 1e-2, 2e-7)


def _run():
    x = np.linspace(0.0, 5e-4, 300)
    force = granflow.friction_slip(np.maximum(x, PARAMS.x0), PARAMS)
    force[[5, 17]] = np.nan
    force[40] = np.inf
    return granflow.Run(t=x / 1e-6, slip=x, velocity=np.full(x.size, 1e-6), force=force)


def test_prepare_counts_the_points_left_out_by_reason():
    run = _run()
    weights = np.ones(300)
    weights[[100, 101]] = 0.0  # after the three non-finite rows are gone
    data = prepare(run, "slip", None, (1e-5, 4e-4), weights[:297], None)
    x = run.slip[np.isfinite(run.force)]
    outside = int(np.count_nonzero((x > 0) & ((x < 1e-5) | (x > 4e-4))))
    assert data.dropped == {
        "non_finite": 3,
        "not_positive": 1,
        "outside_window": outside,
        "zero_weight": 2,
    }
    assert data.z.size == 300 - 3 - 1 - outside - 2


def test_the_fit_reports_and_round_trips_what_it_dropped():
    result = granflow.fit(_run())
    assert dict(result.dropped) == {"non_finite": 3, "not_positive": 1}
    assert result.ndata == 296
    assert "dropped            = 3 non finite, 1 not positive" in result.report()
    again = granflow.FitResult.from_dict(json.loads(json.dumps(result.to_dict())))
    assert again == result and dict(again.dropped) == dict(result.dropped)
    clean = granflow.fit((result.x, result.data))
    assert dict(clean.dropped) == {} and "dropped" not in clean.report()


def test_arrays_with_a_nan_are_still_refused():
    x = np.linspace(1e-6, 5e-4, 50)
    force = granflow.friction_slip(x, PARAMS)
    force[3] = np.nan
    with pytest.raises(granflow.InvalidDataError, match="force must be finite"):
        granflow.fit((x, force))
