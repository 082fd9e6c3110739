"""Anton Paar RheoCompass text/CSV exports.

Layout (labels in English, French or German, see :mod:`granflow.io._columns`)::

    Project:<TAB>name
    Test:<TAB>name                  one or more tests
    Result:<TAB>name
    Interval and data points:<TAB>1<TAB>451
    Interval data:<TAB>Point No.<TAB>Time<TAB>...<TAB>Status
    <TAB><TAB>meaning row (optional: "Constant component", or blank)
    <TAB><TAB>[s]<TAB>...           unit row
    <TAB>1<TAB>0.100<TAB>...        data rows start with an empty cell

Other ``Key:<TAB>value`` lines are metadata of the test (before the first interval) or of
the interval (between its "Interval and data points" and "Interval data" lines).
"""

from __future__ import annotations

import re
from typing import TYPE_CHECKING

from granflow.io import _columns
from granflow.io._file import BlockSpec, parse_blocks, read_with, refuse_interruption
from granflow.io._text import fail, line_list, split

if TYPE_CHECKING:
    from granflow._typing import PathLike
    from granflow.io._file import ParsedFile

__all__ = ["looks_like_rheocompass", "parse_rheocompass", "read_rheocompass"]


#: What a RheoCompass export holds, for the error when none of it is found.
EXPECT = (
    "RheoCompass header lines ('Interval and data points:', 'Interval data:' with column "
    "names, a row of units in brackets, data rows starting with a delimiter)"
)


def looks_like_rheocompass(lines):
    """True when a line starts with RheoCompass's "Interval data:" keyword (any language of
    the table), or, failing that, when a line has the structure of an interval header (see
    :func:`structure_header`)."""
    for line in lines[:2000]:
        head = line.split("\t", 1)[0].split(";", 1)[0].split(",", 1)[0]
        if _columns.match_keyword(head.strip('"')) == "interval_data":
            return True
    for index in range(min(len(lines), 2000)):
        for delimiter in ("\t", ";"):
            if structure_header(lines[index : index + 3], delimiter):
                return True
    return False


def _integer(cells, index):
    try:
        return int(cells[index].strip())
    except (IndexError, ValueError):
        return None


class _RowsEnd:
    """Finds the line end after the last data row: at the first line that does not start
    with the delimiter (one C-speed search), less the blank lines (nothing but delimiters
    and spaces) just before it. A blank line between data rows stays in the block: its
    cells are missing values and the row has no time, which the problems report."""

    def __init__(self, delimiter):
        mark = re.escape(delimiter.encode())
        self._other = re.compile(rb"\n(?!" + mark + rb")")
        self._blank = re.compile(rb"\n(?:" + mark + rb"|[ \t\r])*(?:\n|\Z)")

    def search(self, data, pos):
        other = self._other.search(data, pos)
        stop = len(data) if other is None else other.start()
        while stop > pos:
            previous = data.rfind(b"\n", pos, stop)
            if previous < 0 or not self._blank.match(data, previous):
                break
            stop = previous
        return _End(stop) if other is not None or stop < len(data) else None


class _End:
    """Where a block ends: the offset of the ``\\n`` before the first line after it."""

    def __init__(self, offset):
        self._offset = offset

    def start(self):
        return self._offset


def rows_end(delimiter):
    """The searcher of the line end after a block's last data row (see :class:`_RowsEnd`)."""
    return _RowsEnd(delimiter)


def is_unit_row(line, delimiter):
    """True for a row of units in brackets ("[s]", "[mN·m]"), at least two of them."""
    cells = [cell.strip() for cell in line.split(delimiter) if cell.strip()]
    return len(cells) >= 2 and all(cell[:1] == "[" and cell[-1:] == "]" for cell in cells)


def structure_header(lines, delimiter):
    """True when ``lines`` (a line and the two after it) are, by their structure alone, a
    RheoCompass interval header in any language: a row of names, an optional meaning row,
    then a unit row whose first cell is empty like the data rows' (a table of unknown
    keywords)."""
    if len(lines) < 2 or lines[0].startswith(delimiter) or delimiter not in lines[0]:
        return False
    for below in lines[1:3]:
        if is_unit_row(below, delimiter):
            return below.startswith(delimiter)
        if not below.startswith(delimiter):
            return False
    return False


def _units_and_meanings(cursor, delimiter):
    """The optional meaning row and the unit row below an "Interval data:" line."""
    meanings, units = [], []
    for _ in range(2):
        line = cursor.peek()
        if not line.startswith(delimiter):
            break
        following = line.split(delimiter)[1:]
        if any(cell.strip().startswith("[") for cell in following):
            cursor.advance()
            return meanings, following
        if any(cell.strip()[:1].isdigit() or cell.strip()[:1] == "-" for cell in following):
            break
        meanings = following
        cursor.advance()
    return meanings, units


def _scan(cursor, delimiter, source, problems):
    file_metadata, specs = {}, []
    test, test_metadata, interval_metadata = "", {}, {}
    number, declared, in_interval = 0, None, False
    skipped = []
    end = rows_end(delimiter)
    while not cursor.done():
        line_number = cursor.number
        line = cursor.next()
        if not line.strip():
            continue
        cells = split(line, delimiter)
        keyword = _columns.match_keyword(cells[0]) if cells else None
        if keyword is None and structure_header([line, *cursor.lookahead(2)], delimiter):
            keyword = "interval_data"
        if keyword == "project":
            file_metadata["project"] = " ".join(cell.strip() for cell in cells[1:])
        elif keyword == "test":
            test = " ".join(cell.strip() for cell in cells[1:]) or f"test {len(specs) + 1}"
            test_metadata, interval_metadata, number = {}, {}, 0
        elif keyword == "result":
            test_metadata["result"] = " ".join(cell.strip() for cell in cells[1:])
        elif keyword == "interval_points":
            number = _integer(cells, 1) or number + 1
            declared = _integer(cells, 2)
            interval_metadata, in_interval = {}, True
        elif keyword == "interval_data":
            names = cells[1:]
            if not names:
                raise fail(source, line_number, "an 'Interval data' line without column names")
            meanings, units = _units_and_meanings(cursor, delimiter)
            metadata = {**test_metadata, **interval_metadata}
            if declared is not None:
                metadata["declared_points"] = declared
            specs.append(
                BlockSpec(
                    test=test,
                    number=number or 1,
                    header_line=line_number,
                    names=names,
                    units=units,
                    meanings=meanings,
                    region=cursor.block(end),
                    metadata=metadata,
                    skip_first=True,
                )
            )
            refuse_interruption(cursor, line_number, delimiter)
            declared, in_interval = None, False
        elif cells and cells[0].strip():
            target = interval_metadata if in_interval else test_metadata
            target = target if test else file_metadata
            target[cells[0].strip()] = cells[1:]
        else:
            skipped.append(line_number)
    if skipped:
        problems.append(
            f"skipped {len(skipped)} line(s) outside any data block ({line_list(skipped)})"
        )
    return file_metadata, specs


def parse_rheocompass(text: str, source: str = "<text>", encoding: str = "str") -> ParsedFile:
    """Parse the text of a RheoCompass export.

    Parameters
    ----------
    text : str
        The decoded file content.
    source : str
        The file name, for metadata and messages.
    encoding : str
        The encoding the text was decoded from (recorded only).

    Returns
    -------
    granflow.io.ParsedFile
        Tests and intervals, columns with units, metadata and problems.

    Examples
    --------
    >>> from granflow.io import parse_rheocompass
    >>> text = ("Test:\\tstart-up\\nInterval and data points:\\t1\\t2\\n"
    ...         "Interval data:\\tPoint No.\\tTime\\tTorque\\n\\t\\t[s]\\t[mN·m]\\n"
    ...         "\\t1\\t1.0\\t0.5\\n\\t2\\t2.0\\t0.6\\n")
    >>> parsed = parse_rheocompass(text)
    >>> parsed.intervals[0].si("torque")
    array([0.0005, 0.0006])
    """
    return parse_blocks(_scan, "rheocompass", text, source, encoding, EXPECT)


def read_rheocompass(path: PathLike, max_bytes: int | None = None) -> ParsedFile:
    """Read a RheoCompass export file (any supported encoding); see :func:`parse_rheocompass`
    (``max_bytes``: the size limit, see :func:`granflow.io.read`)."""
    return read_with(parse_rheocompass, path, max_bytes)
