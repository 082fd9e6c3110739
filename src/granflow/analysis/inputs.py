"""The runs of a campaign as :func:`granflow.analyze` sees them, and what identifies them.

Reading a manifest (or taking a :class:`granflow.Campaign`) into :class:`Item` values in
manifest order, a file that cannot be read included; the key that names a run's saved result;
the campaign's summary and provenance.
"""

import hashlib
import json
import os
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from granflow._json import json_safe
from granflow.analysis.files import MANIFEST_NAMES, TRUTH_FILE, read_json
from granflow.analysis.joint import rounded
from granflow.analysis.joint_results import MATERIAL_CONSTANTS
from granflow.analysis.result import RunEntry
from granflow.analysis.run_results import FailedRun, StartupResult
from granflow.analysis.runs import ANALYSES
from granflow.errors import InvalidParameterError
from granflow.model.run import Run

__all__ = [
    "ANALYSIS_VERSION",
    "Item",
    "campaign_summary",
    "identity",
    "imposed_velocity",
    "input_hashes",
    "load_campaign",
    "relative_path",
    "run_entry",
    "run_key",
]

#: Bumped whenever a per-run result changes meaning, so older saved results are not reused
#: (3: a start-up's window counts its non-finite rows, fits count the points they drop).
ANALYSIS_VERSION = 3


def _sha256_file(path):
    digest = hashlib.sha256()
    try:
        with open(path, "rb") as stream:
            for block in iter(lambda: stream.read(1 << 20), b""):
                digest.update(block)
    except OSError:
        return None
    return digest.hexdigest()


def _stem(text):
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", text).strip("._")[:60] or "run"


def run_key(identity, run, kind, options):
    """The name of a run's result file: readable stem plus a hash of everything it depends on.

    The hash covers the analysis version, the run's identity (file name relative to the
    manifest, interval, metadata), its test kind and control mode, its four columns and the
    options that change the per-run work.
    """
    digest = hashlib.sha256()
    header = {
        "version": ANALYSIS_VERSION,
        "identity": identity,
        "kind": kind,
        "control": run.control,
        "meta": {k: v for k, v in json_safe(dict(run.meta)).items() if k not in ("manifest",)},
        "options": options,
        "problems": list(run.problems),
    }
    header["meta"]["source"] = identity["source"]
    digest.update(json.dumps(header, sort_keys=True).encode("utf-8"))
    for name in ("t", "slip", "velocity", "force"):
        digest.update(np.ascontiguousarray(getattr(run, name), dtype="<f8").tobytes())
    return f"{_stem(identity['name'])}-{digest.hexdigest()[:20]}"


@dataclass
class Item:
    """One manifest entry's run (or the failure to read it), in manifest order; the engine
    fills in its kind, key and result as it goes."""

    name: str
    source: str | None
    interval: int | None
    run: Run | None = None
    kind: str | None = None
    reason: str | None = None
    key: str | None = None
    result: object = None

    @property
    def ok(self):
        """Whether the run was read and analysed."""
        return self.result is not None and not isinstance(self.result, FailedRun)


def _find_manifest(source):
    path = Path(source)
    if path.is_dir():
        for name in MANIFEST_NAMES:
            if (path / name).is_file():
                return path / name
        raise InvalidParameterError(
            f"{path}: the folder holds no manifest ({', '.join(MANIFEST_NAMES)})"
        )
    if not path.exists():
        raise InvalidParameterError(f"{path}: no such manifest or folder")
    if path.suffix.lower() not in (".yaml", ".yml", ".csv"):
        raise InvalidParameterError(
            f"{path}: a campaign is a manifest (.yaml, .yml or .csv) or a folder holding one"
        )
    return path


def relative_path(file, folder):
    """``file`` relative to ``folder`` (as given when there is no folder or another drive)."""
    if folder is None:
        return str(file)
    try:
        return os.path.relpath(os.path.abspath(file), os.path.abspath(folder))
    except ValueError:  # another drive
        return str(file)


def _run_name(run, source):
    if "name" in run.meta:
        return str(run.meta["name"])
    return f"{source}#{run.meta.get('interval', 1)}"


def _items_from_manifest(manifest, geometry, executor=None, allow_outside=False):
    """Items in manifest order: each entry's runs, or why the entry gave none (under the
    entry's own label: ``file#interval`` as the manifest asks for it)."""
    from granflow.io.campaign import manifest_runs

    folder = manifest.parent
    items, inputs = [], []
    for entry in manifest_runs(manifest, geometry, executor=executor, allow_outside=allow_outside):
        relative = None if entry.file is None else relative_path(entry.file, folder)
        if relative is not None and relative not in inputs:
            inputs.append(relative)
        if entry.runs:
            items += [_run_item(run, folder) for run in entry.runs]
            continue
        if relative is None:
            name = entry.label
        else:
            name = relative if entry.interval is None else f"{relative}#{entry.interval}"
        items.append(Item(name=name, source=relative, interval=entry.interval, reason=entry.reason))
    return items, inputs


def _run_item(run, folder):
    source = relative_path(run.meta.get("source", "run"), folder)
    return Item(
        name=_run_name(run, source), source=source, interval=run.meta.get("interval"), run=run
    )


def load_campaign(source, geometry=None, executor=None, allow_outside=False):
    """(items, manifest path or None, input files relative to the manifest folder).

    ``geometry`` (a spec for :meth:`granflow.Annulus.from_spec`) is the tube of the manifest
    entries that declare none; a Campaign's runs are already converted, so it takes none.
    ``executor`` (a :class:`granflow._parallel.Executor`) reads the files in parallel;
    ``allow_outside`` reads files outside the manifest's folder too.
    """
    from granflow.io.campaign import Campaign

    if isinstance(source, Campaign):
        if geometry is not None:
            raise InvalidParameterError(
                "geometry applies to a manifest; the runs of a Campaign are already converted "
                "(give the geometry to Campaign.from_manifest)"
            )
        items = [_run_item(run, None) for run in source.runs]
        items += [Item(name="?", source=None, interval=None, reason=p) for p in source.problems]
        inputs = list(dict.fromkeys(item.source for item in items if item.source))
        return items, None, inputs
    manifest = _find_manifest(source)
    items, inputs = _items_from_manifest(manifest, geometry, executor, allow_outside)
    return items, manifest, [manifest.name, *inputs]


def identity(item):
    """What names a run in its key: its name, file and interval."""
    return {"name": item.name, "source": item.source, "interval": item.interval}


def imposed_velocity(item):
    """The imposed velocity [m/s]: the nominal one of a start-up, the manifest's otherwise
    (the median measured velocity of a stress-controlled run is no imposed velocity)."""
    if item.kind == "startup":
        return item.run.nominal_velocity
    value = item.run.meta.get("velocity")
    return None if value is None else float(value)


def _fits(result):
    """The (window, Eq. 3 fit) pairs of a run's result (a start-up, a switch's start-up)."""
    startup = getattr(result, "startup", result)
    if isinstance(startup, StartupResult):
        return [(startup.window, startup.fit)]
    return []


def run_problems(item):
    """The data-quality problems of an item (see :class:`RunEntry`): the reader's, the
    points its fit left out for a NaN or an infinity, or why the entry gave no run."""
    if item.run is None:
        return (item.reason,) if item.reason else ()
    problems = list(item.run.problems)
    for window, fit in _fits(item.result):
        count = window.non_finite + fit.dropped.get("non_finite", 0)
        if count:
            problems.append(
                f"{count} point{'s' if count != 1 else ''} with a NaN or infinite time, slip "
                "or force left out of the fit"
            )
    return tuple(problems)


def run_entry(item, index, strict=False):
    """The :class:`~granflow.analysis.result.RunEntry` of an item whose work is done.

    With ``strict``, a run with data-quality problems is a failed run (stage "quality").
    """
    run = item.run
    result = item.result if run is not None else FailedRun(reason=item.reason)
    problems = run_problems(item)
    stage = None if item.ok else "analysis"
    if strict and problems and run is not None and item.ok:
        result = FailedRun(reason="strict: data-quality problems: " + "; ".join(problems))
        stage = "quality"
    common = {
        "index": index,
        **identity(item),
        "result": result,
        "key": item.key,
        "problems": problems,
    }
    if run is None:
        return RunEntry(
            **common,
            test=None,
            control=None,
            normal_load=None,
            velocity=None,
            preparation=None,
            points=0,
            stage="read",
        )
    return RunEntry(
        **common,
        test=item.kind,
        control=run.control,
        normal_load=run.normal_load,
        velocity=imposed_velocity(item),
        preparation=run.meta.get("preparation"),
        points=len(run),
        stage=stage,
        geometry=run.meta.get("geometry"),
        run=run,
    )


def input_hashes(manifest, inputs):
    """``[{"file", "sha256"}]`` of the input files (relative to the manifest's folder)."""
    folder = manifest.parent if manifest is not None else None
    return [
        {"file": file, "sha256": _sha256_file(folder / file if folder else file)} for file in inputs
    ]


def _truth(manifest):
    """The synthetic truth file of a demo campaign, beside the manifest or one folder up."""
    if manifest is None:
        return None, None
    for folder in (manifest.parent, manifest.parent.parent):
        path = folder / TRUTH_FILE
        if path.is_file():
            return path, read_json(path)
    return None, None


def _geometry_summary(entries):
    """The geometry of the campaign's runs: the one label they share, or a pointer to the
    runs when they differ (None when no run records one)."""
    labels = list(dict.fromkeys(e.geometry for e in entries if e.geometry is not None))
    if not labels:
        return None
    return labels[0] if len(labels) == 1 else "differs between runs (see each run's geometry)"


def campaign_summary(items, entries, manifest, material):
    """The ``campaign`` entry of ``results.json`` and whether the campaign is synthetic.

    Parameters
    ----------
    items : sequence of Item
        The campaign's items, their work done.
    entries : sequence of RunEntry
        Their entries (a run failed under ``strict`` counts as failed).
    manifest : pathlib.Path or None
    material : granflow.analysis.joint_results.Material

    Returns
    -------
    (dict, bool)
    """
    runs = [item for item in items if item.run is not None]
    analysed = sum(entry.ok for entry in entries)
    loads = sorted({rounded(i.run.normal_load) for i in runs if i.run.normal_load is not None})
    speeds = sorted({rounded(v) for v in map(imposed_velocity, runs) if v is not None})
    preparations = sorted(
        {str(i.run.meta["preparation"]) for i in runs if "preparation" in i.run.meta}
    )
    summary = {
        "manifest": None if manifest is None else str(manifest.resolve()),
        "analysed": analysed,
        "geometry": _geometry_summary(entries),
        "counts": {
            "runs": len(items),
            "analysed": analysed,
            "failed": len(items) - analysed,
            "with_problems": sum(bool(entry.problems) for entry in entries),
            "tests": {kind: sum(1 for i in runs if i.kind == kind) for kind in ANALYSES},
            "normal_loads": loads,
            "velocities": speeds,
            "preparations": preparations,
        },
        "problems": [item.reason for item in items if item.run is None],
    }
    path, truth = _truth(manifest)
    synthetic = bool(truth and truth.get("synthetic", True)) or any(
        "synthetic" in str(i.run.meta.get("notes", "")).lower() for i in runs
    )
    if isinstance(truth, dict) and all(n in truth for n in MATERIAL_CONSTANTS):
        contained = {}
        for name in MATERIAL_CONSTANTS:
            low, high = getattr(material, name).ci95
            contained[name] = bool(low is not None and low <= truth[name] <= high)
        summary["truth"] = {
            "file": relative_path(path, manifest.parent),
            "values": {n: truth[n] for n in MATERIAL_CONSTANTS},
            "contained": contained,
        }
    return summary, synthetic
