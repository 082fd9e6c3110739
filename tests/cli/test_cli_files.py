"""`granflow fit` and `granflow convert` read every file granflow reads: instrument exports,
convert's tidy tables (CSV + sidecar JSON, Parquet) and plain CSV; data-quality problems
travel with the run into the fit's output, and --strict makes them errors."""

import json
import sys

import numpy as np
import pandas as pd
import pytest
from conftest import shared_data
from old_tables import write_old_campaign

import granflow as gf
from granflow.cli import main
from granflow.io import tidy, write_rheocompass

TRUTH = gf.Params(a=3.31e-3, alpha=4.186e4, Fd=10e-3, x0=1.978e-7)
VELOCITY = 0.86e-6
PROBLEMS = (
    "run.txt, interval 1: the header declares 401 points, the file has 79",
    "run.txt, interval 1: column 'Torque': 2 non-finite values (lines 40, 41), kept as NaN",
)

#: The real exports (NOTICE.md in their folder) and how many intervals each holds.
REAL_EXPORTS = {
    "rheocompass-en-cp1252-excel-resaved.txt": 12,
    "rheocompass-en-utf16-multiple-tests.csv": 2,
    "rheocompass-en-utf16-shear.txt": 1,
    "rheocompass-en-utf16-viscosity-curve.csv": 11,
    "rheoplus-en-utf8-stress-relaxation.txt": 6,
    "trios/creep_experiment.txt": 1,
    "trios/multi_technique.txt": 3,
}


def startup(points=400, problems=(), **meta):
    """A noiseless start-up at VELOCITY on the record's clock (0 when shearing starts): the
    initial force below x0, Eq. 3 in slip above it."""
    t = np.linspace(0.0, 600.0, points)
    slip = VELOCITY * t
    force = np.where(
        slip < TRUTH.x0,
        gf.initial_force(TRUTH),
        gf.friction_slip(np.maximum(slip, TRUTH.x0), TRUTH),
    )
    return gf.Run(
        t=t,
        slip=slip,
        velocity=np.full(points, VELOCITY),
        force=force,
        meta={"velocity": VELOCITY, "source": "run.txt", "interval": 1, **meta},
        problems=problems,
    )


def one_line_error(err, *names):
    assert err.startswith("granflow fit: error: ") and err.count("\n") == 1, err
    assert "Traceback" not in err and "tokeniz" not in err.lower() and "codec" not in err
    for name in names:
        assert name in err


@pytest.mark.parametrize("name", sorted(REAL_EXPORTS))
def test_fit_runs_or_fails_with_a_sentence_on_each_real_export(name, capsys):
    path = str(shared_data("instrument-exports", *name.split("/")))
    count = REAL_EXPORTS[name]
    code = main(["fit", path, "--interval", "1"])
    captured = capsys.readouterr()
    assert code in (0, 1, 2)
    if code == 2:
        one_line_error(captured.err, path)
    else:
        assert captured.out.startswith(f"fit of {path}") and "[[Variables]]" in captured.out
        assert "geometry: paper (default): r_eff = 13.7322 mm" in captured.out
        assert "Traceback" not in captured.err
    if count > 1:
        assert main(["fit", path]) == 2
        one_line_error(capsys.readouterr().err, f"holds {count} intervals", "--interval N")
    assert main(["fit", path, "--interval", str(count + 1)]) == 2
    one_line_error(capsys.readouterr().err, f"--interval {count + 1}")


def test_fit_reads_an_export_through_the_declared_geometry(tmp_path, capsys):
    tube = "outer_radius=20mm,inner_radius=18mm"
    path = write_rheocompass(
        tmp_path / "run.txt", [startup(), startup()], geometry=gf.Annulus.from_spec(tube)
    )
    assert main(["fit", str(path), "--interval", "2", "--geometry", tube, "--json"]) == 0
    payload = json.loads(capsys.readouterr().out)
    for name in ("a", "alpha", "Fd", "x0"):
        assert payload["params"][name] == pytest.approx(getattr(TRUTH, name), rel=1e-4)
    assert payload["record"]["geometry"]["spec"] == tube
    assert payload["record"]["interval"] == 2 and payload["problems"] == []
    # read with the paper's tube instead, every force is off by r_eff(tube) / r_eff(paper)
    assert main(["fit", str(path), "--interval", "2", "--json"]) == 0
    paper = json.loads(capsys.readouterr().out)
    ratio = (2 / 3 * (20**3 - 18**3) / (20**2 - 18**2)) / 13.732193732193732
    assert paper["params"]["Fd"] == pytest.approx(TRUTH.Fd * ratio, rel=1e-4)
    assert paper["record"]["geometry"]["spec"] == "paper (default)"


def test_fit_prints_and_keeps_the_problems_of_the_run(tmp_path, capsys):
    table = tmp_path / "tidy.csv"
    tidy.write_tidy(table, [startup(problems=PROBLEMS)])
    assert main(["fit", str(table)]) == 0
    out = capsys.readouterr().out
    assert "data quality: 2 problems" in out
    assert all(f"  - {problem}" in out for problem in PROBLEMS)
    assert "[[Display units]]" in out and "Fd = 10 ± " in out and " mN" in out
    assert main(["fit", str(table), "--json"]) == 0
    payload = json.loads(capsys.readouterr().out)
    assert payload["problems"] == list(PROBLEMS)
    assert gf.FitResult.from_dict(payload).params["x0"] == pytest.approx(TRUTH.x0, rel=1e-4)
    assert main(["fit", str(table), "--strict"]) == 1
    captured = capsys.readouterr()
    one_line_error(captured.err, "2 data-quality problems (--strict)", *PROBLEMS)
    assert captured.out == ""


def test_fit_of_a_clean_run_says_so_and_strict_passes(tmp_path, capsys):
    table = tmp_path / "tidy.csv"
    tidy.write_tidy(table, [startup()])
    assert main(["fit", str(table), "--strict"]) == 0
    assert "data quality: no problems recorded by the reader" in capsys.readouterr().out


def test_fit_keeps_the_problems_a_reader_puts_on_an_export_run(tmp_path, monkeypatch, capsys):
    # until the readers record problems themselves: a reader that does
    path = write_rheocompass(tmp_path / "run.txt", startup())
    damaged = startup(problems=PROBLEMS[:1])
    monkeypatch.setattr(gf.io, "read_runs", lambda *args, **kwargs: [damaged])
    assert main(["fit", str(path), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["problems"] == list(PROBLEMS[:1])
    assert main(["fit", str(path), "--strict"]) == 1
    assert "declares 401 points" in capsys.readouterr().err


def test_convert_writes_csv_that_pandas_reads_as_it_is(tmp_path, capsys):
    runs = [startup(problems=PROBLEMS), startup(points=50)]
    export = write_rheocompass(tmp_path / "run.txt", runs)
    out = tmp_path / "tidy.csv"
    assert main(["convert", str(export), "-o", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "wrote 2 runs (450 points)" in printed and "tidy.csv.json" in printed
    assert "geometry: paper (default)" in printed
    frame = pd.read_csv(out)
    assert list(frame.columns) == list(tidy.COLUMNS)
    assert list(frame.columns) == [
        "run", "source", "interval", "control", "t_s", "slip_m", "velocity_m_s", "force_N"
    ]  # fmt: skip
    assert frame["run"].tolist() == [1] * 400 + [2] * 50
    first = frame[frame["run"] == 1]
    np.testing.assert_allclose(first["force_N"], runs[0].force, rtol=1e-9)
    np.testing.assert_allclose(first["t_s"], runs[0].t, rtol=1e-9, atol=1e-12)
    assert set(frame["control"]) == {"rate"} and set(frame["source"]) == {str(export)}
    metadata = json.loads((tmp_path / "tidy.csv.json").read_text(encoding="utf-8"))
    assert metadata["columns"]["force_N"] == "friction force [N]"
    assert metadata["geometry"]["spec"] == "paper (default)"
    assert [entry["points"] for entry in metadata["runs"]] == [400, 50]
    # fit reads convert's output back, choosing the run with --interval
    assert main(["fit", str(out), "--interval", "1", "--json"]) == 0
    payload = json.loads(capsys.readouterr().out)
    assert payload["params"]["alpha"] == pytest.approx(TRUTH.alpha, rel=1e-4)
    assert payload["record"]["geometry"]["spec"] == "paper (default)"


def test_convert_keeps_each_runs_problems_in_its_metadata(tmp_path, capsys):
    table = tmp_path / "in.csv"
    tidy.write_tidy(table, [startup(problems=PROBLEMS), startup()])
    for name in ("out.csv", "out.parquet"):
        out = tmp_path / name
        assert main(["convert", str(table), "-o", str(out)]) == 0
        assert "data quality: 1 run with problems" in capsys.readouterr().out
        back = tidy.read_tidy(out).runs
        assert [run.problems for run in back] == [PROBLEMS, ()]
    metadata = json.loads((tmp_path / "out.csv.json").read_text(encoding="utf-8"))
    assert metadata["runs"][0]["problems"] == list(PROBLEMS)
    assert list(pd.read_parquet(tmp_path / "out.parquet").columns) == list(tidy.COLUMNS)


def test_convert_with_a_declared_geometry_recovers_the_forces(tmp_path, capsys):
    tube = "effective_radius=10mm,mean_radius=9.5mm"
    export = write_rheocompass(tmp_path / "run.txt", startup(), geometry=gf.Annulus.from_spec(tube))
    out = tmp_path / "tidy.parquet"
    assert main(["convert", str(export), "-o", str(out), "--geometry", tube]) == 0
    assert f"geometry: {tube}: r_eff = 10 mm" in capsys.readouterr().out
    frame = pd.read_parquet(out)
    # force = torque / r_eff, with the torque as the reader gives it
    torque = gf.read(export).intervals[0].si("torque")
    np.testing.assert_allclose(frame["force_N"], torque / 10e-3, rtol=1e-12)
    np.testing.assert_allclose(frame["force_N"], startup().force, rtol=1e-8)


def test_fit_reads_a_tidy_table_without_its_sidecar(tmp_path, capsys):
    table = tmp_path / "tidy.csv"
    tidy.write_tidy(table, [startup(), startup()])
    tidy.sidecar_path(table).unlink()
    assert main(["fit", str(table), "--interval", "2", "--json"]) == 0
    payload = json.loads(capsys.readouterr().out)
    assert payload["record"]["geometry"] is None and payload["problems"] == []
    assert main(["fit", str(table), "--geometry", "paper"]) == 2
    assert "--geometry does not apply" in capsys.readouterr().err


def test_fit_reads_an_old_convert_csv(tmp_path, capsys):
    path = write_old_campaign(tmp_path / "old.csv", [startup()])
    assert main(["fit", str(path), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["params"]["Fd"] == pytest.approx(TRUTH.Fd, 1e-4)


def test_a_damaged_tidy_table_is_a_sentence_naming_the_line(tmp_path, capsys):
    table = tmp_path / "tidy.csv"
    tidy.write_tidy(table, [startup(points=20)])
    lines = table.read_text(encoding="utf-8").splitlines()
    cells = lines[5].split(",")
    lines[5] = ",".join([*cells[:4], "abc", *cells[5:]])
    table.write_text("\n".join(lines) + "\n", encoding="utf-8")
    assert main(["fit", str(table)]) == 2
    one_line_error(capsys.readouterr().err, str(table), "line 6", "'t_s' holds a cell that is not")
    lines[5] += ",1,2,3"
    table.write_text("\n".join(lines) + "\n", encoding="utf-8")
    assert main(["fit", str(table)]) == 2
    one_line_error(capsys.readouterr().err, str(table), "line 6")


def test_fit_reads_a_plain_csv_with_instrument_columns(tmp_path, capsys):
    run = startup()
    tube = gf.Annulus.paper()
    path = tmp_path / "torque.csv"
    pd.DataFrame(
        {
            "Time [s]": run.t,
            "Torque [mN·m]": tube.torque_from_force(run.force) * 1e3,
            "Deflection Angle [mrad]": tube.angle_from_slip(run.slip) * 1e3,
        }
    ).to_csv(path, index=False, float_format="%.12g")
    assert main(["fit", str(path), "--json"]) == 0
    payload = json.loads(capsys.readouterr().out)
    assert payload["params"]["x0"] == pytest.approx(TRUTH.x0, rel=1e-4)
    assert payload["record"]["geometry"]["spec"] == "paper (default)"


def test_parquet_without_pyarrow_names_the_extra(tmp_path, monkeypatch, capsys):
    export = write_rheocompass(tmp_path / "run.txt", startup(points=20))
    monkeypatch.setitem(sys.modules, "pyarrow.parquet", None)  # as if not installed
    assert main(["convert", str(export), "-o", str(tmp_path / "tidy.parquet")]) == 2
    assert "pip install granflow[parquet]" in capsys.readouterr().err
