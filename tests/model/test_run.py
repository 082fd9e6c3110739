"""granflow.Run: validation, read-only copies, tidy frames."""

import numpy as np
import pytest

import granflow


def test_run_copies_and_freezes_its_arrays():
    time = np.array([0.0, 1.0, 2.0])
    run = granflow.Run(t=time, slip=[0, 1e-6, 2e-6], velocity=[1e-6] * 3, force=[0.01] * 3)
    time[0] = 99.0
    assert run.t[0] == 0.0
    with pytest.raises(ValueError):
        run.force[0] = 1.0


def test_run_rejects_mismatched_lengths_and_unknown_control():
    with pytest.raises(granflow.InvalidDataError, match="slip"):
        granflow.Run(t=[0, 1], slip=[0], velocity=[0, 0], force=[0, 0])
    with pytest.raises(granflow.InvalidDataError, match="control"):
        granflow.Run(t=[0], slip=[0], velocity=[0], force=[0], control="torque")


def test_frame_round_trip_keeps_values_nan_and_metadata():
    run = granflow.Run(
        t=[0.0, 1.0],
        slip=[0.0, np.nan],
        velocity=[1e-6, 1e-6],
        force=[0.01, 0.02],
        control="stress",
        meta={"source": "a.csv", "interval": 2, "normal_load": 0.05},
    )
    frame = run.to_frame()
    assert list(frame["normal_load"]) == [0.05, 0.05]
    back = granflow.Run.from_frame(frame)
    np.testing.assert_array_equal(back.slip, run.slip)
    assert back.control == "stress" and back.meta["interval"] == 2
    assert back.name == "a.csv#2"


def test_run_pickles_for_process_pools():
    import pickle

    import numpy as np

    import granflow as gf

    run = gf.Run(
        t=[0.0, 1.0],
        slip=[0.0, 1e-6],
        velocity=[1e-6, 1e-6],
        force=[0.0, 1e-3],
        control="stress",
        meta={"source": "a.txt", "interval": 2, "normal_load": 0.05},
    )
    copy = pickle.loads(pickle.dumps(run))
    assert copy.control == "stress"
    assert dict(copy.meta) == dict(run.meta)
    for name in ("t", "slip", "velocity", "force"):
        assert np.array_equal(getattr(copy, name), getattr(run, name))
        assert not getattr(copy, name).flags.writeable
