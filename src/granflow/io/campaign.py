"""A measurement campaign: many runs with their metadata, from a manifest of instrument files.

The manifest is what a user writes once for a folder of exports (YAML or CSV): which file,
which interval, the normal load, the preparation, notes. A :class:`Campaign` selects and
groups runs by load, velocity and preparation, and saves them as granflow's tidy table
(:mod:`granflow.io.tidy`: CSV with a sidecar JSON, or Parquet) that loads back identically.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

from granflow._html import HtmlReport
from granflow._json import json_safe
from granflow.errors import FileFormatError, GranflowError, InvalidParameterError
from granflow.io.manifest import (
    MANIFEST_FIELDS,
    RECORD_KINDS,
    TEST_KINDS,
    BadEntry,
    read_manifest,
)
from granflow.model.run import Run

if TYPE_CHECKING:
    import pandas as pd

    from granflow._typing import PathLike

__all__ = [
    "MANIFEST_FIELDS",
    "TEST_KINDS",
    "Campaign",
    "EntryRuns",
    "geometry_label",
    "manifest_runs",
    "read_manifest",
]


def geometry_label(geometry, declared=True):
    """How a report names a geometry: ``"paper"`` (``"paper (default)"`` when nobody
    declared it) or the tube's radii with r_eff and r_m [mm].

    Examples
    --------
    >>> from granflow import Annulus
    >>> geometry_label(Annulus.paper(), declared=False)
    'paper (default)'
    >>> geometry_label(Annulus.from_spec("outer_radius=10 mm, inner_radius=8 mm"))
    'outer radius 10 mm, inner radius 8 mm (r_eff 9.037 mm, r_m 9 mm)'
    """
    from granflow.model.geometry import Annulus

    if geometry == Annulus.paper():
        return "paper" if declared else "paper (default)"
    text = (
        f"outer radius {geometry.outer_radius * 1e3:.6g} mm, inner radius "
        f"{geometry.inner_radius * 1e3:.6g} mm (r_eff {geometry.effective_radius * 1e3:.4g} mm, "
        f"r_m {geometry.mean_radius * 1e3:.4g} mm)"
    )
    return text + (", torque at the mean radius" if geometry.torque_radius == "mean" else "")


@dataclass(frozen=True)
class EntryRuns:
    """What one manifest entry gave, in manifest order.

    Attributes
    ----------
    label : str
        ``file#interval`` (or ``file``; ``manifest entry N`` without a file), the file as the
        manifest writes it.
    file : pathlib.Path or None
        The file (relative to the working folder), None when the entry names none.
    interval : int or None
        The interval the entry asked for.
    runs : tuple of granflow.Run
        Its runs with the manifest's metadata (empty when it failed).
    reason : str or None
        Why the entry gave no run: a bad entry, a file that cannot be read, a missing interval.
    """

    label: str
    file: Path | None
    interval: int | None
    runs: tuple
    reason: str | None = None


def _entry_geometry(entry, geometry):
    """(Annulus, label) for an entry: its own ``geometry``, else ``geometry``, else the
    paper's (labelled as a default)."""
    from granflow.model.geometry import Annulus

    declared = entry.get("geometry", geometry)
    annulus = Annulus.paper() if declared is None else Annulus.from_spec(declared)
    return annulus, geometry_label(annulus, declared is not None)


def manifest_runs(path, geometry=None, *, executor=None, allow_outside=False):
    """Every entry of a manifest with its runs, reading each file once per geometry.

    Parameters
    ----------
    path : str or pathlib.Path
        The manifest (.yaml/.yml or .csv); file paths in it are relative to its folder.
    geometry : granflow.Annulus, str or mapping, optional
        The tube of entries that do not declare one (:meth:`granflow.Annulus.from_spec`);
        default the paper's. An entry's (or the manifest's defaults') ``geometry`` wins.
    executor : granflow._parallel.Executor, optional
        Reads the files in parallel on its local processes (each file once, however many
        entries name it); default, and with a Dask scheduler, one after the other in this
        process. The result is the same either way.
    allow_outside : bool
        Read files outside the manifest's folder too (see :func:`read_manifest`); default
        False: such an entry fails, named.

    Returns
    -------
    list of EntryRuns
        One per entry, in manifest order; a bad entry or a file that fails keeps its place
        and its label, with the reason.

    Raises
    ------
    granflow.FileFormatError
        A manifest that cannot be read as a whole (see :func:`read_manifest`).
    """
    from granflow.model.geometry import Annulus

    path = Path(path)
    if geometry is not None:
        geometry = Annulus.from_spec(geometry)
    planned, files = [], {}
    for entry in read_manifest(path, errors="collect", allow_outside=allow_outside):
        if isinstance(entry, BadEntry):
            planned.append((entry, None))
            continue
        if entry.get("test") in RECORD_KINDS:
            continue  # a model family's record, no rheometer export: its family reads it
        try:
            annulus, described = _entry_geometry(entry, geometry)
        except GranflowError as exc:
            planned.append((entry, exc))
            continue
        cache_key = (str(path.parent / entry["file"]), annulus)
        files.setdefault(cache_key, None)
        planned.append((entry, (cache_key, described)))
    files = dict(zip(files, _read_files(list(files), executor), strict=True))
    return [_entry_runs(path, entry, plan, files) for entry, plan in planned]


def _read_file(key):
    """The runs of one file ``(file, annulus)``, or the GranflowError that reading it raised."""
    from granflow.io import read_runs

    file, annulus = key
    try:
        return read_runs(file, geometry=annulus)
    except GranflowError as exc:
        return exc


def _read_files(keys, executor):
    """``_read_file`` of each key, in order, through ``executor`` when it runs on this
    machine's processes (a Dask cluster's workers may not see the files: read here)."""
    if executor is None or executor.scheduler is not None or not keys:
        return [_read_file(key) for key in keys]
    found = dict(executor.run(_read_file, keys))
    out = []
    for position, key in enumerate(keys):
        value = found[position]
        if isinstance(value, Exception) and not isinstance(value, GranflowError):
            # a worker that died (or a bug): read the file here, where a bug raises
            value = _read_file(key)
        out.append(value)
    return out


def _entry_runs(path, entry, plan, files):
    """The :class:`EntryRuns` of one manifest entry, its file already read."""
    if isinstance(entry, BadEntry):
        file = None if entry.file is None else path.parent / entry.file
        return EntryRuns(entry.label, file, entry.interval, (), entry.reason)
    file, interval = path.parent / entry["file"], entry.get("interval")
    label = entry["file"] if interval is None else f"{entry['file']}#{interval}"
    try:
        if isinstance(plan, GranflowError):
            raise plan
        cache_key, described = plan
        found = files[cache_key]
        if isinstance(found, GranflowError):
            raise found
        if interval is not None:
            found = [run for run in found if run.meta["interval"] == interval]
            if not found:
                raise FileFormatError(
                    f"{file}: no interval {interval} (the file has {len(files[cache_key])})"
                )
        if not found:
            raise FileFormatError(f"{file}: the file holds no run")
    except GranflowError as exc:
        return EntryRuns(label, file, interval, (), str(exc))
    extra = {k: v for k, v in entry.items() if k not in ("file", "interval", "geometry")}
    extra.update(manifest=str(path), geometry=described)
    runs = tuple(replace(run, meta={**run.meta, **extra}) for run in found)
    return EntryRuns(label, file, interval, runs)


@dataclass(frozen=True, eq=False)
class Campaign(HtmlReport):
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
    def from_manifest(
        cls,
        path: PathLike,
        geometry: Any = None,
        errors: str = "collect",
        *,
        allow_outside: bool = False,
    ) -> Campaign:
        """Read every file a manifest names and attach the manifest's metadata to its runs.

        Parameters
        ----------
        path : str or pathlib.Path
            The manifest (.yaml/.yml or .csv); file paths in it are relative to its folder.
        geometry : granflow.Annulus, str or mapping, optional
            The tube of the entries that declare none (default the paper's); see
            :func:`manifest_runs`. Each run's ``meta["geometry"]`` names the one used.
        errors : {"collect", "raise"}
            "collect" (default) records a file that fails in ``problems`` and reads the
            rest; "raise" stops at the first failure.
        allow_outside : bool
            Read files outside the manifest's folder too (see :func:`read_manifest`).
        """
        if errors not in ("collect", "raise"):
            raise InvalidParameterError(f"errors must be 'collect' or 'raise', got {errors!r}")
        runs, problems = [], []
        for entry in manifest_runs(path, geometry, allow_outside=allow_outside):
            if entry.reason is not None:
                if errors == "raise":
                    raise FileFormatError(entry.reason)
                problems.append(entry.reason)
            runs += entry.runs
        return cls(runs, problems)

    def select(self, *, rtol: float = 1e-06, **criteria: Any) -> Campaign:
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

    def group(self, by: str | tuple[str, ...]) -> dict[Any, Campaign]:
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

    def to_frame(self) -> pd.DataFrame:
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

    def save(self, path: PathLike, geometry: Any = None) -> Any:
        """Save the runs as granflow's tidy table (:mod:`granflow.io.tidy`).

        Parameters
        ----------
        path : str or pathlib.Path
            ``.csv`` (the metadata in a sidecar ``<path>.json``) or ``.parquet`` (in its
            metadata). ``pandas.read_csv(path)`` reads a CSV table as it is.
        geometry : mapping, optional
            The geometry the forces and slips were made with, kept in the metadata.

        Returns
        -------
        pathlib.Path
            The table; :meth:`load` reads it back identically (arrays bit for bit, NaN
            included; metadata as JSON values; each run's problems and the campaign's).
        """
        from granflow.io.tidy import write_tidy

        return write_tidy(path, self.runs, problems=self.problems, geometry=geometry)

    @classmethod
    def load(cls, path: PathLike) -> Campaign:
        """Load a campaign written by :meth:`save`, by ``granflow convert``, or by an earlier
        version of granflow (a CSV whose first line is ``# granflow campaign {...}``).

        Raises
        ------
        granflow.FileFormatError
            A file that is not such a table, naming it (and the line of a bad cell).
        """
        from granflow.io.tidy import read_tidy

        table = read_tidy(path)
        return cls(table.runs, table.problems)

    def run_table(self) -> pd.DataFrame:
        """A pandas DataFrame with one row per run: name, points, control and scalar
        metadata (:meth:`to_frame` has one row per point; :meth:`report` is the text)."""
        import pandas as pd

        rows = []
        for run in self.runs:
            scalars = {k: v for k, v in run.meta.items() if isinstance(v, str | int | float)}
            rows.append({"name": run.name, "points": len(run), "control": run.control, **scalars})
        return pd.DataFrame(rows)

    def report(self) -> str:
        """A readable summary: runs per load, velocity and preparation, and any problems."""
        lines = [f"campaign: {len(self.runs)} runs"]
        for key in ("normal_load", "velocity", "preparation"):
            counts = {group: len(runs) for group, runs in self.group(key).items()}
            text = ", ".join(f"{group!r}: {count}" for group, count in counts.items())
            lines.append(f"  by {key}: {text}")
        lines += [f"  problem: {problem}" for problem in self.problems]
        return "\n".join(lines)

    def to_dict(self) -> dict[str, Any]:
        """JSON-safe description (metadata and problems, no arrays)."""
        return {
            "runs": [
                {
                    "name": run.name,
                    "points": len(run),
                    "control": run.control,
                    "meta": json_safe(dict(run.meta)),
                    "problems": list(run.problems),
                }
                for run in self.runs
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
