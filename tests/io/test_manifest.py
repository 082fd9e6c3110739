"""Manifests read strictly and within bounds: each bad entry is a one-line error under its own
label, the rest of the campaign is read, nothing is expanded, each file is read once."""

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import granflow
from granflow.io import write_rheocompass
from granflow.io.campaign import manifest_runs
from granflow.io.manifest import MAX_MANIFEST_BYTES, BadEntry, read_manifest

GOOD = "  - {file: runs.csv, interval: 1, normal_load: 20 mN}\n"


def _run(seed):
    rng = np.random.default_rng(seed)
    time = np.arange(0.0, 30.0)
    return granflow.Run(
        t=time,
        slip=1e-6 * time,
        velocity=np.full(time.size, 1e-6),
        force=0.01 * (1 - np.exp(-time / 5)) + rng.normal(0, 1e-6, time.size),
    )


@pytest.fixture
def folder(tmp_path):
    write_rheocompass(tmp_path / "runs.csv", [_run(1), _run(2), _run(3)])
    return tmp_path


def _manifest(folder, bad_entry, name="manifest.yaml"):
    path = folder / name
    path.write_text("runs:\n" + GOOD + bad_entry + GOOD.replace("1,", "3,"), encoding="utf-8")
    return path


def _bomb(levels=9):
    """A billion-laughs entry: 9 ** levels strings once expanded (9 ** 9 = 387 million)."""
    lines = ['    notes: &l0 ["lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol"]']
    for level in range(1, levels):
        items = ", ".join([f"*l{level - 1}"] * 9)
        lines.append(f"    sample{level}: &l{level} [{items}]")
    return "  - file: runs.csv\n    interval: 2\n" + "\n".join(lines) + "\n"


@pytest.mark.parametrize(
    ("entry", "label", "message"),
    [
        (_bomb(), "runs.csv#2", "YAML anchors and aliases are not allowed (found &l0)"),
        (
            "  - {file: runs.csv, interval: 2, colour: red}\n",
            "runs.csv#2",
            "unknown field 'colour'",
        ),
        (
            "  - {file: runs.csv, interval: 2, normal_load: -1 mN}\n",
            "runs.csv#2",
            "normal_load must be positive, got '-1 mN'",
        ),
        (
            "  - {file: runs.csv, interval: 2, normal_load: 20}\n",
            "runs.csv#2",
            "normal_load 20 has no unit; write it with one, e.g. '20 mN'",
        ),
        (
            "  - {file: runs.csv, interval: 2, velocity: .nan}\n",
            "runs.csv#2",
            "velocity must be finite",
        ),
        (
            "  - {file: runs.csv, interval: 2, velocity: 0 um/s}\n",
            "runs.csv#2",
            "velocity must be positive",
        ),
        ("  - {file: runs.csv, interval: 99}\n", "runs.csv#99", "no interval 99 (the file has 3)"),
        (
            "  - {file: runs.csv, interval: 2.5}\n",
            "runs.csv",
            "interval must be a positive integer",
        ),
        (
            "  - {file: runs.csv, interval: 2, geometry: 'outer_radius=5 mm'}\n",
            "runs.csv#2",
            "geometry must be 'paper' or give",
        ),
        ("  - {interval: 2}\n", "manifest entry 2 (line 3)", "the entry has no 'file'"),
    ],
)
def test_a_bad_entry_is_one_line_under_its_own_label_and_the_rest_is_read(
    folder, entry, label, message
):
    entries = manifest_runs(_manifest(folder, entry))
    assert [len(e.runs) for e in entries] == [1, 0, 1]
    assert [e.label for e in entries] == ["runs.csv#1", label, "runs.csv#3"]
    reason = entries[1].reason
    assert message in reason and "\n" not in reason
    assert [e.runs[0].meta["interval"] for e in (entries[0], entries[2])] == [1, 3]
    with pytest.raises(granflow.FileFormatError, match=r"entry 2|interval 99"):
        granflow.Campaign.from_manifest(folder / "manifest.yaml", errors="raise")


@pytest.mark.skipif(
    not Path("/proc/self/status").is_file(), reason="reads the peak memory from /proc (Linux)"
)
def test_the_bomb_is_refused_before_expansion_in_little_memory(folder):
    manifest = _manifest(folder, _bomb())
    # VmHWM: the peak resident memory of this process image (unlike ru_maxrss, it does not
    # carry the parent's over the exec)
    script = (
        "import sys\n"
        "from granflow.io.campaign import manifest_runs\n"
        "entries = manifest_runs(sys.argv[1])\n"
        "print(sum(len(e.runs) for e in entries), entries[1].reason.count('\\n'))\n"
        "status = open('/proc/self/status').read().split('VmHWM:')[1]\n"
        "print(status.split()[0])\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", script, str(manifest)],
        capture_output=True,
        text=True,
        timeout=120,
        check=True,
    )
    counts, peak_kib = done.stdout.split("\n")[:2]
    assert counts == "2 0"
    assert int(peak_kib) < 300 * 1024  # peak RSS under 300 MB


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("runs:\n" + GOOD + "colour: red\n", "unknown top-level key 'colour'"),
        ("defaults: {colour: red}\nruns:\n" + GOOD, "defaults (line 1): unknown field 'colour'"),
        (
            "defaults: {normal_load: 20}\nruns:\n" + GOOD,
            "defaults (line 1): normal_load 20 has no unit",
        ),
        ("a: &a [x, x]\nruns:\n" + GOOD, "unknown top-level key 'a'"),
        ("runs: *a\n", "YAML anchors and aliases are not allowed (found *a)"),
        ("runs: [\n", "line 2: not valid YAML"),
    ],
)
def test_a_bad_manifest_as_a_whole_is_one_line(folder, text, message):
    path = folder / "manifest.yaml"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(granflow.FileFormatError, match=r"manifest\.yaml") as error:
        manifest_runs(path)
    assert message in str(error.value) and "\n" not in str(error.value)


def test_an_alias_in_a_merge_key_is_the_entry_error(folder):
    path = folder / "manifest.yaml"
    path.write_text(
        "runs:\n" + GOOD + "  - {<<: *base, file: runs.csv, interval: 2}\n", encoding="utf-8"
    )
    assert "found *base" in manifest_runs(path)[1].reason  # refused before it is looked up
    path.write_text(
        "runs:\n  - &base {file: runs.csv, interval: 1, normal_load: 20 mN}\n"
        "  - {<<: *base, interval: 2}\n" + GOOD.replace("1,", "3,"),
        encoding="utf-8",
    )
    entries = manifest_runs(path)
    assert [len(e.runs) for e in entries] == [0, 0, 1]
    assert "found &base" in entries[0].reason and "found *base" in entries[1].reason


def test_a_manifest_over_the_size_limit_is_refused_unread(folder):
    path = folder / "manifest.yaml"
    path.write_text("runs:\n" + GOOD + "#" * MAX_MANIFEST_BYTES + "\n", encoding="utf-8")
    with pytest.raises(granflow.FileFormatError, match="more than the limit of 1048576 bytes"):
        read_manifest(path)


def test_csv_manifest_entries_are_checked_per_line(folder):
    path = folder / "manifest.csv"
    path.write_text(
        "file,interval,normal_load\nruns.csv,1,20 mN\nruns.csv,2,20\nruns.csv,3,0.02 N\n",
        encoding="utf-8",
    )
    entries = read_manifest(path, errors="collect")
    assert isinstance(entries[1], BadEntry) and entries[1].label == "runs.csv#2"
    assert "line 3: normal_load '20' has no unit" in entries[1].reason
    assert entries[2]["normal_load"] == pytest.approx(0.02, rel=1e-15)
    path.write_text("file,colour\nruns.csv,red\n", encoding="utf-8")
    with pytest.raises(granflow.FileFormatError, match="line 1: unknown column 'colour'"):
        read_manifest(path)


def test_each_file_is_read_once_however_many_entries_name_it(folder, monkeypatch):
    import granflow.io

    calls = []
    original = granflow.io.read_runs

    def counting(path, **options):
        calls.append(str(path))
        return original(path, **options)

    monkeypatch.setattr(granflow.io, "read_runs", counting)
    path = folder / "manifest.yaml"
    path.write_text(
        "runs:\n" + "".join(GOOD.replace("1,", f"{i},") for i in (1, 2, 3)), encoding="utf-8"
    )
    campaign = granflow.Campaign.from_manifest(path)
    assert [run.meta["interval"] for run in campaign] == [1, 2, 3]
    assert len(calls) == 1


def test_the_geometry_converts_and_is_named(folder):
    # the same export three times under three names (one entry may name a run only once)
    for copy in ("paper.csv", "other.csv"):
        (folder / copy).write_bytes((folder / "runs.csv").read_bytes())
    path = folder / "manifest.yaml"
    path.write_text(
        "defaults: {normal_load: 20 mN}\nruns:\n"
        "  - {file: runs.csv, interval: 1}\n"
        "  - {file: paper.csv, interval: 1, geometry: paper}\n"
        "  - {file: other.csv, interval: 1, geometry: 'outer_radius=10 mm, inner_radius=8 mm'}\n",
        encoding="utf-8",
    )
    default, paper, other = granflow.Campaign.from_manifest(path)
    assert default.meta["geometry"] == "paper (default)" and paper.meta["geometry"] == "paper"
    assert other.meta["geometry"].startswith("outer radius 10 mm, inner radius 8 mm")
    tube = granflow.Annulus.from_spec({"outer_radius": 0.01, "inner_radius": 0.008})
    paper_tube = granflow.Annulus.paper()
    # torque -> force with r_eff, angle -> slip with r_m
    ratio = paper_tube.effective_radius / tube.effective_radius
    np.testing.assert_allclose(other.force, paper.force * ratio, rtol=1e-12)
    np.testing.assert_allclose(
        other.slip, paper.slip * tube.mean_radius / paper_tube.mean_radius, rtol=1e-12
    )
    declared = granflow.Campaign.from_manifest(path, geometry="paper")
    assert declared[0].meta["geometry"] == "paper"
