"""Generic CSV/TSV: one header row of column names (units in brackets or parentheses, or a
unit row below), data rows after it; a column map names the columns granflow needs."""

import re
from dataclasses import replace
from pathlib import Path

from granflow.io import _columns
from granflow.io._file import BlockSpec, finish
from granflow.io._text import decode, fail, sniff_delimiter, split

__all__ = ["parse_csv", "read_csv"]

_NAME_UNIT = re.compile(r"^(?P<name>.*?)\s*[\[(](?P<unit>[^\])]*)[\])]\s*$")


def _name_and_unit(cell):
    match = _NAME_UNIT.match(cell.strip())
    if match:
        return match["name"].strip(), match["unit"].strip()
    return cell.strip(), ""


def parse_csv(text, source="<text>", encoding="str", column_map=None, units=None):
    """Parse a plain delimited table (comma, semicolon or tab; quoted fields allowed).

    Parameters
    ----------
    text : str
        The decoded file content.
    column_map : mapping, optional
        ``{quantity: column name}``, e.g. ``{"time": "t", "torque": "M"}``, for columns whose
        names are not in the label table (quantities: time, torque, speed, angle,
        normal_force, shear_stress, shear_rate, strain, status).
    units : mapping, optional
        ``{column name: unit}`` for columns whose unit the file does not give.

    Examples
    --------
    >>> from granflow.io import parse_csv
    >>> parsed = parse_csv("t,M\\n0,1.5\\n1,2.5\\n", column_map={"time": "t", "torque": "M"},
    ...                    units={"t": "s", "M": "mN m"})
    >>> parsed.intervals[0].si("torque")
    array([0.0015, 0.0025])
    """
    lines = text.splitlines()
    column_map = dict(column_map or {})
    units = dict(units or {})
    first = next((i for i, line in enumerate(lines) if line.strip()), None)
    if first is None:
        raise fail(source, 1, "the file is empty")
    delimiter = sniff_delimiter([line for line in lines[first : first + 50] if line.strip()])
    cells = split(lines[first], delimiter)
    names, file_units = zip(*(_name_and_unit(cell) for cell in cells), strict=True)
    names, file_units = list(names), list(file_units)
    start = first + 1
    if start < len(lines):
        below = split(lines[start], delimiter)
        if below and all(cell.strip().startswith("[") or not cell.strip() for cell in below):
            file_units = [cell.strip().strip("[]") for cell in below] + [""] * len(names)
            start += 1
    renamed = {name: quantity for quantity, name in column_map.items()}
    for name in column_map.values():
        if name not in names:
            raise fail(source, first + 1, f"column {name!r} of the column map is not in the header")
    labels, final_units = [], []
    for index, name in enumerate(names):
        quantity = renamed.get(name)
        if quantity is not None and quantity not in _columns.QUANTITIES:
            raise fail(source, first + 1, f"unknown quantity {quantity!r} in the column map")
        labels.append(_columns.label(quantity, "en") if quantity else name)
        final_units.append(units.get(name, file_units[index] if index < len(file_units) else ""))
    stop = start
    while stop < len(lines) and lines[stop].strip():
        stop += 1
    spec = BlockSpec("table", 1, first + 1, labels, final_units, [], start, stop, {})
    parsed = finish(source, "csv", encoding, delimiter, lines, [spec], {}, [])
    original = [
        replace(column, name=names[index]) if names[index] in renamed else column
        for index, column in enumerate(parsed.intervals[0].columns)
    ]
    interval = replace(parsed.intervals[0], columns=tuple(original))
    return replace(parsed, intervals=(interval,))


def read_csv(path, column_map=None, units=None):
    """Read a generic CSV/TSV file; see :func:`parse_csv`."""
    path = Path(path)
    text, encoding, problems = decode(path.read_bytes(), str(path))
    parsed = parse_csv(text, str(path), encoding, column_map=column_map, units=units)
    return replace(parsed, problems=tuple(problems) + parsed.problems) if problems else parsed
