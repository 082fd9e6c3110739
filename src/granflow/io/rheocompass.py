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

from granflow.io import _columns
from granflow.io._file import BlockSpec, parse_blocks, read_with
from granflow.io._text import fail, split

__all__ = ["looks_like_rheocompass", "parse_rheocompass", "read_rheocompass"]


def looks_like_rheocompass(lines):
    """True when a line starts with RheoCompass's "Interval data:" keyword (any language)."""
    for line in lines[:2000]:
        head = line.split("\t", 1)[0].split(";", 1)[0].split(",", 1)[0]
        if _columns.match_keyword(head.strip('"')) == "interval_data":
            return True
    return False


def _integer(cells, index):
    try:
        return int(cells[index].strip())
    except (IndexError, ValueError):
        return None


def _data_rows(lines, start, delimiter):
    """Index after the last data row from ``start``: rows start with the delimiter."""
    stop = start
    count = len(lines)
    while stop < count:
        line = lines[stop]
        if not line.startswith(delimiter) or not line.strip():
            break
        stop += 1
    return stop


def _scan(lines, delimiter, source, problems):
    file_metadata, specs = {}, []
    test, test_metadata, interval_metadata = "", {}, {}
    number, declared, in_interval = 0, None, False
    index = 0
    count = len(lines)
    while index < count:
        line = lines[index]
        if not line.strip():
            index += 1
            continue
        cells = split(line, delimiter)
        keyword = _columns.match_keyword(cells[0]) if cells else None
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
                raise fail(source, index + 1, "an 'Interval data' line without column names")
            row = index + 1
            meanings, units = [], []
            for _ in range(2):
                if row >= count or not lines[row].startswith(delimiter):
                    break
                following = lines[row].split(delimiter)[1:]
                if any(cell.strip().startswith("[") for cell in following):
                    units = following
                    row += 1
                    break
                if any(cell.strip()[:1].isdigit() or cell.strip()[:1] == "-" for cell in following):
                    break
                meanings = following
                row += 1
            stop = _data_rows(lines, row, delimiter)
            metadata = {**test_metadata, **interval_metadata}
            if declared is not None:
                metadata["declared_points"] = declared
            specs.append(
                BlockSpec(
                    test=test,
                    number=number or 1,
                    header_line=index + 1,
                    names=names,
                    units=units,
                    meanings=meanings,
                    start=row,
                    stop=stop,
                    metadata=metadata,
                    skip_first=True,
                )
            )
            declared, in_interval = None, False
            index = stop
            continue
        elif cells and cells[0].strip():
            target = interval_metadata if in_interval else test_metadata
            target = target if test else file_metadata
            target[cells[0].strip()] = cells[1:]
        else:
            problems.append(f"line {index + 1}: skipped a line outside any data block")
        index += 1
    return file_metadata, specs


def parse_rheocompass(text, source="<text>", encoding="str"):
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
    return parse_blocks(_scan, "rheocompass", text, source, encoding)


def read_rheocompass(path):
    """Read a RheoCompass export file (any supported encoding); see :func:`parse_rheocompass`."""
    return read_with(parse_rheocompass, path)
