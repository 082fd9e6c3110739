"""Bytes to text and text to numbers: encoding, delimiter and decimal mark, decided per file.

Nothing here replaces characters blindly: the decimal mark and the thousands separator are
inferred from the numbers in the file, and the numeric block is parsed by pandas' C parser
with exactly those options (the fast path for million-row exports).
"""

import codecs
import csv
import io
import re
from dataclasses import dataclass

import numpy as np

from granflow.errors import FileFormatError

__all__ = ["MISSING_MARKERS", "NumberFormat", "decode", "fail", "read_block", "sniff_delimiter"]

#: Cells that mean "no value": empty, a single space, asterisks (Rheoplus prints ******).
MISSING_MARKERS = ("", " ", "******")
_ASTERISKS = re.compile(r"^\*+$")

_BOMS = (
    (codecs.BOM_UTF32_LE, "utf-32"),
    (codecs.BOM_UTF32_BE, "utf-32"),
    (codecs.BOM_UTF8, "utf-8-sig"),
    (codecs.BOM_UTF16_LE, "utf-16"),
    (codecs.BOM_UTF16_BE, "utf-16"),
)


def _is_marker(cell):
    return isinstance(cell, str) and (not cell.strip() or bool(_ASTERISKS.match(cell.strip())))


def fail(source, line, message):
    """A FileFormatError that names the file and the line (1-based)."""
    return FileFormatError(f"{source}, line {line}: {message}")


def _line_of_offset(text, offset):
    return text.count("\n", 0, offset) + 1


def decode(raw, source):
    """Decode an export: (text, encoding name, problems); readers split it with splitlines().

    BOMs decide UTF-32/UTF-16/UTF-8-sig; without one, a file with many NUL bytes is UTF-16
    (LE or BE from where the NULs sit), else strict UTF-8, else cp1252.
    """
    problems = []
    encoding = None
    for bom, name in _BOMS:
        if raw.startswith(bom):
            encoding = name
            break
    if encoding is None:
        sample = raw[:4096]
        if sample.count(0) > len(sample) // 4:
            even_nuls = sample[0::2].count(0)
            encoding = "utf-16-be" if even_nuls > sample[1::2].count(0) else "utf-16-le"
        else:
            try:
                text = raw.decode("utf-8")
                encoding = "utf-8"
            except UnicodeDecodeError:
                encoding = "cp1252"
    try:
        text = raw.decode(encoding)
    except UnicodeDecodeError as exc:
        if encoding != "cp1252":
            prefix = raw[: exc.start].decode(encoding, errors="replace")
            raise fail(
                source,
                _line_of_offset(prefix, len(prefix)),
                f"the file is not valid {encoding} text (byte {exc.start}: {exc.reason})",
            ) from None
        # cp1252 leaves five bytes undefined; a spreadsheet-mangled file may hold them.
        text = raw.decode(encoding, errors="replace")
        line = _line_of_offset(text, text.index("\ufffd"))
        problems.append(f"line {line}: bytes that are not cp1252 text were replaced by '\ufffd'")
    if "\x00" in text:
        offset = text.index("\x00")
        raise fail(
            source,
            _line_of_offset(text, offset),
            f"NUL character in {encoding} text: the file is binary or has the wrong encoding",
        )
    return text, encoding, problems


def sniff_delimiter(lines):
    """Tab, semicolon or comma: the one that splits the most of the given lines."""
    counts = {}
    for delimiter in ("\t", ";", ","):
        counts[delimiter] = sum(1 for line in lines if delimiter in line)
    best = max(counts, key=lambda delimiter: counts[delimiter])
    return best if counts[best] else "\t"


def split(line, delimiter):
    """The cells of one line (quoted fields allowed), right-stripped of empty trailing cells."""
    if '"' in line:
        cells = next(csv.reader([line], delimiter=delimiter, strict=False), [])
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


def _vote(cell):
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
            vote = _vote(cell.strip())
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
    """One parsed numeric block: float columns (file units), text columns, and what was odd."""

    values: dict
    text: dict
    rows: int
    problems: list


def read_block(
    lines,
    first_line,
    names,
    delimiter,
    numbers,
    source,
    skip_first=False,
    text_columns=(),
    strict=False,
):
    """Parse data rows into columns with pandas' C parser.

    Parameters
    ----------
    lines : list of str
        The data rows, consecutive lines of the file (no blank lines inside).
    first_line : int
        File line number (1-based) of ``lines[0]``, for messages.
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
        ``values[i]`` float64 arrays (NaN where missing or invalid), ``text[i]`` object arrays
        for text columns; problems name the column, the count and the first line.
    """
    import pandas as pd

    offset = 1 if skip_first else 0
    count = len(names)
    if not lines:
        empty = np.empty(0, dtype=np.float64)
        return Block(
            values={i: empty for i in range(count) if i not in text_columns},
            text={i: np.empty(0, dtype=object) for i in text_columns},
            rows=0,
            problems=[],
        )
    try:
        frame = pd.read_csv(
            io.StringIO("\n".join(lines)),
            sep=delimiter,
            header=None,
            names=list(range(count + offset)),
            usecols=list(range(offset, count + offset)),
            dtype={offset + i: str for i in text_columns},
            decimal=numbers.decimal,
            thousands=numbers.thousands,
            na_values=list(MISSING_MARKERS),
            keep_default_na=False,
            skip_blank_lines=False,
            quoting=csv.QUOTE_MINIMAL,
            engine="c",
            low_memory=False,
        )
    except pd.errors.ParserError as exc:
        match = re.search(r"line (\d+)", str(exc))
        line = first_line + int(match.group(1)) - 1 if match else first_line
        found = re.search(r"saw (\d+)", str(exc))
        detail = f"{int(found.group(1)) - offset} cells" if found else "a malformed row"
        raise fail(source, line, f"{detail} where the header has {count} columns") from None
    except (ValueError, IndexError, pd.errors.EmptyDataError) as exc:
        raise fail(source, first_line, f"cannot parse the data rows ({exc})") from None
    if len(frame) != len(lines):
        raise fail(source, first_line, f"{len(lines)} data lines gave {len(frame)} rows")
    problems = []
    values, text = {}, {}
    line_numbers = None
    for position in range(count):
        column = frame[offset + position]
        name = names[position]
        if position in text_columns:
            text[position] = column.fillna("").to_numpy(dtype=object)
            continue
        if pd.api.types.is_numeric_dtype(column.dtype):
            array = column.to_numpy(dtype=np.float64, na_value=np.nan)
            missing = np.isnan(array)
            invalid = np.zeros_like(missing)
        else:
            raw = column.astype(object).tolist()
            missing = np.array(column.isna(), dtype=bool)
            missing |= np.array([_is_marker(cell) for cell in raw], dtype=bool)
            parsed = [numbers.parse(cell) if isinstance(cell, str) else None for cell in raw]
            invalid = np.array([value is None for value in parsed], dtype=bool) & ~missing
            array = np.array([np.nan if v is None else v for v in parsed], dtype=np.float64)
            if invalid.sum() > invalid.size // 2:
                text[position] = column.fillna("").to_numpy(dtype=object)
                continue
        if line_numbers is None:
            line_numbers = np.arange(first_line, first_line + len(lines))
        if missing.any():
            first = int(line_numbers[np.argmax(missing)])
            problems.append(
                f"column {name!r}: {int(missing.sum())} missing values (NaN), first at line {first}"
            )
        if invalid.any():
            index = int(np.argmax(invalid))
            if strict:
                raise fail(
                    source,
                    int(line_numbers[index]),
                    f"column {name!r} has a non-numeric value "
                    f"{frame[offset + position].iloc[index]!r}",
                )
            problems.append(
                f"column {name!r}: {int(invalid.sum())} invalid values (NaN), first "
                f"{frame[offset + position].iloc[index]!r} at line {int(line_numbers[index])}"
            )
        values[position] = array
    return Block(values=values, text=text, rows=len(frame), problems=problems)
