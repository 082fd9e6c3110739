"""Units as people type them, the geometry option, plurals, help with examples, and a closed
pipe that ends quietly."""

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import granflow as gf
from granflow.cli import build_parser, main
from granflow.cli.app import PIPE_CLOSED

CURVE = ["curve", "--k", "0.036/s", "--t0", "0.23s"]
COMMANDS = ("curve", "inspect", "convert", "fit", "simulate", "stability-map", "analyze", "demo")


def single_error(err, command, *parts):
    assert err.startswith(f"granflow {command}: error: ") and err.count("\n") == 1, err
    for part in parts:
        assert part in err


def test_a_bare_number_is_an_error_naming_the_option_and_its_unit(capsys):
    # the example: --a 3.31 --Fd 10 used to draw a 13 782 mN peak
    assert main(["curve", "--a", "3.31", "--k", "0.036/s", "--t0", "0.23s", "--Fd", "10"]) == 2
    captured = capsys.readouterr()
    single_error(captured.err, "curve", "--a needs a unit", "--a 3.31N or --a 3.31mN")
    assert captured.out == ""
    assert main(["curve", "--a", "3.31mN", "--k", "0.036", "--t0", "0.23s", "--Fd", "10mN"]) == 2
    single_error(capsys.readouterr().err, "curve", "--k needs a unit", "--k 0.036/s")
    assert main([*CURVE, "--a", "3.31mN", "--Fd", "10"]) == 2
    single_error(capsys.readouterr().err, "curve", "--Fd needs a unit", "--Fd 10mN")


@pytest.mark.parametrize(
    "args",
    [
        ["--a", "3.31mN", "--Fd", "10mN", "--velocity", "0.86um/s"],
        ["--a", "0.00331 N", "--Fd", "1e4 uN", "--velocity", "860 nm/s"],
        ["--a", "3.31*mN", "--Fd", "0.01N", "--velocity", "51.6um/min"],
    ],
)
def test_pint_expressions_give_the_same_curve(args, capsys):
    assert main([*CURVE, *args]) == 0
    assert "F = 13.78294706 mN at t = 24.30497781 s" in capsys.readouterr().out


def test_negative_quantities_with_units_are_values_not_options(capsys):
    parser = build_parser()
    args = parser.parse_args([*CURVE, "--a", "3mN", "--Fd", "-1mN", "--velocity", "-.86um/s"])
    assert args.Fd == "-1mN" and args.velocity == "-.86um/s"
    args = parser.parse_args(["fit", "run.csv", "--window", "-5s:10s", "--velocity", "-3e-6m/s"])
    assert args.window == "-5s:10s" and args.velocity == "-3e-6m/s"
    # the value reaches the library, which names what is wrong with it
    assert main([*CURVE, "--a", "3.31mN", "--Fd", "10mN", "--velocity", "-0.86um/s"]) == 2
    single_error(capsys.readouterr().err, "curve", "velocity must be positive", "-8.6e-07 m/s")


def test_zero_and_ratios_need_no_unit(tmp_path, capsys):
    params = tmp_path / "p.yaml"
    params.write_text("a: 3.31 mN\nk: 0.036 /s\nt0: 0.23 s\nFd: 10 mN\nvelocity: 0.86 um/s\n")
    args = ["--params", str(params), "--switch-points", "5s", "--ratios", "1.01,1.2", "--ramp", "0"]
    assert main(["stability-map", *args]) == 0
    assert "[[Stability map]]" in capsys.readouterr().out
    assert main(["stability-map", *args[:3], "5", *args[4:]]) == 2
    single_error(capsys.readouterr().err, "stability-map", "--switch-points needs a unit", "5s")


def test_geometry_is_read_with_units_and_stated(tmp_path, capsys):
    run = gf.Run(t=[0.0, 1.0], slip=[0.0, 1e-6], velocity=[1e-6] * 2, force=[0.01, 0.02])
    export = gf.io.write_rheocompass(tmp_path / "run.txt", run)
    tube = "outer_diameter=30mm,wall_thickness=2mm"
    assert main(["inspect", str(export), "--geometry", tube]) == 0
    out = capsys.readouterr().out
    r_eff = 2 / 3 * (15**3 - 13**3) / (15**2 - 13**2)  # mm
    assert f"geometry:  {tube}: r_eff = {r_eff:.6g} mm" in out and "r_m = 14 mm" in out
    # the export holds the paper's torque: through this tube, force = torque / r_eff
    expected = 0.02 * 13.732193732193732 / r_eff * 1e3  # mN
    assert f"force {0.01 * 13.732193732193732 / r_eff * 1e3:.4g} to {expected:.4g} mN" in out
    assert main(["inspect", str(export)]) == 0
    assert "geometry:  paper (default): r_eff = 13.7322 mm" in capsys.readouterr().out
    assert (
        main(["inspect", str(export), "--geometry", "outer_diameter=0.03,wall_thickness=2mm"]) == 2
    )
    single_error(
        capsys.readouterr().err, "inspect", "--geometry outer_diameter needs a unit",
        "outer_diameter=0.03mm",
    )  # fmt: skip
    assert main(["inspect", str(export), "--geometry", "radius=3mm"]) == 2
    single_error(capsys.readouterr().err, "inspect", "unknown key 'radius'")


def test_plurals_read_right(tmp_path, capsys):
    run = gf.Run(t=[0.0], slip=[0.0], velocity=[1e-6], force=[0.01])
    export = gf.io.write_rheocompass(tmp_path / "one.txt", run)
    assert main(["convert", str(export), "-o", str(tmp_path / "one.csv")]) == 0
    assert "wrote 1 run (1 point) to" in capsys.readouterr().out
    curve = tmp_path / "c.csv"
    assert main([*CURVE, "--a", "3.31mN", "--Fd", "10mN", "--points", "2", "-o", str(curve)]) == 0
    assert "wrote 2 points to" in capsys.readouterr().out


def test_help_gives_one_example_per_command_with_units(capsys):
    assert main(["--help"]) == 0
    out = capsys.readouterr().out
    for command in COMMANDS:
        assert f"\n  granflow {command} " in out
    assert "needs its unit" in out and f"{PIPE_CLOSED} the output pipe" in out
    for command in ("curve", "inspect", "convert", "fit", "simulate", "stability-map"):
        assert main([command, "--help"]) == 0
        text = capsys.readouterr().out
        assert "example" in text and "needs its unit" in text


def test_bad_output_suffix_is_refused_before_reading(tmp_path, capsys):
    assert main(["convert", "missing.txt", "-o", str(tmp_path / "out.xlsx")]) == 2
    single_error(capsys.readouterr().err, "convert", "-o must end in .csv or .parquet")


def test_a_closed_pipe_ends_quietly(tmp_path):
    params = gf.Params(a=3.31e-3, alpha=4.186e4, Fd=10e-3, x0=1.978e-7)
    x = np.linspace(2e-7, 5e-4, 4000)
    path = tmp_path / "curve.csv"
    pd.DataFrame({"slip [m]": x, "force [N]": gf.friction_slip(x, params)}).to_csv(path)
    source = Path(gf.__file__).resolve().parents[1]
    env = {**os.environ, "PYTHONPATH": f"{source}{os.pathsep}{os.environ.get('PYTHONPATH', '')}"}
    code = "import sys; from granflow.cli import main; sys.exit(main(sys.argv[1:]))"
    process = subprocess.Popen(
        [sys.executable, "-c", code, "fit", str(path), "--json"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        env=env,
    )
    assert process.stdout.readline().strip() == b"{"  # then the reader goes away (| head -1)
    process.stdout.close()
    err = process.stderr.read().decode()
    process.stderr.close()
    assert process.wait(timeout=300) == PIPE_CLOSED
    assert err == ""


def test_the_summary_wraps_between_words_never_inside_a_number():
    from granflow.cli.campaign import wrapped

    line = (
        "forecast fig3a_stress_ramp_trios.txt#1: t_f at 81.6 s: 204.22 s [204.00, 204.44] (90%) "
        "-> at 193.8 s: 204.32 s [204.308, 204.324] (90%); observed 204 s (converged)"
    )
    text = wrapped("  " + line, width=60)
    assert len(text.splitlines()) > 1
    words = line.split()
    assert text.split() == words  # nothing split, nothing lost
    assert all(row.startswith("  ") for row in text.splitlines())
    assert all(row.startswith("      ") for row in text.splitlines()[1:])  # continued, indented
