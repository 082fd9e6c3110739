"""Bytes to text and text to numbers: encoding, delimiter and decimal mark, decided per file.

Nothing here replaces characters blindly: the decimal mark and the thousands separator are
inferred from the numbers in the file, and the numeric block is parsed by pandas' C parser
with exactly those options (the fast path for million-row exports).
"""

import csv
import io
import re
import warnings
from dataclasses import dataclass

import numpy as np

from granflow.io import _buffer, _columns
from granflow.io._buffer import fail

__all__ = [
    "MISSING_MARKERS",
    "NumberFormat",
    "count_cells",
    "decimal_vote",
    "decode",
    "fail",
    "read_block",
    "sniff_delimiter",
]

#: Cells that mean "no value": empty, a single space, asterisks (Rheoplus prints ******).
MISSING_MARKERS = ("", " ", "******")
_ASTERISKS = re.compile(r"^\*+$")


def _is_marker(cell):
    return isinstance(cell, str) and (not cell.strip() or bool(_ASTERISKS.match(cell.strip())))


def decode(raw, source):
    """Decode an export's bytes: (text, encoding name, problems), as :func:`_buffer.load`
    reads a file (BOMs, UTF-16 by its NULs, strict UTF-8, else cp1252; line ends made LF)."""
    buffer = _buffer.read_stream(io.BytesIO(raw), source)
    text = buffer.text(0, len(buffer.data)).replace("\r\n", "\n")
    return text, buffer.encoding, list(buffer.problems)


def sniff_delimiter(lines):
    """Tab, semicolon or comma: the one that splits the most of the given lines."""
    counts = {}
    for delimiter in ("\t", ";", ","):
        counts[delimiter] = sum(1 for line in lines if delimiter in line)
    best = max(counts, key=lambda delimiter: counts[delimiter])
    return best if counts[best] else "\t"


def split(line, delimiter):
    """The cells of one line (quoted fields allowed), right-stripped of empty trailing cells.

    A stray carriage return inside the line (a line end of another system) is a space; a line
    the csv module refuses (a field past its size limit) is split at every delimiter, so that
    what is wrong with it is found, and named with its line, where its cells are read."""
    if '"' in line:
        try:
            cells = next(
                csv.reader([line.replace("\r", " ")], delimiter=delimiter, strict=False), []
            )
        except csv.Error:
            cells = line.split(delimiter)
    else:
        cells = line.split(delimiter)
    while cells and not cells[-1].strip():
        cells.pop()
    return cells


@dataclass(frozen=True)
class NumberFormat:
    """How numbers are written in one file: decimal mark and thousands separator."""

    decimal: str = "."
    thousands: str | None = None

    def parse(self, text):
        """A float from one cell, or None when it is not a number in this format."""
        cell = text.strip()
        if self.thousands:
            cell = cell.replace(self.thousands, "")
        if self.decimal != ".":
            if "." in cell:
                return None
            cell = cell.replace(self.decimal, ".")
        try:
            return float(cell)
        except ValueError:
            return None


_COMMA_ONLY = re.compile(r"^[-+]?(\d+),(\d+)([eE][-+]?\d+)?$")
_DOT_ONLY = re.compile(r"^[-+]?(\d+)\.(\d+)([eE][-+]?\d+)?$")
_COMMA_GROUPS = re.compile(r"^[-+]?\d{1,3}(,\d{3})+(\.\d+)?$")
_DOT_GROUPS = re.compile(r"^[-+]?\d{1,3}(\.\d{3})+(,\d+)?$")


def decimal_vote(cell):
    """Evidence from one cell: 'dot', 'comma', 'dot,' (dot decimal, comma thousands),
    'comma.' (comma decimal, dot thousands) or None (no evidence)."""
    if "," in cell and "." in cell:
        if _COMMA_GROUPS.match(cell):
            return "dot,"
        if _DOT_GROUPS.match(cell):
            return "comma."
        return None
    match = _COMMA_ONLY.match(cell)
    if match:
        whole, fraction, exponent = match.groups()
        if exponent or len(fraction) != 3 or whole.lstrip("-+") in ("0", "") or len(whole) > 3:
            return "comma"
        return None
    if _COMMA_GROUPS.match(cell):
        return "dot,"
    match = _DOT_ONLY.match(cell)
    if match:
        whole, fraction, exponent = match.groups()
        if exponent or len(fraction) != 3 or whole.lstrip("-+") in ("0", "") or len(whole) > 3:
            return "dot"
        return None
    if _DOT_GROUPS.match(cell) and cell.count(".") > 1:
        return "comma."
    return None


def sniff_numbers(rows, delimiter, source):
    """The NumberFormat of a file from (line number, cells) samples of its data rows.

    A cell like ``0,0073`` or ``1,5E+3`` is a decimal comma, ``12.5`` a decimal dot,
    ``9,945.692`` a comma thousands separator; ``1,234`` alone says nothing. Contradicting
    evidence (a decimal comma and a decimal dot in one file) is an error naming both lines.
    """
    seen = {}
    for line, cells in rows:
        for cell in cells:
            vote = decimal_vote(cell.strip())
            if vote is not None and vote not in seen:
                seen[vote] = line
    comma_decimal = {vote: line for vote, line in seen.items() if vote.startswith("comma")}
    dot_decimal = {vote: line for vote, line in seen.items() if vote.startswith("dot")}
    if comma_decimal and dot_decimal:
        raise fail(
            source,
            max(min(comma_decimal.values()), min(dot_decimal.values())),
            f"numbers with a decimal comma (line {min(comma_decimal.values())}) and with a "
            f"decimal dot (line {min(dot_decimal.values())}) in one file",
        )
    if comma_decimal:
        if delimiter == ",":
            raise fail(
                source, min(comma_decimal.values()), "decimal commas in a comma-delimited file"
            )
        return NumberFormat(",", "." if "comma." in comma_decimal else None)
    return NumberFormat(".", "," if "dot," in dot_decimal else None)


@dataclass
class Block:
    """One parsed numeric block: float columns (file units), text columns, and what was odd
    (``problems``: (column index or None, sentence) pairs)."""

    values: dict
    text: dict
    rows: int
    problems: list


class _Region(io.RawIOBase):
    """A read-only stream over a memoryview: pandas reads a block without a copy of it."""

    def __init__(self, view):
        super().__init__()
        self._view = view
        self._pos = 0

    def readable(self):
        return True

    def readinto(self, target):
        count = min(len(target), len(self._view) - self._pos)
        target[:count] = self._view[self._pos : self._pos + count]
        self._pos += count
        return count


def line_list(lines, most=5):
    """ "line 7" or "lines 2-4, 9 and 3 more" for sorted file line numbers."""
    lines = np.asarray(lines, dtype=np.int64)
    breaks = np.flatnonzero(np.diff(lines) != 1) + 1
    firsts = lines[np.r_[0, breaks]]
    lasts = lines[np.r_[breaks - 1, lines.size - 1]]
    items = [
        str(first) if first == last else f"{first}-{last}"
        for first, last in zip(firsts[:most].tolist(), lasts[:most].tolist(), strict=True)
    ]
    more = f" and {firsts.size - most} more" if firsts.size > most else ""
    return ("line " if lines.size == 1 else "lines ") + ", ".join(items) + more


#: The longest cell text a message quotes [characters]; a longer one is cut, with "…".
SHOWN_CELL = 40


def _shown_cell(cell):
    """A cell as a message quotes it: its repr, cut after :data:`SHOWN_CELL` characters (a
    damaged file may hold a cell of a megabyte)."""
    text = str(cell)
    return repr(text if len(text) <= SHOWN_CELL else text[:SHOWN_CELL] + "…")


def _cells_problem(name, what, mask, line_numbers, example=""):
    """ "column 'Torque': 3 missing values kept as NaN, first at line 2 (lines 2-4)"."""
    lines = line_numbers[mask]
    count = lines.size
    plural = "s" if count > 1 else ""
    first = f"{example} at line {lines[0]}" if example else f"at line {lines[0]}"
    where = f", first {first} ({line_list(lines)})" if count > 1 else f" {first}"
    return f"column {name!r}: {count} {what} value{plural} kept as NaN{where}"


def read_block(
    buffer,
    region,
    names,
    delimiter,
    numbers,
    source,
    skip_first=False,
    text_columns=(),
    strict=False,
):
    """Parse data rows into columns with pandas' C parser, in one pass over their bytes.

    Parameters
    ----------
    buffer : granflow.io._buffer.Buffer
        The file's content.
    region : tuple
        ``(start, stop, first_line, rows)`` from :meth:`Cursor.block`: the byte range of
        the rows (consecutive lines, no blank line inside), the file line number of the
        first row and the number of rows.
    names : list of str
        Column names (as in the file), one per cell after the skipped first cell.
    skip_first : bool
        Drop the first cell of each row (RheoCompass rows start with an empty label cell).
    text_columns : iterable of int
        Columns kept as text (status columns).
    strict : bool
        A numeric column's cell that is not a number (nor a missing-value marker) is an
        error naming its line, instead of a NaN and a problem.

    Returns
    -------
    Block
        ``values[i]`` float64 arrays (NaN where missing, invalid or infinite), ``text[i]``
        object arrays for text columns; problems name the column, the count and the lines.
    """
    import pandas as pd

    start, stop, first_line, rows = region
    offset = 1 if skip_first else 0
    count = len(names)
    most, short = count_cells(buffer.data, start, stop, delimiter, count + offset)
    if short is not None:
        cells = _cells_of_line(buffer, start, short, delimiter) - offset
        raise fail(
            source,
            first_line + short,
            f"{max(cells, 0)} cells where the header has {count} columns (a row cut short, or "
            "separators that differ from the header's)",
        )
    width = max(count + offset, most)
    if not rows:
        empty = np.empty(0, dtype=np.float64)
        return Block(
            values={i: empty for i in range(count) if i not in text_columns},
            text={i: np.empty(0, dtype=object) for i in text_columns},
            rows=0,
            problems=[],
        )
    stream = io.BufferedReader(_Region(memoryview(buffer.data)[start:stop]), 1 << 20)
    try:
        with warnings.catch_warnings():
            # chunk by chunk (low_memory): a column with text in some chunks comes back as
            # objects, which _numbers reads cell by cell; pandas' DtypeWarning says no more
            warnings.simplefilter("ignore", pd.errors.DtypeWarning)
            frame = pd.read_csv(
                stream,
                sep=delimiter,
                header=None,
                names=list(range(width)),
                # every cell of a row wider than the header is read, and checked below
                usecols=list(range(offset, width)) if width == count + offset else None,
                index_col=False,
                dtype={offset + i: "category" for i in text_columns},
                decimal=numbers.decimal,
                thousands=numbers.thousands,
                na_values=list(MISSING_MARKERS),
                keep_default_na=False,
                skip_blank_lines=False,
                quoting=csv.QUOTE_MINIMAL,
                encoding=buffer.codec,
                encoding_errors="replace",
                engine="c",
                low_memory=True,
            )
    except pd.errors.ParserError as exc:
        match = re.search(r"line (\d+)", str(exc))
        line = first_line + int(match.group(1)) - 1 if match else first_line
        found = re.search(r"saw (\d+)", str(exc))
        detail = f"{int(found.group(1)) - offset} cells" if found else "a malformed row"
        raise fail(source, line, f"{detail} where the header has {count} columns") from None
    except (ValueError, IndexError, pd.errors.EmptyDataError) as exc:
        raise fail(source, first_line, f"cannot parse the data rows ({exc})") from None
    if len(frame) != rows:
        raise fail(source, first_line, f"{rows} data lines gave {len(frame)} rows")
    if width > count + offset:
        _refuse_wide_rows(frame, buffer, region, delimiter, count, offset, width, source)
    problems = []
    values, text = {}, {}
    line_numbers = np.arange(first_line, first_line + rows)
    for position in range(count):
        column = frame[offset + position]
        if position in text_columns:
            text[position] = _text_cells(column)
            continue
        parsed = _numbers(column, numbers)
        if parsed is None:
            text[position] = _text_cells(column)
            continue
        array, missing, invalid = parsed
        name = names[position]
        _refuse_broken_numbers(column, invalid, line_numbers, name, position, source)
        infinite = ~np.isfinite(array) & ~missing & ~invalid
        if missing.any():
            problems.append((position, _cells_problem(name, "missing", missing, line_numbers)))
        if invalid.any():
            index = int(np.argmax(invalid))
            example = _shown_cell(column.iloc[index])
            if strict:
                raise fail(
                    source,
                    int(line_numbers[index]),
                    f"{_columns.column_label(position, name)} holds a cell that is not a number",
                )
            problems.append(
                (position, _cells_problem(name, "invalid", invalid, line_numbers, example))
            )
        if infinite.any():
            example = _shown_cell(str(column.iloc[int(np.argmax(infinite))]).strip())
            problems.append(
                (position, _cells_problem(name, "non-finite", infinite, line_numbers, example))
            )
            array[infinite] = np.nan
        values[position] = array
    return Block(values=values, text=text, rows=len(frame), problems=problems)


#: Bytes of a data block scanned at once when counting its cells.
_SCAN = 1 << 24
#: A cell that starts like a number: a sign, then a digit or a decimal mark and a digit.
_NUMBER_START = re.compile(r"^\s*[-+]?(?:\d|[.,]\d)")


def count_cells(data, start, stop, delimiter, needed):
    """(most cells in a line, 0-based index of the first line with fewer than ``needed``)
    of the data rows ``data[start:stop]``: delimiters plus one, counted on the bytes a
    chunk at a time (a quoted delimiter counts too: never fewer cells than pandas sees)."""
    code = ord(delimiter)
    most, short, lines, position = 0, None, 0, start
    while position < stop:
        end = min(position + _SCAN, stop)
        if end < stop:
            newline = data.find(b"\n", end, stop)
            end = stop if newline < 0 else newline + 1
        chunk = np.frombuffer(data, dtype=np.uint8, count=end - position, offset=position)
        delimiters = np.flatnonzero(chunk == code)
        breaks = np.flatnonzero(chunk == 10)
        ends = breaks if breaks.size and breaks[-1] == chunk.size - 1 else np.r_[breaks, chunk.size]
        per_line = np.diff(np.r_[0, np.searchsorted(delimiters, ends)]) + 1
        if per_line.size:
            most = max(most, int(per_line.max()))
            fewer = np.flatnonzero(per_line < needed)
            if short is None and fewer.size:
                short = lines + int(fewer[0])
        lines += per_line.size
        position = end
    return most, short


def _refuse_wide_rows(frame, buffer, region, delimiter, count, offset, width, source):
    """A row with more cells than the header is an error naming its line (empty trailing
    cells excepted): reading only the header's width would silently drop what it holds."""
    import pandas as pd

    start, _, first_line, _ = region
    filled = np.zeros(len(frame), dtype=bool)
    for position in range(count + offset, width):
        column = frame[position]
        present = column.notna().to_numpy()
        if pd.api.types.is_numeric_dtype(column.dtype):
            filled |= present
            continue
        cells = column.astype(object).to_numpy()
        for index in np.flatnonzero(present):
            filled[index] |= not _is_marker(cells[index])
    if not filled.any():
        return
    index = int(np.argmax(filled))
    line = first_line + index
    cells = _cells_of_line(buffer, start, index, delimiter) - offset
    hint = ""
    if delimiter == "," and cells >= 2 * count:
        hint = (
            " (numbers with a decimal comma in a comma-separated file? granflow reads decimal "
            "commas with semicolon or tab separators)"
        )
    raise fail(source, line, f"{cells} cells where the header has {count} columns{hint}")


def _cells_of_line(buffer, start, index, delimiter):
    """The cells of line ``index`` (0-based) of the block starting at byte ``start``, empty
    trailing cells not counted."""
    position = start
    for _ in range(index):
        position = buffer.data.find(b"\n", position) + 1
    end = buffer.data.find(b"\n", position)
    text = buffer.text(position, len(buffer.data) if end < 0 else end).rstrip("\r")
    return len(split(text, delimiter))


def _refuse_broken_numbers(column, invalid, line_numbers, name, position, source):
    """A cell that starts like a number but is not one whole ('12.5.3', '1.2e', '0,5' in a
    file of decimal dots) is an error naming its line: part of a number is a wrong number.
    Text cells ('abc', 'n/a') stay invalid values, kept as NaN."""
    if not invalid.any():
        return
    for index in np.flatnonzero(invalid):
        cell = column.iloc[int(index)]
        if isinstance(cell, str) and _NUMBER_START.match(cell):
            raise fail(
                source,
                int(line_numbers[index]),
                f"{_columns.column_label(position, name)} holds a cell that starts like a "
                "number but is not one",
            )


def _text_cells(column):
    """The cells of a text column as an object array ("" where empty)."""
    if hasattr(column, "cat"):
        categories = np.asarray(column.cat.categories, dtype=object)
        codes = column.cat.codes.to_numpy()
        return np.append(categories, "")[codes]  # code -1 (empty) picks the last
    cells = column.to_numpy(dtype=object)
    cells[column.isna().to_numpy()] = ""
    return cells


def _numbers(column, numbers):
    """(values, missing, invalid) of a column; None when most cells are text (a text column).

    Columns pandas parsed as numbers are converted at once; others cell by cell (a few odd
    cells in a numeric column, or cells pandas read as text such as ``nan``).
    """
    import pandas as pd

    if pd.api.types.is_numeric_dtype(column.dtype):
        # a copy: under copy-on-write (pandas 3) the frame's own buffer is read-only, and
        # the non-finite cells are set to NaN in place below
        array = column.to_numpy(dtype=np.float64, na_value=np.nan, copy=True)
        return array, np.isnan(array), np.zeros(array.shape, dtype=bool)
    raw = column.astype(object).tolist()
    missing = np.array([cell is None or _is_marker(cell) or _isnan(cell) for cell in raw])
    parsed = [
        float(cell)
        if isinstance(cell, int | float)
        else numbers.parse(cell)
        if isinstance(cell, str)
        else None
        for cell in raw
    ]
    invalid = np.array([value is None for value in parsed], dtype=bool) & ~missing
    if invalid.sum() > invalid.size // 2:
        return None
    array = np.array([np.nan if v is None else v for v in parsed], dtype=np.float64)
    return array, missing, invalid


def _isnan(cell):
    return isinstance(cell, float) and cell != cell
