"""stability_map(): outcomes, agreement of the two methods, processes, exports."""

import json
import math

import numpy as np
import pytest
from scipy.optimize import brentq

import granflow as gf
from granflow.simulation.stability import map_row

V = 0.86e-6


@pytest.fixture(scope="module")
def blue():
    return gf.Params.from_time_domain(a=3.31e-3, k=0.036, t0=0.23, Fd=10e-3, velocity=V)


def test_small_map_matches_the_closed_form(blue):
    points = [5.0, 10.0, 80.0]
    ratios = [0.95, 1.01, 1.3]
    smap = gf.stability_map(blue, points, ratios, velocity=V)
    assert smap.outcome.tolist() == [
        ["stop", "stop", "failure"],
        ["stop", "stop", "failure"],
        ["stop", "failure", "failure"],
    ]
    top = gf.peak(blue)
    for i, point in enumerate(points):
        start = V * point  # the record clock: slip v t since the start of shear
        assert smap.switch_slip[i] == pytest.approx(start, rel=1e-14)
        force = gf.friction_slip(start, blue)
        assert smap.switch_force[i] == pytest.approx(force, rel=1e-12)
        for j, ratio in enumerate(ratios):
            sigma = ratio * force
            if smap.outcome[i, j] == "failure":
                assert math.isnan(smap.stop_slip[i, j])
                assert smap.failure_time[i, j] == 0.0  # quasi-statically, at once
                assert smap.failure_force[i, j] == pytest.approx(sigma, rel=1e-14)
            elif ratio <= 1:
                assert smap.stop_slip[i, j] == 0.0
            else:
                stop = brentq(lambda x, s=sigma: gf.friction_slip(x, blue) - s, start, top.slip)
                assert smap.stop_slip[i, j] == pytest.approx(stop - start, rel=1e-8)
    assert smap.failed.sum() == 4 and smap.stopped.sum() == 5


def test_processes_give_the_same_map_in_the_same_order(blue):
    points = np.linspace(4.0, 60.0, 7)
    ratios = np.linspace(0.98, 1.1, 5)
    serial = gf.stability_map(blue, points, ratios, velocity=V, jobs=1)
    parallel = gf.stability_map(blue, points, ratios, velocity=V, jobs=2)
    np.testing.assert_array_equal(serial.outcome, parallel.outcome)
    np.testing.assert_array_equal(serial.stop_slip, parallel.stop_slip)
    np.testing.assert_array_equal(serial.switch_force, parallel.switch_force)


def test_map_row_is_a_plain_function_of_picklable_arguments(blue):
    import pickle

    task = (blue.to_dict(), V, 10.0, [1.01, 1.5], 60.0, 0.0, {"method": "quasistatic"})
    switch_slip, _, cells = pickle.loads(pickle.dumps(map_row))(task)
    assert switch_slip == pytest.approx(10 * V, rel=1e-14)
    assert [cell[0] for cell in cells] == ["stop", "failure"]


@pytest.mark.slow
def test_quasistatic_and_slow_dynamic_maps_agree(blue):
    """20 x 20 cells: the dynamic method with the force ramped slowly compared with the
    inertial time agrees on fail/stop everywhere and on the stop slip to 1e-3."""
    points = np.linspace(2.0, 40.0, 20)
    ratios = np.linspace(1.005, 1.1, 20)
    common = {"velocity": V, "hold": 360.0, "ramp": 300.0, "jobs": 2}
    quasistatic = gf.stability_map(blue, points, ratios, **common)
    dynamic = gf.stability_map(blue, points, ratios, method="dynamic", **common)
    np.testing.assert_array_equal(quasistatic.outcome, dynamic.outcome)
    assert quasistatic.stopped.sum() > 50 and quasistatic.failed.sum() > 50
    stopped = quasistatic.stopped
    np.testing.assert_allclose(
        dynamic.stop_slip[stopped], quasistatic.stop_slip[stopped], rtol=1e-3
    )
    assert "dynamic" in dynamic.report() and "quasistatic" in quasistatic.report()


def test_exports_and_report(blue):
    smap = gf.stability_map(blue, [10.0, 80.0], [0.99, 1.01], velocity=V)
    frame = smap.to_frame()
    assert len(frame) == 4
    assert frame.loc[3, "outcome"] == "failure"
    assert frame.attrs["method"] == "quasistatic"
    data = json.loads(json.dumps(smap.to_dict()))
    assert data["outcome"] == [["stop", "stop"], ["stop", "failure"]]
    assert data["stop_slip"][1][1] is None
    report = smap.report()
    assert "method        = quasistatic" in report
    assert "ratio 1.01" in report
    assert "2 switch points x 2 ratios" in repr(smap)


def test_bad_arguments(blue):
    with pytest.raises(gf.InvalidParameterError, match="switch_points must be positive"):
        gf.stability_map(blue, [-1.0], [1.0], velocity=V)
    with pytest.raises(gf.InvalidParameterError, match="stress_ratios must be positive"):
        gf.stability_map(blue, [1.0], [0.0], velocity=V)
    with pytest.raises(gf.InvalidParameterError, match="must be finite"):
        gf.stability_map(blue, [math.nan], [1.0], velocity=V)
    with pytest.raises(gf.InvalidParameterError, match="jobs"):
        gf.stability_map(blue, [1.0], [1.0], velocity=V, jobs=0)
    with pytest.raises(gf.InvalidParameterError, match="ramp must not exceed"):
        gf.stability_map(blue, [1.0], [1.0], velocity=V, hold=1.0, ramp=2.0)
    with pytest.raises(gf.InvalidParameterError, match="dynamic"):
        gf.stability_map(blue, [1.0], [1.0], velocity=V, mass=1.0)
    with pytest.raises(gf.InvalidParameterError, match="empty"):
        gf.stability_map(blue, [], [1.0], velocity=V)


def test_any_executor_with_map_runs_the_rows(blue):
    class InOrder:
        def __init__(self):
            self.calls = 0

        def map(self, function, tasks):
            self.calls += 1
            return [function(task) for task in tasks]

    executor = InOrder()
    points, ratios = [5.0, 80.0], [0.95, 1.3]
    smap = gf.stability_map(blue, points, ratios, velocity=V, executor=executor)
    assert executor.calls == 1
    serial = gf.stability_map(blue, points, ratios, velocity=V)
    np.testing.assert_array_equal(smap.outcome, serial.outcome)
    np.testing.assert_array_equal(smap.stop_slip, serial.stop_slip)


def test_a_dask_scheduler_gives_the_same_map(blue):
    distributed = pytest.importorskip("distributed")
    points, ratios = [5.0, 10.0, 80.0], [0.95, 1.01]
    serial = gf.stability_map(blue, points, ratios, velocity=V)
    with distributed.Client(
        processes=False, n_workers=1, threads_per_worker=2, dashboard_address=None
    ) as client:
        smap = gf.stability_map(blue, points, ratios, velocity=V, scheduler=client)
        assert client.status == "running"  # the map leaves a client it was given open
    np.testing.assert_array_equal(smap.outcome, serial.outcome)
    np.testing.assert_array_equal(smap.stop_slip, serial.stop_slip)
    np.testing.assert_array_equal(smap.switch_force, serial.switch_force)
    assert "scheduler" not in smap.options


def test_executor_and_scheduler_exclude_each_other(blue):
    with pytest.raises(gf.InvalidParameterError, match="executor or scheduler"):
        gf.stability_map(
            blue, [1.0], [1.0], velocity=V, executor=object(), scheduler="tcp://localhost:1"
        )


def test_from_dict_inverts_to_dict_through_json(blue):
    direct = gf.DirectEffect(1e-4)
    built = gf.stability_map(
        blue, [5.0, 60.0], [0.9, 1.05], velocity=0.86e-6, jobs=1, direct_effect=direct
    )
    again = type(built).from_dict(json.loads(json.dumps(built.to_dict())))
    assert again.to_dict() == built.to_dict()
    for name in ("switch_points", "stress_ratios", "switch_slip", "switch_force"):
        np.testing.assert_array_equal(getattr(again, name), getattr(built, name))
    for name in ("stop_slip", "failure_time", "failure_force"):
        np.testing.assert_array_equal(getattr(again, name), getattr(built, name))  # NaN == NaN
    np.testing.assert_array_equal(again.outcome, built.outcome)
    np.testing.assert_array_equal(again.messages, built.messages)
    assert again.params == built.params
    assert again.options["direct_effect"] == direct
    assert (again.velocity, again.method, again.clock) == (0.86e-6, built.method, built.clock)


def test_a_switch_before_the_model_takes_over_names_t0():
    p = gf.Params.from_time_domain(a=3.31e-3, k=0.036, t0=0.23, Fd=10e-3, velocity=0.86e-6)
    with pytest.raises(gf.InvalidParameterError, match=r"t0 = x0 / velocity = 0\.23 s"):
        gf.stability_map(p, [0.1, 10.0], [1.01], velocity=0.86e-6)
