"""Fuzzing the manifest (issue 31): hostile manifests, written here with the truth of each
entry, are read entry by entry as that truth (a good entry's fields, a bad entry under its
own label, the manifest and its line named) or refused as a whole with a FileFormatError
naming the manifest and a line; files outside the campaign folder are never read; nothing
else escapes. The budget: see :mod:`fuzzing`."""

import math
import os
import re

import pytest
from fuzzing import budget
from hypothesis import event, given
from hypothesis import strategies as st

import granflow
from granflow.io.campaign import manifest_runs
from granflow.io.manifest import BadEntry, read_manifest

#: (as written, where it leads: a name inside the folder, or None outside)
FILES = (
    ("r1.csv", "r1.csv"),
    ("r2.csv", "r2.csv"),
    ("./r3.csv", "r3.csv"),
    ("sub/../r1.csv", "r1.csv"),
    ("missing.csv", "missing.csv"),
    ("../outside.csv", None),
    ("{absolute_outside}", None),
    ("link.csv", None),
)
#: (as written, SI value or None where the entry is bad because of it)
LOADS = (
    ("20 mN", 0.02),
    ("0.05 N", 0.05),
    ("20", None),
    ("-1 mN", None),
    ("1e300 N", None),
    ("abc", None),
    (".nan", None),
    ("5 furlongs", None),
)
VELOCITIES = (("0.86 um/s", 0.86e-6), ("1 mm/s", 1e-3), ("0 um/s", None), ("fast", None))
DAMAGES = ("none", "duplicate key", "deep nesting", "anchor", "unknown top-level",
           "broken yaml", "not utf-8", "no runs", "bom")  # fmt: skip


@pytest.fixture
def folder(tmp_path):
    campaign = tmp_path / "campaign"
    campaign.mkdir(exist_ok=True)
    text = "Time [s],Torque [mN m]\n" + "".join(f"{i}.5,{i + 1}.25\n" for i in range(12))
    for name in ("r1.csv", "r2.csv", "r3.csv"):
        (campaign / name).write_text(text, encoding="utf-8")
    outside = tmp_path / "outside.csv"
    outside.write_text("root:x:0:0:secret,line\n1,2\n", encoding="utf-8")
    link = campaign / "link.csv"
    if not link.is_symlink():
        link.symlink_to(outside)
    return campaign


@st.composite
def entries(draw):
    """A manifest entry: its fields as written, and (expected fields or None when bad)."""
    written, bad = {}, False
    file, inside = draw(st.sampled_from(FILES))
    written["file"] = file
    expected = {"file": file}
    if draw(st.booleans()):
        interval = draw(st.sampled_from((1, 2, "x", 0)))
        written["interval"] = interval
        if isinstance(interval, int) and interval > 0:
            expected["interval"] = interval
        else:
            bad = True
    for key, pool in (("normal_load", LOADS), ("velocity", VELOCITIES)):
        if draw(st.booleans()):
            text, value = draw(st.sampled_from(pool))
            written[key] = text
            expected[key] = value
            bad = bad or value is None
    if draw(st.booleans()):
        notes = draw(st.sampled_from(("plain", "café µm", "x" * 300)))
        written["notes"] = notes
        expected["notes"] = notes
    if draw(st.integers(0, 9)) == 0:
        written["colour"] = "red"
        bad = True
    return written, (None if bad else expected), inside


def _yaml_entry(written, flow):
    def value(v):
        return str(v) if not isinstance(v, str) or v[:1] not in "*&!%@`'\"{[" else repr(v)

    if flow:
        return "  - {" + ", ".join(f"{k}: {value(v)}" for k, v in written.items()) + "}"
    items = list(written.items())
    lines = [f"  - {items[0][0]}: {value(items[0][1])}"]
    lines += [f"    {k}: {value(v)}" for k, v in items[1:]]
    return "\n".join(lines)


def _lines_of(text):
    return [int(number) for number in re.findall(r"line[s]? (\d+)", text)]


@budget(150)
@given(data=st.data())
def test_a_hostile_manifest_is_read_entry_by_entry_or_refused_naming_its_line(folder, data):
    absolute = str(folder.parent / "outside.csv")
    made = data.draw(st.lists(entries(), min_size=1, max_size=8))
    damage = data.draw(st.sampled_from(DAMAGES))
    flow = data.draw(st.booleans())
    blocks = []
    for written, _, _ in made:
        written = {k: (absolute if v == "{absolute_outside}" else v) for k, v in written.items()}
        blocks.append(_yaml_entry(written, flow))
    whole_error = damage in ("duplicate key", "deep nesting", "unknown top-level", "broken yaml",
                             "not utf-8", "no runs")  # fmt: skip
    anchored = None
    if damage == "duplicate key":
        blocks[0] = blocks[0].replace("  - {", "  - {notes: a, notes: b, ", 1)
        if not flow:
            blocks[0] += "\n    sample: a\n    sample: b"
    elif damage == "deep nesting":
        depth = data.draw(st.integers(17, 3000))
        blocks.append(f"  - {{file: r1.csv, notes: {'[' * depth}{']' * depth}}}")
    elif damage == "anchor":
        anchored = data.draw(st.integers(0, len(blocks) - 1))
        blocks[anchored] = blocks[anchored].replace("  - ", "  - &a ", 1)
    elif damage == "broken yaml":
        blocks.append("  - {file: [r1.csv")
    text = "runs:\n" + "\n".join(blocks) + "\n"
    if damage == "unknown top-level":
        text += "colour: red\n"
    if damage == "no runs":
        text = "runs: []\n"
    raw = text.encode("utf-8")
    if damage == "not utf-8":
        raw += "# é\n".encode("latin-1")
    if damage == "bom":
        raw = b"\xef\xbb\xbf" + raw
    path = folder / "manifest.yaml"
    path.write_bytes(raw)
    event(f"damage: {damage}")
    try:
        read = read_manifest(path, errors="collect")
    except granflow.FileFormatError as error:
        event("refused as a whole")
        message = str(error)
        assert whole_error, (damage, message)
        assert str(path) in message and _lines_of(message), message
        with pytest.raises(granflow.FileFormatError):
            manifest_runs(path)
        return
    assert not whole_error, damage
    assert len(read) == len(made)
    claimed = {}
    for index, ((_, expected, inside), entry) in enumerate(zip(made, read, strict=True)):
        bad = expected is None or inside is None or index == anchored
        if not bad:  # a repeat of a good entry before it is bad too (a bad one claims none)
            interval = expected.get("interval")
            earlier = claimed.setdefault(inside, set())
            bad = None in earlier or (interval is None and earlier) or interval in earlier
            if not bad:
                earlier.add(interval)
        event("a bad entry" if bad else "a good entry")
        if bad:
            assert isinstance(entry, BadEntry), (index, entry)
            assert str(path) in entry.reason and f"entry {index + 1}" in entry.reason
            assert _lines_of(entry.reason) or index == anchored, entry.reason
            assert "secret" not in entry.reason and "root:x" not in entry.reason
            continue
        assert not isinstance(entry, BadEntry), (index, entry.reason)
        assert entry["file"] == expected["file"] or expected["file"] == "{absolute_outside}"
        for key, value in expected.items():
            if key == "file":
                continue
            if isinstance(value, float):
                assert math.isclose(entry[key], value, rel_tol=1e-12), (key, entry[key])
            else:
                assert entry[key] == value, (key, entry[key], value)
    found = manifest_runs(path)  # reads the files: only those inside the folder
    assert len(found) == len(read)
    for entry in found:
        if entry.reason is not None:
            assert str(path) in entry.reason or (entry.file and str(entry.file) in entry.reason)
            assert "secret" not in entry.reason and "root:x" not in entry.reason
        for run in entry.runs:
            source = os.path.realpath(run.meta["source"])
            assert source.startswith(os.path.realpath(folder) + os.sep), source


def test_the_manifest_fuzzer_meets_every_kind_of_entry():
    """The generator's pools hold good and bad values of each kind (a check of the test)."""
    assert any(value is None for _, value in LOADS) and any(value for _, value in LOADS)
    assert any(inside is None for _, inside in FILES) and any(inside for _, inside in FILES)
