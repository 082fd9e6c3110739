"""``granflow watch`` against a real writer: one process appends an export in real time
(accelerated) while ``granflow watch`` follows it in another; the tests read the watch's log
and assert on the order of events, never on how long anything took."""

import base64
import json
import os
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from live_writer import export_steps, write_plan

import granflow as gf
from granflow.forecast.branch import branch_slip
from granflow.io import write_rheocompass
from granflow.model.friction import peak

HERE = Path(__file__).resolve().parent
SOURCE = Path(gf.__file__).resolve().parents[1]
PARAMS = gf.Params(a=3.3e-3, alpha=5e4, Fd=11e-3, x0=0.3e-6)
#: Long enough for any step of a test on a loaded machine; the tests end on events.
LIMIT = 300


def environment():
    """This checkout's granflow first on the path of the processes the tests start."""
    path = os.environ.get("PYTHONPATH")
    return {**os.environ, "PYTHONPATH": str(SOURCE) + (os.pathsep + path if path else "")}


def watch(*args):
    """Start ``granflow watch`` with the arguments."""
    return subprocess.Popen(
        [sys.executable, "-m", "granflow", "watch", *map(str, args)],
        env=environment(),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


def writer(plan):
    return subprocess.Popen(
        [sys.executable, str(HERE / "live_writer.py"), str(plan)], env=environment()
    )


def finish(*processes):
    """Wait for the processes; the watch's output for the failure message."""
    outputs = []
    for process in processes:
        try:
            out, err = process.communicate(timeout=LIMIT)
        except subprocess.TimeoutExpired:
            process.kill()
            out, err = process.communicate()
        outputs.append((process.returncode, out, err))
    return outputs


def read_log(path):
    return [json.loads(line) for line in Path(path).read_text().splitlines()]


def record(path, held_at=None, tail=12, dt=0.5, duration=150.0, noise=3e-9, seed=3):
    """A force ramp to failure (its slip running away after it), or ramped to ``held_at``
    F_peak and held; written as a RheoCompass export (UTF-16 with its BOM). Returns the time
    of the first row after the failure (None if it never fails)."""
    rng = np.random.default_rng(seed)
    top = peak(PARAMS)
    rate = top.force / duration
    if held_at is None:
        t = np.arange(0.0, duration, dt)
        force = rate * t
    else:
        t = np.arange(0.0, 1.3 * duration, dt)
        force = np.minimum(rate * t, held_at * top.force)
    slip = branch_slip(force, PARAMS, PARAMS.alpha * top.slip) - PARAMS.x0
    failing = None
    if held_at is None:
        after = t[-1] + dt * np.arange(1, tail + 1)
        runaway = slip[-1] + 1e-4 * np.arange(1, tail + 1)  # flowing
        failing = float(after[0])
        t, slip, force = np.r_[t, after], np.r_[slip, runaway], np.r_[force, rate * after]
    slip = slip + noise * rng.standard_normal(t.size)
    run = gf.Run(
        t=t,
        slip=slip,
        velocity=np.gradient(slip, t),
        force=force + 2e-6 * rng.standard_normal(t.size),
        control="stress",
        meta={"normal_load": 0.05},
    )
    write_rheocompass(path, run, test="stress ramp", encoding="utf-16")
    return failing


def test_the_alarm_precedes_the_failing_row(tmp_path):
    export, live, log = tmp_path / "ramp.txt", tmp_path / "live.txt", tmp_path / "watch.jsonl"
    failing = record(export)
    # written at 8 times real time: a forecast per batch keeps up even on a busy machine (at
    # 15 times a loaded runner fell behind and read the failing rows in one batch)
    steps, _, _ = export_steps(export, live, speed=8.0, split_every=7)
    write_plan(tmp_path / "plan.json", steps, log)
    follower = watch(live, "--log", log, "--horizon", "30s", "--until-end", "--stall", "3s")
    source = writer(tmp_path / "plan.json")
    (_, _, _), (code, out, err) = finish(source, follower)
    assert code == 0, err
    entries = read_log(log)
    events = [entry["event"] for entry in entries]
    assert events[0] == "start" and events[-1] == "end"
    alarms = [i for i, entry in enumerate(entries) if entry["event"] == "alarm"]
    failures = [i for i, entry in enumerate(entries) if entry["event"] == "failure"]
    assert alarms and failures, events
    assert alarms[0] < failures[0]
    assert entries[alarms[0]]["t"] < failing  # the alarm came from rows before the failing one
    assert entries[alarms[0]]["probability_within_horizon"] >= 0.5
    forecasts = [entry for entry in entries if entry["event"] == "forecast"]
    assert all(entry["kind"] == "failure" for entry in forecasts)
    times = [entry["t"] for entry in forecasts]
    assert times == sorted(times) and len(forecasts) > 5  # followed, not read at the end
    for entry in forecasts:
        for field in ("t", "kind", "force_interval", "time_interval", "alarm"):
            assert field in entry
        assert 0.0 <= entry["probability_within_horizon"] <= 1.0
    assert "[alarm]" in out


def test_a_record_held_below_the_peak_raises_no_alarm(tmp_path):
    export, live, log = tmp_path / "held.txt", tmp_path / "live.txt", tmp_path / "watch.jsonl"
    assert record(export, held_at=0.6, dt=1.0, duration=300.0) is None
    steps, times, _ = export_steps(export, live, speed=30.0)
    write_plan(tmp_path / "plan.json", steps, log)
    follower = watch(live, "--log", log, "--horizon", "30s", "--until-end", "--stall", "3s")
    source = writer(tmp_path / "plan.json")
    (_, _, _), (code, _, err) = finish(source, follower)
    assert code == 0, err
    entries = read_log(log)
    forecasts = [entry for entry in entries if entry["event"] == "forecast"]
    assert forecasts and forecasts[-1]["t"] == times[-1]
    assert not [entry for entry in entries if entry["event"] == "alarm"]
    assert not any(entry["alarm"] for entry in entries)
    assert forecasts[-1]["held"] and forecasts[-1]["probability_within_horizon"] == 0.0


def test_a_file_truncated_damaged_and_given_a_new_interval(tmp_path):
    """The file's own events, each said in the log in the order they happened."""
    first, second, third = tmp_path / "a.txt", tmp_path / "b.txt", tmp_path / "c.txt"
    record(first, duration=60.0, dt=1.0)
    record(second, held_at=0.5, duration=60.0, dt=1.0, seed=4)
    record(third, held_at=0.5, duration=40.0, dt=1.0, seed=6)
    # written again: a file of two intervals (the second begins in the same file)
    runs = [gf.read_runs(second)[0], gf.read_runs(third)[0]]
    write_rheocompass(second, runs, test="stress ramp", encoding="utf-16")
    live, log = tmp_path / "live.txt", tmp_path / "watch.jsonl"
    steps, _, _ = export_steps(first, live, speed=40.0, split_every=5, trailer=False)
    end = steps[-1][0]
    # a damaged row (its speed 'abc'), then the file truncated and written again
    damaged = "\t999\t999.5\tabc\t1.0\t2.0\tDy_auto\r\n".encode("utf-16-le")
    steps.append([end + 0.6, "append", str(live), base64.b64encode(damaged).decode()])
    seen = base64.b64encode(b'"event":"damaged"').decode()
    steps.append([end + 0.7, "wait", str(log), seen])  # the watch has read it
    steps.append([end + 2.0, "truncate", str(live), ""])
    again, _, _ = export_steps(second, live, speed=40.0, offset=end + 2.5)
    steps += again
    write_plan(tmp_path / "plan.json", steps, log)
    follower = watch(live, "--log", log, "--until-end", "--stall", "3s")
    source = writer(tmp_path / "plan.json")
    finish(source, follower)
    entries = read_log(log)
    events = [entry["event"] for entry in entries]
    assert "damaged" in events and "truncated" in events, events
    assert events.index("damaged") < events.index("truncated")
    assert "invalid" in entries[events.index("damaged")]["message"]
    after = entries[events.index("truncated") :]
    begun = [entry["interval"] for entry in after if entry["event"] == "interval"]
    assert begun == [1, 2]  # the file read again, then its second interval
    forecast_intervals = [entry["interval"] for entry in after if entry["event"] == "forecast"]
    assert forecast_intervals[0] == 1 and forecast_intervals[-1] == 2
    assert forecast_intervals == sorted(forecast_intervals)


def test_a_folder_in_which_exports_appear(tmp_path):
    folder, log = tmp_path / "exports", tmp_path / "watch.jsonl"
    folder.mkdir()
    first, second = tmp_path / "a.txt", tmp_path / "b.txt"
    record(first, duration=60.0, dt=1.0)
    record(second, duration=60.0, dt=1.0, seed=5)
    steps, _, _ = export_steps(first, folder / "run1.txt", speed=40.0)
    more, _, _ = export_steps(second, folder / "run2.txt", speed=40.0, offset=steps[-1][0] + 1)
    write_plan(tmp_path / "plan.json", steps + more, log)
    follower = watch(folder, "--log", log, "--until-end", "--stall", "3s")
    source = writer(tmp_path / "plan.json")
    (_, _, _), (code, _, err) = finish(source, follower)
    assert code == 0, err
    entries = read_log(log)
    forecast_sources = [Path(e["source"]).name for e in entries if e["event"] == "forecast"]
    assert "run1.txt" in forecast_sources and "run2.txt" in forecast_sources
    assert forecast_sources.index("run1.txt") < forecast_sources.index("run2.txt")
    opened = [Path(e["source"]).name for e in entries if e["event"] == "opened"]
    assert opened == ["run1.txt", "run2.txt"]


def test_ctrl_c_stops_the_watch_and_leaves_the_log_whole(tmp_path):
    export, live, log = tmp_path / "ramp.txt", tmp_path / "live.txt", tmp_path / "watch.jsonl"
    record(export, duration=150.0, dt=0.5)
    steps, _, _ = export_steps(export, live, speed=2.0)  # slow: still writing at the stop
    write_plan(tmp_path / "plan.json", steps, log)
    follower = watch(live, "--log", log)
    source = writer(tmp_path / "plan.json")
    try:
        while True:  # until the first forecast is in the log
            if follower.poll() is not None:
                pytest.fail(f"the watch ended early: {follower.communicate()}")
            lines = log.read_text().splitlines() if log.exists() else []
            if any('"event":"forecast"' in line for line in lines):
                break
        follower.send_signal(signal.SIGINT)
        ((code, _, err),) = finish(follower)
    finally:
        source.kill()
        source.wait()
    assert code == 0, err
    text = log.read_text()
    assert text.endswith("\n")
    entries = read_log(log)  # every line is whole JSON
    assert entries[-1]["event"] == "stopped"


def test_on_alarm_runs_the_command_with_the_forecast(tmp_path):
    export, log, out = tmp_path / "ramp.txt", tmp_path / "watch.jsonl", tmp_path / "alarm.txt"
    record(export)
    command = f"env | grep ^GRANFLOW_ > {out}"
    follower = watch(
        "--replay",
        export,
        "--speed",
        "40",
        "--log",
        log,
        "--horizon",
        "30s",
        "--until-end",
        "--on-alarm",
        command,
    )
    ((code, _, err),) = finish(follower)
    assert code == 0, err
    events = [entry["event"] for entry in read_log(log)]
    assert "alarm" in events and "on-alarm" in events
    assert events.index("alarm") < events.index("on-alarm")
    values = dict(line.split("=", 1) for line in out.read_text().splitlines() if "=" in line)
    assert float(values["GRANFLOW_PROBABILITY"]) >= 0.5
    assert values["GRANFLOW_EVENT"] == "alarm"
    assert json.loads(values["GRANFLOW_FORECAST"])["event"] == "alarm"


def test_bad_arguments_name_the_culprit(tmp_path, capsys):
    from granflow.cli import main

    assert (
        main(
            [
                "watch",
                str(tmp_path / "x.txt"),
                "--log",
                str(tmp_path / "l.jsonl"),
                "--horizon",
                "60",
            ]
        )
        == 2
    )
    assert "--horizon needs a unit" in capsys.readouterr().err
    log = str(tmp_path / "l.jsonl")
    assert main(["watch", str(tmp_path / "x.txt"), "--log", log, "--confirm", "10"]) == 2
    assert "--confirm needs a unit" in capsys.readouterr().err
    assert main(["watch", str(tmp_path / "x.txt"), "--log", log, "--confirm", "-5s"]) == 2
    assert "confirm must be zero or positive, got -5 s" in capsys.readouterr().err
    assert main(["watch", str(tmp_path), "--log", str(tmp_path / "l.jsonl"), "--replay"]) == 2
    assert "--replay needs a finished export" in capsys.readouterr().err
    assert (
        main(["watch", str(tmp_path / "x.txt"), "--log", str(tmp_path / "l.jsonl"), "--speed", "3"])
        == 2
    )
    assert "--speed applies to --replay only" in capsys.readouterr().err
    assert (
        main(
            [
                "watch",
                str(tmp_path / "x.txt"),
                "--log",
                str(tmp_path / "l.jsonl"),
                "--serve",
                "host:port",
            ]
        )
        == 2
    )
    assert "--serve takes [HOST:]PORT" in capsys.readouterr().err


def test_the_watch_keeps_unused_libraries_out_of_its_process(tmp_path):
    """A watch runs all day: pandas' pyarrow and pint's dask (42 MiB of resident memory
    together) stay out of its process, and the forecasts are made without them; a caller's
    interpreter that runs the command in-process keeps both importable."""
    export, log = tmp_path / "ramp.txt", tmp_path / "watch.jsonl"
    record(export, dt=1.0)
    code = (
        "import sys\n"
        "from granflow.cli.app import main\n"
        f"sys.argv = ['granflow', 'watch', {str(export)!r}, '--log', {str(log)!r},"
        " '--until-end', '--horizon', '30s', '--stall', '1s']\n"
        "code = main()\n"
        "print(sorted(n for n in ('pyarrow', 'dask', 'pandas', 'pint') if sys.modules.get(n)))\n"
        "sys.exit(code)\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", code], env=environment(), capture_output=True, text=True
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip().splitlines()[-1] == "['pandas', 'pint']"
    entries = read_log(log)
    assert entries[-1]["event"] == "end"
    assert [e for e in entries if e["event"] == "forecast"][-1]["probability_within_horizon"] > 0.5

    from granflow.cli import main

    # in-process (a caller's interpreter): the command runs as far as its arguments' check
    assert main(["watch", str(export), "--log", str(tmp_path / "l.jsonl"), "--speed", "3"]) == 2
    assert sys.modules.get("dask", False) is not None  # nothing kept out here
    import pyarrow  # noqa: F401  (still importable in the caller's interpreter)
