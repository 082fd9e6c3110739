"""granflow's tidy table: pandas reads it as it is, granflow reads it back bit for bit (values,
NaN, metadata, problems), and the tables of earlier versions still load."""

import json
from dataclasses import replace

import numpy as np
import pandas as pd
import pytest
from old_tables import write_old_campaign

import granflow
from granflow.io import tidy

PROBLEMS = ("a.txt, interval 1: the header declares 40 points, the file has 12",)
FAILED = ("missing.csv: no such file",)
GEOMETRY = {"spec": "paper", "effective_radius": 0.0137, "mean_radius": 0.0137}


def awkward_runs():
    """Runs that test the round trip: 17-digit values over 600 decades, subnormals, -0, inf
    and NaN, an empty run, stress control, unicode and nested metadata, problems."""
    rng = np.random.default_rng(7)
    size = 500
    values = rng.normal(size=(4, size)) * 10.0 ** rng.integers(-300, 300, size=(4, size))
    values[0, :6] = [0.0, 5e-324, 2.2250738585072014e-308, 1.7976931348623157e308, -0.0, 1e-310]
    values[1, 1:4] = [np.nan, np.inf, -np.inf]
    values[3, 10:20] = np.nan
    first = granflow.Run(
        t=values[0],
        slip=values[1],
        velocity=values[2],
        force=values[3],
        meta={"source": "a.txt", "interval": 1, "sample": "PMMA µ-beads", "normal_load": 0.05},
        problems=PROBLEMS,
    )
    empty = granflow.Run(t=[], slip=[], velocity=[], force=[], meta={"source": "b.txt"})
    creep = granflow.Run(
        t=[0.0, 0.5, 1.0],
        slip=[0.0, np.nan, 3e-9],
        velocity=[np.nan] * 3,
        force=[0.01] * 3,
        control="stress",
        meta={"source": "c.txt", "interval": "2b", "steps": [1, 2], "note": {"by": "Ünal"}},
    )
    return [first, empty, creep]


def same_bits(a, b):
    """Whether two float arrays are equal bit for bit (any NaN equal to any NaN)."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    if a.shape != b.shape or not np.array_equal(np.isnan(a), np.isnan(b)):
        return False
    keep = ~np.isnan(a)
    return np.array_equal(a[keep].view(np.int64), b[keep].view(np.int64))


def assert_same_runs(runs, back):
    assert len(back) == len(runs)
    for run, other in zip(runs, back, strict=True):
        for name in ("t", "slip", "velocity", "force"):
            assert same_bits(getattr(run, name), getattr(other, name)), name
        assert other.control == run.control
        assert dict(other.meta) == dict(run.meta)
        assert other.problems == run.problems


@pytest.mark.parametrize("suffix", [".csv", ".parquet"])
def test_round_trip_is_bit_for_bit(tmp_path, suffix):
    runs = awkward_runs()
    path = tidy.write_tidy(tmp_path / f"t{suffix}", runs, problems=FAILED, geometry=GEOMETRY)
    table = tidy.read_tidy(path)
    assert_same_runs(runs, table.runs)
    assert table.problems == FAILED and table.geometry == GEOMETRY
    campaign = granflow.Campaign(runs, FAILED)
    back = granflow.Campaign.load(campaign.save(tmp_path / f"c{suffix}"))
    assert_same_runs(runs, back)
    assert back.problems == FAILED


def test_csv_is_read_by_pandas_as_it_is(tmp_path):
    runs = awkward_runs()
    path = tidy.write_tidy(tmp_path / "t.csv", runs, geometry=GEOMETRY)
    frame = pd.read_csv(path)
    assert list(frame.columns) == list(tidy.COLUMNS)
    assert frame["run"].tolist() == [1] * 500 + [3] * 3  # the empty run 2 has no row
    assert frame["control"].tolist() == ["rate"] * 500 + ["stress"] * 3
    assert frame["source"].tolist() == ["a.txt"] * 500 + ["c.txt"] * 3
    # an interval that is not an integer is empty in the table, kept in the metadata
    assert frame["interval"].iloc[0] == 1 and frame["interval"].iloc[-3:].isna().all()
    assert same_bits(frame["force_N"].iloc[:500], runs[0].force)
    metadata = json.loads(tidy.sidecar_path(path).read_text(encoding="utf-8"))
    assert metadata["granflow"] == 1 and metadata["geometry"] == GEOMETRY
    assert metadata["columns"]["t_s"] == "time since the start of the interval [s]"
    assert [entry["points"] for entry in metadata["runs"]] == [500, 0, 3]
    assert metadata["runs"][2]["meta"]["note"] == {"by": "Ünal"}
    assert tidy.metadata_location(path) == f"{path}.json"


def test_parquet_keeps_the_metadata_in_the_file(tmp_path):
    path = tidy.write_tidy(tmp_path / "t.parquet", awkward_runs()[:1], problems=FAILED)
    assert list(pd.read_parquet(path).columns) == list(tidy.COLUMNS)
    assert not tidy.sidecar_path(path).exists()
    assert tidy.metadata_location(path) == f"{path} (Parquet metadata 'granflow')"


def test_csv_without_its_sidecar_gives_the_table_alone(tmp_path):
    runs = awkward_runs()
    path = tidy.write_tidy(tmp_path / "t.csv", runs, problems=FAILED)
    tidy.sidecar_path(path).unlink()
    table = tidy.read_tidy(path)
    assert [len(run) for run in table.runs] == [500, 3]  # the empty run has no row
    assert table.runs[0].meta == {"source": "a.txt", "interval": 1}
    assert table.runs[1].control == "stress" and table.runs[1].meta == {"source": "c.txt"}
    assert same_bits(table.runs[1].slip, runs[2].slip)
    assert table.problems == () and table.geometry is None


@pytest.mark.parametrize("suffix", [".csv", ".parquet"])
def test_an_old_campaign_table_still_loads(tmp_path, suffix):
    first, _, creep = awkward_runs()
    # the old Parquet writer could not mix text and integers in a metadata column
    runs = [first, replace(creep, meta={**creep.meta, "interval": 2})]
    path = write_old_campaign(tmp_path / f"old{suffix}", runs, FAILED)
    assert tidy.is_tidy_table(path)
    back = granflow.Campaign.load(path)
    assert_same_runs(runs, back)
    assert back.problems == FAILED
    assert tidy.read_tidy(path).geometry is None


def test_the_new_format_replaces_the_comment_line(tmp_path):
    path = granflow.Campaign(awkward_runs()).save(tmp_path / "c.csv")
    assert path.read_text(encoding="utf-8").startswith(",".join(tidy.COLUMNS) + "\n")


def test_bad_input_names_the_file_and_the_reason(tmp_path):
    run = awkward_runs()[2]
    with pytest.raises(granflow.InvalidParameterError, match=r"\.csv or \.parquet.*'t\.txt'"):
        tidy.write_tidy(tmp_path / "t.txt", [run])
    with pytest.raises(granflow.InvalidParameterError, match=r"runs\[1\] must be a granflow"):
        tidy.write_tidy(tmp_path / "t.csv", [run, "run"])
    with pytest.raises(granflow.FileFormatError, match="no such file"):
        tidy.read_tidy(tmp_path / "none.csv")
    other = tmp_path / "other.csv"
    other.write_text("time,force\n1,2\n", encoding="utf-8")
    assert not tidy.is_tidy_table(other)
    with pytest.raises(granflow.FileFormatError, match="line 1: not a granflow table"):
        tidy.read_tidy(other)
    path = tidy.write_tidy(tmp_path / "t.csv", [run, run])
    sidecar = tidy.sidecar_path(path)
    metadata = json.loads(sidecar.read_text(encoding="utf-8"))
    metadata["runs"][1]["points"] = 4
    sidecar.write_text(json.dumps(metadata), encoding="utf-8")
    with pytest.raises(granflow.FileFormatError, match="run 2 has 3 rows, its metadata says 4"):
        tidy.read_tidy(path)
    del metadata["runs"][1]
    sidecar.write_text(json.dumps(metadata), encoding="utf-8")
    with pytest.raises(granflow.FileFormatError, match="run 2 is not in the table's metadata"):
        tidy.read_tidy(path)
    sidecar.write_text("{", encoding="utf-8")
    with pytest.raises(granflow.FileFormatError, match=r"t\.csv\.json: not a JSON file"):
        granflow.Campaign.load(path)
    lines = path.read_text(encoding="utf-8").splitlines()
    lines[1] = lines[1].replace("stress", "sideways")
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    sidecar.unlink()
    with pytest.raises(granflow.FileFormatError, match=r"t\.csv, line 2: run 1: .*'sideways'"):
        tidy.read_tidy(path)
    plain = tmp_path / "plain.parquet"
    pd.DataFrame({"x": [1.0]}).to_parquet(plain)
    with pytest.raises(granflow.FileFormatError, match="without granflow's metadata"):
        tidy.read_tidy(plain)
