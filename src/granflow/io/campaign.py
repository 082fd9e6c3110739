"""A measurement campaign: many runs with their metadata, from a manifest of instrument files.

The manifest is what a user writes once for a folder of exports (YAML or CSV): which file,
which interval, the normal load, the preparation, notes. A :class:`Campaign` selects and
groups runs by load, velocity and preparation, and saves the tidy data as Parquet or CSV
that loads back identically.
"""

import json
import math
from dataclasses import dataclass, field
from pathlib import Path

from granflow._json import json_safe
from granflow.errors import FileFormatError, GranflowError, InvalidParameterError
from granflow.model.run import Run

__all__ = ["MANIFEST_FIELDS", "TEST_KINDS", "Campaign", "read_manifest"]

#: Manifest columns: file (required), interval (default: all), normal_load [N or with a
#: unit, "50 mN"], velocity [m/s or "0.86 um/s"], rest_time [s or "5 min"], preparation,
#: sample, notes, test (one of :data:`TEST_KINDS`; inferred from the data when absent),
#: switch_time [s or with a unit; for a switch test: when the force was imposed].
MANIFEST_FIELDS = (
    "file",
    "interval",
    "normal_load",
    "velocity",
    "rest_time",
    "preparation",
    "sample",
    "notes",
    "test",
    "switch_time",
)
#: What a run is: a rate-controlled start-up (Fig. 2), a stress ramp (Fig. 3a), creep under a
#: constant stress (Fig. 3b), or a switch from rate to stress control (Fig. 3c).
TEST_KINDS = ("startup", "ramp", "creep", "switch")
_QUANTITIES = ("normal_load", "velocity", "rest_time", "switch_time")
_HEADER = "# granflow campaign "


def _entry(raw, where, manifest):
    """One manifest entry, checked: values with units to SI, unknown keys refused."""
    if not isinstance(raw, dict):
        raise FileFormatError(f"{manifest}, {where}: an entry must be a mapping, got {raw!r}")
    entry = {}
    for key, value in raw.items():
        key = str(key).strip()
        if key not in MANIFEST_FIELDS:
            raise FileFormatError(
                f"{manifest}, {where}: unknown field {key!r}; known: {', '.join(MANIFEST_FIELDS)}"
            )
        if value is None or (isinstance(value, float) and math.isnan(value)) or value == "":
            continue
        if key in _QUANTITIES:
            from granflow.model.units import parse_quantity, si_unit

            try:
                value = parse_quantity(value, si_unit(key), key)
            except InvalidParameterError as exc:
                raise FileFormatError(f"{manifest}, {where}: {exc}") from None
        elif key == "interval":
            try:
                value = int(value)
            except (TypeError, ValueError):
                raise FileFormatError(
                    f"{manifest}, {where}: interval must be an integer, got {value!r}"
                ) from None
        elif key == "test":
            value = str(value).strip().lower()
            if value not in TEST_KINDS:
                raise FileFormatError(
                    f"{manifest}, {where}: test must be one of {', '.join(TEST_KINDS)}, "
                    f"got {value!r}"
                )
        else:
            value = str(value)
        entry[key] = value
    if "file" not in entry:
        raise FileFormatError(f"{manifest}, {where}: the entry has no 'file'")
    return entry


def read_manifest(path):
    """Read a manifest (YAML: a list of entries, or ``runs:`` with optional ``defaults:``;
    or CSV with a header row of :data:`MANIFEST_FIELDS`) into a list of checked dicts."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8-sig")
    except (OSError, UnicodeDecodeError) as exc:
        raise FileFormatError(f"{path}: cannot read the manifest ({exc})") from None
    if path.suffix.lower() in (".yaml", ".yml"):
        import yaml

        try:
            document = yaml.safe_load(text)
        except yaml.YAMLError as exc:
            raise FileFormatError(f"{path}: not valid YAML ({exc})") from None
        defaults = {}
        if isinstance(document, dict):
            defaults = document.get("defaults") or {}
            document = document.get("runs")
        if not isinstance(document, list):
            raise FileFormatError(f"{path}: expected a list of runs (or 'runs:' with a list)")
        return [
            _entry({**defaults, **raw} if isinstance(raw, dict) else raw, f"entry {i}", path)
            for i, raw in enumerate(document, start=1)
        ]
    import csv

    rows = list(csv.DictReader(text.splitlines()))
    return [_entry(row, f"line {i}", path) for i, row in enumerate(rows, start=2)]


@dataclass(frozen=True, eq=False)
class Campaign:
    """Runs with metadata: the unit of analysis of a measurement campaign.

    Parameters
    ----------
    runs : sequence of granflow.Run
        The runs, in order.
    problems : sequence of str
        What failed while building the campaign (a file that could not be read, ...).

    Examples
    --------
    >>> import numpy as np, granflow
    >>> runs = [granflow.Run(t=[0.0, 1.0], slip=[0.0, 1e-6], velocity=[1e-6, 1e-6],
    ...                      force=[0.01, 0.011], meta={"normal_load": load, "preparation": "A"})
    ...         for load in (0.05, 0.05, 0.1)]
    >>> campaign = granflow.Campaign(runs)
    >>> sorted(campaign.group("normal_load"))
    [0.05, 0.1]
    >>> len(campaign.select(normal_load=0.05))
    2
    """

    runs: tuple
    problems: tuple = field(default=())

    def __post_init__(self):
        runs = tuple(self.runs)
        for index, run in enumerate(runs):
            if not isinstance(run, Run):
                raise InvalidParameterError(f"runs[{index}] must be a granflow.Run, got {run!r}")
        object.__setattr__(self, "runs", runs)
        object.__setattr__(self, "problems", tuple(self.problems))

    def __len__(self):
        return len(self.runs)

    def __iter__(self):
        return iter(self.runs)

    def __getitem__(self, index):
        return self.runs[index]

    def __repr__(self):
        return f"Campaign({len(self.runs)} runs, {len(self.problems)} problems)"

    @classmethod
    def from_manifest(cls, path, geometry=None, errors="collect"):
        """Read every file a manifest names and attach the manifest's metadata to its runs.

        Parameters
        ----------
        path : str or pathlib.Path
            The manifest (.yaml/.yml or .csv); file paths in it are relative to its folder.
        geometry : granflow.Annulus, optional
            Default ``Annulus.paper()``.
        errors : {"collect", "raise"}
            "collect" (default) records a file that fails in ``problems`` and reads the
            rest; "raise" stops at the first failure.
        """
        from granflow.io import read_runs

        if errors not in ("collect", "raise"):
            raise InvalidParameterError(f"errors must be 'collect' or 'raise', got {errors!r}")
        path = Path(path)
        runs, problems = [], []
        for entry in read_manifest(path):
            file = path.parent / entry["file"]
            try:
                found = read_runs(file, geometry=geometry)
                if "interval" in entry:
                    chosen = [run for run in found if run.meta["interval"] == entry["interval"]]
                    if not chosen:
                        raise FileFormatError(
                            f"{file}: no interval {entry['interval']} (the file has {len(found)})"
                        )
                    found = chosen
            except GranflowError as exc:
                if errors == "raise":
                    raise
                problems.append(str(exc))
                continue
            extra = {key: value for key, value in entry.items() if key not in ("file", "interval")}
            for run in found:
                meta = {**run.meta, **extra, "manifest": str(path)}
                runs.append(
                    Run(run.t, run.slip, run.velocity, run.force, control=run.control, meta=meta)
                )
        return cls(runs, problems)

    def select(self, *, rtol=1e-6, **criteria):
        """The runs whose metadata match every criterion (floats within ``rtol``).

        ``velocity`` compares the run's nominal velocity; other keys compare ``meta`` values
        (normal_load, preparation, control, sample, ...). A callable criterion is a predicate.
        """
        chosen = [
            run
            for run in self.runs
            if all(_matches(_value(run, key), wanted, rtol) for key, wanted in criteria.items())
        ]
        return Campaign(chosen, self.problems)

    def group(self, by):
        """``{key: Campaign}`` grouped by one field or a tuple of fields, in first-seen order.

        Floats are grouped after rounding to 6 significant digits (loads and velocities
        written by hand and by instruments differ in the last digits).
        """
        fields = (by,) if isinstance(by, str) else tuple(by)
        groups = {}
        for run in self.runs:
            key = tuple(_rounded(_value(run, name)) for name in fields)
            groups.setdefault(key if len(fields) > 1 else key[0], []).append(run)
        return {key: Campaign(runs, self.problems) for key, runs in groups.items()}

    def to_frame(self):
        """The tidy data: one row per point, columns ``run`` (0-based), t, slip, velocity,
        force [SI], control, and each scalar metadata entry as a column."""
        import pandas as pd

        frames = []
        for index, run in enumerate(self.runs):
            frame = run.to_frame()
            frame.insert(0, "run", index)
            frames.append(frame)
        if not frames:
            return pd.DataFrame(columns=["run", "t", "slip", "velocity", "force", "control"])
        tidy = pd.concat(frames, ignore_index=True)
        tidy.attrs = {}
        return tidy

    def _header(self):
        return {
            "runs": [{"control": run.control, "meta": json_safe(dict(run.meta))} for run in self],
            "problems": list(self.problems),
        }

    def save(self, path):
        """Save the tidy data as Parquet (.parquet) or CSV (.csv); :meth:`load` reads it back
        identically (values bit for bit, NaN included; metadata as JSON values)."""
        path = Path(path)
        suffix = path.suffix.lower()
        frame = self.to_frame()
        header = json.dumps(self._header(), ensure_ascii=False)
        if suffix == ".parquet":
            import pyarrow as pa
            import pyarrow.parquet as pq

            table = pa.Table.from_pandas(frame, preserve_index=False)
            metadata = {**(table.schema.metadata or {}), b"granflow": header.encode("utf-8")}
            pq.write_table(table.replace_schema_metadata(metadata), path)
        elif suffix == ".csv":
            with path.open("w", encoding="utf-8", newline="") as stream:
                stream.write(_HEADER + header + "\n")
                frame.to_csv(stream, index=False, float_format="%.17g")
        else:
            raise InvalidParameterError(f"save to .parquet or .csv, got {path.name!r}")
        return path

    @classmethod
    def load(cls, path):
        """Load a campaign written by :meth:`save`."""
        import pandas as pd

        path = Path(path)
        try:
            if path.suffix.lower() == ".parquet":
                import pyarrow.parquet as pq

                table = pq.read_table(path)
                header = json.loads(table.schema.metadata[b"granflow"].decode("utf-8"))
                frame = table.to_pandas()
            else:
                with path.open(encoding="utf-8") as stream:
                    first = stream.readline()
                    if not first.startswith(_HEADER):
                        raise FileFormatError(f"{path}, line 1: not a granflow campaign CSV")
                    header = json.loads(first[len(_HEADER) :])
                    frame = pd.read_csv(stream, dtype={"control": str}, low_memory=False)
        except (OSError, KeyError, ValueError) as exc:
            if isinstance(exc, FileFormatError):
                raise
            raise FileFormatError(f"{path}: not a granflow campaign file ({exc})") from None
        runs = []
        groups = frame.groupby("run", sort=True)
        for index, description in enumerate(header["runs"]):
            rows = groups.get_group(index) if index in groups.groups else frame.iloc[:0]
            runs.append(
                Run(
                    t=rows["t"].to_numpy(dtype=float),
                    slip=rows["slip"].to_numpy(dtype=float),
                    velocity=rows["velocity"].to_numpy(dtype=float),
                    force=rows["force"].to_numpy(dtype=float),
                    control=description["control"],
                    meta=description["meta"],
                )
            )
        return cls(runs, header.get("problems", ()))

    def summary(self):
        """A pandas DataFrame with one row per run: name, points, control and metadata."""
        import pandas as pd

        rows = []
        for run in self.runs:
            scalars = {k: v for k, v in run.meta.items() if isinstance(v, str | int | float)}
            rows.append({"name": run.name, "points": len(run), "control": run.control, **scalars})
        return pd.DataFrame(rows)

    def report(self):
        """A readable summary: runs per load, velocity and preparation, and any problems."""
        lines = [f"campaign: {len(self.runs)} runs"]
        for key in ("normal_load", "velocity", "preparation"):
            counts = {group: len(runs) for group, runs in self.group(key).items()}
            text = ", ".join(f"{group!r}: {count}" for group, count in counts.items())
            lines.append(f"  by {key}: {text}")
        lines += [f"  problem: {problem}" for problem in self.problems]
        return "\n".join(lines)

    def to_dict(self):
        """JSON-safe description (metadata and problems, no arrays)."""
        return {
            "runs": [
                {"name": run.name, "points": len(run), **desc}
                for run, desc in zip(self.runs, self._header()["runs"], strict=True)
            ],
            "problems": list(self.problems),
        }


def _value(run, key):
    if key == "velocity":
        return run.nominal_velocity
    if key == "control":
        return run.control
    return run.meta.get(key)


def _rounded(value):
    if isinstance(value, float) and math.isfinite(value) and value != 0:
        return float(f"{value:.6g}")
    return value


def _matches(value, wanted, rtol):
    if callable(wanted):
        return bool(wanted(value))
    if isinstance(wanted, int | float) and not isinstance(wanted, bool):
        return isinstance(value, int | float) and math.isclose(value, wanted, rel_tol=rtol)
    return value == wanted
