"""Every CSV granflow writes names each quantity one way (its unit after an underscore:
t_s, slip_m, velocity_m_s, force_N), has one row per instant, and is read back by every
command that reads files (issue 31, point 12)."""

import re

import numpy as np
import pandas as pd
import pytest

import granflow as gf
from granflow.cli import main

PARAMS = "a: 3.31 mN\nalpha: 4.19e4 1/m\nFd: 10 mN\nx0: 0.198 um\n"
RAMP = "segments:\n  - force_ramp: {rate: 0.05 mN/s, duration: 400 s}\n"
SWITCH = (
    "segments:\n  - velocity: {velocity: 0.86 um/s, duration: 80 s}\n"
    "  - switch_to_force: {duration: 60 s, factor: 1.01}\n"
)


@pytest.fixture
def written(tmp_path, capsys):
    """The CSVs of simulate (a stress ramp that fails, a switch), curve and stability-map."""
    params = tmp_path / "params.yaml"
    params.write_text(PARAMS, encoding="utf-8")
    files = {}
    for name, protocol in (("ramp", RAMP), ("switch", SWITCH)):
        (tmp_path / f"{name}.yaml").write_text(protocol, encoding="utf-8")
        files[name] = tmp_path / f"{name}.csv"
        argv = ["simulate", str(tmp_path / f"{name}.yaml"), "--params", str(params)]
        main([*argv, "-o", str(files[name])])
    files["curve"] = tmp_path / "curve.csv"
    main(["curve", "--a", "3.31mN", "--alpha", "4.19e4/m", "--x0", "0.198um", "--Fd", "10mN",
          "-o", str(files["curve"])])  # fmt: skip
    files["map"] = tmp_path / "map.csv"
    main(["stability-map", "--params", str(params), "--switch-points", "5s,40s", "--ratios",
          "0.99,1.01", "-o", str(files["map"])])  # fmt: skip
    capsys.readouterr()
    return files


def test_every_csv_names_its_quantities_with_their_units(written):
    headers = {name: list(pd.read_csv(path).columns) for name, path in written.items()}
    simulated = [
        "t_s", "slip_m", "velocity_m_s", "force_N", "state_N", "age_s", "displacement_m",
        "segment", "control",
    ]  # fmt: skip
    assert headers["ramp"] == simulated and headers["switch"] == simulated
    assert headers["curve"] == ["t_s", "slip_m", "force_N"]
    assert headers["map"] == [
        "switch_point_s", "stress_ratio", "switch_slip_m", "switch_force_N", "imposed_force_N",
        "outcome", "stop_slip_m", "failure_time_s", "failure_force_N",
    ]  # fmt: skip


def test_a_simulated_record_has_one_row_per_instant(written):
    for name in ("ramp", "switch"):
        t = pd.read_csv(written[name])["t_s"].to_numpy()
        assert np.all(np.diff(t) > 0), name
    # the switch fails at once at 80 s: the row kept there is the state from then on
    frame = pd.read_csv(written["switch"])
    assert frame["t_s"].iloc[-1] == 80.0 and frame["velocity_m_s"].iloc[-1] == np.inf


def test_a_simulated_record_goes_straight_into_forecast_failure(written):
    (run,) = gf.read_runs(written["ramp"])
    assert run.control == "stress"
    before = run.t < 200.0  # the ramp fails at 275.6 s
    forecast = gf.forecast_failure(run.t[before], run.slip[before], run.force[before])
    assert forecast.report()


@pytest.mark.parametrize("name", ["ramp", "switch", "curve"])
def test_inspect_and_convert_read_every_written_record(written, tmp_path, capsys, name):
    assert main(["inspect", str(written[name])]) == 0
    out = capsys.readouterr().out
    assert "t_s [s] -> time" in out and "force_N [N] -> force" in out
    assert "force none" not in out
    table = tmp_path / f"{name}-tidy.csv"
    assert main(["convert", str(written[name]), "-o", str(table)]) == 0
    capsys.readouterr()
    (run,) = gf.read_runs(table)
    frame = pd.read_csv(written[name])
    np.testing.assert_array_equal(run.t, frame["t_s"].to_numpy())
    np.testing.assert_array_equal(run.force, frame["force_N"].to_numpy())


def test_fit_reads_the_curve_and_convert_reads_its_own_table(written, tmp_path, capsys):
    assert main(["fit", str(written["curve"]), "--json"]) == 0
    capsys.readouterr()
    table = tmp_path / "both.csv"
    assert main(["convert", str(written["curve"]), str(written["ramp"]), "-o", str(table)]) == 0
    capsys.readouterr()
    runs = gf.read_runs(table)  # granflow's own table: its runs as written, not one block
    assert len(runs) == 2 and [len(run) for run in runs] == [
        len(pd.read_csv(written["curve"])),
        len(pd.read_csv(written["ramp"])),
    ]
    assert main(["fit", str(table), "--interval", "1", "--json"]) == 0


def test_forecast_reads_a_simulated_record(written, capsys):
    """The simulation's slip is the model's x (it starts at x0): the command counts it from
    the loading's start, says so, and dates the failure (it once declined: "its slip starts
    at 0.198 µm, not at 0")."""
    code = main(["forecast", str(written["ramp"]), "--until", "200s"])
    captured = capsys.readouterr()
    assert code == 0, captured.err
    assert "Traceback" not in captured.err
    assert "the slip starts at 0.198 µm where the loading starts" in captured.out
    match = re.search(r"t_f = \S+ s\s+90%: \[([\d.]+), ([\d.]+|inf)\] s", captured.out)
    assert match, captured.out
    frame = pd.read_csv(written["ramp"])
    failure = frame["t_s"].iloc[-1]  # the simulation's failure, its last row
    shown = 1e-7 * failure  # the ends are printed with 8 significant digits
    assert float(match[1]) - shown <= failure <= float(match[2]) + shown
