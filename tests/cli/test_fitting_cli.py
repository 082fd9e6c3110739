"""The `granflow fit` command, run in-process."""

import json

import numpy as np
import pandas as pd
import pytest

from granflow import Params, friction_time
from granflow.cli import main

VELOCITY = 0.86e-6
TRUTH = Params.from_time_domain(a=3.31e-3, k=0.036, t0=0.23, Fd=10e-3, velocity=VELOCITY)


@pytest.fixture
def curve_csv(tmp_path):
    t = np.linspace(0.5, 600.0, 1200)
    force = friction_time(t, TRUTH, VELOCITY) + np.random.default_rng(0).normal(0, 5e-5, t.size)
    path = tmp_path / "run.csv"
    pd.DataFrame(
        {"time [s]": t, "slip [µm]": t * VELOCITY * 1e6, "force [mN]": force * 1e3}
    ).to_csv(path, index=False)
    return path


def test_fit_command_prints_a_report(curve_csv, capsys):
    assert main(["fit", str(curve_csv)]) == 0
    out = capsys.readouterr().out
    assert "[[Variables]]" in out and "alpha" in out


def test_fit_command_json_time_domain_with_fixed_fd(curve_csv, capsys):
    code = main(
        [
            "fit",
            str(curve_csv),
            "--domain",
            "time",
            "--fix",
            "Fd=10mN",
            "--json",
            "--velocity",
            "0.86um/s",
            "--window",
            "1s:",
        ]
    )
    assert code == 0
    payload = json.loads(capsys.readouterr().out)
    assert payload["params"]["Fd"] == pytest.approx(0.01)
    assert payload["fixed"] == ["Fd"]
    assert payload["params"]["k"] == pytest.approx(0.036, rel=0.02)
    assert payload["window"][0] >= 1.0
    assert payload["velocity"] == pytest.approx(VELOCITY)


def test_fit_command_errors(tmp_path, curve_csv, capsys):
    assert main(["fit", str(tmp_path / "missing.csv")]) == 2
    assert "no such file" in capsys.readouterr().err
    bad = tmp_path / "bad.csv"
    bad.write_text("time [s],voltage [V]\n1,2\n")
    assert main(["fit", str(bad)]) == 2
    assert "need a force column" in capsys.readouterr().err
    furlongs = tmp_path / "furlongs.csv"
    furlongs.write_text("Time [s],Torque [furlongs]\n1,2\n")
    assert main(["fit", str(furlongs)]) == 2
    assert "furlongs" in capsys.readouterr().err
    nounit = tmp_path / "nounit.csv"
    nounit.write_text("time,force [mN]\n1,2\n")
    assert main(["fit", str(nounit)]) == 2
    assert "has no unit" in capsys.readouterr().err
    text = tmp_path / "text.csv"
    text.write_text("time [s],force [mN]\n1,2\n2,abc\n")
    assert main(["fit", str(text)]) == 2
    assert "line 3" in capsys.readouterr().err
    assert main(["fit", str(curve_csv), "--fix", "k=1"]) == 2
    assert "--fix" in capsys.readouterr().err
    flat = tmp_path / "flat.csv"
    pd.DataFrame({"slip [um]": np.linspace(0.1, 500, 200), "force [mN]": np.ones(200)}).to_csv(
        flat, index=False
    )
    assert main(["fit", str(flat)]) == 2
    assert "overshoot" in capsys.readouterr().err


def test_fit_reads_underscore_units_and_ignores_other_columns(tmp_path, capsys):
    # granflow curve -o writes time_s, slip_m, force_N; a velocity column in um/s (no speed
    # unit) is left alone, as any column the fit does not use
    t = np.linspace(0.5, 600.0, 600)
    force = friction_time(t, TRUTH, VELOCITY)
    path = tmp_path / "curve.csv"
    pd.DataFrame(
        {"time_s": t, "slip_m": t * VELOCITY, "force_N": force, "velocity [um/s]": 0.86}
    ).to_csv(path, index=False)
    assert main(["fit", str(path), "--json"]) == 0
    payload = json.loads(capsys.readouterr().out)
    assert payload["domain"] == "slip"
    assert payload["params"]["alpha"] == pytest.approx(TRUTH.alpha, rel=1e-4)


def test_fit_converts_header_units_to_si(tmp_path, capsys):
    # time in minutes and force in uN: the fitted t0 and Fd come back in s and N
    t = np.linspace(0.5, 600.0, 600)
    force = friction_time(t, TRUTH, VELOCITY)
    path = tmp_path / "minutes.csv"
    pd.DataFrame({"t (min)": t / 60.0, "F [µN]": force * 1e6}).to_csv(path, index=False)
    code = main(["fit", str(path), "--json", "--velocity", "0.86um/s"])
    assert code == 0
    payload = json.loads(capsys.readouterr().out)
    assert payload["params"]["t0"] == pytest.approx(0.23, rel=1e-3)
    assert payload["params"]["Fd"] == pytest.approx(0.01, rel=1e-4)


def test_fit_refuses_a_unit_of_the_wrong_dimension(tmp_path, capsys):
    path = tmp_path / "wrong.csv"
    path.write_text("time [s],force [mm]\n1,2\n2,3\n")
    assert main(["fit", str(path)]) == 2
    err = capsys.readouterr().err
    assert "force" in err and "'mm'" in err
