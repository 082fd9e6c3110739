"""Generic CSV/TSV: one header row of column names (units in brackets or parentheses, or a
unit row below), data rows after it; a column map names the columns granflow needs."""

from __future__ import annotations

import re
from collections.abc import Mapping
from typing import TYPE_CHECKING

from granflow.io import _buffer, _columns
from granflow.io._file import BlockSpec, finish, head_lines, read_with
from granflow.io._text import fail, sniff_delimiter, split

if TYPE_CHECKING:
    from granflow._typing import PathLike
    from granflow.io._file import ParsedFile

__all__ = ["parse_csv", "read_csv"]

#: What a table holds, for the error when none of it is found.
EXPECT = "a header row of column names followed by data rows"
#: Every layout granflow reads, for the error when a file has none of them.
KNOWN_LAYOUTS = (
    "a RheoCompass export ('Interval data:' or a header row above a row of [units]), a "
    "Rheoplus export ('Data Series Information'), a TRIOS export ('[step]') or a table "
    "(a header row of column names, optionally a row of [units], then data rows)"
)
_ROWS_END = re.compile(rb"\n(?=[ \t\r\x0b\x0c]*(?:\n|\Z))")
_CONTENT = re.compile(rb"\S")
_NAME_UNIT = re.compile(r"^(?P<name>.*?)\s*[\[(](?P<unit>[^\])]*)[\])]\s*$")


def _name_and_unit(cell):
    """(name, unit) of a header cell: "Torque [mN·m]", "t (min)", or the names granflow
    writes ("force_N": the unit after the underscore, the name kept as written)."""
    match = _NAME_UNIT.match(cell.strip())
    if match:
        return match["name"].strip(), match["unit"].strip()
    own = _columns.own_column(cell)
    return cell.strip(), "" if own is None else own[1]


def parse_csv(
    text: str,
    source: str = "<text>",
    encoding: str = "str",
    column_map: Mapping[str, str] | None = None,
    units: Mapping[str, str] | None = None,
    only_mapped: bool = False,
    strict: bool = False,
) -> ParsedFile:
    """Parse a plain delimited table (comma, semicolon or tab; quoted fields allowed).

    Parameters
    ----------
    text : str
        The decoded file content.
    column_map : mapping, optional
        ``{quantity: column name}``, e.g. ``{"time": "t", "torque": "M"}``, for columns whose
        names are not in the label table (quantities: time, torque, speed, angle,
        normal_force, shear_stress, shear_rate, strain, status; and slip [m] and force [N],
        the columns of a tidy table, which are found through the map only).
    units : mapping, optional
        ``{column name: unit}`` for columns whose unit the file does not give.
    only_mapped : bool
        Interpret only the columns of ``column_map``; the others are read as they are (no
        quantity, no unit check), for tables whose other columns are not instrument data.
    strict : bool
        A cell that is not a number is an error naming its line and column, not a NaN.

    Examples
    --------
    >>> from granflow.io import parse_csv
    >>> parsed = parse_csv("t,M\\n0,1.5\\n1,2.5\\n", column_map={"time": "t", "torque": "M"},
    ...                    units={"t": "s", "M": "mN m"})
    >>> parsed.intervals[0].si("torque")
    array([0.0015, 0.0025])
    >>> table = parse_csv("slip [um],force [mN]\\n1,2\\n", column_map={"force": "force"},
    ...                   only_mapped=True)
    >>> table.intervals[0].si("force")
    array([0.002])
    """
    buffer = _buffer.from_text(text, encoding)
    column_map = dict(column_map or {})
    units = dict(units or {})
    cursor = _buffer.Cursor(buffer, source, EXPECT)
    while not cursor.done() and not cursor.peek().strip():
        cursor.advance()
    if cursor.done():
        raise fail(source, 1, "the file is empty")
    first = cursor.number
    header = cursor.next()
    delimiter = sniff_delimiter(
        [line for line in [header, *head_lines(buffer, 50)] if line.strip()]
    )
    cells = split(header, delimiter)
    if not cells:
        raise fail(source, first, f"the header line holds no column names; expected {EXPECT}")
    names, file_units = zip(*(_name_and_unit(cell) for cell in cells), strict=True)
    names, file_units = list(names), list(file_units)
    below = split(cursor.peek(), delimiter)
    if below and all(cell.strip().startswith("[") or not cell.strip() for cell in below):
        file_units = [cell.strip().strip("[]") for cell in below] + [""] * len(names)
        cursor.advance()
    mapped = {name: quantity for quantity, name in column_map.items()}
    known = (*_columns.QUANTITIES, *_columns.MAPPED_ONLY)
    for name in column_map.values():
        if name not in names:
            raise fail(source, first, f"column {name!r} of the column map is not in the header")
    for name in names:
        if name in mapped and mapped[name] not in known:
            raise fail(source, first, f"unknown quantity {mapped[name]!r} in the column map")
    unmapped = "" if only_mapped else None
    quantities = [
        mapped.get(name, unmapped if only_mapped or own is None else own[0])
        for name, own in zip(names, map(_columns.own_column, names), strict=True)
    ]
    final_units = [
        units.get(name, file_units[index] if index < len(file_units) else "")
        for index, name in enumerate(names)
    ]
    region = cursor.block(_ROWS_END)
    if not region[3]:
        raise fail(source, first, f"no data rows below the header; expected {KNOWN_LAYOUTS}")
    problems = []
    rest = _CONTENT.search(buffer.data, cursor.pos)
    if rest:
        line = buffer.line_number(rest.start())
        problems.append(
            f"ignored the lines after the blank line that ends the table (from line {line})"
        )
    spec = BlockSpec(
        "table", 1, first, names, final_units, [], region, {}, False, quantities, strict
    )
    return finish(source, "csv", buffer, delimiter, [spec], {}, problems)


def read_csv(
    path: PathLike,
    column_map: Mapping[str, str] | None = None,
    units: Mapping[str, str] | None = None,
    only_mapped: bool = False,
    strict: bool = False,
    max_bytes: int | None = None,
) -> ParsedFile:
    """Read a generic CSV/TSV file; see :func:`parse_csv` (``max_bytes``: the size limit,
    see :func:`granflow.io.read`)."""
    return read_with(
        parse_csv,
        path,
        max_bytes,
        column_map=column_map,
        units=units,
        only_mapped=only_mapped,
        strict=strict,
    )
