"""Format detection and the two entry points, :func:`read` and :func:`read_runs`."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

from granflow.errors import FileFormatError
from granflow.io import _buffer
from granflow.io._file import head_lines
from granflow.io._runs import runs_from_file
from granflow.io._text import fail
from granflow.io.generic import parse_csv
from granflow.io.rheocompass import looks_like_rheocompass, parse_rheocompass
from granflow.io.rheoplus import looks_like_rheoplus, parse_rheoplus
from granflow.io.trios import looks_like_trios, parse_trios

if TYPE_CHECKING:
    from granflow._typing import PathLike
    from granflow.io._file import ParsedFile
    from granflow.model.run import Run

_PARSERS = {
    "rheocompass": parse_rheocompass,
    "rheoplus": parse_rheoplus,
    "trios": parse_trios,
    "csv": parse_csv,
}
FORMATS = tuple(_PARSERS)


def detect_format(text: str) -> str:
    """ "rheoplus", "rheocompass", "trios" or "csv" from the keywords in the text (its first
    5000 lines)."""
    lines = head_lines(_buffer.from_text(text), 5000, 16 << 20)
    if looks_like_rheoplus(lines):
        return "rheoplus"
    if looks_like_rheocompass(lines):
        return "rheocompass"
    if looks_like_trios(lines):
        return "trios"
    return "csv"


def detect_file_format(path: PathLike, max_bytes: int | None = None) -> str:
    """The format :func:`read` would find in a file: "rheoplus", "rheocompass", "trios" or
    "csv" (see :func:`detect_format`).

    Raises
    ------
    granflow.FileFormatError
        The file cannot be read or is over the size limit.
    """
    path = Path(path)
    return detect_format(_buffer.load(path, max_bytes))


def parse(
    text: str,
    source: str = "<text>",
    format: str | None = None,
    encoding: str = "str",
    **options: Any,
) -> ParsedFile:
    """Parse decoded text in the given (or detected) format; ``options`` go to parse_csv."""
    form = format or detect_format(text)
    if form not in _PARSERS:
        raise FileFormatError(f"{source}: unknown format {form!r}; known: {', '.join(FORMATS)}")
    if form == "csv":
        return parse_csv(text, source=source, encoding=encoding, **options)
    if options:
        raise FileFormatError(f"{source}: options {sorted(options)} apply to CSV files only")
    return _PARSERS[form](text, source=source, encoding=encoding)


def read(
    path: PathLike, format: str | None = None, *, max_bytes: int | None = None, **options: Any
) -> ParsedFile:
    """Read an instrument export, detecting its encoding and format.

    Parameters
    ----------
    path : str or pathlib.Path
        The export file; never modified.
    format : {"rheocompass", "rheoplus", "trios", "csv"}, optional
        Skip detection.
    max_bytes : int, optional
        Largest file accepted [bytes]; a larger one is refused before it is read. Default:
        the ``GRANFLOW_MAX_BYTES`` environment variable, else
        ``granflow.io._buffer.MAX_BYTES`` (2 GiB). Reading costs about the file's size in
        memory (half of it for UTF-16) plus the parsed columns.
    **options
        ``column_map`` and ``units`` for generic CSV (see :func:`parse_csv`).

    Returns
    -------
    ParsedFile
        ``format``, ``encoding``, ``tests``, ``intervals`` (columns with units, values in file
        units, metadata, data-quality problems), ``problems``; ``report()`` prints it.

    Raises
    ------
    granflow.FileFormatError
        The file cannot be read, is over the size limit, or is not an export of a known
        layout; the message names the file and the line, and what was expected.

    Examples
    --------
    >>> import granflow, tempfile, pathlib
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "run.csv"
    >>> _ = path.write_text("Time [s];Torque [mN·m]\\n0,5;1,25\\n1,5;1,5\\n", encoding="utf-8")
    >>> parsed = granflow.read(path)
    >>> parsed.decimal, parsed.intervals[0].si("torque")
    (',', array([0.00125, 0.0015 ]))
    """
    path = Path(path)
    buffer = _buffer.load(path, max_bytes)
    if buffer.is_blank():
        raise fail(str(path), 1, "the file is empty")
    return parse(buffer, source=str(path), format=format, encoding=buffer.encoding, **options)


def read_runs(
    path: PathLike,
    geometry: Any = None,
    format: str | None = None,
    *,
    max_bytes: int | None = None,
    **options: Any,
) -> list[Run]:
    """Read an export and turn each interval into a :class:`granflow.Run`.

    Parameters
    ----------
    path : str or pathlib.Path
        The export file.
    geometry : granflow.Annulus, optional
        The contact; default ``Annulus.paper()``. Torque -> force with its effective radius,
        deflection angle -> slip and rotational speed -> velocity at its mean radius.
    format, max_bytes, **options
        As for :func:`read`.

    Returns
    -------
    list of granflow.Run
        One per interval: ``t`` [s], ``slip`` [m] (zero at the first angle of the interval),
        ``velocity`` [m/s], ``force`` [N], NaN where the file has no value or no column;
        ``control`` "rate" or "stress"; ``meta`` with ``source``, ``interval`` (1-based, in
        file order), ``test``, and what the file says (sample, normal_load, ...);
        ``problems``: the data-quality sentences of the interval ("FILE, interval K: ..."),
        rows without a time dropped. A table granflow wrote (``granflow convert``,
        :meth:`Campaign.save`: :func:`granflow.io.read_tidy`) gives its runs as written
        (forces and slips already converted: ``geometry`` does not apply).

    Examples
    --------
    >>> import granflow, tempfile, pathlib
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "run.csv"
    >>> _ = path.write_text("Time [s],Torque [mN m],Deflection Angle [mrad]\\n"
    ...                     "0,0.1,1\\n1,0.2,2\\n", encoding="utf-8")
    >>> run = granflow.read_runs(path)[0]
    >>> [round(float(value) * 1e6, 6) for value in run.slip]  # um
    [0.0, 13.7]
    """
    from granflow.io import tidy
    from granflow.model.geometry import Annulus

    if format is None and not options and tidy.is_tidy_table(path):
        return list(tidy.read_tidy(path).runs)  # granflow's own table: its runs as written
    parsed = read(path, format=format, max_bytes=max_bytes, **options)
    return runs_from_file(parsed, geometry or Annulus.paper())
