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

**Records of a model family.** A manifest entry whose ``test`` is a record family's
(:mod:`granflow.families`) is analysed by that family's ``analyse``, on a worker, after the
joint stage; ``results.json`` holds it under the ``test`` kind and the report shows the
family's section (``velocity_steps``: :mod:`granflow.analysis.velocity_steps`). A record
that cannot be read or analysed is a failed run (stage: its ``test``), the rest analysed.

A run that cannot be analysed (an error, or a fit with ``success=False``) is a failed run; a
file that cannot be read is one too; the rest goes on.

**Joint analyses** (main process, only where the campaign allows): velocity collapse over the
start-up runs of one preparation at the load with the most distinct velocities; Amontons' law
over loads with the runs at the most common velocity (the material constants mu_a, mu_d,
alpha; with one load, a joint fit at that load divided by the load); the preparation spread
over repeats of one preparation state (same load and velocity, and the same manifest
``preparation_state``, else the same ``preparation`` label), with x0 also from a joint fit
that holds a, alpha and Fd common to the repeats; each start-up fit against the force noise
of its plateau (a normalised chi-square); the model comparison on the first start-up run of
the largest (load, velocity) group, which is also the run sampled with ``mcmc=True``.

**Predictions.** The static yield per load, ``F_peak`` from the material constants and the
mean x0 of the start-ups at that load (pooled over all start-ups for a load without any),
with a standard error propagated linearly from the covariance of the constants and the
standard error of the mean x0, and the spread over the preparations; a stability map at a
representative load (that of the first switch run, else the most common start-up load);
each ramp's observed failure force against the predicted F_peak; each switch's observed
outcome against :func:`granflow.simulate` (quasi-static, slip clock) with the run's own
start-up fit (or the material constants at its load).

**Processes.** With local workers (``jobs`` > 1) every task runs on a worker, even one
alone, and the workers are ended between stages (reading, per-run work, the joint stage's
stability map and forecasts, the velocity-step records, the tables, the figures), so that
the next stage's workers start from this process without what the last stage's loaded: no
process holds pandas (reading, tables), matplotlib (figures) and the compiled kernels all at
once, and this process loads neither pandas nor matplotlib (it runs the joint fits, so it
holds the kernels). With ``jobs=1`` everything runs in this process, which then holds all
of it.

**Results on disk.** Each run's result is written atomically to ``OUTPUT/runs/<key>.json`` as
soon as it is ready; the key hashes the run's file name, interval, metadata and data and the
analysis options, so ``resume=True`` reuses exactly the results that still match. Everything
is ordered by the manifest, never by completion, and everything that differs between two
equivalent analyses (dates, durations, jobs, scheduler, runs fitted now or reused) is kept in
``results["timing"]`` only.
"""

from __future__ import annotations

import contextlib
import datetime
import os
import time
import warnings
from collections.abc import Callable, Sequence
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from granflow._files import writable_folder, write_atomic
from granflow._json import json_safe
from granflow._parallel import Executor
from granflow._progress import RunProgress, silenced
from granflow.analysis.files import (
    FIGURES_DIR,
    REPORT_FILE,
    RESULTS_FILE,
    RUN_RECORD_MARKER,
    RUNS_DIR,
    TABLES_DIR,
    dump_json,
    read_json,
    write_json,
)
from granflow.analysis.forecasts import CUT_FRACTIONS
from granflow.analysis.forecasts import LEVEL as FORECAST_LEVEL
from granflow.analysis.inputs import (
    ANALYSIS_VERSION,
    campaign_summary,
    identity,
    input_hashes,
    load_campaign,
    run_entry,
    run_key,
)
from granflow.analysis.outputs import make_figures, write_report, write_tables
from granflow.analysis.predictions import MAP_HOLD, MAP_POINTS, MAP_RATIOS
from granflow.analysis.record_stage import analyse_records
from granflow.analysis.result import AnalysisResult, record_analyses
from granflow.analysis.run_results import FailedRun, run_result_from_dict
from granflow.analysis.runs import (
    ELASTIC_RAMP_TOLERANCE,
    RUNAWAY_FACTOR,
    StartupData,
    analyse_run,
    classify,
    startup_data,
)
from granflow.analysis.stage import joint_stage
from granflow.errors import InvalidParameterError
from granflow.families import record_families
from granflow.fitting.results import FrozenMap

if TYPE_CHECKING:
    from granflow._typing import PathLike
    from granflow.io.campaign import Campaign

__all__ = [
    "ANALYSIS_VERSION",
    "RUNAWAY_FACTOR",
    "AnalysisResult",
    "StartupData",
    "analyze",
    "classify",
    "startup_data",
]

_DEFAULT_REFERENCE_VELOCITY = 1e-6  # m/s, as granflow.simulate


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
        saved = read_json(path)
        if isinstance(saved, dict) and RUN_RECORD_MARKER in saved:
            files.append(path)
    previous = read_json(output / RESULTS_FILE)
    if isinstance(previous, dict) and "granflow_version" in previous:
        listed = [RESULTS_FILE, REPORT_FILE]
        listed += [f.get(k) for f in previous.get("figures", []) for k in ("png", "svg", "pdf")]
        listed += [p for t in previous.get("tables", {}).values() for p in t.values()]
        for family in record_families():
            part = previous.get(family.test_kind) or {}
            listed += [r.get("figure") for r in part.get("records", [])]
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


def analyze(
    source: PathLike | Campaign,
    output: PathLike,
    *,
    jobs: int | None = None,
    scheduler: Any = None,
    resume: bool = False,
    quiet: bool = False,
    mcmc: bool = False,
    seed: int = 0,
    progress: Callable[[int, int, str], object] | None = None,
    geometry: Any = None,
    strict: bool = False,
    figure_formats: Sequence[str] = ("png",),
    allow_outside: bool = False,
) -> AnalysisResult:
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
        Local worker processes for reading the files, the per-run work, the stability map,
        the forecasts, the tables and the figures; default every core; 1 runs everything
        in this process (for debugging; it then holds pandas, matplotlib and the compiled
        kernels at once: a higher peak memory than any one process of a parallel
        analysis). The results and files are the same whatever the number.
    scheduler : str or dask.distributed.Client or cluster, optional
        Run the per-run work, the stability map, the forecasts and the figures on Dask
        distributed instead (the files are read in this process): a scheduler address
        (``"tcp://host:8786"``), a Client, or a cluster object (``LocalCluster``). Needs
        the extra ``granflow[dask]``, and granflow installed on the workers.
    resume : bool
        Reuse the saved result of every run whose data and options still match (after an
        interrupted analysis); False starts clean.
    quiet : bool
        No progress output on stderr. Otherwise one progress bar over the runs where a person
        watches (a terminal, or Jupyter: tqdm's auto mode), one line per run in a log.
    mcmc : bool
        Also sample the posterior of the representative start-up fit (needs
        ``granflow[mcmc]``).
    seed : int
        Seed of the MCMC sampler.
    progress : callable, optional
        Called as ``progress(done, total, name)`` after each run analysed in this call (in
        completion order); an exception it raises stops the analysis, and the finished runs
        stay saved for ``resume=True``.
    geometry : granflow.Annulus, str or mapping, optional
        The tube of the manifest entries that declare none (what
        :meth:`granflow.Annulus.from_spec` reads: ``"paper"``, radii, or r_eff and r_m);
        default the paper's, reported as ``"paper (default)"``. A manifest's ``geometry``
        (in its defaults or an entry) wins. Not with a Campaign (already converted).
    strict : bool
        Make every data-quality problem an error: a run with problems (``runs[*].problems``)
        is a failed run, named, and the rest is analysed.
    figure_formats : sequence of {"png", "svg", "pdf"}
        The files of each figure in ``figures/``, each figure drawn once (default PNG, which
        the report embeds; the report links an SVG where there is one).
    allow_outside : bool
        Read files outside the manifest's folder too. Default False: an entry whose file
        lies outside it (``..``, an absolute path, a symbolic link leading out) fails,
        named, so that a manifest someone else wrote reads only the campaign's files.

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
    from granflow.plotting.files import check_formats

    figure_formats = check_formats(figure_formats, "figure_formats")  # an error now, not later
    if mcmc:
        _require_emcee()  # a missing extra is an error now, not after the fits
    # checked now, not after the fits: the folder is made and a file written in it
    output = Path(writable_folder(output, "output folder"))
    reporter = RunProgress(quiet, progress)
    stages = {}
    # one executor for the whole analysis: reading, the per-run work, the joint stage's
    # parallel parts, the tables and the figures all run on it; its local workers are
    # recycled between stages, so that no worker holds two stages' stacks
    executor = Executor(jobs, scheduler, isolate=True)
    try:
        reporter.stage("reading")
        items, manifest, inputs = load_campaign(source, geometry, executor, allow_outside)
        executor.recycle()
        stages["read_s"] = time.perf_counter() - clock
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
        executor.recycle()
        stages["runs_s"] = time.perf_counter() - clock_stage
        reporter.stage("joint analyses, predictions and forecasts")
        clock_stage = time.perf_counter()
        entries = tuple(run_entry(item, index, strict) for index, item in enumerate(items))
        with silenced():  # one bar per campaign: none from the stability map or MCMC
            joint = _noted(joint_stage, entries, executor, mcmc=mcmc, seed=seed)
        executor.recycle()
        stages["joint_s"] = time.perf_counter() - clock_stage
        analysed = analyse_records(manifest, output, allow_outside, executor, reporter, stages)
        for files in analysed.pop("files"):
            inputs += [file for file in files if file not in inputs]
        description = executor.description
        clock_stage = time.perf_counter()
        options = {"mcmc": mcmc, "seed": seed, "strict": bool(strict), "reference": reference}
        result = _assemble(items, entries, manifest, inputs, joint, options)
        failed = [
            f"failed: {f['name']}: {f['reason']}"
            for part in analysed.values()
            for f in part.get("failed", ())
        ]
        result = replace(
            result,
            record_analyses=record_analyses(analysed),
            warnings=result.warnings + tuple(failed),
        )
        notes = list(result.warnings)
        content = result.to_dict()  # once: encoding the joint analyses is the slow part
        reporter.stage("tables")
        tables = write_tables(output, content, notes, executor)
        executor.recycle()
        reporter.stage("figures")
        figures = make_figures(output, result, joint, notes, figure_formats, executor)
    except BaseException:
        reporter.close()
        raise
    finally:
        executor.close()
    result = replace(
        result, warnings=tuple(notes), figures=tuple(figures), tables=FrozenMap(tables)
    )
    changed = {"warnings": result.warnings, "figures": result.figures, "tables": result.tables}
    content = {**content, **json_safe(changed)}
    _remove_stale_records(output, items)
    stages["outputs_s"] = time.perf_counter() - clock_stage
    timing = {
        "started": started.isoformat(timespec="seconds"),
        "finished": None,
        "elapsed_s": None,
        "jobs": None if scheduler is not None else jobs,
        "scheduler": description if scheduler is not None else None,
        "fitted_now": len(todo),
        "reused": reused,
        "stages_s": stages,
    }
    result = replace(result, output=output, fitted_now=len(todo), reused=reused)
    reporter.stage("report")
    report = write_report(output, replace(result, timing=_finished(timing, clock)))
    result = replace(result, timing=_finished(timing, clock), report=report)
    # the content computed once above (to_dict does not depend on the timing, the output
    # folder or the report, which are all that changed since): encoding the joint
    # analyses again is what makes it slow on a large campaign
    write_json(output / RESULTS_FILE, {**content, "timing": json_safe(result.timing)})
    reporter.finish(report)
    return result


def _noted(stage, *args, **kwargs):
    """``stage(*args, **kwargs)`` (a :class:`JointStage`) with NumPy's floating-point warnings
    kept as the campaign's warnings ("joint stage: overflow encountered in ...") instead of
    lines on stderr; other warnings go on as they were."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", RuntimeWarning)
        joint = stage(*args, **kwargs)
    numerical = []
    for item in caught:
        if issubclass(item.category, RuntimeWarning):
            numerical.append(f"joint stage: numerical warning: {item.message}")
        else:
            warnings.warn_explicit(item.message, item.category, item.filename, item.lineno)
    if not numerical:
        return joint
    return replace(joint, warnings=joint.warnings + tuple(dict.fromkeys(numerical)))


def _require_emcee():
    """An ImportError naming the extra when emcee is missing."""
    try:
        import emcee  # noqa: F401
    except ImportError as exc:
        raise ImportError(
            "sample_posterior needs emcee: install the extra with "
            "`pip install granflow[mcmc]` (emcee and corner)"
        ) from exc


def _reference_velocity(items):
    """The median nominal velocity of the start-ups [m/s]: the scale of a runaway."""
    velocities = [
        item.run.nominal_velocity
        for item in items
        if item.run is not None and classify(item.run) == "startup" and item.run.nominal_velocity
    ]
    return float(np.median(velocities)) if velocities else _DEFAULT_REFERENCE_VELOCITY


def _plan(items, output, reference, resume):
    """Classify and key every run; rebuild the saved results that still match (resume).

    Returns the ``(item, options)`` pairs still to analyse and the number reused.
    """
    todo, reused = [], 0
    for item in items:
        if item.run is None:
            continue
        item.kind = classify(item.run)
        options = {"reference_velocity": reference} if item.kind == "ramp" else {}
        item.key = run_key(identity(item), item.run, item.kind, options)
        saved = read_json(output / RUNS_DIR / f"{item.key}.json") if resume else None
        if (
            isinstance(saved, dict)
            and saved.get(RUN_RECORD_MARKER) == ANALYSIS_VERSION
            and saved.get("key") == item.key
        ):
            item.result = run_result_from_dict(item.kind, saved)
            reused += 1
        else:
            todo.append((item, options))
    return todo, reused


def _run_all(todo, executor, output, reporter):
    """Analyse the runs of ``todo``, saving each result (atomically) as soon as it is ready:
    ``to_dict(include_arrays=True)``, which ``from_dict`` turns back into the same result."""
    reporter.start(len(todo))
    tasks = [
        (item.run, item.kind, options, {RUN_RECORD_MARKER: ANALYSIS_VERSION, "key": item.key})
        for item, options in todo
    ]
    try:
        for position, outcome in _first_alone(executor, tasks, [item.kind for item, _ in todo]):
            item = todo[position][0]
            if isinstance(outcome, Exception):  # the worker died: not saved, retried on resume
                reason = f"the worker failed: {type(outcome).__name__}: {outcome}"
                item.result = FailedRun(reason=reason)
            else:
                result, text = outcome  # the record, encoded by the worker (as write_json)
                write_atomic(
                    output / RUNS_DIR / f"{item.key}.json",
                    lambda temporary, text=text: temporary.write_text(text, encoding="utf-8"),
                )
                item.result = result
            reporter.step(item.name)
    except BaseException:
        reporter.close()
        raise


def _first_alone(executor, tasks, kinds):
    """``executor.run(_analyse_and_record, tasks)`` with the first start-up run alone, before
    the others: on a first run the compiled kernels are not cached yet, and every worker
    would compile the same ones side by side (twice the work on two workers); after it the
    others load them from the cache. Yields ``(position, outcome)`` as ``run`` does."""
    first = next((i for i, kind in enumerate(kinds) if kind == "startup"), None)
    if first is None or len(tasks) < 2 or executor.jobs == 1:
        yield from executor.run(_analyse_and_record, tasks)
        return
    for _, outcome in executor.run(_analyse_and_record, [tasks[first]]):
        yield first, outcome
    rest = [i for i in range(len(tasks)) if i != first]
    for position, outcome in executor.run(_analyse_and_record, [tasks[i] for i in rest]):
        yield rest[position], outcome


def _analyse_and_record(task):
    """Analyse one run and encode the record that saves it, both in the worker.

    ``task = (run, kind, options, header)``; returns ``(result, text)``: the result of
    :func:`~granflow.analysis.runs.analyse_run` and the JSON text of
    ``{**header, **result.to_dict(include_arrays=True)}`` as :func:`write_json` writes it,
    so that encoding the records runs in parallel too.
    """
    run, kind, options, header = task
    result = analyse_run((run, kind, options))
    return result, dump_json({**header, **result.to_dict(include_arrays=True)})


def _remove_stale_records(output, items):
    """Saved run results of runs that are no longer in the campaign (or whose data changed)."""
    keys = {item.key for item in items if item.key}
    for path in (output / RUNS_DIR).glob("*.json"):
        if path.stem not in keys and RUN_RECORD_MARKER in (read_json(path) or {}):
            with contextlib.suppress(OSError):
                path.unlink()


def _finished(timing, clock):
    """``timing`` with the time finished and the time elapsed now."""
    now = datetime.datetime.now(datetime.UTC)
    return FrozenMap(
        {
            **timing,
            "finished": now.isoformat(timespec="seconds"),
            "elapsed_s": round(time.perf_counter() - clock, 3),
        }
    )


def _assemble(items, entries, manifest, inputs, joint, options):
    """The campaign's result without tables, figures and timing, in manifest order."""
    import platform

    import granflow

    warnings_list = []
    for item, entry in zip(items, entries, strict=True):
        if item.result is not None:
            warnings_list += item.result.warnings
        if not entry.ok:
            warnings_list.append(f"failed: {entry.name}: {entry.reason}")
    campaign, synthetic = campaign_summary(items, entries, manifest, joint.material)
    provenance = {
        "granflow_version": granflow.__version__,
        "python": platform.python_version(),
        "inputs": input_hashes(manifest, inputs),
        "options": {
            "mcmc": options["mcmc"],
            "seed": options["seed"],
            "strict": options["strict"],
            "analysis_version": ANALYSIS_VERSION,
            "runaway_factor": RUNAWAY_FACTOR,
            "reference_velocity": options["reference"],
            "elastic_ramp_tolerance": ELASTIC_RAMP_TOLERANCE,
            "forecast": {"cut_fractions": list(CUT_FRACTIONS), "level": FORECAST_LEVEL},
            "stability_map": {
                "switch_points": MAP_POINTS,
                "stress_ratios": MAP_RATIOS,
                "hold": MAP_HOLD,
            },
        },
    }
    return AnalysisResult(
        granflow_version=granflow.__version__,
        synthetic=synthetic,
        campaign=FrozenMap(campaign),
        runs=entries,
        material=joint.material,
        analyses=joint.analyses,
        predictions=joint.predictions,
        forecasts=joint.forecasts,
        warnings=tuple(warnings_list + list(joint.warnings)),
        provenance=FrozenMap(provenance),
    )
