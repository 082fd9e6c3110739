"""granflow inspect and granflow convert, in-process; ``python -m granflow.cli``."""

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
from conftest import shared_data

import granflow
from granflow.cli import main
from granflow.io import tidy, write_rheocompass


def _shear_export():
    return shared_data("instrument-exports", "rheocompass-en-utf16-shear.txt")


def test_inspect_prints_format_columns_and_rows(capsys):
    assert main(["inspect", str(_shear_export())]) == 0
    out = capsys.readouterr().out
    assert "format:    rheocompass" in out
    assert "utf-16" in out and "20 rows" in out and "Torque [mN·m] -> torque" in out


def test_inspect_bad_file_exits_2(tmp_path, capsys):
    bad = tmp_path / "bad.txt"
    bad.write_text("Time [s]\tTorque [furlongs]\n1\t2\n", encoding="utf-8")
    assert main(["inspect", str(bad)]) == 2
    assert "furlongs" in capsys.readouterr().err


def test_convert_writes_a_campaign_and_reports_failures(tmp_path, capsys):
    run = granflow.Run(t=[0.0, 1.0], slip=[0.0, 1e-6], velocity=[1e-6] * 2, force=[0.01, 0.02])
    good = write_rheocompass(tmp_path / "good.csv", [run, run], language="de", decimal=",")
    output = tmp_path / "tidy.parquet"
    code = main(
        ["convert", str(good), str(tmp_path / "none.csv"), "-o", str(output), "--geometry", "paper"]
    )
    captured = capsys.readouterr()
    assert code == 1 and "none.csv" in captured.err and "wrote 2 runs (4 points)" in captured.out
    table = tidy.read_tidy(output)
    np.testing.assert_allclose(table.runs[1].force, [0.01, 0.02], rtol=1e-9)
    assert table.geometry["spec"] == "paper"
    assert len(table.problems) == 1 and "none.csv" in table.problems[0]
    assert (
        main(
            [
                "convert",
                str(good),
                "-o",
                str(tmp_path / "t.csv"),
                "--geometry",
                "outer_diameter=29.7mm,wall_thickness=2.3mm",
            ]
        )
        == 0
    )


def test_python_dash_m_runs_the_command(tmp_path):
    source = Path(granflow.__file__).parents[1]  # the granflow under test, not another one
    completed = subprocess.run(
        [sys.executable, "-m", "granflow.cli", "convert", str(tmp_path / "none.csv"), "-o", "x"],
        capture_output=True,
        text=True,
        env={**os.environ, "PYTHONPATH": str(source)},
        cwd=tmp_path,
    )
    assert completed.returncode == 2 and completed.stdout == ""
    assert completed.stderr.startswith("granflow convert: error: -o must end in .csv")
    version = subprocess.run(
        [sys.executable, "-m", "granflow.cli", "--version"],
        capture_output=True,
        text=True,
        env={**os.environ, "PYTHONPATH": str(source)},
        check=True,
    )
    assert version.stdout.strip() == f"granflow {granflow.__version__}"
