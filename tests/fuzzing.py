"""Generators of damaged files for the fuzzing suite, each with the truth it was made from.

A file is written here, independently of granflow's writers, from a table of cells whose
numbers are known exactly (``float`` of the text written): an export of every format
granflow reads (RheoCompass in three languages, Rheoplus, TRIOS, a plain table with
instrument columns or with granflow's own names, a velocity-step record), in several
encodings, delimiters, decimal marks and line ends. Then one damage is done to it, and
:class:`Expect` says what a correct reader may answer: the values it must read (a prefix of
the rows, a NaN where a cell was made non-finite, ...) and whether an error naming the file
and a line is acceptable, or required (and on which line).

The number of cases each fuzz test runs is its small budget in the test suite;
``GRANFLOW_FUZZ_EXAMPLES=N`` runs N per test (a longer run by hand).
"""

from __future__ import annotations

import math
import os
import re
from dataclasses import dataclass, field, replace

import numpy as np
from hypothesis import HealthCheck, settings
from hypothesis import strategies as st

#: Examples per fuzz test: the suite's small budget unless GRANFLOW_FUZZ_EXAMPLES says more.
LONG_RUN = int(os.environ.get("GRANFLOW_FUZZ_EXAMPLES", "0") or 0)


def budget(small):
    """Hypothesis settings of a fuzz test: ``small`` examples in the test suite, derandomized
    (the same cases every run); ``GRANFLOW_FUZZ_EXAMPLES`` examples, random, by hand."""
    return settings(
        max_examples=LONG_RUN or small,
        deadline=None,
        derandomize=not LONG_RUN,
        database=None,
        suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
    )


# --------------------------------------------------------------------------- the tables


@dataclass(frozen=True)
class Column:
    """A column as written: header label, unit text, the quantity granflow reads it as, and
    the factor from the file's unit to SI (a divisor where the unit is a decimal prefix, as
    the reader divides, so that the expected values are rounded the same way)."""

    label: str
    unit: str
    quantity: str
    divisor: float = 1.0


INSTRUMENT = {
    "en": ("Time", "Torque", "Deflection Angle", "Rotational Speed"),
    "fr": ("Temps", "Couple", "Angle de Déflexion", "Vitesse de Rotation"),
    "de": ("Zeit", "Drehmoment", "Auslenkwinkel", "Drehzahl"),
}
INSTRUMENT_UNITS = (("s", "time", 1.0), ("mN·m", "torque", 1e3), ("mrad", "angle", 1e3),
                    ("1/min", "speed", 60.0))  # fmt: skip
OWN = (
    Column("t_s", "", "time"),
    Column("slip_m", "", "slip"),
    Column("velocity_m_s", "", "velocity"),
    Column("force_N", "", "force"),
)


def instrument_columns(language, count):
    labels = INSTRUMENT[language]
    return tuple(
        Column(label, unit, quantity, divisor)
        for label, (unit, quantity, divisor) in zip(labels[:count], INSTRUMENT_UNITS, strict=False)
    )


@st.composite
def numbers(draw, rows):
    """Cells of one column: decimals of up to 6 digits, each with its exact value."""
    cells = []
    for _ in range(rows):
        whole = draw(st.integers(-99999, 99999))
        digits = draw(st.integers(0, 5))
        fraction = draw(st.integers(0, 10**digits - 1)) if digits else 0
        sign = "-" if whole < 0 or (whole == 0 and draw(st.booleans()) and fraction) else ""
        text = f"{sign}{abs(whole)}" + (f".{fraction:0{digits}d}" if digits else "")
        cells.append(text)
    return cells


@dataclass(frozen=True)
class Table:
    """The cells of a file's data rows (with a dot as decimal mark) and their values."""

    columns: tuple
    cells: tuple  # rows of cell texts, one per column

    @property
    def rows(self):
        return len(self.cells)

    def values(self):
        """The SI value of every cell, as the reader converts it: rows x columns."""
        out = np.empty((self.rows, len(self.columns)))
        for j, column in enumerate(self.columns):
            for i, row in enumerate(self.cells):
                out[i, j] = float(row[j]) / column.divisor
        return out


@st.composite
def tables(draw, columns, fewest=2, most=30):
    count = draw(st.integers(fewest, most))
    time = [f"{i}.5" for i in range(count)]  # increasing, and a decimal mark to sniff
    others = [draw(numbers(count)) for _ in columns[1:]]
    cells = tuple(tuple(row) for row in zip(time, *others, strict=True))
    return Table(tuple(columns), cells)


# --------------------------------------------------------------------------- the formats


@dataclass(frozen=True)
class Written:
    """A file as lines of text, where its data rows are, and how it is encoded."""

    name: str
    form: str
    table: Table
    lines: tuple
    data_lines: tuple  # 0-based line index of each data row
    cell_offset: int  # cells before the first column's cell in a data row
    delimiter: str
    decimal: str
    encoding: str
    newline: str


def _row(table, i, delimiter, decimal, prefix=()):
    cells = [cell.replace(".", decimal) for cell in table.cells[i]]
    return delimiter.join([*prefix, *cells])


def write_csv(table, delimiter, decimal, encoding, newline, name="table.csv"):
    header = delimiter.join(
        f"{column.label} [{column.unit}]" if column.unit else column.label
        for column in table.columns
    )
    rows = [_row(table, i, delimiter, decimal) for i in range(table.rows)]
    return Written(name, "csv", table, (header, *rows), tuple(range(1, 1 + table.rows)), 0,
                   delimiter, decimal, encoding, newline)  # fmt: skip


_RHEOCOMPASS = {
    "en": ("Project:", "Test:", "Result:", "Interval and data points:", "Interval data:",
           "Point No."),
    "fr": ("Projet:", "Test:", "Résultat:", "Intervalle et points de données:",
           "Interval données:", "N° de point"),
    "de": ("Projekt:", "Test:", "Ergebnis:", "Intervall und Datenpunkte:", "Intervalldaten:",
           "Punkt Nr."),
}  # fmt: skip


def write_rheocompass(table, language, decimal, encoding, newline, name="export.txt"):
    project, test, result, points, data, point = _RHEOCOMPASS[language]
    labels = "\t".join(column.label for column in table.columns)
    units = "\t".join(f"[{column.unit}]" for column in table.columns)
    head = [
        f"{project}\tfuzz",
        f"{test}\tstart-up",
        f"{result}\tr",
        f"{points}\t1\t{table.rows}",
        f"{data}\t{point}\t{labels}",
        f"\t\t{units}",
    ]
    rows = [_row(table, i, "\t", decimal, ("", str(i + 1))) for i in range(table.rows)]
    first = len(head)
    return Written(name, "rheocompass", table, (*head, *rows),
                   tuple(range(first, first + table.rows)), 2, "\t", decimal, encoding,
                   newline)  # fmt: skip


def write_rheoplus(table, decimal, encoding, newline, name="rheoplus.txt"):
    labels = "\t".join(column.label for column in table.columns)
    units = "\t".join(f"[{column.unit}]" for column in table.columns)
    head = [
        "Data Series Information",
        "Name:\t\t\tseries A",
        f"Number of Data Points:\t\t\t{table.rows}",
        f"Meas. Pts.\t{labels}",
        f"\t{units}",
    ]
    rows = [_row(table, i, "\t", decimal, (str(i + 1),)) for i in range(table.rows)]
    first = len(head)
    return Written(name, "rheoplus", table, (*head, *rows),
                   tuple(range(first, first + table.rows)), 1, "\t", decimal, encoding,
                   newline)  # fmt: skip


def write_trios(table, encoding, newline, name="trios.txt"):
    labels = "\t".join(column.label for column in table.columns)
    units = "\t".join(column.unit for column in table.columns)
    head = ["Filename\tfuzz", "[step]", "Flow - 1", labels, units]
    rows = [_row(table, i, "\t", ".") for i in range(table.rows)]
    first = len(head)
    return Written(name, "trios", table, (*head, *rows),
                   tuple(range(first, first + table.rows)), 0, "\t", ".", encoding,
                   newline)  # fmt: skip


TRIOS_COLUMNS = (
    Column("Step time", "s", "interval_time"),
    Column("Torque", "µN.m", "torque", 1e6),
    Column("Displacement", "rad", "angle"),
    Column("Axial force", "N", "normal_force"),
)


@st.composite
def exports(draw):
    """A clean export of any format granflow reads, with its truth."""
    form = draw(st.sampled_from(("csv", "own", "rheocompass", "rheoplus", "trios")))
    newline = draw(st.sampled_from(("\n", "\r\n")))
    if form in ("csv", "own"):
        delimiter = draw(st.sampled_from((",", ";", "\t")))
        decimal = "." if delimiter == "," else draw(st.sampled_from((".", ",")))
        encoding = draw(st.sampled_from(("utf-8", "utf-8-sig", "cp1252", "utf-16")))
        if form == "own":
            columns = OWN[: draw(st.integers(2, 4))]
        else:
            columns = instrument_columns("en", draw(st.integers(2, 4)))
        return write_csv(draw(tables(columns)), delimiter, decimal, encoding, newline)
    if form == "rheocompass":
        language = draw(st.sampled_from(tuple(_RHEOCOMPASS)))
        columns = instrument_columns(language, draw(st.integers(2, 4)))
        decimal = draw(st.sampled_from((".", ",")))
        encoding = draw(st.sampled_from(("utf-16", "utf-8", "cp1252")))
        return write_rheocompass(draw(tables(columns)), language, decimal, encoding, newline)
    if form == "rheoplus":
        columns = (Column("Time", "s", "time"), Column("Torque", "µNm", "torque", 1e6),
                   Column("Deflection Angle", "mrad", "angle", 1e3))  # fmt: skip
        columns = columns[: draw(st.integers(2, 3))]
        decimal = draw(st.sampled_from((".", ",")))
        return write_rheoplus(draw(tables(columns)), decimal, "utf-8", newline)
    columns = TRIOS_COLUMNS[: draw(st.integers(2, 4))]
    return write_trios(draw(tables(columns)), draw(st.sampled_from(("utf-8", "cp1252"))), newline)


# --------------------------------------------------------------------------- bytes


def encode(lines, encoding, newline):
    """(bytes, the byte offset of each line's end) of lines joined by ``newline`` and ended
    by it; a BOM first for utf-8-sig and utf-16."""
    bom = {"utf-8-sig": b"\xef\xbb\xbf", "utf-16": b"\xff\xfe"}.get(encoding, b"")
    codec = {"utf-8-sig": "utf-8", "utf-16": "utf-16-le"}.get(encoding, encoding)
    parts, ends, size = [bom], [], len(bom)
    for line in lines:
        body = line.encode(codec)
        ends.append(size + len(body))
        chunk = body + newline.encode(codec)
        parts.append(chunk)
        size += len(chunk)
    return b"".join(parts), ends


def mixed(lines, encoding, newline, index, body):
    """The bytes of ``lines`` with line ``index`` replaced by ``body`` (another encoding)."""
    codec = codec_of(encoding)
    bom = {"utf-8-sig": b"\xef\xbb\xbf", "utf-16": b"\xff\xfe"}.get(encoding, b"")
    end = newline.encode(codec)
    parts = [body if k == index else line.encode(codec) for k, line in enumerate(lines)]
    return bom + b"".join(part + end for part in parts)


def codec_of(encoding):
    return {"utf-8-sig": "utf-8", "utf-16": "utf-16-le"}.get(encoding, encoding)


# --------------------------------------------------------------------------- damages


@dataclass(frozen=True)
class Expect:
    """What a correct reader answers to a damaged file.

    ``values`` (rows x columns, SI, NaN where the cell holds no number) is the read it must
    give when it reads; ``error`` is "never", "may" or "must"; ``line`` the line an error
    must name (1-based), when known.
    """

    values: np.ndarray | None
    error: str = "never"
    line: int | None = None
    note: str = ""


@dataclass(frozen=True)
class Damaged:
    written: Written
    raw: bytes
    expect: Expect
    damage: str = "none"
    details: dict = field(default_factory=dict)


NON_FINITE = ("inf", "-inf", "Infinity", "1e400", "-1E999", "nan", "NaN")


def _relines(written, lines):
    return replace(written, lines=tuple(lines))


@st.composite
def damaged(draw, written):
    """One damage to a written file, and what a correct reader answers to it."""
    truth = written.table.values()
    kinds = ("none", "truncate", "extra cell", "blank extra cell", "non-finite",
             "mixed encoding", "cross delimiter", "cross decimal", "duplicate row",
             "delete row", "blank line")  # fmt: skip
    kind = draw(st.sampled_from(kinds))
    lines = list(written.lines)
    row = draw(st.integers(0, written.table.rows - 1))
    at = written.data_lines[row]
    codec = codec_of(written.encoding)
    if kind == "truncate":
        raw, ends = encode(lines, written.encoding, written.newline)
        cut = draw(st.integers(0, len(raw)))
        whole = sum(1 for index in written.data_lines if ends[index] < cut)
        expect = Expect(truth[:whole], "may", note=f"cut at byte {cut}")
        return Damaged(written, raw[:cut], expect, kind, {"cut": cut})
    if kind in ("extra cell", "blank extra cell"):
        token = " " if kind == "blank extra cell" else draw(st.sampled_from(("1", "x", "0.5")))
        lines[at] = lines[at] + written.delimiter + token
        expect = Expect(truth) if kind == "blank extra cell" else Expect(None, "must", at + 1)
        return _done(written, lines, expect, kind, {"row": row})
    if kind == "non-finite":
        column = draw(st.integers(0, len(written.table.columns) - 1))
        token = draw(st.sampled_from(NON_FINITE))
        cells = lines[at].split(written.delimiter)
        cells[written.cell_offset + column] = token
        lines[at] = written.delimiter.join(cells)
        values = truth.copy()
        values[row, column] = np.nan
        return _done(written, lines, Expect(values), kind, {"row": row, "column": column})
    if kind == "mixed encoding":
        index = draw(st.integers(0, len(lines) - 1))
        other = draw(st.sampled_from(("latin-1", "utf-8", "cp1252")))
        body = lines[index].encode(other, errors="replace")
        raw = mixed(lines, written.encoding, written.newline, index, body)
        same = body == lines[index].encode(codec)
        expect = Expect(truth, "never" if same else "may")
        return Damaged(written, raw, expect, kind, {"line": index + 1, "as": other})
    if kind == "cross delimiter":
        other = draw(
            st.sampled_from([d for d in ("\t", ";", ",", " | ") if d != written.delimiter])
        )
        lines[at] = lines[at].replace(written.delimiter, other)
        return _done(written, lines, Expect(None, "must", at + 1), kind, {"row": row})
    if kind == "cross decimal":
        column = draw(st.integers(0, len(written.table.columns) - 1))
        cells = lines[at].split(written.delimiter)
        position = written.cell_offset + column
        other = "," if written.decimal == "." else "."
        changed = cells[position].replace(written.decimal, other)
        error = "may" if changed != cells[position] else "never"
        cells[position] = changed
        lines[at] = written.delimiter.join(cells)
        return _done(written, lines, Expect(truth, error), kind, {"row": row, "column": column})
    if kind == "duplicate row":
        lines.insert(at, lines[at])
        values = np.insert(truth, row, truth[row], axis=0)
        return _done(written, lines, Expect(values), kind, {"row": row})
    if kind == "delete row":
        del lines[at]
        return _done(written, lines, Expect(np.delete(truth, row, axis=0)), kind, {"row": row})
    if kind == "blank line":
        lines.insert(at, "")
        return _done(written, lines, Expect(truth[:row], "may"), kind, {"row": row})
    return _done(written, lines, Expect(truth), kind, {})


def _done(written, lines, expect, kind, details):
    raw, _ = encode(lines, written.encoding, written.newline)
    return Damaged(written, raw, expect, kind, details)


# --------------------------------------------------------------------------- checks

LINE = re.compile(r"line (\d+)")


def check_error(error, path, expect):
    """A GranflowError that names the file and a line (the expected line when known)."""
    message = str(error)
    assert str(path) in message, message
    lines = [int(number) for number in LINE.findall(message)]
    assert lines, message
    if expect.line is not None:
        assert expect.line in lines, (expect.line, message)
    assert "\n" not in message, message


def same_values(read, expected):
    """Equal arrays, NaN where NaN, to the last bits but for a rounding of the converter."""
    read = np.asarray(read, dtype=float)
    assert read.shape == expected.shape, (read.shape, expected.shape)
    both = np.isnan(read) & np.isnan(expected)
    np.testing.assert_allclose(read[~both], expected[~both], rtol=4e-16, atol=0)
    assert np.array_equal(np.isnan(read), np.isnan(expected))


def interval_values(interval, columns):
    """The interval's values of the written columns, SI, rows x columns."""
    out = []
    for column in columns:
        values = interval.si(column.quantity)
        assert values is not None, (column.quantity, interval)
        out.append(values)
    return np.column_stack(out) if out else np.empty((0, 0))


def finite_or_nan(value):
    return value if math.isfinite(value) else math.nan


# --------------------------------------------------------------------------- tidy tables


@dataclass(frozen=True)
class TidyCase:
    """A tidy table's runs (their arrays are the truth), whether it has its sidecar, and its
    CSV as lines."""

    runs: tuple
    sidecar: bool
    lines: tuple


SERIES = ("t", "slip", "velocity", "force")
#: The cell of each series in a row of a tidy table (run, source, interval, control first).
SERIES_CELL = {"t": 4, "slip": 5, "velocity": 6, "force": 7}


@st.composite
def tidy_runs(draw):
    """One to three runs with arbitrary finite floats (inf velocities too), sources with a
    comma or a non-ASCII character."""
    import granflow

    finite = st.floats(-1e6, 1e6, allow_nan=False, allow_infinity=False)
    runs = []
    for number in range(draw(st.integers(1, 3))):
        size = draw(st.integers(1, 12))
        steps = draw(st.lists(st.floats(1e-3, 1e3), min_size=size, max_size=size))
        t = np.cumsum(steps)
        columns = {"t": t}
        for name in ("slip", "velocity", "force"):
            values = draw(st.lists(finite, min_size=size, max_size=size))
            columns[name] = np.array(values, dtype=float)
        if draw(st.booleans()):
            columns["velocity"][-1] = np.inf  # a quasi-static failure
        source = draw(st.sampled_from(("a.txt", "b µm.txt", "c,d.txt")))
        meta = {"source": source, "interval": number + 1}
        runs.append(granflow.Run(**columns, meta=meta))
    return tuple(runs)


def tidy_expected(runs, order=None, changed=None):
    """The runs' arrays after a damage: the table rows ``order`` (indices into the table's
    rows, default all, in order), with ``changed`` ((table row, series), value) set.
    Returns {run number: {series: array}}, the runs in their first row's order."""
    table = [(number, k) for number, run in enumerate(runs, start=1) for k in range(len(run))]
    order = range(len(table)) if order is None else order
    out = {}
    for index in order:
        number, k = table[index]
        entry = out.setdefault(number, {name: [] for name in SERIES})
        for name in SERIES:
            value = getattr(runs[number - 1], name)[k]
            if changed is not None and changed[0] == (index, name):
                value = changed[1]
            entry[name].append(value)
    return {
        number: {n: np.array(v, dtype=float) for n, v in e.items()} for number, e in out.items()
    }


def csv_cells(line):
    import csv

    return next(csv.reader([line]))


def csv_line(cells):
    import csv
    import io

    stream = io.StringIO()
    csv.writer(stream, lineterminator="").writerow(cells)
    return stream.getvalue()


# --------------------------------------------------------------------------- velocity steps


@st.composite
def velocity_step_files(draw):
    """A velocity-step record: time, load-point displacement with one step of velocity,
    friction (and a normal stress column sometimes), as its text lines and its truth."""
    rows = draw(st.integers(45, 90))
    start = draw(st.integers(0, 50000))
    step_at = draw(st.integers(20, rows - 20))
    slow, fast = draw(st.sampled_from(((1, 10), (3, 10), (10, 2))))
    time = [f"{start + i / 10:.1f}" for i in range(rows)]
    displacement, position = [], 1000 * draw(st.integers(0, 9))
    for i in range(rows):
        displacement.append(f"{position / 1000:.3f}")
        position += slow if i < step_at else fast
    friction = [f"0.{draw(st.integers(4000, 7000))}" for _ in range(rows)]
    stress = draw(st.booleans())
    unit = draw(st.sampled_from(("microns", "µm", "um")))
    delimiter = draw(st.sampled_from(("\t", ",")))
    header = ["Time(s)", f"Displ({unit})", "Friction", *(["Normal_stress(MPa)"] if stress else [])]
    cells = [
        [time[i], displacement[i], friction[i], *(["20.0"] if stress else [])] for i in range(rows)
    ]
    lines = (delimiter.join(header), *(delimiter.join(row) for row in cells))
    encoding = draw(st.sampled_from(("utf-8", "utf-16", "cp1252")))
    newline = draw(st.sampled_from(("\n", "\r\n")))
    truth = np.array([[float(row[0]), float(row[1]), float(row[2])] for row in cells])
    return lines, delimiter, encoding, newline, truth


def velocity_step_truth(values):
    """(t from the first row [s], displacement from the first row [m], friction) as the
    reader computes them from the values of the file's rows."""
    t = values[:, 0] * 1.0
    displacement = values[:, 1] * 1e-6
    return t - t[0], displacement - displacement[0], values[:, 2] * 1.0
