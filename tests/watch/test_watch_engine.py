"""The watch's engine in process: alarms raised and cleared in order, rows left out and
said, a held force, the log's JSON, the pooled record, the replay's clock."""

import json
import math

import numpy as np
import pytest

import granflow as gf
from granflow.errors import InvalidParameterError
from granflow.forecast.pooling import Pool
from granflow.forecast.synthetic import ramp_record
from granflow.io.follow import Rows
from granflow.watch.engine import LOG_FIELDS, Settings, Watch, held
from granflow.watch.outputs import Log, alarm_environment
from granflow.watch.server import parse_address
from granflow.watch.sources import Replay

PARAMS = gf.Params(a=3.3e-3, alpha=5e4, Fd=11e-3, x0=0.3e-6)


def _rows(t, slip, force, interval=1):
    return Rows("test.txt", interval, "ramp", "stress", t, slip, np.zeros(np.size(t)), force)


def test_the_alarm_is_raised_before_the_failure_and_each_record_is_whole():
    t, slip, force, failure = ramp_record(PARAMS, rate=0.065e-3, noise=2e-9, seed=1, dt=1.0)
    log, raised = [], []
    watch = Watch(Settings(horizon=30.0, alarm=0.5), log.append, on_alarm=raised.append)
    for start in range(0, t.size, 10):
        part = slice(start, start + 10)
        watch.take([_rows(t[part], slip[part], force[part])])
        watch.forecast()
    events = [entry["event"] for entry in log]
    assert "alarm" in events
    last_alarm = max(i for i, e in enumerate(events) if e == "alarm")
    assert log[last_alarm]["t"] < failure
    assert raised and raised[-1] == log[last_alarm]
    alarm_on = [entry["alarm"] for entry in log if entry["event"] == "forecast"]
    assert alarm_on[-1]  # on as the failure comes
    for entry in log:
        assert set(LOG_FIELDS) <= set(entry)
        json.dumps(entry, allow_nan=False)  # nulls, never NaN or inf


def test_an_alarm_clears_when_the_probability_falls_back():
    log = []
    watch = Watch(Settings(horizon=60.0, alarm=0.5), log.append)
    stream = None
    t, slip, force, _ = ramp_record(PARAMS, rate=0.065e-3, noise=2e-9, seed=1, dt=1.0)
    watch.take([_rows(t[:150], slip[:150], force[:150])])
    watch.forecast()
    stream = watch.current
    stream.probability = 0.9
    watch._after(stream)
    stream.probability = 0.1
    watch._after(stream)
    assert [e["event"] for e in log[-4:]] == ["forecast", "alarm", "forecast", "clear"]
    assert log[-1]["alarm"] is False and log[-3]["alarm"] is True


def test_a_confirmed_alarm_waits_for_the_probability_to_hold():
    """With ``confirm=10`` s the alarm is raised at the first forecast 10 s of record after
    the probability first reached the threshold, never on a forecast that reached it once,
    and a fall below starts the wait again."""
    log = []
    watch = Watch(Settings(horizon=60.0, alarm=0.5, confirm=10.0), log.append)
    t, slip, force, _ = ramp_record(PARAMS, rate=0.065e-3, noise=2e-9, seed=1, dt=1.0)
    watch.take([_rows(t[:150], slip[:150], force[:150])])
    watch.forecast()
    stream = watch.current
    assert stream.bounded()
    events = []
    for when, probability in [
        (150, 0.9),  # reached: the wait begins
        (155, 0.1),  # fell back: no alarm, the wait ends
        (160, 0.9),
        (165, 0.95),
        (170, 0.9),  # 10 s at or above: raised
        (175, 0.2),  # cleared
        (180, 0.9),
        (185, 0.9),
    ]:
        stream.t, stream.probability = float(when), probability
        before = len(log)
        watch._after(stream)
        events += [(when, e["event"]) for e in log[before:] if e["event"] != "forecast"]
    assert events == [(170, "alarm"), (175, "clear")]
    with pytest.raises(InvalidParameterError, match="confirm must be zero or positive"):
        Settings(confirm=-1.0)


def test_rows_out_of_order_or_without_force_are_left_out_and_said():
    log = []
    watch = Watch(Settings(), log.append)
    t = np.arange(20.0)
    force = 1e-4 * t
    force[5] = np.nan
    watch.take([_rows(t, 1e-9 * t, force)])
    watch.take([_rows(np.array([3.0, 20.0]), np.zeros(2), np.ones(2) * 1e-3)])
    said = [entry["message"] for entry in log if entry["event"] == "left out"]
    assert said == [
        "1 rows left out of the forecast (1 without a usable time or force)",
        "1 rows left out of the forecast (1 not after the last time)",
    ]
    assert watch.current.rows == 20


def test_a_ramp_that_stops_rising_is_held():
    t = np.arange(0.0, 400.0)
    ramp = 1e-5 * t
    rng = np.random.default_rng(0)
    noise = 1e-7 * rng.standard_normal(t.size)
    assert not held(t, ramp + noise)
    assert held(t, np.minimum(ramp, 3e-3) + noise)
    assert not held(t[:20], ramp[:20])  # too short to tell


def test_settings_and_addresses_name_the_culprit():
    with pytest.raises(InvalidParameterError, match="horizon must be positive"):
        Settings(horizon=0.0)
    with pytest.raises(InvalidParameterError, match="alarm must be a probability"):
        Settings(alarm=1.5)
    with pytest.raises(InvalidParameterError, match="test must be one of"):
        Settings(test="shear")
    assert parse_address("8765") == ("127.0.0.1", 8765)
    assert parse_address("0.0.0.0:0") == ("0.0.0.0", 0)
    with pytest.raises(InvalidParameterError, match="0 to 65535"):
        parse_address("70000")


def test_the_log_appends_whole_json_lines(tmp_path):
    path = tmp_path / "w.jsonl"
    for _ in range(2):
        log = Log(path)
        log.write({"event": "forecast", "t": 1.0, "force_interval": [0.01, None]})
        log.close()
    lines = path.read_text().splitlines()
    assert len(lines) == 2 and all(json.loads(line)["force_interval"][1] is None for line in lines)
    environment = alarm_environment(
        {
            "event": "alarm",
            "t": 2.5,
            "probability_within_horizon": 0.75,
            "time_interval": [3.0, None],
            "force_interval": [0.01, 0.02],
        }
    )
    assert environment["GRANFLOW_PROBABILITY"] == "0.75"
    assert environment["GRANFLOW_TIME_HIGH"] == ""


def test_the_pool_keeps_equal_runs_of_samples():
    pool = Pool(["t"], max_points=16)
    samples = np.arange(1000.0)
    for start in range(0, 1000, 37):
        pool.add({"t": samples[start : start + 37]})
    column = pool.column("t")
    width = pool.width
    whole = (1000 // width) * width
    np.testing.assert_allclose(column[: whole // width], samples[:whole].reshape(-1, width).mean(1))
    assert column[-1] == pytest.approx(samples[whole:].mean())
    assert 8 <= pool.size - 1 <= 16 and pool.samples == 1000


def test_a_pooled_running_forecast_is_the_one_shot_forecast_of_its_record():
    t, slip, force, _ = ramp_record(PARAMS, rate=0.065e-3, noise=2e-9, seed=2, dt=0.25)
    cut = int(0.85 * t.size)
    running = gf.RunningForecast(max_points=128, warm_start=False)
    for start in range(0, cut, 100):
        part = slice(start, min(start + 100, cut))
        forecast = running.update(t[part], slip[part], force[part])
    assert running.t.size <= 129
    one = gf.forecast_failure(running.t, running.slip, running.force)
    assert forecast.time == pytest.approx(one.time, rel=1e-6)
    assert forecast.time_interval == pytest.approx(one.time_interval, rel=1e-6)


def test_a_replay_gives_the_rows_as_their_time_comes(tmp_path):
    from granflow.io import write_rheocompass

    run = gf.Run(
        t=np.arange(0.0, 50.0),
        slip=np.zeros(50),
        velocity=np.zeros(50),
        force=np.linspace(0, 1e-3, 50),
        control="stress",
    )
    path = write_rheocompass(tmp_path / "r.txt", [run, run])
    now = [0.0]
    replay = Replay(path, speed=10.0, now=lambda: now[0])
    got = []
    while not replay.finished:
        for event in replay.poll():
            if isinstance(event, Rows):
                got.append((event.interval, event.t[0], event.t[-1]))
        now[0] += 0.5
    assert [g[0] for g in got][:1] == [1] and got[-1][0] == 2
    assert got[0] == (1, 0.0, 0.0) and got[1] == (1, 1.0, 5.0)  # 5 s of record a step
    assert math.isclose(sum(g[2] - g[1] + 1 for g in got), 100)


def test_the_prior_from_a_campaign_is_taken_at_the_record_s_load(tmp_path):
    from granflow.forecast.prior import Prior
    from granflow.watch.prior import MaterialPrior, prior_for, read_prior

    results = tmp_path / "results.json"
    material = {
        name: {"value": value, "stderr": 0.01 * value}
        for name, value in (("mu_a", 0.06), ("mu_d", 0.2), ("alpha", 5e4))
    }
    results.write_text(json.dumps({"material": {**material, "source": "amontons joint fit"}}))
    prior = read_prior(results)
    assert isinstance(prior, MaterialPrior)
    at_load, why = prior_for(prior, {"normal_load": 0.05})
    assert why is None and at_load.a == pytest.approx((0.003, 3e-5))
    assert prior_for(prior, {})[1].startswith("no prior")
    mapping = tmp_path / "prior.json"
    mapping.write_text(json.dumps({"Fd": [0.011, 0.0002]}))
    assert isinstance(read_prior(mapping), Prior)
    mapping.write_text(json.dumps({"material": {"source": None, "reason": "no start-ups"}}))
    with pytest.raises(InvalidParameterError, match="no start-ups"):
        read_prior(mapping)


def test_a_start_up_gets_the_peak_forecast_and_no_alarm():
    from granflow.model.friction import friction_time

    velocity = 0.86e-6
    params = gf.Params.from_time_domain(a=3.31e-3, k=0.036, t0=0.23, Fd=10e-3, velocity=velocity)
    t = np.arange(1.0, 20.0, 0.25)
    force = friction_time(t, params, velocity)
    force = force + 2e-5 * np.random.default_rng(0).standard_normal(t.size)
    log = []
    watch = Watch(Settings(), log.append)
    rows = Rows("s.txt", 1, "start-up", "rate", t, velocity * t, np.full(t.size, velocity), force)
    watch.take([rows])
    watch.forecast()
    forecasts = [entry for entry in log if entry["event"] == "forecast"]
    assert forecasts and forecasts[-1]["kind"] == "peak"
    assert "time_interval" not in forecasts[-1]  # the contract: absent for a peak
    assert forecasts[-1]["peak_force"] is not None and not forecasts[-1]["alarm"]
