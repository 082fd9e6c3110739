"""The tidy table ``granflow convert`` writes and ``granflow fit`` reads back.

One row per point, the columns of :data:`COLUMNS` (units in their names), so that
``pandas.read_csv(path)`` reads it as it is. Everything else (each run's metadata and
data-quality problems, the files that failed, the geometry) is JSON: in a sidecar file
``<table>.json`` beside a CSV table (``tidy.csv`` -> ``tidy.csv.json``), in the schema
metadata (key ``granflow``) of a Parquet table. Tables of earlier versions (a
``# granflow campaign`` first line; Parquet with columns t, slip, ...) are read with
:meth:`granflow.Campaign.load`.
"""

import json
import re
from pathlib import Path

import granflow
from granflow.cli._common import UsageError
from granflow.errors import FileFormatError, GranflowError

__all__ = ["COLUMNS", "DESCRIPTION", "check_suffix", "load", "save"]

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
#: Run attribute -> column.
_SERIES = {"t": "t_s", "slip": "slip_m", "velocity": "velocity_m_s", "force": "force_N"}
_REQUIRED = ("run", "t_s", "force_N")
_KEY = "granflow"
_VERSION = 1
_OLD_CSV = b"# granflow campaign "

DESCRIPTION = (
    "The table has one row per point, columns run, source, interval, control, t_s, slip_m,\n"
    "velocity_m_s, force_N (SI; empty where unknown); pandas.read_csv reads it as it is. Each\n"
    "run's metadata and data-quality problems, the files that failed and the geometry are in\n"
    "TABLE.json beside a CSV (tidy.csv -> tidy.csv.json), in the metadata of a Parquet table."
)


def check_suffix(path):
    """Refuse an output that is neither .csv nor .parquet (before any work is done)."""
    if Path(path).suffix.lower() not in (".csv", ".parquet"):
        raise UsageError(f"-o must end in .csv or .parquet, got {Path(path).name!r}")


def sidecar(path):
    """The metadata file beside a CSV table."""
    return Path(f"{path}.json")


def save(runs, failures, path, choice):
    """Write ``runs`` as a tidy table; returns (table path, where the metadata went).

    Parameters
    ----------
    runs : sequence of granflow.Run
    failures : sequence of str
        The files that could not be read, one sentence each.
    path : str or pathlib.Path
        ``.csv`` (with a sidecar ``.json``) or ``.parquet``.
    choice : GeometryChoice
        The geometry the exports were converted with.
    """
    import pandas as pd

    from granflow._json import json_safe

    check_suffix(path)
    path = Path(path)
    frames = [
        pd.DataFrame(
            {
                "run": number,
                "source": str(run.meta.get("source", "")),
                "interval": run.meta.get("interval"),
                "control": run.control,
                **{column: getattr(run, name) for name, column in _SERIES.items()},
            },
            index=range(len(run)),
        )
        for number, run in enumerate(runs, start=1)
    ]
    frame = pd.concat(frames, ignore_index=True)[list(COLUMNS)]
    metadata = {
        _KEY: _VERSION,
        "columns": COLUMNS,
        "geometry": choice.to_dict(),
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
        "problems": list(failures),
    }
    text = json.dumps(metadata, ensure_ascii=False, indent=1)
    if path.suffix.lower() == ".csv":
        frame.to_csv(path, index=False, float_format="%.17g")
        sidecar(path).write_text(text + "\n", encoding="utf-8")
        return path, sidecar(path)
    pa, pq = _pyarrow()
    table = pa.Table.from_pandas(frame, preserve_index=False)
    schema = {**(table.schema.metadata or {}), _KEY.encode(): text.encode("utf-8")}
    pq.write_table(table.replace_schema_metadata(schema), path)
    return path, f"{path} (Parquet metadata '{_KEY}')"


def load(path):
    """(runs, geometry) of a tidy table, or None when ``path`` is not one.

    ``geometry`` is the mapping the table was converted with, or None when unknown (a CSV
    without its sidecar, a table of an earlier version).
    """
    path = Path(path)
    if path.suffix.lower() == ".parquet":
        return _load_parquet(path)
    with path.open("rb") as stream:
        first = stream.readline(65536)
    if first.startswith(_OLD_CSV):
        return list(granflow.Campaign.load(path)), None
    names = {cell.strip().strip('"') for cell in first.decode("utf-8", "replace").split(",")}
    if not set(_REQUIRED) <= names:
        return None
    metadata = None
    if sidecar(path).is_file():
        try:
            metadata = json.loads(sidecar(path).read_text(encoding="utf-8"))
        except (UnicodeDecodeError, json.JSONDecodeError) as exc:
            raise FileFormatError(f"{sidecar(path)}: not a JSON file ({exc})") from None
    return _runs(_read_csv(path), metadata, path)


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


def _load_parquet(path):
    _, pq = _pyarrow()
    try:
        table = pq.read_table(path)
    except (OSError, ValueError):
        raise FileFormatError(f"{path}: not a readable Parquet file") from None
    schema = table.schema.metadata or {}
    if _KEY.encode() not in schema:
        raise FileFormatError(
            f"{path}: a Parquet file without granflow's metadata; granflow reads the Parquet "
            "tables 'granflow convert' writes"
        )
    if "t_s" not in table.column_names:
        return list(granflow.Campaign.load(path)), None
    metadata = json.loads(schema[_KEY.encode()].decode("utf-8"))
    return _runs(table.to_pandas(), metadata, path)


def _read_csv(path):
    import pandas as pd

    try:
        return pd.read_csv(path, dtype={"source": str, "control": str}, low_memory=False)
    except pd.errors.ParserError as exc:
        line = re.search(r"line (\d+)", str(exc))
        where = f", line {line[1]}" if line else ""
        raise FileFormatError(f"{path}{where}: a row has more cells than the header") from None
    except UnicodeDecodeError:
        raise FileFormatError(f"{path}: not a UTF-8 text file") from None


def _numbers(frame, column, path):
    """A column as floats; a cell that is not a number is an error naming its line."""
    import numpy as np
    import pandas as pd

    if column not in frame:
        return np.full(len(frame), np.nan)
    values = pd.to_numeric(frame[column], errors="coerce").to_numpy(dtype=float)
    bad = np.isnan(values) & frame[column].notna().to_numpy()
    if bad.any():
        row = int(np.argmax(bad))
        raise FileFormatError(
            f"{path}, line {row + 2}: column {column!r} holds {frame[column].iloc[row]!r}, "
            "not a number"
        )
    return values


def _runs(frame, metadata, path):
    """(runs, geometry) from the table and its metadata (None: the table alone)."""
    import numpy as np

    metadata = metadata or {}
    described = {entry.get("run"): entry for entry in metadata.get("runs", [])}
    numbers = _numbers(frame, "run", path)
    if np.isnan(numbers).any():
        raise FileFormatError(
            f"{path}, line {int(np.argmax(np.isnan(numbers))) + 2}: the 'run' cell is empty"
        )
    series = {name: _numbers(frame, column, path) for name, column in _SERIES.items()}
    _, first = np.unique(numbers, return_index=True)
    runs = []
    for row in np.sort(first):
        number = numbers[row]
        rows = numbers == number
        entry = described.get(int(number), {})
        meta = entry.get("meta") or {
            key: frame[key].iloc[row] for key in ("source", "interval") if key in frame
        }
        control = frame["control"].iloc[row] if "control" in frame else "rate"
        try:
            runs.append(
                granflow.Run(
                    **{name: values[rows] for name, values in series.items()},
                    control=control,
                    meta=meta,
                    problems=entry.get("problems", ()),
                )
            )
        except GranflowError as exc:
            raise FileFormatError(f"{path}, run {int(number)}: {exc}") from None
    return runs, metadata.get("geometry")
