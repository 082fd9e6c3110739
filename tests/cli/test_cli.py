"""The command line, run in-process."""

import pandas as pd
import pytest

import granflow as gf
from granflow.cli import main

CURVE = ["curve", "--a", "3.31mN", "--k", "0.036/s", "--t0", "0.23s", "--Fd", "10mN"]


def test_curve_prints_the_peak(capsys):
    assert main([*CURVE, "--velocity", "0.86um/s"]) == 0
    out = capsys.readouterr().out
    assert "F = 13.78294706 mN at t = 24.30497781 s" in out


def test_curve_writes_csv(tmp_path, capsys):
    target = tmp_path / "curve.csv"
    assert main([*CURVE, "--points", "50", "-o", str(target)]) == 0
    frame = pd.read_csv(target)
    assert list(frame.columns) == ["t_s", "slip_m", "force_N"]
    assert len(frame) == 50
    params = gf.Params.from_time_domain(3.31e-3, 0.036, 0.23, 10e-3, 0.86e-6)
    expected = gf.friction_time(frame["t_s"].to_numpy(), params, 0.86e-6)
    assert frame["force_N"].to_numpy() == pytest.approx(expected, rel=1e-15)
    assert "wrote 50 points" in capsys.readouterr().out


def test_curve_slip_domain_with_units(capsys):
    args = ["curve", "--a", "3.31mN", "--alpha", "41860.465/m", "--x0", "0.1978um", "--Fd", "10mN"]
    assert main(args) == 0
    assert "F = 13.7829" in capsys.readouterr().out


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["curve", "--a", "3mN", "--Fd", "10mN"], "either --k and --t0"),
        ([*CURVE, "--velocity=-1um/s"], "velocity must be positive"),
        (["curve", "--a", "3kg", "--k", "0.03/s", "--t0", "0.2s", "--Fd", "1mN"], "--a"),
        ([*CURVE, "--duration", "0.1s"], "--duration must exceed t0"),
    ],
)
def test_curve_usage_errors_are_one_line(capsys, args, message):
    assert main(args) == 2
    err = capsys.readouterr().err
    assert message in err
    assert err.count("\n") == 1 and "Traceback" not in err


def test_version_and_help(capsys):
    assert main(["--version"]) == 0
    assert gf.__version__ in capsys.readouterr().out
    assert main(["curve", "--help"]) == 0
    assert "examples:" in capsys.readouterr().out
    assert main([]) == 2
