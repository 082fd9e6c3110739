"""granflow's own table of runs: one row per point, metadata beside it.

The table has the columns of :data:`COLUMNS` (SI, units in their names; empty where unknown),
so that ``pandas.read_csv(path)`` reads it as it is. Everything else is JSON: the column
descriptions, the geometry the forces and slips were made with, each run's metadata and
data-quality problems, and what failed while gathering the runs. The JSON is a sidecar file
``<table>.json`` beside a CSV table (``tidy.csv`` -> ``tidy.csv.json``) and the schema
metadata (key ``granflow``) of a Parquet table.

:func:`write_tidy` writes it (``granflow convert`` and :meth:`granflow.Campaign.save`);
:func:`read_tidy` reads it back bit for bit, and also the tables of earlier versions (a CSV
whose first line is ``# granflow campaign {...}``; Parquet with columns t, slip, ...).

Examples
--------
>>> import tempfile, pathlib, granflow
>>> from granflow.io.tidy import read_tidy, write_tidy
>>> run = granflow.Run(t=[0.0, 1.0], slip=[0.0, 1e-6], velocity=[1e-6, 1e-6],
...                    force=[0.01, float("nan")], problems=["a gap in time"])
>>> path = pathlib.Path(tempfile.mkdtemp()) / "tidy.csv"
>>> _ = write_tidy(path, [run])
>>> sorted(p.name for p in path.parent.iterdir())
['tidy.csv', 'tidy.csv.json']
>>> back = read_tidy(path)
>>> back.runs[0].force, back.runs[0].problems
(array([0.01,  nan]), ('a gap in time',))
"""

from __future__ import annotations

import json
import re
import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from granflow.errors import FileFormatError, GranflowError, InvalidParameterError
from granflow.model.run import Run
from granflow.model.units import column_name

if TYPE_CHECKING:
    from granflow._typing import PathLike
    from granflow.model.run import Run

__all__ = [
    "COLUMNS",
    "SUFFIXES",
    "TidyTable",
    "is_tidy_table",
    "metadata_location",
    "read_tidy",
    "sidecar_path",
    "write_tidy",
]

#: The columns of the table, in order, and what each holds.
COLUMNS = {
    "run": "the run's number in the table: 1, 2, ... ('granflow fit TABLE --interval N')",
    "source": "the file the run was read from",
    "interval": "the interval's number in that file (1-based, in file order)",
    "control": "'rate' (imposed velocity) or 'stress' (imposed force)",
    "t_s": "time since the start of the interval [s]",
    "slip_m": "slip at the mean radius, 0 at the start of the interval [m]",
    "velocity_m_s": "sliding velocity at the mean radius [m/s]",
    "force_N": "friction force [N]",
}
#: The file suffixes a table may have.
SUFFIXES = (".csv", ".parquet")
#: Run attribute -> column: the names every table granflow writes gives these quantities.
_SERIES = {name: column_name(name) for name in ("t", "slip", "velocity", "force")}
_REQUIRED = ("run", "t_s", "force_N")
_KEY = "granflow"
_VERSION = 1
#: The first line of a CSV table of earlier versions (the metadata as JSON after it).
_OLD_CSV = "# granflow campaign "


@dataclass(frozen=True)
class TidyTable:
    """What :func:`read_tidy` found.

    Attributes
    ----------
    runs : tuple of granflow.Run
        The runs, in table order, with their metadata and data-quality problems.
    problems : tuple of str
        What failed while the runs were gathered (a file that could not be read, ...).
    geometry : dict or None
        The geometry the forces and slips were made with, as the writer described it; None
        when unknown (a CSV without its sidecar, a table of an earlier version).
    """

    runs: tuple
    problems: tuple = ()
    geometry: dict | None = None


def sidecar_path(path):
    """The metadata file beside a CSV table: ``<table>.json``.

    Parameters
    ----------
    path : str or pathlib.Path
        The CSV table.

    Returns
    -------
    pathlib.Path
    """
    return Path(f"{path}.json")


def metadata_location(path):
    """Where :func:`write_tidy` puts the metadata of ``path``, in words.

    Parameters
    ----------
    path : str or pathlib.Path
        The table (.csv or .parquet).

    Returns
    -------
    str
        The sidecar's path for a CSV table; ``"<table> (Parquet metadata 'granflow')"``.
    """
    if _suffix(path) == ".csv":
        return str(sidecar_path(path))
    return f"{path} (Parquet metadata '{_KEY}')"


def write_tidy(
    path: PathLike, runs: Sequence[Run], *, problems: Sequence[str] = (), geometry: Any = None
) -> Path:
    """Write runs as a tidy table (.csv with a sidecar .json, or .parquet).

    Parameters
    ----------
    path : str or pathlib.Path
        The table; its suffix (.csv or .parquet) chooses the format. An existing file (and
        its sidecar) is replaced.
    runs : sequence of granflow.Run
        The runs; the table numbers them 1, 2, ... in this order. Their arrays are written
        with 17 significant digits, so that :func:`read_tidy` gives them back bit for bit.
    problems : sequence of str, optional
        What failed while gathering the runs, one sentence each.
    geometry : mapping, optional
        The geometry the forces and slips were made with (JSON-safe), kept as it is.

    Returns
    -------
    pathlib.Path
        The table; :func:`metadata_location` says where the metadata went.

    Raises
    ------
    granflow.InvalidParameterError
        A suffix other than .csv or .parquet, or a run that is not a :class:`granflow.Run`.
    ImportError
        A Parquet table without pyarrow (the ``parquet`` extra).
    """
    import pandas as pd

    from granflow._json import json_safe

    path = Path(path)
    suffix = _suffix(path)
    runs = tuple(runs)
    for index, run in enumerate(runs):
        if not isinstance(run, Run):
            raise InvalidParameterError(f"runs[{index}] must be a granflow.Run, got {run!r}")
    frame = pd.DataFrame(
        {
            "run": _repeat(range(1, len(runs) + 1), runs, "int64"),
            "source": _repeat([str(run.meta.get("source", "")) for run in runs], runs),
            "interval": _interval_column(runs),
            "control": _repeat([run.control for run in runs], runs),
            **{column: _concat(runs, name) for name, column in _SERIES.items()},
        }
    )
    metadata = {
        _KEY: _VERSION,
        "columns": COLUMNS,
        "geometry": json_safe(geometry),
        "runs": [
            {
                "run": number,
                "name": run.name,
                "points": len(run),
                "control": run.control,
                "meta": json_safe(dict(run.meta)),
                "problems": list(run.problems),
            }
            for number, run in enumerate(runs, start=1)
        ],
        "problems": [str(problem) for problem in problems],
    }
    text = json.dumps(metadata, ensure_ascii=False, indent=1)
    if suffix == ".csv":
        frame.to_csv(path, index=False, float_format="%.17g")
        sidecar_path(path).write_text(text + "\n", encoding="utf-8")
        return path
    pa, pq = _pyarrow()
    table = pa.Table.from_pandas(frame, preserve_index=False)
    schema = {**(table.schema.metadata or {}), _KEY.encode(): text.encode("utf-8")}
    pq.write_table(table.replace_schema_metadata(schema), path)
    return path


def is_tidy_table(path: PathLike) -> bool:
    """Whether ``path`` is a table granflow wrote (so that :func:`read_tidy` is the reader).

    A Parquet file counts (:func:`read_tidy` says when it is not granflow's); a CSV counts when
    its first line is the header of :data:`COLUMNS` (at least run, t_s and force_N) or the
    comment line of an earlier version.

    Parameters
    ----------
    path : str or pathlib.Path

    Returns
    -------
    bool
    """
    path = Path(path)
    if path.suffix.lower() == ".parquet":
        return True
    try:
        with path.open("rb") as stream:
            first = stream.readline(65536).decode("utf-8", "replace")
    except OSError:
        return False
    if first.startswith(_OLD_CSV):
        return True
    names = {cell.strip().strip('"') for cell in first.split(",")}
    return set(_REQUIRED) <= names


def read_tidy(path: PathLike) -> TidyTable:
    """Read a table :func:`write_tidy` wrote, or one of an earlier version.

    Parameters
    ----------
    path : str or pathlib.Path
        The table (.csv, its sidecar beside it when there is one, or .parquet).

    Returns
    -------
    TidyTable
        The runs (arrays bit for bit, NaN included; metadata as JSON values), the problems and
        the geometry. A CSV without its sidecar gives runs with ``source`` and ``interval``
        from the table, no problems and no geometry.

    Raises
    ------
    granflow.FileFormatError
        A file that is not such a table, naming it and, for a bad cell, its line.
    ImportError
        A Parquet table without pyarrow (the ``parquet`` extra).
    """
    path = Path(path)
    if not path.is_file():
        raise FileFormatError(f"{path}: no such file")
    if path.suffix.lower() == ".parquet":
        return _read_parquet(path)
    with path.open("rb") as stream:
        first = stream.readline(65536).decode("utf-8", "replace")
    if first.startswith(_OLD_CSV):
        return _read_old_csv(path)
    if not is_tidy_table(path):
        raise FileFormatError(
            f"{path}, line 1: not a granflow table (the header needs {', '.join(_REQUIRED)})"
        )
    metadata = None
    if sidecar_path(path).is_file():
        try:
            metadata = json.loads(sidecar_path(path).read_text(encoding="utf-8"))
        except (UnicodeDecodeError, json.JSONDecodeError) as exc:
            raise FileFormatError(f"{sidecar_path(path)}: not a JSON file ({exc})") from None
    return _table(_read_csv(path), metadata, path)


def _suffix(path):
    suffix = Path(path).suffix.lower()
    if suffix not in SUFFIXES:
        raise InvalidParameterError(f"path must end in .csv or .parquet, got {Path(path).name!r}")
    return suffix


def _repeat(values, runs, dtype=object):
    """One value per run, repeated over the run's points."""
    import numpy as np

    return np.repeat(np.array(list(values), dtype=dtype), [len(run) for run in runs])


def _interval_column(runs):
    """The runs' ``meta["interval"]``: integers, or floats with NaN where one is not an integer."""
    intervals = [run.meta.get("interval") for run in runs]
    numbers = [isinstance(v, int | float) and not isinstance(v, bool) for v in intervals]
    if all(numbers) and all(isinstance(value, int) for value in intervals):
        return _repeat(intervals, runs, "int64")
    pairs = zip(intervals, numbers, strict=True)
    values = [float(value) if number else float("nan") for value, number in pairs]
    return _repeat(values, runs, float)


def _concat(runs, name):
    import numpy as np

    return np.concatenate([getattr(run, name) for run in runs]) if runs else np.array([])


def _pyarrow():
    """(pyarrow, pyarrow.parquet), or an ImportError naming the extra."""
    try:
        import pyarrow as pa
        import pyarrow.parquet as pq
    except ImportError:
        raise ImportError(
            "Parquet tables need pyarrow: pip install granflow[parquet] (or write .csv)"
        ) from None
    return pa, pq


def _read_parquet(path):
    _, pq = _pyarrow()
    try:
        table = pq.read_table(path)
    except (OSError, ValueError):
        raise FileFormatError(f"{path}: not a readable Parquet file") from None
    schema = table.schema.metadata or {}
    if _KEY.encode() not in schema:
        raise FileFormatError(
            f"{path}: a Parquet file without granflow's metadata; granflow reads the Parquet "
            "tables it writes"
        )
    metadata = _json(schema[_KEY.encode()].decode("utf-8"), path)
    if "t_s" not in table.column_names:
        return _old_table(table.to_pandas(), metadata, path)
    return _table(table.to_pandas(), metadata, path)


def _json(text, path):
    try:
        metadata = json.loads(text)
    except json.JSONDecodeError as exc:
        raise FileFormatError(f"{path}: granflow's metadata is not JSON ({exc})") from None
    if not isinstance(metadata, dict):
        raise FileFormatError(f"{path}: granflow's metadata is not a JSON object")
    return metadata


def _read_csv(path, skip=0):
    """The table as a DataFrame, its rows checked first as every reader checks them: UTF-8
    text, a last line with its line end (granflow ends every table with one: a file
    without it was cut short), every row as wide as the header."""
    import io

    import pandas as pd

    from granflow.io import _buffer
    from granflow.io._text import count_cells

    data = _buffer.load(path).data
    try:
        bytes(data).decode("utf-8")
    except UnicodeDecodeError as exc:
        line = data.count(b"\n", 0, exc.start) + 1
        raise FileFormatError(f"{path}, line {line}: not UTF-8 text") from None
    if data and data[-1:] not in (b"\n", b"\r"):
        line = data.count(b"\n") + 1
        raise FileFormatError(
            f"{path}, line {line}: the last line has no line end: the table was cut short"
        )
    start = 0
    for _ in range(skip + 1):  # past the comment line of an old table and the header
        start = data.find(b"\n", start) + 1
    header = data[: start - 1].rsplit(b"\n", 1)[-1].count(b",") + 1
    most, short = count_cells(data, start, len(data), ",", header)
    if short is not None and data[start:].strip():
        raise FileFormatError(
            f"{path}, line {skip + 2 + short}: a row has fewer cells than the header's {header}"
        )
    if most > header:  # more commas than the header's: read the rows with their quotes
        _refuse_wide_rows(data[start:], header, path, skip + 2)
    try:
        with warnings.catch_warnings():  # empty cells after the last column are no data
            warnings.simplefilter("ignore", pd.errors.ParserWarning)
            return pd.read_csv(
                io.BytesIO(data),
                skiprows=skip,
                dtype={"source": str, "control": str},
                low_memory=False,
                index_col=False,
            )
    except pd.errors.ParserError as exc:
        line = re.search(r"line (\d+)", str(exc))
        where = f", line {int(line[1]) + skip}" if line else ""
        raise FileFormatError(f"{path}{where}: a row has more cells than the header") from None


def _refuse_wide_rows(rows, header, path, first_line):
    """A row with more cells than the header (quoted commas are one cell) is an error naming
    its line; pandas would drop the extra cells of the first row silently."""
    import csv

    text = bytes(rows).decode("utf-8").splitlines()
    for number, line in enumerate(text, start=first_line):
        try:
            cells = next(csv.reader([line]), [])
        except csv.Error:  # a field past the csv module's limit, say
            cells = line.split(",")
        while len(cells) > header and not cells[-1].strip():
            cells.pop()
        if len(cells) > header:
            raise FileFormatError(
                f"{path}, line {number}: a row has {len(cells)} cells where the header has {header}"
            )


def _numbers(frame, column, path, header_line=1):
    """A column as floats (NaN where absent); a cell that is not a number names its line."""
    import numpy as np
    import pandas as pd

    if column not in frame:
        return np.full(len(frame), np.nan)
    values = pd.to_numeric(frame[column], errors="coerce").to_numpy(dtype=float)
    bad = np.isnan(values) & frame[column].notna().to_numpy()
    if bad.any():
        row = int(np.argmax(bad))
        raise FileFormatError(
            f"{path}, line {row + header_line + 1}: column {column!r} holds a cell that is "
            "not a number"
        )
    return values


def _rows_by_run(numbers, path, header_line=1):
    """{run number: row indices}, in the order the numbers first appear."""
    import numpy as np

    if np.isnan(numbers).any():
        line = int(np.argmax(np.isnan(numbers))) + header_line + 1
        raise FileFormatError(f"{path}, line {line}: the 'run' cell is empty")
    values, first, inverse = np.unique(numbers, return_index=True, return_inverse=True)
    order = np.argsort(inverse, kind="stable")
    groups = np.split(order, np.cumsum(np.bincount(inverse, minlength=len(values)))[:-1])
    return {int(values[k]): groups[k] for k in np.argsort(first)}


def _run(path, number, columns, rows, header_line=1, **fields):
    try:
        return Run(**{name: values[rows] for name, values in columns.items()}, **fields)
    except GranflowError as exc:
        where = f", line {int(rows[0]) + header_line + 1}" if len(rows) else ""
        raise FileFormatError(f"{path}{where}: run {number}: {exc}") from None


def _fields(entry):
    """The Run fields a metadata entry holds: control, meta, problems."""
    return {key: entry[key] for key in ("control", "meta", "problems") if key in entry}


def _table(frame, metadata, path):
    """The TidyTable of a table (columns of COLUMNS) and its metadata (None: the table alone)."""
    rows = _rows_by_run(_numbers(frame, "run", path), path)
    columns = {name: _numbers(frame, column, path) for name, column in _SERIES.items()}
    if metadata is None:
        runs = []
        for number, where in rows.items():
            first = where[0] if len(where) else 0
            meta = {
                key: frame[key].iloc[first]
                for key in ("source", "interval")
                if key in frame and frame[key].notna().iloc[first]
            }
            control = frame["control"].iloc[first] if "control" in frame else "rate"
            runs.append(_run(path, number, columns, where, control=control, meta=meta))
        return TidyTable(tuple(runs), (), None)
    runs = []
    for entry in metadata.get("runs", []):
        number = entry.get("run")
        where = rows.pop(number, [])
        if "points" in entry and len(where) != entry["points"]:
            last = int(where[-1]) + 2 if len(where) else len(frame) + 1
            raise FileFormatError(
                f"{path}, line {last}: run {number} has {len(where)} rows, its metadata says "
                f"{entry['points']}; the table and its metadata do not belong together"
            )
        runs.append(_run(path, number, columns, where, **_fields(entry)))
    if rows:
        number, where = next(iter(rows.items()))
        raise FileFormatError(
            f"{path}, line {int(where[0]) + 2}: run {number} is not in the table's metadata"
        )
    return TidyTable(tuple(runs), tuple(metadata.get("problems", ())), metadata.get("geometry"))


def _read_old_csv(path):
    """A CSV of an earlier version: ``# granflow campaign {json}``, then the table."""
    with path.open(encoding="utf-8") as stream:
        first = stream.readline()
    return _old_table(_read_csv(path, skip=1), _json(first[len(_OLD_CSV) :], path), path)


def _old_table(frame, metadata, path):
    """The TidyTable of an earlier version's table: columns run (0-based), t, slip, velocity,
    force; the runs' control, meta and problems in the metadata's ``runs``."""
    rows = _rows_by_run(_numbers(frame, "run", path, 2), path, 2)
    columns = {name: _numbers(frame, name, path, 2) for name in _SERIES}
    runs = [
        _run(path, index + 1, columns, rows.get(index, []), 2, **_fields(entry))
        for index, entry in enumerate(metadata.get("runs", []))
    ]
    return TidyTable(tuple(runs), tuple(metadata.get("problems", ())), None)
