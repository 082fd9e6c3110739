"""Run.problems travels with the run through selection, pickling and frames."""

import pickle

import numpy as np
import pytest

from granflow import InvalidDataError, Run


def _run(problems=()):
    t = np.arange(5.0)
    return Run(t, t * 1e-6, np.full(5, 1e-6), t * 1e-3, problems=problems)


def test_a_clean_run_has_no_problems():
    assert _run().problems == ()


def test_problems_survive_select_pickle_and_frames():
    run = _run(["3 non-finite force cells dropped"])
    assert run.problems == ("3 non-finite force cells dropped",)
    assert run.select(run.t > 1).problems == run.problems
    assert pickle.loads(pickle.dumps(run)).problems == run.problems
    assert Run.from_frame(run.to_frame()).problems == run.problems


@pytest.mark.parametrize("bad", [[""], [3], 7])
def test_problems_must_be_sentences(bad):
    with pytest.raises(InvalidDataError, match="problems"):
        _run(bad)


def test_shifted_moves_the_clock_and_remembers_it():
    run = _run(["gap"]).shifted(time="2 s", slip=1e-6).shifted(time=1.0)
    assert np.array_equal(run.t, np.arange(5.0) - 3.0)
    assert np.allclose(run.slip, np.arange(5.0) * 1e-6 - 1e-6, rtol=0, atol=1e-20)
    assert run.meta["time_shift"] == 3.0
    assert run.meta["slip_shift"] == 1e-6
    assert run.problems == ("gap",)


def test_shifted_refuses_a_wrong_unit():
    from granflow import InvalidParameterError

    with pytest.raises(InvalidParameterError, match="time"):
        _run().shifted(time="2 mm")
