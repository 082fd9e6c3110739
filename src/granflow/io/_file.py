"""What a reader returns: a parsed file, its intervals and their columns (file units kept)."""

from dataclasses import dataclass, field, replace
from pathlib import Path
from types import MappingProxyType

from granflow._json import json_safe
from granflow.errors import InvalidParameterError
from granflow.io import _columns
from granflow.io._text import decode, fail, read_block

__all__ = ["Column", "Interval", "ParsedFile", "parse_blocks", "read_with", "with_problems"]


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
    """

    test: str
    number: int
    line: int
    columns: tuple
    values: MappingProxyType
    text: MappingProxyType
    rows: int
    metadata: MappingProxyType = field(default_factory=dict)
    problems: tuple = ()

    def __post_init__(self):
        object.__setattr__(self, "metadata", MappingProxyType(dict(self.metadata)))
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
            if column.quantity == quantity and index in self.values:
                rank = _columns.match_quantity(column.name)[1] or 0
                if best is None or rank < best[0]:
                    best = (rank, index)
        return None if best is None else best[1]

    def si(self, quantity):
        """The values of ``quantity`` in SI units (a new array), or None if no such column."""
        index = self.find(quantity)
        if index is None:
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
    """
    columns = []
    for index, name in enumerate(names):
        unit = units[index].strip() if index < len(units) else ""
        if unit.startswith("[") and unit.endswith("]"):
            unit = unit[1:-1].strip()
        given = quantities[index] if quantities is not None else None
        quantity = _columns.match_quantity(name)[0] if given is None else given or None
        factor = None
        if quantity is not None:
            try:
                factor = _columns.si_factor(quantity, unit)
            except InvalidParameterError as exc:
                raise fail(source, line, f"column {name.strip()!r}: {exc}") from None
        meaning = meanings[index].strip() if index < len(meanings) else ""
        columns.append(Column(name.strip(), unit, quantity, factor, meaning))
    return tuple(columns)


def make_interval(
    test,
    number,
    header_line,
    columns,
    rows,
    first_line,
    delimiter,
    numbers,
    source,
    metadata,
    skip_first=False,
    strict=False,
):
    """Parse the data rows of one interval and wrap them with their columns and metadata;
    ``strict``: a cell that is not a number is an error naming its line (not a NaN)."""
    text_columns = [i for i, column in enumerate(columns) if column.quantity == "status"]
    block = read_block(
        rows,
        first_line,
        [column.name for column in columns],
        delimiter,
        numbers,
        source,
        skip_first=skip_first,
        text_columns=text_columns,
        strict=strict,
    )
    problems = list(block.problems)
    for index in list(block.text):
        column = columns[index]
        if column.quantity not in (None, "status"):
            raise fail(
                source,
                first_line,
                f"column {column.name!r} should hold numbers ({column.quantity}) but holds text "
                f"such as {block.text[index][0]!r}",
            )
    declared = metadata.get("declared_points")
    if declared is not None and declared != block.rows:
        problems.append(f"the header declares {declared} points, the file has {block.rows}")
    return Interval(
        test=test,
        number=number,
        line=header_line,
        columns=columns,
        values=block.values,
        text=block.text,
        rows=block.rows,
        metadata=metadata,
        problems=tuple(problems),
    )


@dataclass
class BlockSpec:
    """Where one interval sits in the lines of a file, found by a format's scanner."""

    test: str
    number: int
    header_line: int
    names: list
    units: list
    meanings: list
    start: int
    stop: int
    metadata: dict
    skip_first: bool = False
    quantities: list | None = None
    strict: bool = False


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
    from granflow.io._text import _vote

    number = numbers.parse(text) if text else None
    if number is None and numbers.decimal == "." and _vote(text) == "dot,":
        number = float(text.replace(",", ""))
    return text if number is None else number


def finish(source, form, encoding, delimiter, lines, specs, metadata, problems):
    """Sniff the number format from the data rows of every block, then parse each block."""
    from granflow.io._text import sniff_numbers

    if not specs:
        raise fail(source, max(len(lines), 1), f"no data block found in this {form} export")
    samples = []
    for spec in specs:
        picks = list(range(spec.start, min(spec.stop, spec.start + 100)))
        picks += list(range(max(spec.start + 100, spec.stop - 100), spec.stop))
        for index in picks:
            cells = lines[index].split(delimiter)
            samples.append((index + 1, cells[1:] if spec.skip_first else cells))
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
        if spec.stop <= spec.start:
            problems.append(
                f"line {spec.header_line}: interval {spec.number} of {spec.test!r} has no data rows"
            )
        intervals.append(
            make_interval(
                spec.test,
                spec.number,
                spec.header_line,
                columns,
                lines[spec.start : spec.stop],
                spec.start + 1,
                delimiter,
                numbers,
                source,
                spec_metadata,
                skip_first=spec.skip_first,
                strict=spec.strict,
            )
        )
    file_metadata = {}
    for key, value in metadata.items():
        if isinstance(value, list):
            key, value = metadata_value(key, value, numbers)
        file_metadata[key] = value
    return ParsedFile(
        source=source,
        format=form,
        encoding=encoding,
        delimiter=delimiter,
        decimal=numbers.decimal,
        thousands=numbers.thousands,
        metadata=file_metadata,
        intervals=tuple(intervals),
        problems=tuple(problems),
    )


def with_problems(parsed, problems):
    """``parsed`` with ``problems`` (found while decoding the file) before its own."""
    return replace(parsed, problems=tuple(problems) + parsed.problems) if problems else parsed


def read_with(parse, path, **options):
    """Read an export with a format's parser: the ``read_<format>(path)`` of each reader.

    Parameters
    ----------
    parse : callable
        ``parse_<format>(text, source=..., encoding=..., **options)``.
    path : str or pathlib.Path
        The export file; never modified.
    **options
        Passed on to ``parse``.
    """
    path = Path(path)
    text, encoding, problems = decode(path.read_bytes(), str(path))
    return with_problems(parse(text, source=str(path), encoding=encoding, **options), problems)


def parse_blocks(scan, form, text, source, encoding):
    """Parse an export whose ``scan(lines, delimiter, source, problems)`` finds its blocks:
    the ``parse_<format>(text)`` of each block-structured reader."""
    from granflow.io._text import sniff_delimiter

    lines = text.splitlines()
    problems = []
    delimiter = sniff_delimiter([line for line in lines[:200] if line.strip()])
    metadata, specs = scan(lines, delimiter, source, problems)
    return finish(source, form, encoding, delimiter, lines, specs, metadata, problems)
