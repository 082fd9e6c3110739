"""TA Instruments TRIOS text exports ("Export to LIMS" / text).

Layout: ``Key<TAB>value`` lines for the file (Filename, Instrument name, Sample name, ...),
then one block per step::

    [step]
    Flow Peak Hold - 1            the step name
    Key<TAB>value                 optional step metadata (granflow's writer adds some)
    Step time<TAB>Torque<TAB>...  column names
    s<TAB>µN.m<TAB>...            units (no brackets)
    0.5<TAB>12.3<TAB>...          data rows up to a blank line or the next [step]
"""

from __future__ import annotations

import re
from typing import TYPE_CHECKING

from granflow.io import _columns
from granflow.io._file import BlockSpec, parse_blocks, read_with
from granflow.io._text import split

if TYPE_CHECKING:
    from granflow._typing import PathLike
    from granflow.io._file import ParsedFile

__all__ = ["looks_like_trios", "parse_trios", "read_trios"]


def looks_like_trios(lines):
    """True when the file has TRIOS's "[step]" section lines."""
    return any(line.strip().lower() == "[step]" for line in lines[:5000])


def _is_header(cells):
    known = [_columns.match_quantity(cell)[0] for cell in cells]
    return sum(quantity is not None for quantity in known) >= 2


#: What a TRIOS export holds, for the error when none of it is found.
EXPECT = "TRIOS '[step]' sections, each with a step name, a header row and a row of units"
_ROWS_END = re.compile(rb"\n(?=[ \t\r\x0b\x0c]*(?:\n|\Z)|[ \t]*\[step\][ \t\r]*(?:\n|\Z))", re.I)


def _scan(cursor, delimiter, source, problems):
    specs, file_metadata = [], {}
    step, metadata, steps = None, {}, 0
    while not cursor.done():
        line_number = cursor.number
        line = cursor.next()
        if not line.strip():
            continue
        if line.strip().lower() == "[step]":
            steps += 1
            while not cursor.done() and not cursor.peek().strip():
                cursor.advance()
            step = cursor.next().strip() or f"step {steps}"
            metadata = {}
            continue
        cells = split(line, delimiter)
        if step is not None and _is_header(cells):
            units = cursor.next().split(delimiter)
            region = cursor.block(_ROWS_END)
            specs.append(BlockSpec(step, steps, line_number, cells, units, [], region, metadata))
            step = None
            continue
        target = metadata if step is not None else file_metadata
        if cells:
            target[cells[0].strip()] = cells[1:]
    return file_metadata, specs


def parse_trios(text: str, source: str = "<text>", encoding: str = "str") -> ParsedFile:
    """Parse the text of a TRIOS export into a :class:`granflow.io.ParsedFile`.

    Examples
    --------
    >>> from granflow.io import parse_trios
    >>> text = ("Filename\\tdemo\\n[step]\\nPeak hold - 1\\nStep time\\tTorque\\n"
    ...         "s\\tµN.m\\n1\\t2.5\\n2\\t3.5\\n")
    >>> parse_trios(text).intervals[0].si("torque")
    array([2.5e-06, 3.5e-06])
    """
    return parse_blocks(_scan, "trios", text, source, encoding, EXPECT)


def read_trios(path: PathLike, max_bytes: int | None = None) -> ParsedFile:
    """Read a TRIOS text export; see :func:`parse_trios`."""
    return read_with(parse_trios, path, max_bytes)
