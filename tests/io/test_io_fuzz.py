"""Fuzzing the readers (issue 31): damaged exports of every format granflow reads, each
made with a known truth (:mod:`fuzzing`), are read equal to that truth or refused with a
GranflowError naming the file and a line; mutated real exports likewise raise only
FileFormatError; nothing else escapes, nothing hangs, and inputs are not modified.

The budget is small in the test suite (the same cases every run); set
GRANFLOW_FUZZ_EXAMPLES=N for N random cases per test (see the README)."""

import atexit
import hashlib
import os
import shutil
import tempfile
from dataclasses import replace
from pathlib import Path

import numpy as np
from conftest import shared_data
from fuzzing import (
    NON_FINITE,
    SERIES,
    SERIES_CELL,
    Expect,
    budget,
    check_error,
    csv_cells,
    csv_line,
    damaged,
    encode,
    exports,
    interval_values,
    mixed,
    same_values,
    tidy_expected,
    tidy_runs,
    velocity_step_files,
    velocity_step_truth,
)
from hypothesis import event, given
from hypothesis import strategies as st

import granflow
from granflow.errors import GranflowError
from granflow.io import write_rheocompass, write_trios


def _exports():
    beside = Path(__file__).resolve().parents[2].parent / "shared"
    root = Path(os.environ.get("GRANFLOW_SHARED", beside))
    return root / "data" / "instrument-exports"


def _written(directory):
    time = np.linspace(0.0, 20.0, 15)
    run = granflow.Run(
        t=time,
        slip=1e-6 * time,
        velocity=np.full(15, 1e-6),
        force=0.01 + 1e-4 * time,
        meta={"normal_load": 0.05, "sample": "s"},
    )
    french = write_rheocompass(
        directory / "fr.csv", [run, run], language="fr", decimal=",", units={"torque": "µN·m"}
    )
    german = write_rheocompass(directory / "de.txt", run, language="de", encoding="cp1252")
    trios = write_trios(directory / "trios.txt", [run, run])
    return [french, german, trios]


SOURCES = sorted(path for path in _exports().glob("*.*") if path.suffix != ".md")
# written at collection time (the files are parameters); removed when the process ends
_WRITTEN_DIR = Path(tempfile.mkdtemp(prefix="granflow-fuzz-"))
atexit.register(shutil.rmtree, _WRITTEN_DIR, ignore_errors=True)


def _sources():
    return SOURCES + _written(_WRITTEN_DIR)


ALL_SOURCES = _sources()
HASHES = {path: hashlib.sha256(path.read_bytes()).hexdigest() for path in ALL_SOURCES}


def _encoding(raw):
    if raw.startswith((b"\xff\xfe", b"\xfe\xff")):
        return "utf-16"
    try:
        raw.decode("utf-8")
        return "utf-8"
    except UnicodeDecodeError:
        return "cp1252"


def _mutate(raw, kind, where, payload):
    if kind == "truncate":
        return raw[: int(where * len(raw))]
    if kind == "random bytes":
        at = int(where * len(raw))
        return raw[:at] + payload + raw[at:]
    encoding = _encoding(raw)
    lines = raw.decode(encoding, errors="replace").split("\n")
    at = min(int(where * len(lines)), len(lines) - 1)
    if kind == "delete line":
        del lines[at]
    elif kind == "duplicate line":
        lines.insert(at, lines[at])
    elif kind == "swap delimiters":
        lines = [line.replace("\t", ";" if payload[:1] < b"\x80" else ",") for line in lines]
    elif kind == "swap one line's delimiter":
        lines[at] = lines[at].replace("\t", ",")
    return "\n".join(lines).encode(encoding, errors="replace")


KINDS = (
    "truncate",
    "random bytes",
    "delete line",
    "duplicate line",
    "swap delimiters",
    "swap one line's delimiter",
)


@budget(150)
@given(
    source=st.sampled_from(ALL_SOURCES),
    kinds=st.lists(st.sampled_from(KINDS), min_size=1, max_size=3),
    where=st.floats(0.0, 1.0),
    payload=st.binary(min_size=1, max_size=12),
)
def test_mutated_exports_raise_only_file_format_errors(tmp_path, source, kinds, where, payload):
    raw = source.read_bytes()
    for kind in kinds:
        raw = _mutate(raw, kind, where, payload)
    copy = tmp_path / f"mutated{source.suffix}"
    copy.write_bytes(raw)
    try:
        runs = granflow.read_runs(copy)
    except granflow.FileFormatError as exc:
        message = str(exc)
        assert str(copy) in message, message
        assert "line " in message, message
    else:
        assert all(isinstance(run, granflow.Run) for run in runs)
    assert hashlib.sha256(source.read_bytes()).hexdigest() == HASHES[source]


def test_inputs_are_never_modified():
    for path in ALL_SOURCES:
        granflow.read(path)
        granflow.read_runs(path)
        assert hashlib.sha256(path.read_bytes()).hexdigest() == HASHES[path]


def test_the_real_exports_are_among_the_fuzzed_files():
    exports = shared_data("instrument-exports")
    assert exports.resolve() == _exports().resolve()
    assert len(SOURCES) >= 5, f"only {len(SOURCES)} real exports found in {exports}"


@budget(400)
@given(data=st.data())
def test_a_damaged_export_reads_as_its_truth_or_is_refused_naming_file_and_line(tmp_path, data):
    made = data.draw(damaged(data.draw(exports())))
    path = tmp_path / made.written.name
    path.write_bytes(made.raw)
    expect = made.expect
    context = (made.written.form, made.written.encoding, made.damage, made.details)
    try:
        parsed = granflow.read(path)
    except GranflowError as error:
        event(f"{made.written.form}, {made.damage}: refused")
        assert expect.error in ("may", "must"), (context, str(error))
        check_error(error, path, expect)
        return
    assert expect.error != "must", (context, parsed.report())
    event(f"{made.written.form}, {made.damage}: read")
    quantities = [column.quantity for column in made.written.table.columns]
    found = [i for i in parsed.intervals if any(i.find(q) is not None for q in quantities)]
    if expect.values.shape[0] == 0:  # nothing of the truth is left: nothing of it is read
        assert sum(interval.rows for interval in found) == 0, (context, parsed.report())
        _runs_or_error(path, expect)
        return
    (interval,) = parsed.intervals
    try:
        same_values(interval_values(interval, made.written.table.columns), expect.values)
    except AssertionError as failure:
        raise AssertionError((context, parsed.report())) from failure
    _runs_or_error(path, expect)


def _runs_or_error(path, expect):
    """The file as runs, or a GranflowError naming it and a line: nothing else."""
    try:
        runs = granflow.read_runs(path)
    except GranflowError as error:
        check_error(error, path, replace(expect, line=None))
    else:
        assert all(isinstance(run, granflow.Run) for run in runs)


# --------------------------------------------------------------------------- tidy tables

TIDY_DAMAGES = ("none", "truncate", "extra cell", "blank extra cell", "non-finite",
                "cross delimiter", "mixed encoding", "duplicate row", "delete row",
                "blank line")  # fmt: skip


@budget(150)
@given(data=st.data())
def test_a_damaged_tidy_table_reads_as_its_truth_or_is_refused_naming_file_and_line(tmp_path, data):
    from granflow.io import tidy

    runs = data.draw(tidy_runs())
    path = tidy.write_tidy(tmp_path / "table.csv", runs)
    sidecar = data.draw(st.booleans())
    if not sidecar:
        tidy.sidecar_path(path).unlink()
    lines = path.read_text(encoding="utf-8").splitlines()
    total = len(lines) - 1
    kind = data.draw(st.sampled_from(TIDY_DAMAGES))
    row = data.draw(st.integers(0, total - 1))
    at = row + 1
    # a row more or fewer: refused where the metadata counts the rows, read where none does
    counted = "may" if sidecar else "never"
    expect, raw = Expect(tidy_expected(runs)), None
    if kind == "truncate":
        raw, ends = encode(lines, "utf-8", "\n")
        cut = data.draw(st.integers(0, len(raw)))
        whole = sum(1 for index in range(1, len(lines)) if ends[index] < cut)
        expect, raw = Expect(tidy_expected(runs, range(whole)), "may"), raw[:cut]
    elif kind == "blank extra cell":  # granflow never writes one: refused or read whole
        lines[at] += ","
        expect = Expect(expect.values, "may")
    elif kind == "extra cell":
        lines[at] += ",7"
        expect = Expect(None, "must", at + 1)
    elif kind == "non-finite":
        name = data.draw(st.sampled_from(SERIES))
        token = data.draw(st.sampled_from(NON_FINITE))
        cells = csv_cells(lines[at])
        cells[SERIES_CELL[name]] = token
        lines[at] = csv_line(cells)
        expect = Expect(tidy_expected(runs, changed=((row, name), float(token))), "may")
    elif kind == "cross delimiter":
        lines[at] = lines[at].replace(",", ";")
        expect = Expect(None, "must", at + 1)
    elif kind == "mixed encoding":
        index = data.draw(st.integers(0, len(lines) - 1))
        body = lines[index].encode("latin-1", errors="replace")
        raw = mixed(lines, "utf-8", "\n", index, body)
        expect = Expect(expect.values, "never" if body == lines[index].encode() else "may")
    elif kind == "duplicate row":
        lines.insert(at, lines[at])
        order = [*range(row + 1), *range(row, total)]
        expect = Expect(tidy_expected(runs, order), counted)
    elif kind == "delete row":
        del lines[at]
        order = [index for index in range(total) if index != row]
        expect = Expect(tidy_expected(runs, order), counted)
    elif kind == "blank line":
        lines.insert(at, "")
        expect = Expect(expect.values, "may")
    if raw is None:
        raw, _ = encode(lines, "utf-8", "\n")
    path.write_bytes(raw)
    context = (kind, sidecar, row)
    try:
        table = tidy.read_tidy(path)
    except GranflowError as error:
        event(f"tidy, {kind}: refused")
        assert expect.error in ("may", "must"), (context, str(error))
        check_error(error, path, expect)
        return
    assert expect.error != "must", context
    event(f"tidy, {kind}: read")
    assert len(table.runs) == len(expect.values), context
    for run, arrays in zip(table.runs, expect.values.values(), strict=True):
        for name in SERIES:
            same_values(getattr(run, name), arrays[name])


# --------------------------------------------------------------------------- velocity steps

STEP_DAMAGES = ("none", "truncate", "extra cell", "blank extra cell", "non-finite",
                "cross delimiter", "cross decimal", "mixed encoding", "duplicate row",
                "delete row", "blank line")  # fmt: skip


@budget(100)
@given(data=st.data())
def test_a_damaged_velocity_step_record_reads_as_its_truth_or_is_refused(tmp_path, data):
    from granflow import rsf

    lines, delimiter, encoding, newline, truth = data.draw(velocity_step_files())
    lines = list(lines)
    kind = data.draw(st.sampled_from(STEP_DAMAGES))
    row = data.draw(st.integers(1, len(truth) - 2))  # not the first row: it sets the origin
    at = row + 1
    expect, raw = Expect(truth), None
    if kind == "truncate":
        raw, ends = encode(lines, encoding, newline)
        cut = data.draw(st.integers(0, len(raw)))
        whole = sum(1 for index in range(1, len(lines)) if ends[index] < cut)
        expect, raw = Expect(truth[:whole], "may"), raw[:cut]
    elif kind in ("extra cell", "blank extra cell"):
        lines[at] += delimiter + (" " if kind == "blank extra cell" else "9")
        expect = Expect(truth) if kind == "blank extra cell" else Expect(None, "must", at + 1)
    elif kind == "non-finite":
        cells = lines[at].split(delimiter)
        cells[data.draw(st.integers(0, 2))] = data.draw(st.sampled_from(NON_FINITE))
        lines[at] = delimiter.join(cells)
        expect = Expect(None, "must", at + 1)
    elif kind == "cross delimiter":
        lines[at] = lines[at].replace(delimiter, ";")
        expect = Expect(None, "must", at + 1)
    elif kind == "cross decimal":
        lines[at] = lines[at].replace(".", ",", 1)
        expect = Expect(truth, "may")
    elif kind == "mixed encoding":
        index = data.draw(st.integers(0, len(lines) - 1))
        other = data.draw(st.sampled_from(("latin-1", "utf-8")))
        body = lines[index].encode(other, errors="replace")
        raw = mixed(lines, encoding, newline, index, body)
        same = body == lines[index].encode({"utf-16": "utf-16-le"}.get(encoding, encoding))
        expect = Expect(truth, "never" if same else "may")
    elif kind == "duplicate row":
        lines.insert(at, lines[at])
        expect = Expect(None, "must", at + 2)  # the time repeats on the copy
    elif kind == "delete row":
        del lines[at]
        expect = Expect(np.delete(truth, row, axis=0))
    elif kind == "blank line":
        lines.insert(at, "")
        expect = Expect(truth)
    if raw is None:
        raw, _ = encode(lines, encoding, newline)
    path = tmp_path / "steps.txt"
    path.write_bytes(raw)
    context = (kind, encoding, repr(delimiter), row)
    try:
        record = rsf.read_velocity_steps(path)
    except GranflowError as error:
        event(f"velocity steps, {kind}: refused")
        assert expect.error in ("may", "must"), (context, str(error))
        check_error(error, path, expect)
        return
    assert expect.error != "must", context
    event(f"velocity steps, {kind}: read")
    t, displacement, friction = velocity_step_truth(expect.values)
    same_values(record.t, t)
    same_values(record.displacement, displacement)
    same_values(record.friction, friction)
