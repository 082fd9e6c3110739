"""Manifests tried as a user (or someone who shares one) would (issue 31, points 3, 8, 10,
11, 12): repeats and duplicated keys are errors naming both lines, deep nesting is refused
before it recurses, files outside the campaign folder are not read, and no message copies
the content of a file."""

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import granflow
from granflow.io import write_rheocompass
from granflow.io.campaign import manifest_runs
from granflow.io.manifest import BadEntry, read_manifest


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
def campaign(tmp_path):
    folder = tmp_path / "campaign"
    folder.mkdir()
    write_rheocompass(folder / "runs.csv", [_run(1), _run(2), _run(3)])
    return folder


def _write(folder, text, name="manifest.yaml"):
    path = folder / name
    path.write_text(text, encoding="utf-8")
    return path


# --------------------------------------------------------------------------- point 3


def test_the_same_entry_twice_is_an_error_naming_both_lines_and_counted_once(campaign):
    path = _write(
        campaign,
        "runs:\n"
        "  - {file: runs.csv, interval: 1, normal_load: 20 mN}\n"
        "  - {file: runs.csv, interval: 2, normal_load: 20 mN}\n"
        "  - {file: ./runs.csv, interval: 1, normal_load: 20 mN}\n",
    )
    entries = read_manifest(path, errors="collect")
    assert isinstance(entries[2], BadEntry) and not isinstance(entries[0], BadEntry)
    assert "entry 3 (line 4)" in entries[2].reason and "entry 1 (line 2)" in entries[2].reason
    campaign_runs = granflow.Campaign.from_manifest(path)
    assert [run.meta["interval"] for run in campaign_runs] == [1, 2]
    assert len(campaign_runs.problems) == 1
    with pytest.raises(granflow.FileFormatError, match=r"line 4.*line 2"):
        read_manifest(path)


def test_a_whole_file_and_one_of_its_intervals_are_the_same_runs_twice(campaign):
    path = _write(campaign, "runs:\n  - {file: runs.csv}\n  - {file: runs.csv, interval: 3}\n")
    entries = read_manifest(path, errors="collect")
    assert isinstance(entries[1], BadEntry) and "already named by entry 1" in entries[1].reason


def test_csv_manifest_repeats_name_both_lines(campaign):
    path = _write(campaign, "file,interval\nruns.csv,2\nruns.csv,1\nruns.csv,2\n", "m.csv")
    entries = read_manifest(path, errors="collect")
    assert isinstance(entries[2], BadEntry)
    assert "line 4" in entries[2].reason and "line 2" in entries[2].reason


def test_a_duplicated_yaml_key_is_an_error_naming_both_lines(campaign):
    path = _write(campaign, "runs:\n  - file: runs.csv\n    interval: 1\n    interval: 2\n")
    with pytest.raises(granflow.FileFormatError) as caught:
        read_manifest(path, errors="collect")
    message = str(caught.value)
    assert "lines 3 and 4" in message and "'interval'" in message


# --------------------------------------------------------------------------- point 8


@pytest.mark.parametrize("depth", [17, 5000, 100_000])
def test_a_manifest_nested_deeply_is_refused_before_it_recurses(campaign, depth):
    path = _write(campaign, f"runs:\n  - file: runs.csv\n    notes: {'[' * depth}{']' * depth}\n")
    with pytest.raises(granflow.FileFormatError, match=r"line 3: collections nested more"):
        read_manifest(path)


# --------------------------------------------------------------------------- point 11


def test_files_outside_the_campaign_folder_are_refused_and_not_read(campaign, tmp_path):
    secret = tmp_path / "secret.txt"
    secret.write_text("root:x:0:0:the first line of a private file\n", encoding="utf-8")
    (campaign / "link.txt").symlink_to(secret)
    path = _write(
        campaign,
        "runs:\n"
        "  - {file: ../secret.txt}\n"
        f"  - {{file: {secret}}}\n"
        "  - {file: link.txt}\n"
        "  - {file: runs.csv, interval: 1}\n",
    )
    entries = manifest_runs(path)
    assert [len(entry.runs) for entry in entries] == [0, 0, 0, 1]
    for entry in entries[:3]:
        assert "outside the campaign folder" in entry.reason
        assert "root:x" not in entry.reason and "private" not in entry.reason
    for first_line in ("root:x:0:0:private\n", "root:x:0:0:private\n1\n2\n", "a,b\n1,2\n"):
        secret.write_text(first_line, encoding="utf-8")
        path = _write(campaign, "runs:\n  - {file: ../secret.txt}\n")
        (entry,) = manifest_runs(path, allow_outside=True)  # read, and failed, named only
        assert entry.reason is not None and "secret.txt" in entry.reason, entry.reason
        assert "root:x" not in entry.reason and "private" not in entry.reason, entry.reason
        assert "'a'" not in entry.reason and "'b'" not in entry.reason, entry.reason


def test_an_absolute_path_inside_the_folder_is_read(campaign):
    path = _write(campaign, f"runs:\n  - {{file: {campaign / 'runs.csv'}, interval: 2}}\n")
    (entry,) = manifest_runs(path)
    assert len(entry.runs) == 1 and entry.reason is None


# --------------------------------------------------------------------------- point 12


@pytest.mark.parametrize("text", ["runs: []\n", "[]\n", "file,interval\n"])
def test_a_manifest_without_runs_is_an_error(campaign, text):
    name = "m.csv" if text.startswith("file") else "manifest.yaml"
    path = _write(campaign, text, name)
    with pytest.raises(granflow.FileFormatError, match="lists no runs"):
        read_manifest(path)


# --------------------------------------------------------------------------- point 10


@pytest.mark.skipif(
    not Path("/proc/self/status").is_file(), reason="reads the peak memory from /proc (Linux)"
)
def test_twelve_thousand_entries_are_read_in_bounded_memory(campaign):
    lines = ["runs:"]
    lines += [f"  - {{file: runs.csv, interval: {1 + i % 3}}}" for i in range(12_000)]
    path = _write(campaign, "\n".join(lines) + "\n")
    assert path.stat().st_size < (1 << 20)
    script = (
        "import sys\n"
        "from granflow.io.campaign import manifest_runs\n"
        "entries = manifest_runs(sys.argv[1])\n"
        "print(sum(len(e.runs) for e in entries), sum(e.reason is not None for e in entries))\n"
        "print(open('/proc/self/status').read().split('VmHWM:')[1].split()[0])\n"
    )
    source = Path(granflow.__file__).resolve().parents[1]  # the granflow under test
    done = subprocess.run(
        [sys.executable, "-c", script, str(path)],
        capture_output=True,
        text=True,
        timeout=300,
        check=True,
        env={**os.environ, "PYTHONPATH": str(source)},
    )
    counts, peak_kib = done.stdout.split("\n")[:2]
    assert counts == "3 11997"  # three runs, the repeats failed and named
    assert int(peak_kib) < 1024 * 1024  # under 1 GB


@pytest.mark.parametrize(
    ("field", "value"),
    [("normal_load", "1e300 N"), ("velocity", "1e10 m/s"), ("rest_time", "1e12 s")],
)
def test_a_quantity_beyond_any_laboratory_record_is_the_entrys_error(campaign, field, value):
    path = _write(campaign, f"runs:\n  - {{file: runs.csv, interval: 1, {field}: {value}}}\n")
    (entry,) = read_manifest(path, errors="collect")
    assert isinstance(entry, BadEntry)
    assert f"{field} '{value}' is beyond any laboratory record" in entry.reason
