"""Anton Paar Rheoplus text exports (the software before RheoCompass).

Layout: one "Data Series Information" block per series (test), ``Key:<TAB><TAB><TAB>value``
metadata (name, device, measuring system, calculating constants, interval number, number of
data points, measuring profile), then a header row starting with "Meas. Pts.", a unit row
("[s]", "[µNm]", "[]") and data rows up to a blank line. ``******`` marks a missing value.
"""

from __future__ import annotations

import re
from typing import TYPE_CHECKING

from granflow.io import _columns
from granflow.io._file import BlockSpec, parse_blocks, read_with, refuse_interruption
from granflow.io._text import split

if TYPE_CHECKING:
    from granflow._typing import PathLike
    from granflow.io._file import ParsedFile

__all__ = ["looks_like_rheoplus", "parse_rheoplus", "read_rheoplus"]


def looks_like_rheoplus(lines):
    """True when the file has Rheoplus's "Data Series Information" keyword."""
    return any(_columns.match_keyword(line.strip()) == "series" for line in lines[:200])


def _joined(cells):
    return " ".join(cell.strip() for cell in cells if cell.strip())


#: What a Rheoplus export holds, for the error when none of it is found.
EXPECT = (
    "a Rheoplus 'Data Series Information' block, a header row starting with 'Meas. Pts.', "
    "a row of units in brackets and data rows starting with a point number"
)
_ROWS_END = re.compile(rb"\n(?![0-9])")


def _scan(cursor, delimiter, source, problems):
    specs, file_metadata = [], {}
    test, metadata, number, declared = "", {}, 0, None
    last_key = ""
    while not cursor.done():
        line_number = cursor.number
        line = cursor.next()
        if not line.strip():
            continue
        cells = split(line, delimiter)
        head = cells[0].strip() if cells else ""
        keyword = _columns.match_keyword(head)
        if keyword == "series":
            test, metadata, number, declared = f"series {len(specs) + 1}", {}, 0, None
        elif keyword == "interval":
            try:
                number = int(_joined(cells[1:]))
            except ValueError:
                number += 1
        elif keyword == "profile":
            profile = []
            while cursor.peek().strip() and cursor.peek()[:1] in " \t":
                profile.append(_joined(split(cursor.next(), delimiter)))
            metadata["profile"] = "; ".join(profile)
        elif _columns.match_quantity(head)[0] == "point":
            units = cursor.peek().split(delimiter)
            if any(cell.strip().startswith("[") for cell in units):
                cursor.advance()
            spec_metadata = dict(metadata)
            if declared is not None:
                spec_metadata["declared_points"] = declared
            region = cursor.block(_ROWS_END)
            specs.append(
                BlockSpec(test, number or 1, line_number, cells, units, [], region, spec_metadata)
            )
            refuse_interruption(cursor, line_number, delimiter)
        elif head.endswith(":") or len(cells) > 1:
            key = head.lstrip("- ").rstrip(":").strip()
            value = _joined(cells[1:])
            target = metadata if test else file_metadata
            if not key and last_key in target:
                target[last_key] = [*target[last_key], *cells[1:]]
                continue
            last_key = key
            if _columns.normalize(key) == "name":
                test = value or test
            elif _columns.normalize(key) == "number of data points":
                try:
                    declared = int(value)
                except ValueError:
                    declared = None
            elif test:
                metadata[key] = cells[1:]
            else:
                file_metadata[key] = cells[1:]
    return file_metadata, specs


def parse_rheoplus(text: str, source: str = "<text>", encoding: str = "str") -> ParsedFile:
    """Parse the text of a Rheoplus export into a :class:`granflow.io.ParsedFile`.

    Examples
    --------
    >>> from granflow.io import parse_rheoplus
    >>> text = ("Data Series Information\\nName:\\t\\t\\tdemo\\n\\n"
    ...         "Meas. Pts.\\tTime\\tTorque\\n\\t[s]\\t[µNm]\\n1\\t1E0\\t******\\n2\\t2E0\\t5E0\\n")
    >>> parse_rheoplus(text).intervals[0].si("torque").tolist()
    [nan, 5e-06]
    """
    return parse_blocks(_scan, "rheoplus", text, source, encoding, EXPECT)


def read_rheoplus(path: PathLike, max_bytes: int | None = None) -> ParsedFile:
    """Read a Rheoplus export file; see :func:`parse_rheoplus`."""
    return read_with(parse_rheoplus, path, max_bytes)
