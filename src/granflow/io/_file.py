"""What a reader returns: a parsed file, its intervals and their columns (file units kept)."""

from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from types import MappingProxyType
from typing import Any

import numpy as np

from granflow._json import json_safe
from granflow.errors import InvalidParameterError
from granflow.io import _buffer, _columns
from granflow.io._text import fail, line_list, read_block

__all__ = ["Column", "Interval", "ParsedFile", "parse_blocks", "read_with"]


@dataclass(frozen=True)
class Column:
    """One column of an interval: its label and unit as in the file, and what it measures.

    ``quantity`` is the key in :data:`granflow.io._columns.QUANTITIES` ("torque", ...) or
    None for columns granflow does not interpret; ``factor`` converts file units to SI.
    """

    name: str
    unit: str
    quantity: str | None = None
    factor: float | None = None
    meaning: str = ""

    def to_dict(self):
        """JSON-safe dict."""
        return {
            "name": self.name,
            "unit": self.unit,
            "quantity": self.quantity,
            "factor": self.factor,
            "meaning": self.meaning,
        }


@dataclass(frozen=True, eq=False)
class Interval:
    """One interval (a block of data rows) with the test it belongs to and its metadata.

    ``values[i]`` holds the numbers of column i in the file's unit (NaN where missing or
    invalid), ``text[i]`` the cells of text columns (status); :meth:`si` converts a quantity.
    ``problems`` are data-quality sentences (without the file's name), and
    ``problem_quantities[k]`` the quantity problem k is about (None: the whole block; "": a
    column granflow does not interpret).
    """

    test: str
    number: int
    line: int
    columns: tuple
    values: MappingProxyType
    text: MappingProxyType
    rows: int
    metadata: Mapping[str, Any] = field(default_factory=dict)
    problems: tuple = ()
    problem_quantities: tuple = ()

    def __post_init__(self):
        object.__setattr__(self, "metadata", MappingProxyType(dict(self.metadata)))
        object.__setattr__(self, "problems", tuple(self.problems))
        quantities = tuple(self.problem_quantities)
        quantities += (None,) * (len(self.problems) - len(quantities))
        object.__setattr__(self, "problem_quantities", quantities)
        for name in ("values", "text"):
            object.__setattr__(self, name, MappingProxyType(dict(getattr(self, name))))

    def __len__(self):
        return self.rows

    def __repr__(self):
        return (
            f"Interval(test={self.test!r}, number={self.number}, rows={self.rows}, "
            f"columns={[column.name for column in self.columns]})"
        )

    def find(self, quantity):
        """Index of the column that measures ``quantity`` (best-ranked label), or None."""
        best = None
        for index, column in enumerate(self.columns):
            if column.quantity == quantity and (index in self.values or index in self.text):
                rank = _columns.match_quantity(column.name)[1] or 0
                if best is None or rank < best[0]:
                    best = (rank, index)
        return None if best is None else best[1]

    def si(self, quantity):
        """The values of ``quantity`` in SI units (a new array), or None if no such column."""
        index = self.find(quantity)
        if index is None or index not in self.values:
            return None
        factor = self.columns[index].factor
        inverse = round(1.0 / factor)
        if inverse > 1 and abs(1.0 / factor - inverse) < 1e-9 * inverse:
            # decimal prefixes (µ, m): dividing by 1e6 is correctly rounded, * 1e-6 is not
            return self.values[index] / inverse
        return self.values[index] * factor

    def frame(self):
        """The interval as a pandas DataFrame in file units, columns named ``name [unit]``."""
        import pandas as pd

        data = {}
        for index, column in enumerate(self.columns):
            label = f"{column.name} [{column.unit}]" if column.unit else column.name
            while label in data:
                label += "'"
            data[label] = self.values[index] if index in self.values else self.text[index]
        return pd.DataFrame(data)

    def to_dict(self):
        """JSON-safe summary (no data arrays)."""
        return {
            "test": self.test,
            "number": self.number,
            "line": self.line,
            "rows": self.rows,
            "columns": [column.to_dict() for column in self.columns],
            "metadata": {key: json_safe(value) for key, value in self.metadata.items()},
            "problems": list(self.problems),
        }


@dataclass(frozen=True, eq=False)
class ParsedFile:
    """A parsed export: format, encoding, number format, file metadata, intervals, problems."""

    source: str
    format: str
    encoding: str
    delimiter: str
    decimal: str
    thousands: str | None
    metadata: MappingProxyType
    intervals: tuple
    problems: tuple = ()

    def __post_init__(self):
        object.__setattr__(self, "metadata", MappingProxyType(dict(self.metadata)))
        object.__setattr__(self, "intervals", tuple(self.intervals))
        object.__setattr__(self, "problems", tuple(self.problems))

    def __repr__(self):
        return (
            f"ParsedFile({self.source!r}, format={self.format!r}, encoding={self.encoding!r}, "
            f"{len(self.intervals)} intervals)"
        )

    @property
    def tests(self):
        """Names of the tests in the file, in order, each once."""
        return tuple(dict.fromkeys(interval.test for interval in self.intervals))

    def to_dict(self):
        """JSON-safe summary of the file (no data arrays)."""
        return {
            "source": self.source,
            "format": self.format,
            "encoding": self.encoding,
            "delimiter": self.delimiter,
            "decimal": self.decimal,
            "thousands": self.thousands,
            "metadata": {key: json_safe(value) for key, value in self.metadata.items()},
            "tests": list(self.tests),
            "intervals": [interval.to_dict() for interval in self.intervals],
            "problems": list(self.problems),
        }

    def report(self):
        """A readable summary: what was found, interval by interval."""
        from granflow.io._runs import control_mode

        delimiter = {"\t": "tab", ";": "semicolon", ",": "comma"}.get(
            self.delimiter, self.delimiter
        )
        thousands = f", thousands {self.thousands!r}" if self.thousands else ""
        lines = [
            f"file:      {self.source}",
            f"format:    {self.format}",
            f"encoding:  {self.encoding}; delimiter {delimiter}; "
            f"decimal {self.decimal!r}{thousands}",
            f"tests:     {len(self.tests)}; intervals: {len(self.intervals)}",
        ]
        for ordinal, interval in enumerate(self.intervals, start=1):
            lines.append(
                f"[{ordinal}] test {interval.test!r}, interval {interval.number}: "
                f"{interval.rows} rows from line {interval.line}, control {control_mode(interval)}"
            )
            for column in interval.columns:
                meaning = f" -> {column.quantity}" if column.quantity else ""
                lines.append(f"      {column.name} [{column.unit}]{meaning}")
            for problem in interval.problems:
                lines.append(f"      problem: {problem}")
        for problem in self.problems:
            lines.append(f"problem: {problem}")
        return "\n".join(lines)


def make_columns(names, units, meanings, source, line, quantities=None):
    """Columns with quantities and SI factors; an unknown unit names itself and the line.

    ``quantities[i]``, when given, is what column i measures: a quantity name, ``""`` for a
    column left uninterpreted, or None to recognise it by its label (the default for all).
    When no label is known (a language or vendor outside the table), the columns' roles
    come from their units (:func:`granflow.io._columns.quantity_from_unit`), one column
    per quantity.
    """
    units = [_unit(units[index] if index < len(units) else "") for index in range(len(names))]
    chosen = [
        _columns.refine(_columns.match_quantity(name)[0], unit) if given is None else given or None
        for name, unit, given in zip(names, units, quantities or [None] * len(names), strict=True)
    ]
    if quantities is None and not set(chosen) - {None, "point", *_columns.TEXT_QUANTITIES}:
        for index, unit in enumerate(units):
            role = _columns.quantity_from_unit(unit) if chosen[index] is None else None
            if role is not None and role not in chosen:
                chosen[index] = role
    columns = []
    for index, name in enumerate(names):
        quantity, unit = chosen[index], units[index]
        factor = None
        if quantity is not None:
            try:
                factor = _columns.si_factor(quantity, unit)
            except InvalidParameterError as exc:
                label = _columns.column_label(index, name)
                raise fail(source, line, f"{label}: {exc}") from None
        meaning = meanings[index].strip() if index < len(meanings) else ""
        columns.append(Column(name.strip(), unit, quantity, factor, meaning))
    return tuple(columns)


def _unit(cell):
    unit = cell.strip()
    return unit[1:-1].strip() if unit.startswith("[") and unit.endswith("]") else unit


def make_interval(spec, columns, buffer, delimiter, numbers, source, metadata):
    """Parse the data rows of one block and wrap them with their columns, metadata and
    data-quality problems (missing, invalid or infinite cells, a truncated block, rows
    without a time, time that does not increase, gaps in time)."""
    text_columns = [
        i for i, column in enumerate(columns) if column.quantity in _columns.TEXT_QUANTITIES
    ]
    block = read_block(
        buffer,
        spec.region,
        [column.name for column in columns],
        delimiter,
        numbers,
        source,
        skip_first=spec.skip_first,
        text_columns=text_columns,
        strict=spec.strict,
    )
    for index in list(block.text):
        column = columns[index]
        if column.quantity not in (None, *_columns.TEXT_QUANTITIES):
            cells = block.text[index]
            filled = np.flatnonzero([bool(str(cell).strip()) for cell in cells])
            raise fail(
                source,
                spec.region[2] + (int(filled[0]) if filled.size else 0),
                f"{_columns.column_label(index, column.name)} should hold numbers "
                f"({column.quantity}) but holds text",
            )
    problems = [(columns[index].quantity or "", sentence) for index, sentence in block.problems]
    _, _, first_line, rows = spec.region
    if spec.cut_line is not None:
        problems.append(
            (
                None,
                f"line {spec.cut_line}, the last of the file, has no line end: the file looks "
                "cut short there, so that row was left out (its last number may be incomplete)",
            )
        )
    declared = metadata.get("declared_points")
    if not rows:
        problems.append((None, f"no data rows after the header at line {spec.header_line}"))
    elif declared is not None and declared != rows:
        what = "truncated" if rows < declared else "more rows than declared"
        lines = f"lines {first_line}-{first_line + rows - 1}"
        problems.append(
            (None, f"the header declares {declared} points, found {rows} ({what}, {lines})")
        )
    interval = Interval(
        test=spec.test,
        number=spec.number,
        line=spec.header_line,
        columns=columns,
        values=block.values,
        text=block.text,
        rows=block.rows,
        metadata=metadata,
    )
    time = interval.si("interval_time")
    time = interval.si("time") if time is None else time
    if time is not None and rows:
        problems += [(None, sentence) for sentence in time_problems(time, first_line)]
    quantities, sentences = zip(*problems, strict=True) if problems else ((), ())
    return replace(interval, problems=sentences, problem_quantities=quantities)


#: A step this many times the median step (and the steps beside it) is a gap in time.
GAP_FACTOR = 10.0


def time_problems(time, first_line):
    """Sentences about a time column [s] whose first row is on file line ``first_line``:
    rows without a time (dropped from the run), time that does not increase, and gaps: steps
    over :data:`GAP_FACTOR` times the median step and over half that factor times the smaller
    step beside them (so a logarithmic grid, whose steps grow smoothly, has none); rows kept."""
    lines = np.arange(first_line, first_line + time.size)
    sentences = []
    finite = np.isfinite(time)
    if not finite.all():
        count = int((~finite).sum())
        sentences.append(
            f"{count} row{'s' if count > 1 else ''} without a time dropped from the run "
            f"({line_list(lines[~finite])})"
        )
    time, lines = time[finite], lines[finite]
    if time.size < 3:
        return sentences
    step = np.diff(time)
    backwards = step <= 0
    if backwards.any():
        count = int(backwards.sum())
        sentences.append(
            f"time does not increase at {count} row{'s' if count > 1 else ''} "
            f"({line_list(lines[1:][backwards])}); rows kept"
        )
    forward = step[step > 0]
    if forward.size < 3:
        return sentences
    median = float(np.median(forward))
    before = np.r_[np.inf, step[:-1]]
    after = np.r_[step[1:], np.inf]
    neighbours = np.fmin(np.where(before > 0, before, np.inf), np.where(after > 0, after, np.inf))
    gap = (step > GAP_FACTOR * median) & (
        step > GAP_FACTOR / 2 * np.where(np.isinf(neighbours), median, neighbours)
    )
    if gap.any():
        count = int(gap.sum())
        largest = float(step[gap].max())
        sentences.append(
            f"{count} gap{'s' if count > 1 else ''} in time over {GAP_FACTOR:g}x the median "
            f"step {median:.3g} s, largest {largest:.3g} s (before {line_list(lines[1:][gap])}); "
            "rows kept"
        )
    return sentences


@dataclass
class BlockSpec:
    """Where one interval sits in a file, found by a format's scanner: ``region`` is
    ``(start, stop, first_line, rows)`` from :meth:`granflow.io._buffer.Cursor.block`."""

    test: str
    number: int
    header_line: int
    names: list
    units: list
    meanings: list
    region: tuple
    metadata: dict
    skip_first: bool = False
    quantities: list | None = None
    strict: bool = False
    cut_line: int | None = None


def without_cut_row(buffer, spec):
    """``spec`` without the last row of the file when that row has no line end.

    A file whose last line lacks its line end was most likely cut short while it was written
    or copied, perhaps in the middle of a number ('0.0123' cut to '0.01' still reads as a
    number): the row is left out and :attr:`BlockSpec.cut_line` names its line.
    """
    start, stop, first_line, rows = spec.region
    data = buffer.data
    if not rows or stop < len(data) or data[-1:] in (b"\n", b"\r"):
        return spec
    last = data.rfind(b"\n", start, stop)
    region = (start, start if last < 0 else last + 1, first_line, rows - 1)
    return replace(spec, region=region, cut_line=first_line + rows - 1)


def metadata_value(key, cells, numbers):
    """A metadata entry (key, value): known keys with units go to SI floats, others stay text.

    ``cells`` are the cells after the label; a unit may sit in the label ("Rest Time [min]")
    or in a cell of its own ("[N]" or "N").
    """
    label = key.strip().rstrip(":").strip()
    known = _columns.match_metadata(label)
    text = " ".join(cell.strip() for cell in cells if cell.strip())
    if known is None:
        return label, header_number(text, numbers)
    _, si_unit = _columns.METADATA[known]
    if known == "control":
        return known, _columns.control_from_text(text) or text
    if si_unit is None:
        return known, text
    unit = ""
    if "[" in label and label.endswith("]"):
        unit = label[label.index("[") + 1 : -1]
    parts = [cell.strip() for cell in cells if cell.strip()]
    if not parts:
        return known, None
    number = numbers.parse(parts[0])
    if len(parts) > 1 and not unit:
        unit = parts[1].strip("[]")
    if number is None:
        return known, text
    from granflow.model.units import to_si

    try:
        return known, float(to_si(number, unit or si_unit, known)) if unit else number
    except InvalidParameterError:
        return known, text


def header_number(text, numbers):
    """A header value as a float when it is one number (thousands separators allowed, as in
    Rheoplus's ``9,945.692``), else the text unchanged."""
    from granflow.io._text import decimal_vote

    number = numbers.parse(text) if text else None
    if number is None and numbers.decimal == "." and decimal_vote(text) == "dot,":
        number = float(text.replace(",", ""))
    return text if number is None else number


def _sample(buffer, region, count):
    """(line number, line) of the first and last ``count`` rows of a block."""
    start, stop, first_line, rows = region
    if rows <= 2 * count:
        return list(enumerate(buffer.text(start, stop).split("\n")[:rows], start=first_line))
    head = buffer.text(start, _after_lines(buffer, start, count))
    sample = list(enumerate(head.split("\n")[:count], start=first_line))
    tail_start = stop
    for _ in range(count):
        tail_start = buffer.data.rfind(b"\n", start, tail_start - 1) + 1 or start
    tail = buffer.text(tail_start, stop).split("\n")
    tail = tail[:-1] if not tail[-1] else tail
    return sample + list(enumerate(tail, start=first_line + rows - len(tail)))


def _after_lines(buffer, start, count):
    position = start
    for _ in range(count):
        position = buffer.data.find(b"\n", position) + 1 or len(buffer.data)
    return position


def refuse_interruption(cursor, header_line, delimiter):
    """A data block ends at a blank line, at the end of the file or at the next keyword
    line; any other line there cut the rows short (a line damaged, in another encoding or
    with other separators), and is an error naming it, not the end of the data."""
    if cursor.done():
        return
    line = cursor.peek()
    cells = line.split(delimiter)
    if not line.strip(" \t" + delimiter) or _columns.match_keyword(cells[0] if cells else ""):
        return
    raise fail(
        cursor.source,
        cursor.number,
        f"this line interrupts the data rows of the interval whose header is on line "
        f"{header_line}: it is not a data row (a damaged line, another encoding or other "
        "separators?)",
    )


def finish(source, form, buffer, delimiter, specs, metadata, problems):
    """Sniff the number format from the data rows of every block, then parse each block."""
    from granflow.io._text import sniff_numbers

    if not specs:
        raise fail(
            source,
            buffer.line_number(len(buffer.data)),
            f"no data block found in this {form} export",
        )
    specs = [without_cut_row(buffer, spec) for spec in specs]
    samples = []
    for spec in specs:
        for line, row in _sample(buffer, spec.region, 100):
            cells = row.split(delimiter)
            samples.append((line, cells[1:] if spec.skip_first else cells))
    numbers = sniff_numbers(samples, delimiter, source)
    intervals = []
    for spec in specs:
        spec_metadata = {}
        for key, value in spec.metadata.items():
            if isinstance(value, list):
                key, value = metadata_value(key, value, numbers)
            spec_metadata[key] = value
        columns = make_columns(
            spec.names, spec.units, spec.meanings, source, spec.header_line, spec.quantities
        )
        intervals.append(
            make_interval(spec, columns, buffer, delimiter, numbers, source, spec_metadata)
        )
    file_metadata = {}
    for key, value in metadata.items():
        if isinstance(value, list):
            key, value = metadata_value(key, value, numbers)
        file_metadata[key] = value
    return ParsedFile(
        source=source,
        format=form,
        encoding=buffer.encoding,
        delimiter=delimiter,
        decimal=numbers.decimal,
        thousands=numbers.thousands,
        metadata=file_metadata,
        intervals=tuple(intervals),
        problems=tuple(buffer.problems) + tuple(problems),
    )


def read_with(parse, path, max_bytes=None, **options):
    """Read an export with a format's parser: the ``read_<format>(path)`` of each reader.

    Parameters
    ----------
    parse : callable
        ``parse_<format>(text, source=..., encoding=..., **options)``.
    path : str or pathlib.Path
        The export file; never modified.
    max_bytes : int, optional
        Largest accepted file size [bytes] (see :func:`granflow.io._buffer.size_limit`).
    **options
        Passed on to ``parse``.
    """
    buffer = _buffer.load(path, max_bytes)
    return parse(buffer, source=str(Path(path)), encoding=buffer.encoding, **options)


def head_lines(buffer, count=200, size=1 << 20):
    """The first ``count`` lines of a buffer (at most ``size`` bytes), decoded."""
    end = _after_lines(buffer, 0, count)
    return [line.rstrip("\r") for line in buffer.text(0, min(end, size)).split("\n")[:count]]


def parse_blocks(scan, form, text, source, encoding, expect):
    """Parse an export whose ``scan(cursor, delimiter, source, problems)`` finds its blocks:
    the ``parse_<format>(text)`` of each block-structured reader. ``expect`` says what the
    format's header looks like, for the error when none is found."""
    from granflow.io._text import sniff_delimiter

    buffer = _buffer.from_text(text, encoding)
    problems = []
    delimiter = sniff_delimiter([line for line in head_lines(buffer) if line.strip()])
    cursor = _buffer.Cursor(buffer, source, expect)
    metadata, specs = scan(cursor, delimiter, source, problems)
    return finish(source, form, buffer, delimiter, specs, metadata, problems)
