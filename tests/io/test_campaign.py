"""Campaigns: manifests (YAML and CSV) over written exports, select/group, save/load."""

import numpy as np
import pandas as pd
import pytest

import granflow
from granflow.io import write_rheocompass, write_trios


def _run(load, velocity, preparation, seed):
    rng = np.random.default_rng(seed)
    time = np.arange(0.0, 30.0)
    force = 0.2 * load * (1 - np.exp(-time / 5)) + rng.normal(0, 2e-5, time.size)
    force[3] = np.nan
    return granflow.Run(
        t=time,
        slip=velocity * time,
        velocity=np.full(time.size, velocity),
        force=force,
        meta={"sample": "PMMA", "preparation": preparation},
    )


@pytest.fixture
def folder(tmp_path):
    write_rheocompass(
        tmp_path / "light.csv",
        [_run(0.05, 1e-6, "A", 1), _run(0.05, 2e-6, "A", 2)],
        language="fr",
        decimal=",",
    )
    write_trios(tmp_path / "heavy.txt", [_run(0.1, 1e-6, "B", 3)])
    (tmp_path / "campaign.yaml").write_text(
        "defaults:\n  notes: synthetic\n"
        "runs:\n"
        "  - {file: light.csv, interval: 1, normal_load: 50 mN, preparation: A}\n"
        "  - {file: light.csv, interval: 2, normal_load: 0.05 N, preparation: A}\n"
        "  - {file: heavy.txt, normal_load: 100mN, preparation: B}\n"
        "  - {file: missing.csv, normal_load: 1 N}\n",
        encoding="utf-8",
    )
    (tmp_path / "campaign.csv").write_text(
        "file,interval,normal_load,preparation,notes\n"
        "light.csv,1,50 mN,A,first\nlight.csv,2,0.05 N,A,\nheavy.txt,,0.1 N,B,\n",
        encoding="utf-8",
    )
    return tmp_path


def test_yaml_manifest_reads_runs_and_collects_the_failing_file(folder):
    campaign = granflow.Campaign.from_manifest(folder / "campaign.yaml")
    assert len(campaign) == 3
    assert len(campaign.problems) == 1 and "missing.csv" in campaign.problems[0]
    loads = [run.normal_load for run in campaign]
    assert loads == pytest.approx([0.05, 0.05, 0.1], rel=1e-15)
    assert [run.meta["notes"] for run in campaign] == ["synthetic"] * 3
    assert campaign[1].nominal_velocity == pytest.approx(2e-6, rel=1e-9)
    with pytest.raises(granflow.FileFormatError, match=r"missing\.csv"):
        granflow.Campaign.from_manifest(folder / "campaign.yaml", errors="raise")


def test_csv_manifest_gives_the_same_runs(folder):
    from_yaml = granflow.Campaign.from_manifest(folder / "campaign.yaml")
    from_csv = granflow.Campaign.from_manifest(folder / "campaign.csv")
    assert len(from_csv) == 3 and from_csv.problems == ()
    for a, b in zip(from_yaml, from_csv, strict=True):
        np.testing.assert_array_equal(a.force, b.force)
        assert a.normal_load == b.normal_load
    assert from_csv[0].meta["notes"] == "first"


def test_select_and_group(folder):
    campaign = granflow.Campaign.from_manifest(folder / "campaign.yaml")
    assert len(campaign.select(normal_load=0.05)) == 2
    assert len(campaign.select(normal_load=0.05, velocity=1e-6)) == 1
    assert len(campaign.select(preparation="B")) == 1
    assert len(campaign.select(normal_load=lambda load: load > 0.07)) == 1
    by_load = campaign.group("normal_load")
    assert {key: len(group) for key, group in by_load.items()} == {0.05: 2, 0.1: 1}
    by_both = campaign.group(("preparation", "velocity"))
    assert sorted(len(group) for group in by_both.values()) == [1, 1, 1]
    assert "by normal_load" in campaign.report()


@pytest.mark.parametrize("suffix", [".parquet", ".csv"])
def test_save_and_load_identically(folder, suffix):
    campaign = granflow.Campaign.from_manifest(folder / "campaign.yaml")
    path = campaign.save(folder / f"tidy{suffix}")
    back = granflow.Campaign.load(path)
    assert len(back) == len(campaign) and back.problems == campaign.problems
    for a, b in zip(campaign, back, strict=True):
        for name in ("t", "slip", "velocity", "force"):
            np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
        assert a.control == b.control
        assert dict(a.meta) == dict(b.meta)
        assert a.problems == b.problems
    if suffix == ".csv":  # pandas reads the table as it is; the metadata is beside it
        table = pd.read_csv(path)
        assert table["run"].tolist() == [k for k, run in enumerate(campaign, 1) for _ in run.t]
        np.testing.assert_array_equal(table["force_N"], np.concatenate([r.force for r in back]))
    frame = back.to_frame()
    assert {"run", "t", "slip", "velocity", "force", "control", "normal_load"} <= set(frame)
    assert len(frame) == sum(len(run) for run in campaign)


def test_manifest_errors_name_the_entry(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("- {file: a.csv, normal_load: 5 furlongs}\n", encoding="utf-8")
    with pytest.raises(granflow.FileFormatError, match="entry 1"):
        granflow.Campaign.from_manifest(bad, errors="raise")
    bad.write_text("- {file: a.csv, colour: red}\n", encoding="utf-8")
    with pytest.raises(granflow.FileFormatError, match="unknown field 'colour'"):
        granflow.Campaign.from_manifest(bad, errors="raise")
    (problem,) = granflow.Campaign.from_manifest(bad).problems
    assert "entry 1 (line 1): unknown field 'colour'" in problem


def test_manifest_test_kind_is_checked(tmp_path):
    manifest = tmp_path / "manifest.csv"
    manifest.write_text("file,test\nrun.csv,Creep\n", encoding="utf-8")
    assert granflow.io.campaign.read_manifest(manifest) == [{"file": "run.csv", "test": "creep"}]
    manifest.write_text("file,test\nrun.csv,slide\n", encoding="utf-8")
    with pytest.raises(granflow.FileFormatError, match="line 2: test must be one of"):
        granflow.io.campaign.read_manifest(manifest)
