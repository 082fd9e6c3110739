"""A whole campaign, from a manifest of instrument exports to results, tables, figures and a report.

:func:`analyze` reads every run a manifest names, analyses each run on its own (the part that
runs in parallel), then runs the joint analyses the campaign allows and predicts the
stress-controlled behaviour from the fitted constants. The rules it follows:

**What a run is.** The manifest's ``test`` field (``startup``, ``ramp``, ``creep``, ``switch``)
wins. Without it: a rate-controlled run is a start-up; a stress-controlled run that begins
with at least 10 points at one positive velocity (within 5 %) is a switch from rate to
stress control; otherwise a stress-controlled run whose force rises (the median of its last
tenth exceeds that of its first tenth by more than 5 % of the former) is a stress ramp, and
one whose force stays level is a creep test.

**Per-run work.**

* *start-up*: Eq. 3 fitted in the slip domain (:func:`granflow.fit`). Abscissa: the measured
  slip where it is finite and strictly increasing, otherwise the nominal velocity times the
  time. Fit window: the model starts at x0, and fitting.py keeps the objective continuous for
  points below x0 (they are compared with the initial force), so every point with positive
  slip is fitted, except an *elastic loading ramp* at the start: the leading points over
  which the force rises in a straight line from the first point (all interior points within
  5 noise standard deviations of the chord from the first point, the noise taken from second
  differences), which Eq. 3 does not describe. The window starts at the last point of that
  line (the kink where the layer starts to slide).
* *creep*: :func:`granflow.fit_creep` on the slip from the first point at which the force has
  reached 98 % of its level (the median of the second half), time and slip counted from it.
* *stress ramp*: the observed failure. The slip *runs away* at the first point whose slip
  velocity (the velocity column, or the slip's derivative) reaches ``RUNAWAY_FACTOR`` (10)
  times the campaign's reference velocity (the median start-up velocity; 1 µm/s without
  start-ups), or from which on the velocity is missing to the end (an export's runaway
  marker). Creep is slower than the drive and the flow after a failure much faster, so the
  factor need not be fine-tuned. The failure force is the largest force the layer held: the
  force at the last point before the runaway.
* *switch*: the switch is at the manifest's ``switch_time`` when given, else at the first
  point whose velocity departs from the nominal one by more than half of it (or is missing).
  The points before it are fitted as a start-up; the outcome after it is *failure* (a
  runaway as above, relative to the nominal velocity), *stop* (last velocity below 1 % of
  the nominal one) or *creep*.

A run that cannot be analysed (an error, or a fit with ``success=False``) is a failed run; a
file that cannot be read is one too; the rest goes on.

**Joint analyses** (main process, only where the campaign allows): velocity collapse over the
start-up runs at the load with the most distinct velocities; Amontons' law over loads with
the runs at the most common velocity (the material constants mu_a, mu_d, alpha; with one load,
a joint fit at that load divided by the load); the preparation spread over repeats (same
load, velocity and preparation); the model comparison on the first start-up run of the
largest (load, velocity) group, which is also the run sampled with ``mcmc=True``.

**Predictions.** The static yield per load, ``F_peak`` from the material constants and the
mean x0 of the start-ups at that load (pooled over all start-ups for a load without any),
with a standard error propagated linearly from the covariance of the constants and the
standard error of the mean x0, and the spread over the preparations; a stability map at a
representative load (that of the first switch run, else the most common start-up load);
each ramp's observed failure force against the predicted F_peak; each switch's observed
outcome against :func:`granflow.simulate` (quasi-static, slip clock) with the run's own
start-up fit (or the material constants at its load).

**Results on disk.** Each run's result is written atomically to ``OUTPUT/runs/<key>.json`` as
soon as it is ready; the key hashes the run's file name, interval, metadata and data and the
analysis options, so ``resume=True`` reuses exactly the results that still match. Everything
is ordered by the manifest, never by completion, and everything that differs between two
equivalent analyses (dates, durations, jobs, scheduler, runs fitted now or reused) is kept in
``results["timing"]`` only.
"""

import contextlib
import datetime
import hashlib
import json
import math
import os
import re
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from types import MappingProxyType

import numpy as np

from granflow._json import json_safe
from granflow._parallel import Executor
from granflow.analysis.joint import _MAP_HOLD, _MAP_POINTS, _MAP_RATIOS, _joint_stage, _rounded
from granflow.analysis.outputs import (
    FIGURES_DIR,
    REPORT_FILE,
    RESULTS_FILE,
    RUNS_DIR,
    TABLES_DIR,
    _dump,
    _make_figures,
    _read_json,
    _write_json,
    _write_report,
    _write_tables,
)
from granflow.analysis.runs import (
    _ANALYSES,
    _RAMP_TOLERANCE,
    RUNAWAY_FACTOR,
    StartupData,
    analyse_run,
    classify,
    startup_data,
)
from granflow.errors import InvalidParameterError
from granflow.model.run import Run

__all__ = [
    "RUNAWAY_FACTOR",
    "AnalysisResult",
    "StartupData",
    "analyze",
    "classify",
    "startup_data",
]

#: Bumped whenever a per-run result changes meaning, so older saved results are not reused.
ANALYSIS_VERSION = 1
_MARKER = "granflow_run_record"
_MANIFEST_NAMES = ("manifest.yaml", "manifest.yml", "manifest.csv")
_DEFAULT_REFERENCE_VELOCITY = 1e-6  # m/s, as granflow.simulate


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
    }
    header["meta"]["source"] = identity["source"]
    digest.update(json.dumps(header, sort_keys=True).encode("utf-8"))
    for name in ("t", "slip", "velocity", "force"):
        digest.update(np.ascontiguousarray(getattr(run, name), dtype="<f8").tobytes())
    return f"{_stem(identity['name'])}-{digest.hexdigest()[:20]}"


# --------------------------------------------------------------------------- progress


class _Progress:
    """Reports finished runs on stderr: a bar on a terminal, plain lines otherwise."""

    def __init__(self, quiet, callback, stream=None):
        self.quiet = quiet
        self.callback = callback
        self.stream = stream or sys.stderr
        self.terminal = bool(getattr(self.stream, "isatty", lambda: False)())
        self.total = 0
        self.done = 0

    def line(self, text):
        if not self.quiet:
            print(text, file=self.stream, flush=True)

    def start(self, total):
        self.total, self.done = total, 0

    def finish(self):
        """End an unfinished bar (after an interruption), so that what follows starts a line."""
        if self.terminal and not self.quiet and 0 < self.done < self.total:
            self.stream.write("\n")
            self.stream.flush()

    def step(self, name):
        self.done += 1
        if self.callback is not None:
            self.callback(self.done, self.total, name)
        if self.quiet:
            return
        if self.terminal:
            width = 30
            filled = int(width * self.done / max(self.total, 1))
            bar = "#" * filled + "-" * (width - filled)
            text = f"\r[{bar}] {self.done}/{self.total} {name[-40:]:<40}"
            self.stream.write(text)
            if self.done == self.total:
                self.stream.write("\n")
            self.stream.flush()
        else:
            print(f"fitted {self.done}/{self.total}: {name}", file=self.stream, flush=True)


# --------------------------------------------------------------------------- the campaign


@dataclass
class _Item:
    """One manifest entry's run (or the failure to read it), in manifest order."""

    name: str
    source: str | None
    interval: int | None
    run: Run | None = None
    kind: str | None = None
    reason: str | None = None
    key: str | None = None
    record: dict | None = None


def _find_manifest(source):
    path = Path(source)
    if path.is_dir():
        for name in _MANIFEST_NAMES:
            if (path / name).is_file():
                return path / name
        raise InvalidParameterError(
            f"{path}: the folder holds no manifest ({', '.join(_MANIFEST_NAMES)})"
        )
    if not path.exists():
        raise InvalidParameterError(f"{path}: no such manifest or folder")
    if path.suffix.lower() not in (".yaml", ".yml", ".csv"):
        raise InvalidParameterError(
            f"{path}: a campaign is a manifest (.yaml, .yml or .csv) or a folder holding one"
        )
    return path


def _relative(file, folder):
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


def _items_from_manifest(manifest):
    """Items in manifest order: each entry's runs, or the reason its file failed."""
    from granflow.io.campaign import Campaign, read_manifest

    entries = read_manifest(manifest)
    campaign = Campaign.from_manifest(manifest, errors="collect")
    folder = manifest.parent
    runs, problems = list(campaign.runs), list(campaign.problems)
    items, position, inputs = [], 0, []
    for entry in entries:
        file = str(folder / entry["file"])
        relative = _relative(file, folder)
        if relative not in inputs:
            inputs.append(relative)
        taken = []
        while position < len(runs) and runs[position].meta.get("source") == file:
            taken.append(runs[position])
            position += 1
            if "interval" in entry:
                break
        if taken:
            items += [_run_item(run, folder) for run in taken]
            continue
        reason = next((p for p in problems if file in p), None)
        if reason is not None:
            problems.remove(reason)
        else:
            reason = "the file holds no run"
        name = relative if "interval" not in entry else f"{relative}#{entry['interval']}"
        items.append(
            _Item(name=name, source=relative, interval=entry.get("interval"), reason=reason)
        )
    items += [_run_item(run, folder) for run in runs[position:]]
    items += [_Item(name="?", source=None, interval=None, reason=p) for p in problems]
    return items, inputs


def _run_item(run, folder):
    source = _relative(run.meta.get("source", "run"), folder)
    return _Item(
        name=_run_name(run, source), source=source, interval=run.meta.get("interval"), run=run
    )


def _load(source):
    """(items, manifest path or None, input files relative to the manifest folder)."""
    from granflow.io.campaign import Campaign

    if isinstance(source, Campaign):
        items = [_run_item(run, None) for run in source.runs]
        items += [_Item(name="?", source=None, interval=None, reason=p) for p in source.problems]
        inputs = list(dict.fromkeys(item.source for item in items if item.source))
        return items, None, inputs
    manifest = _find_manifest(source)
    items, inputs = _items_from_manifest(manifest)
    return items, manifest, [manifest.name, *inputs]


# --------------------------------------------------------------------------- small helpers


def _identity(item):
    return {
        "name": item.name,
        "source": item.source,
        "interval": item.interval,
    }


def _describe(item):
    """The manifest-facing fields of a run's entry in results["runs"]."""
    run = item.run
    if run is None:
        return {
            **_identity(item),
            "test": None,
            "control": None,
            "normal_load": None,
            "velocity": None,
            "preparation": None,
            "points": 0,
        }
    return {
        **_identity(item),
        "test": item.kind,
        "control": run.control,
        "normal_load": run.normal_load,
        "velocity": _imposed_velocity(item),
        "preparation": run.meta.get("preparation"),
        "points": len(run),
    }


def _imposed_velocity(item):
    """The imposed velocity [m/s]: the nominal one of a start-up, the manifest's otherwise
    (the median measured velocity of a stress-controlled run is no imposed velocity)."""
    if item.kind == "startup":
        return item.run.nominal_velocity
    value = item.run.meta.get("velocity")
    return None if value is None else float(value)


# --------------------------------------------------------------------------- the result


@dataclass(frozen=True, eq=False)
class AnalysisResult:
    """What :func:`analyze` wrote, and the results it holds.

    Attributes
    ----------
    output : pathlib.Path
        The output folder.
    results : mapping
        The content of ``results.json`` (SI units).
    fitted_now, reused : int
        Runs analysed in this call, and runs whose saved result was reused (``resume=True``).
    report : pathlib.Path or None
        ``report.html``, when the report could be rendered.
    """

    output: Path
    results: MappingProxyType
    fitted_now: int
    reused: int
    report: Path | None = None

    def __repr__(self):
        return (
            f"AnalysisResult({len(self.results['runs'])} runs, {len(self.failed_runs)} failed, "
            f"output={str(self.output)!r})"
        )

    @property
    def results_path(self):
        """``OUTPUT/results.json``."""
        return self.output / RESULTS_FILE

    @property
    def failed_runs(self):
        """The runs that could not be analysed: ``name``, ``source``, ``reason``."""
        return self.results["failed_runs"]

    @property
    def material(self):
        """mu_a, mu_d [-] and alpha [1/m], each ``{"value", "stderr", "ci95"}``."""
        return self.results["material"]

    @property
    def exit_code(self):
        """0 when every run was analysed, 1 when some failed (the command's exit code)."""
        return 1 if self.failed_runs else 0

    def summary(self):
        """A one-screen summary: counts, material constants with intervals, predictions,
        failed runs, and where the output is (display units)."""
        results = self.results
        campaign = results["campaign"]
        counts = campaign["counts"]
        lines = [
            f"campaign: {counts['runs']} runs"
            + (" (synthetic data)" if results["synthetic"] else "")
            + f", {counts['analysed']} analysed, {counts['failed']} failed "
            f"({self.fitted_now} analysed now, {self.reused} reused)"
        ]
        material = results["material"]
        if material["mu_a"]["value"] is None:
            lines.append(f"material constants: not determined ({material.get('reason')})")
        else:
            lines.append(f"material constants ({material['source']}):")
            for name, unit in (("mu_a", ""), ("mu_d", ""), ("alpha", " 1/m")):
                entry = material[name]
                low, high = entry["ci95"]
                lines.append(
                    f"  {name:<5} = {entry['value']:.5g} +/- {entry['stderr']:.2g}{unit}   "
                    f"95%: [{low:.5g}, {high:.5g}]"
                )
        truth = campaign.get("truth")
        if truth:
            inside = ", ".join(
                f"{name} {'inside' if ok else 'OUTSIDE'}" for name, ok in truth["contained"].items()
            )
            lines.append(f"  synthetic truth: {inside} the 95 % intervals")
        yields = results["predictions"].get("static_yield", [])
        if yields:
            text = "; ".join(
                f"{row['normal_load'] * 1e3:.4g} mN -> {row['F_peak'] * 1e3:.4g} "
                f"+/- {row['stderr'] * 1e3:.2g} mN"
                for row in yields[:6]
            )
            lines.append(f"static yield F_peak: {text}" + (" ..." if len(yields) > 6 else ""))
        for row in results["analyses"].get("stress_ramp", []):
            if "observed" in row and "predicted" in row:
                lines.append(
                    f"stress ramp {row['run']}: failed at "
                    f"{row['observed']['failure_force'] * 1e3:.4g} mN, predicted F_peak "
                    f"{row['predicted']['failure_force'] * 1e3:.4g} +/- "
                    f"{math.hypot(row['F_peak_stderr'], row['F_peak_spread']) * 1e3:.2g} mN"
                    + (" (consistent)" if row["consistent"] else " (NOT consistent)")
                )
        for row in results["analyses"].get("switch", []):
            if "predicted" in row:
                lines.append(
                    f"switch {row['run']}: observed {row['observed']['outcome']}, predicted "
                    f"{row['predicted']['outcome']}"
                    + (" (agree)" if row["agree"] else " (DISAGREE)")
                )
        if results["warnings"]:
            lines.append(f"warnings: {len(results['warnings'])} (see results.json or the report)")
        if self.failed_runs:
            lines.append(f"failed runs ({len(self.failed_runs)}):")
            for entry in self.failed_runs[:10]:
                lines.append(f"  {entry['name']}: {entry['reason']}")
            if len(self.failed_runs) > 10:
                lines.append(f"  ... and {len(self.failed_runs) - 10} more in results.json")
        lines.append(f"output: {self.output.resolve()}")
        return "\n".join(lines)


# --------------------------------------------------------------------------- analyze


def _check_jobs(jobs):
    if jobs is None:
        return os.cpu_count() or 1
    if isinstance(jobs, bool) or not isinstance(jobs, int | np.integer) or jobs < 1:
        raise InvalidParameterError(f"jobs must be a positive integer or None, got {jobs!r}")
    return int(jobs)


def _own_files(output):
    """Files of an earlier analysis in OUTPUT: its run records and what its results list."""
    files = []
    for path in sorted((output / RUNS_DIR).glob("*.json")):
        saved = _read_json(path)
        if isinstance(saved, dict) and _MARKER in saved:
            files.append(path)
    previous = _read_json(output / RESULTS_FILE)
    if isinstance(previous, dict) and "granflow_version" in previous:
        listed = [RESULTS_FILE, REPORT_FILE]
        listed += [f.get(k) for f in previous.get("figures", []) for k in ("png", "svg")]
        listed += [p for t in previous.get("tables", {}).values() for p in t.values()]
        for relative in listed:
            if isinstance(relative, str) and (output / relative).is_file():
                files.append(output / relative)
    return files


def _remove_leftovers(output):
    """Temporary files an interrupted analysis may have left (never anything else)."""
    import shutil

    for folder in (output, output / RUNS_DIR, output / TABLES_DIR, output / FIGURES_DIR):
        if folder.is_dir():
            for path in folder.glob(".*.tmp"):
                with contextlib.suppress(OSError):
                    path.unlink()
    for path in output.glob(".figures-*"):
        shutil.rmtree(path, ignore_errors=True)


def _truth(manifest):
    """The synthetic truth file of a demo campaign, beside the manifest or one folder up."""
    try:
        from granflow.analysis.demo import TRUTH_FILE
    except ImportError:
        TRUTH_FILE = "synthetic_truth.json"
    if manifest is None:
        return None, None
    for folder in (manifest.parent, manifest.parent.parent):
        path = folder / TRUTH_FILE
        if path.is_file():
            return path, _read_json(path)
    return None, None


def _campaign_summary(items, manifest, material):
    runs = [item for item in items if item.run is not None]
    ok = [item for item in runs if item.record and item.record["status"] == "ok"]
    loads = sorted({_rounded(i.run.normal_load) for i in runs if i.run.normal_load is not None})
    speeds = sorted({_rounded(v) for v in map(_imposed_velocity, runs) if v is not None})
    preparations = sorted(
        {str(i.run.meta["preparation"]) for i in runs if "preparation" in i.run.meta}
    )
    summary = {
        "manifest": None if manifest is None else str(manifest.resolve()),
        "analysed": len(ok),
        "counts": {
            "runs": len(items),
            "analysed": len(ok),
            "failed": len(items) - len(ok),
            "tests": {kind: sum(1 for i in runs if i.kind == kind) for kind in _ANALYSES},
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
    if isinstance(truth, dict) and all(n in truth for n in ("mu_a", "mu_d", "alpha")):
        contained = {}
        for name in ("mu_a", "mu_d", "alpha"):
            low, high = material[name]["ci95"]
            contained[name] = bool(low is not None and low <= truth[name] <= high)
        summary["truth"] = {
            "file": _relative(path, manifest.parent),
            "values": {n: truth[n] for n in ("mu_a", "mu_d", "alpha")},
            "contained": contained,
        }
    return summary, synthetic


def analyze(
    source,
    output,
    *,
    jobs=None,
    scheduler=None,
    resume=False,
    quiet=False,
    mcmc=False,
    seed=0,
    progress=None,
):
    """Analyse a whole campaign and write results, tables, figures and a report.

    The rules (what a run is, the fit window, the joint analyses, the predictions) are in the
    documentation of :mod:`granflow.analysis`.

    Parameters
    ----------
    source : str, pathlib.Path or granflow.Campaign
        A manifest (.yaml, .yml, .csv), a folder holding ``manifest.yaml``/``.yml``/``.csv``,
        or a Campaign.
    output : str or pathlib.Path
        Output folder (made if missing). granflow writes ``results.json``, ``report.html``,
        ``runs/``, ``tables/`` and ``figures/`` there and touches nothing else.
    jobs : int, optional
        Local worker processes for the per-run work and the stability map; default every
        core; 1 runs everything in this process.
    scheduler : str or dask.distributed.Client or cluster, optional
        Run the per-run work on Dask distributed instead: a scheduler address
        (``"tcp://host:8786"``), a Client, or a cluster object (``LocalCluster``). Needs
        the extra ``granflow[dask]``, and granflow installed on the workers.
    resume : bool
        Reuse the saved result of every run whose data and options still match (after an
        interrupted analysis); False starts clean.
    quiet : bool
        No progress output on stderr.
    mcmc : bool
        Also sample the posterior of the representative start-up fit (needs
        ``granflow[mcmc]``).
    seed : int
        Seed of the MCMC sampler.
    progress : callable, optional
        Called as ``progress(done, total, name)`` after each run analysed in this call (in
        completion order); an exception it raises stops the analysis, and the finished runs
        stay saved for ``resume=True``.

    Returns
    -------
    AnalysisResult

    Raises
    ------
    InvalidParameterError
        A source that is neither a manifest nor a folder holding one; bad ``jobs``.
    FileFormatError
        A manifest that cannot be read (a data file that cannot be read is a failed run).
    ImportError
        ``scheduler`` without Dask, ``mcmc`` without emcee.

    Examples
    --------
    >>> import granflow
    >>> result = granflow.analyze("campaign/", "out", jobs=2)  # doctest: +SKIP
    >>> result.material["alpha"]["value"], result.exit_code  # doctest: +SKIP
    """
    started = datetime.datetime.now(datetime.UTC)
    clock = time.perf_counter()
    jobs = _check_jobs(jobs)
    if isinstance(seed, bool) or not isinstance(seed, int | np.integer):
        raise InvalidParameterError(f"seed must be an integer, got {seed!r}")
    seed = int(seed)
    if mcmc:
        from granflow.fitting.mcmc import _emcee

        _emcee()  # a missing extra is an error now, not after the fits
    output = Path(output)
    reporter = _Progress(quiet, progress)
    stages = {}
    items, manifest, inputs = _load(source)
    stages["read_s"] = time.perf_counter() - clock
    executor = Executor(jobs, scheduler)
    try:
        output.mkdir(parents=True, exist_ok=True)
        (output / RUNS_DIR).mkdir(exist_ok=True)
        _remove_leftovers(output)
        if not resume:
            for path in _own_files(output):
                with contextlib.suppress(OSError):
                    path.unlink()
        reference = _reference_velocity(items)
        todo, reused = _plan(items, output, reference, resume)
        if reused:
            reporter.line(f"reusing {reused} saved run results from {output / RUNS_DIR}")
        clock_stage = time.perf_counter()
        _run_all(todo, executor, output, reporter)
        stages["runs_s"] = time.perf_counter() - clock_stage
        reporter.line("joint analyses and predictions")
        clock_stage = time.perf_counter()
        context = _joint_stage(items, executor, mcmc=mcmc, seed=seed)
        stages["joint_s"] = time.perf_counter() - clock_stage
        description = executor.description
    finally:
        executor.close()
    clock_stage = time.perf_counter()
    results = _assemble(items, manifest, inputs, context, mcmc, seed, reference)
    results["tables"] = _write_tables(output, results, results["warnings"])
    reporter.line("figures")
    results["figures"] = _make_figures(output, context, results["warnings"])
    _remove_stale_records(output, items)
    stages["outputs_s"] = time.perf_counter() - clock_stage
    results["timing"] = {
        "started": started.isoformat(timespec="seconds"),
        "finished": None,
        "elapsed_s": None,
        "jobs": None if scheduler is not None else jobs,
        "scheduler": description if scheduler is not None else None,
        "fitted_now": len(todo),
        "reused": reused,
        "stages_s": stages,
    }
    results = json_safe(results)
    reporter.line("report")
    _finish_timing(results, clock)
    report = _write_report(output, results)
    _finish_timing(results, clock)
    _write_json(output / RESULTS_FILE, results)
    return AnalysisResult(
        output=output, results=results, fitted_now=len(todo), reused=reused, report=report
    )


def _reference_velocity(items):
    """The median nominal velocity of the start-ups [m/s]: the scale of a runaway."""
    velocities = [
        item.run.nominal_velocity
        for item in items
        if item.run is not None and classify(item.run) == "startup" and item.run.nominal_velocity
    ]
    return float(np.median(velocities)) if velocities else _DEFAULT_REFERENCE_VELOCITY


def _plan(items, output, reference, resume):
    """Classify and key every run; attach the saved results that still match (resume).

    Returns the ``(item, options)`` pairs still to analyse and the number reused.
    """
    todo, reused = [], 0
    for item in items:
        if item.run is None:
            continue
        item.kind = classify(item.run)
        options = {"reference_velocity": reference} if item.kind == "ramp" else {}
        item.key = run_key(_identity(item), item.run, item.kind, options)
        saved = _read_json(output / RUNS_DIR / f"{item.key}.json") if resume else None
        if (
            isinstance(saved, dict)
            and saved.get(_MARKER) == ANALYSIS_VERSION
            and saved.get("key") == item.key
        ):
            item.record = saved
            reused += 1
        else:
            todo.append((item, options))
    return todo, reused


def _run_all(todo, executor, output, reporter):
    """Analyse the runs of ``todo``, saving each result (atomically) as soon as it is ready.

    A result goes through JSON before it is used, so that a fresh result and a saved one are
    the same values.
    """
    reporter.start(len(todo))
    tasks = [(item.run, item.kind, options) for item, options in todo]
    try:
        for position, result in executor.run(analyse_run, tasks):
            item = todo[position][0]
            if isinstance(result, Exception):  # the worker died: not saved, retried on resume
                item.record = {
                    "status": "failed",
                    "reason": f"the worker failed: {type(result).__name__}: {result}",
                    "warnings": [],
                }
            else:
                record = {_MARKER: ANALYSIS_VERSION, "key": item.key, **result}
                record = json.loads(_dump(record))
                _write_json(output / RUNS_DIR / f"{item.key}.json", record)
                item.record = record
            reporter.step(item.name)
    finally:
        reporter.finish()


def _remove_stale_records(output, items):
    """Saved run results of runs that are no longer in the campaign (or whose data changed)."""
    keys = {item.key for item in items if item.key}
    for path in (output / RUNS_DIR).glob("*.json"):
        if path.stem not in keys and _MARKER in (_read_json(path) or {}):
            with contextlib.suppress(OSError):
                path.unlink()


def _finish_timing(results, clock):
    now = datetime.datetime.now(datetime.UTC)
    results["timing"]["finished"] = now.isoformat(timespec="seconds")
    results["timing"]["elapsed_s"] = round(time.perf_counter() - clock, 3)


def _assemble(items, manifest, inputs, context, mcmc, seed, reference):
    """results.json without tables, figures and timing, in manifest order."""
    import platform

    import granflow

    entries, failed, warnings_list = [], [], []
    for index, item in enumerate(items):
        entry = {"index": index, **_describe(item)}
        if item.run is None:
            entry.update(status="failed", reason=item.reason, stage="read")
        else:
            record = {k: v for k, v in item.record.items() if k != _MARKER}
            warnings_list += record.pop("warnings", [])
            entry.update(record)
            if entry["status"] == "failed":
                entry["stage"] = "analysis"
        if entry["status"] == "failed":
            failed.append(
                {
                    "name": item.name,
                    "source": item.source,
                    "interval": item.interval,
                    "stage": entry["stage"],
                    "reason": entry["reason"],
                }
            )
            warnings_list.append(f"failed: {item.name}: {entry['reason']}")
        entries.append(entry)
    folder = manifest.parent if manifest is not None else None
    provenance_inputs = [
        {"file": file, "sha256": _sha256_file(folder / file if folder else file)} for file in inputs
    ]
    campaign, synthetic = _campaign_summary(items, manifest, context.material)
    return {
        "granflow_version": granflow.__version__,
        "synthetic": synthetic,
        "campaign": campaign,
        "runs": entries,
        "failed_runs": failed,
        "material": context.material,
        "analyses": context.analyses,
        "predictions": context.predictions,
        "warnings": warnings_list + context.warnings,
        "figures": [],
        "tables": {},
        "provenance": {
            "granflow_version": granflow.__version__,
            "python": platform.python_version(),
            "inputs": provenance_inputs,
            "options": {
                "mcmc": mcmc,
                "seed": seed,
                "analysis_version": ANALYSIS_VERSION,
                "runaway_factor": RUNAWAY_FACTOR,
                "reference_velocity": reference,
                "elastic_ramp_tolerance": _RAMP_TOLERANCE,
                "stability_map": {
                    "switch_points": _MAP_POINTS,
                    "stress_ratios": _MAP_RATIOS,
                    "hold": _MAP_HOLD,
                },
            },
        },
    }
