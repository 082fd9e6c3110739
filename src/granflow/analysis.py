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
* *stress ramp*: the observed failure, where the slip runs away: the first point whose slip
  velocity (the velocity column, or the slip's derivative) reaches ``FAILURE_FACTOR`` (1000)
  times the campaign's reference velocity (the median start-up velocity, 1 µm/s without
  start-ups), or from which on the velocity is missing to the end (the runaway marker of an
  export); otherwise the last point, when its slip velocity exceeds 100 times the run's
  median. The failure force is the force there.
* *switch*: the switch is the first point whose velocity departs from the nominal one by
  more than half of it (or is missing); the points before it are fitted as a start-up, and
  the outcome after it is *failure* (velocity at least ``FAILURE_FACTOR`` times the nominal
  one, or missing to the end), *stop* (last velocity below 1 % of it) or *creep*.

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
import tempfile
import time
import warnings
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType

import numpy as np

from granflow._json import json_safe
from granflow.errors import (
    ConvergenceWarning,
    FitError,
    GranflowError,
    InvalidDataError,
    InvalidParameterError,
)
from granflow.run import Run

__all__ = [
    "FAILURE_FACTOR",
    "AnalysisResult",
    "StartupData",
    "analyze",
    "classify",
    "startup_data",
]

#: Bumped whenever a per-run result changes meaning, so older saved results are not reused.
ANALYSIS_VERSION = 1
#: A slip velocity this many times the reference velocity is a runaway (failure).
FAILURE_FACTOR = 1000.0
RESULTS_FILE = "results.json"
REPORT_FILE = "report.html"
RUNS_DIR = "runs"
TABLES_DIR = "tables"
FIGURES_DIR = "figures"
_MARKER = "granflow_run_record"
_MANIFEST_NAMES = ("manifest.yaml", "manifest.yml", "manifest.csv")
_DEFAULT_REFERENCE_VELOCITY = 1e-6  # m/s, as granflow.simulate
_RAMP_TOLERANCE = 5.0  # noise standard deviations for the elastic ramp's straight line
_LEVEL_POINTS = 10  # points at one velocity that make a stress-controlled run a switch
_MAP_POINTS, _MAP_RATIOS = 8, 7  # the stability map's grid
_MAP_HOLD = 60.0  # s under force control in each cell of the map


# --------------------------------------------------------------------------- what a run is


def classify(run):
    """The kind of test a run is: ``"startup"``, ``"ramp"``, ``"creep"`` or ``"switch"``.

    The metadata's ``test`` (from the manifest) wins; otherwise the rule in the module's
    documentation decides from the control mode, the velocity and the force.

    Examples
    --------
    >>> import numpy as np, granflow
    >>> t = np.arange(50.0)
    >>> ramp = granflow.Run(t=t, slip=1e-9 * t, velocity=np.full(50, 1e-9),
    ...                     force=1e-4 * t, control="stress")
    >>> classify(ramp)
    'ramp'
    """
    from granflow.campaign import TEST_KINDS

    declared = run.meta.get("test")
    if isinstance(declared, str) and declared.strip().lower() in TEST_KINDS:
        return declared.strip().lower()
    if run.control == "rate":
        return "startup"
    velocity = run.velocity[np.isfinite(run.velocity)]
    if velocity.size >= _LEVEL_POINTS:
        lead = velocity[:_LEVEL_POINTS]
        level = float(np.median(lead))
        if level > 0 and np.all(np.abs(lead - level) <= 0.05 * level):
            return "switch"
    force = run.force[np.isfinite(run.force)]
    if force.size < 2:
        return "creep"
    tenth = max(1, force.size // 10)
    first, last = float(np.median(force[:tenth])), float(np.median(force[-tenth:]))
    return "ramp" if last - first > 0.05 * abs(last) else "creep"


# --------------------------------------------------------------------------- start-up window


@dataclass(frozen=True, eq=False)
class StartupData:
    """The points of a start-up run that are fitted, and how they were chosen.

    Attributes
    ----------
    slip : numpy.ndarray
        Abscissa of the fitted points [m].
    force : numpy.ndarray
        Friction force [N].
    abscissa : {"slip", "velocity*time"}
        Measured slip, or the nominal velocity times the time.
    elastic_points : int
        Leading points left out as the elastic loading ramp (0 if none was found).
    velocity : float or None
        Nominal velocity of the run [m/s].
    """

    slip: np.ndarray
    force: np.ndarray
    abscissa: str
    elastic_points: int
    velocity: float | None

    def describe(self):
        """JSON-safe summary of the window."""
        return {
            "abscissa": self.abscissa,
            "elastic_points": self.elastic_points,
            "start": float(self.slip[0]),
            "stop": float(self.slip[-1]),
            "points": int(self.slip.size),
        }


def _noise(values):
    from granflow.fitting import _noise_level

    return _noise_level(np.asarray(values, dtype=float))


def _elastic_ramp_end(x, force):
    """Index of the last point of the leading straight line, or None (see the module doc)."""
    if x.size < 4:
        return None
    top = int(np.argmax(force))
    tolerance = _RAMP_TOLERANCE * _noise(force) + 1e-6 * abs(float(force[top]))
    end = None
    for index in range(2, top):
        span = x[index] - x[0]
        chord = force[0] + (force[index] - force[0]) * (x[1:index] - x[0]) / span
        if np.max(np.abs(force[1:index] - chord)) > tolerance:
            break
        end = index
    return end


def startup_data(run):
    """The slip and force of a start-up run inside the fit window (rule: module doc).

    Parameters
    ----------
    run : granflow.Run

    Returns
    -------
    StartupData

    Raises
    ------
    InvalidDataError
        Without finite forces, or without a usable slip and a nominal velocity.
    """
    velocity = run.nominal_velocity
    keep = np.isfinite(run.t) & np.isfinite(run.force)
    with_slip = keep & np.isfinite(run.slip)
    slip = run.slip[with_slip]
    if slip.size >= 2 and np.all(np.diff(slip) > 0):
        x, force, abscissa = slip, run.force[with_slip], "slip"
    else:
        if velocity is None or not velocity > 0:
            raise InvalidDataError(
                f"{run.name}: the slip is missing or not strictly increasing, and there is no "
                "nominal velocity to compute it from the time"
            )
        t = run.t[keep]
        if t.size < 2 or np.any(np.diff(t) <= 0):
            raise InvalidDataError(f"{run.name}: the time is not strictly increasing")
        x, force, abscissa = velocity * (t - t[0]), run.force[keep], "velocity*time"
    end = _elastic_ramp_end(x, force)
    start = 0 if end is None else end
    x, force = x[start:], force[start:]
    return StartupData(
        slip=x,
        force=force,
        abscissa=abscissa,
        elastic_points=start,
        velocity=velocity,
    )


# --------------------------------------------------------------------------- per-run work


class _RunFailedError(GranflowError):
    """A run that cannot be analysed; ``partial`` keeps what was found before the failure."""

    def __init__(self, message, partial=None):
        super().__init__(message)
        self.partial = dict(partial or {})


def _fit_startup(data, name):
    from granflow.fitting import fit
    from granflow.model import NoPeakError, peak

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ConvergenceWarning)
        result = fit((data.slip, data.force), domain="slip", velocity=data.velocity)
    out = {"fit": result.to_dict(), "window": data.describe(), "warnings": []}
    if not result.success:
        raise _RunFailedError(f"the fit did not succeed: {result.message}", out)
    bounds = [n for n in result.names if result.at_bound[n]]
    if bounds:
        out["warnings"].append(f"{name}: fit at a bound of its search range: {', '.join(bounds)}")
    try:
        top = peak(result.to_params(), velocity=data.velocity)
        out["peak"] = top.to_dict()
    except NoPeakError:
        out["peak"] = None
    smooth = (
        np.convolve(data.force, np.ones(5) / 5.0, mode="same")
        if data.force.size > 5
        else data.force
    )
    index = int(np.argmax(smooth))
    out["observed_peak"] = {"force": float(smooth[index]), "slip": float(data.slip[index])}
    return out


def _analyse_startup(run, options):
    data = startup_data(run)
    return _fit_startup(data, run.name)


def _increasing_time(run, columns):
    """Finite rows (time and ``columns``), duplicate times reduced to their last row."""
    keep = np.isfinite(run.t)
    for name in columns:
        keep &= np.isfinite(getattr(run, name))
    rows = np.flatnonzero(keep)
    t = run.t[rows]
    if t.size and np.any(np.diff(t) < 0):
        raise InvalidDataError(f"{run.name}: the time decreases")
    last = np.r_[np.diff(t) > 0, True] if t.size else np.zeros(0, dtype=bool)
    return rows[last]


def _analyse_creep(run, options):
    from granflow.creep import fit_creep

    rows = _increasing_time(run, ("slip", "force"))
    if rows.size < 4:
        raise InvalidDataError(f"{run.name}: fewer than 4 points with time, slip and force")
    force = run.force[rows]
    level = float(np.median(force[force.size // 2 :]))
    start = int(np.argmax(force >= 0.98 * level)) if level > 0 else 0
    rows = rows[start:]
    t = run.t[rows] - run.t[rows[0]]
    slip = run.slip[rows] - run.slip[rows[0]]
    result = fit_creep(t, slip)
    out = {
        "fit": result.to_dict(),
        "stress": level,
        "creep_start": float(run.t[rows[0]]),
        "creep_slip": float(slip[-1]),
        "duration": float(t[-1]),
        "warnings": [],
    }
    if not result.success:
        raise _RunFailedError(f"the creep fit did not succeed: {result.message}", out)
    return out


def _slip_velocity(run):
    """The velocity column where it has finite values, else the slip's time derivative."""
    if np.isfinite(run.velocity).any():
        return np.array(run.velocity)
    velocity = np.full(run.t.shape, np.nan)
    rows = _increasing_time(run, ("slip",))
    if rows.size >= 2:
        velocity[rows[1:]] = np.diff(run.slip[rows]) / np.diff(run.t[rows])
        velocity[rows[0]] = 0.0
    return velocity


def _missing_to_end(velocity):
    """Index from which the velocity is missing to the end (after a finite value), or None."""
    finite = np.flatnonzero(np.isfinite(velocity))
    if finite.size == 0 or finite[-1] == velocity.size - 1:
        return None
    return int(finite[-1] + 1)


def _last_finite_force(run, index):
    finite = np.flatnonzero(np.isfinite(run.force[: index + 1]))
    return (float(run.force[finite[-1]]), int(finite[-1])) if finite.size else (math.nan, index)


def _analyse_ramp(run, options):
    velocity = _slip_velocity(run)
    threshold = FAILURE_FACTOR * options["reference_velocity"]
    fast = np.flatnonzero(np.isfinite(velocity) & (velocity >= threshold))
    candidates = []
    if fast.size:
        candidates.append((int(fast[0]), f"slip velocity above {threshold:.3g} m/s"))
    missing = _missing_to_end(velocity)
    if missing is not None:
        candidates.append((missing, "velocity missing to the end of the run (runaway)"))
    finite = velocity[np.isfinite(velocity)]
    positive = finite[finite > 0]
    if not candidates and positive.size and finite[-1] > 100.0 * float(np.median(positive)):
        candidates.append((int(np.flatnonzero(np.isfinite(velocity))[-1]), "run ends accelerating"))
    rows = _increasing_time(run, ("force",))
    out = {"warnings": []}
    if rows.size >= 2:
        before = rows[: max(2, rows.size // 2)]
        slope = np.polyfit(run.t[before], run.force[before], 1)[0]
        out["loading_rate"] = float(slope)
    if not candidates:
        out["failure"] = {"observed": False, "reason": "the slip does not run away in this run"}
        out["warnings"].append(f"{run.name}: no failure observed in the stress ramp")
        return out
    index, criterion = min(candidates)
    force, where = _last_finite_force(run, index)
    out["failure"] = {
        "observed": True,
        "criterion": criterion,
        "index": index,
        "time": float(run.t[where]),
        "slip": float(run.slip[where]) if np.isfinite(run.slip[where]) else None,
        "force": force,
    }
    return out


def _analyse_switch(run, options):
    velocity = np.array(run.velocity)
    nominal = run.meta.get("velocity")
    finite = np.flatnonzero(np.isfinite(velocity))
    if nominal is None and finite.size:
        nominal = float(np.median(velocity[finite[: max(1, finite.size // 10)]]))
    if nominal is None or not nominal > 0:
        raise InvalidDataError(f"{run.name}: no nominal velocity for the rate-controlled part")
    nominal = float(nominal)
    departs = ~np.isfinite(velocity) | (np.abs(velocity - nominal) > 0.5 * nominal)
    # the drive may need a few points to reach the velocity: look from the first point at it
    level = np.flatnonzero(~departs)
    after = np.flatnonzero(departs[level[0] :]) + level[0] if level.size else level
    if after.size == 0:
        raise InvalidDataError(
            f"{run.name}: no switch from rate to stress control found (the velocity never "
            "departs from the nominal one)"
        )
    switch = int(after[0])
    if switch < 2:
        raise InvalidDataError(f"{run.name}: the switch comes before any rate-controlled data")
    force_before, where = _last_finite_force(run, switch - 1)
    imposed = run.force[switch:]
    imposed = imposed[np.isfinite(imposed)]
    level = float(np.median(imposed)) if imposed.size else force_before
    tail = velocity[switch:]
    threshold = FAILURE_FACTOR * nominal
    if np.any(np.isfinite(tail) & (tail >= threshold)) or _missing_to_end(velocity) is not None:
        outcome = "failure"
    elif np.isfinite(tail[-1]) and abs(tail[-1]) <= 0.01 * nominal:
        outcome = "stop"
    else:
        outcome = "creep"
    t_switch = float(run.t[where])
    out = {
        "switch": {
            "index": switch,
            "time": t_switch,
            "velocity": nominal,
            "force_before": force_before,
            "imposed_force": level,
            "factor": level / force_before if force_before > 0 else None,
            "hold": float(np.nanmax(run.t[switch:]) - t_switch),
            "outcome": outcome,
        },
        "warnings": [],
        "fit": None,
    }
    startup = run.select(np.arange(len(run)) < switch)
    try:
        out.update(_fit_startup(startup_data(startup), run.name), switch=out["switch"])
    except (_RunFailedError, FitError, InvalidDataError) as exc:
        out["fit_error"] = f"the start-up part could not be fitted: {exc}"
        out["warnings"].append(f"{run.name}: {out['fit_error']}")
    return out


_ANALYSES = {
    "startup": _analyse_startup,
    "creep": _analyse_creep,
    "ramp": _analyse_ramp,
    "switch": _analyse_switch,
}


def analyse_run(task):
    """Analyse one run: ``task = (run, kind, options)`` -> a JSON-safe dict.

    A top-level function, so that process pools and Dask workers can run it. Never raises for
    a problem of the run: ``status`` is ``"failed"`` and ``reason`` says why.
    """
    run, kind, options = task
    try:
        with np.errstate(all="ignore"):
            out = _ANALYSES[kind](run, options)
        out.update(status="ok", reason=None)
    except _RunFailedError as exc:
        out = {**exc.partial, "status": "failed", "reason": str(exc)}
    except GranflowError as exc:
        out = {"status": "failed", "reason": str(exc)}
    except Exception as exc:  # a batch reports what failed and goes on with the rest
        out = {"status": "failed", "reason": f"{type(exc).__name__}: {exc}"}
    out.setdefault("warnings", [])
    return json_safe(out)


# --------------------------------------------------------------------------- files


def _write_atomic(path, write):
    """Call ``write(temporary_path)``, then move the file into place (same folder)."""
    path = Path(path)
    handle, temporary = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    os.close(handle)
    try:
        write(Path(temporary))
        os.replace(temporary, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(temporary)
        raise
    return path


def _dump(value):
    return json.dumps(value, indent=2, ensure_ascii=False, allow_nan=False) + "\n"


def _write_json(path, value):
    text = _dump(value)
    return _write_atomic(path, lambda temporary: temporary.write_text(text, encoding="utf-8"))


def _read_json(path):
    try:
        return json.loads(Path(path).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None


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


# --------------------------------------------------------------------------- execution


class _Executor:
    """Per-run tasks over local processes or a Dask cluster; results come as they finish."""

    def __init__(self, jobs, scheduler):
        self.jobs = jobs
        self.scheduler = scheduler
        self._pool = None
        self._client = None
        self._own_client = False
        self._futures = []
        if scheduler is not None:
            self._connect(scheduler)

    def _connect(self, scheduler):
        try:
            from distributed import Client
        except ImportError as exc:
            raise ImportError(
                "--scheduler needs Dask distributed: install the extra with "
                "`pip install granflow[dask]`"
            ) from exc
        if isinstance(scheduler, Client):
            self._client = scheduler
        else:
            self._client = Client(scheduler, timeout="30s")
            self._own_client = True

    @property
    def description(self):
        if self._client is not None:
            return f"dask {self._client.scheduler.address}"
        return f"local, {self.jobs} process{'es' if self.jobs > 1 else ''}"

    def _local_pool(self):
        if self._pool is None:
            from concurrent.futures import ProcessPoolExecutor

            self._pool = ProcessPoolExecutor(max_workers=self.jobs, initializer=_worker_init)
        return self._pool

    def run(self, function, tasks):
        """Yield ``(position, result or exception)`` for each task, in completion order."""
        if not tasks:
            return
        if self._client is not None:
            from distributed import as_completed

            futures = self._client.map(function, tasks, pure=False)
            self._futures = futures
            where = {future.key: position for position, future in enumerate(futures)}
            for future in as_completed(futures):
                yield where[future.key], _outcome(future.result)
            return
        if self.jobs == 1 or len(tasks) == 1:
            for position, task in enumerate(tasks):
                yield position, function(task)
            return
        from concurrent.futures import as_completed

        pool = self._local_pool()
        futures = {pool.submit(function, task): position for position, task in enumerate(tasks)}
        self._futures = list(futures)
        for future in as_completed(futures):
            yield futures[future], _outcome(future.result)

    def map(self, function, items):
        """``[function(item) for item in items]``, on the same workers."""
        items = list(items)
        if self._client is not None:
            return self._client.gather(self._client.map(function, items, pure=False))
        if self.jobs == 1 or len(items) == 1:
            return [function(item) for item in items]
        return list(self._local_pool().map(function, items))

    def close(self):
        for future in self._futures:
            future.cancel()
        if self._pool is not None:
            self._pool.shutdown(wait=True, cancel_futures=True)
        if self._client is not None and self._own_client:
            self._client.close()


def _worker_init():
    """Workers leave Ctrl-C to the main process, which stops the pool cleanly."""
    import signal

    signal.signal(signal.SIGINT, signal.SIG_IGN)


def _outcome(result):
    try:
        return result()
    except Exception as exc:  # a worker that died: report the run, do not keep the result
        return exc


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
    from granflow.campaign import Campaign, read_manifest

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
    from granflow.campaign import Campaign

    if isinstance(source, Campaign):
        items = [_run_item(run, None) for run in source.runs]
        items += [_Item(name="?", source=None, interval=None, reason=p) for p in source.problems]
        inputs = list(dict.fromkeys(item.source for item in items if item.source))
        return items, None, inputs
    manifest = _find_manifest(source)
    items, inputs = _items_from_manifest(manifest)
    return items, manifest, [manifest.name, *inputs]


# --------------------------------------------------------------------------- small helpers


def _rounded(value):
    if value is None:
        return None
    value = float(value)
    return float(f"{value:.6g}") if math.isfinite(value) and value != 0 else value


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
        "velocity": run.nominal_velocity,
        "preparation": run.meta.get("preparation"),
        "points": len(run),
    }


def _estimate(value, stderr, ci95):
    return {"value": value, "stderr": stderr, "ci95": [ci95[0], ci95[1]]}


def _no_material(reason):
    empty = {"value": None, "stderr": None, "ci95": [None, None]}
    return {
        "mu_a": dict(empty),
        "mu_d": dict(empty),
        "alpha": dict(empty),
        "source": None,
        "reason": reason,
    }


def _most_common(values):
    """The most frequent value (ties: the first seen)."""
    counts = Counter(values)
    best = max(counts.values())
    return next(value for value in values if counts[value] == best)


# --------------------------------------------------------------------------- rebuilt fits


def _fit_from_record(record, data):
    """The :class:`granflow.FitResult` of a saved start-up record, with its arrays rebuilt.

    Saved results and fresh ones give the same object (JSON keeps every float exactly), so
    joint analyses, figures and MCMC never depend on whether a run was fitted now.
    """
    from granflow._fitcore import FrozenMap, model_only
    from granflow.fitting import FitResult

    saved = record["fit"]
    names = tuple(saved["params"])
    keep = data.slip > 0
    x, y = data.slip[keep], data.force[keep]

    def number(value):
        return math.nan if value is None else float(value)

    params = {n: number(saved["params"][n]) for n in names}
    best = model_only(np.ascontiguousarray(x), *(params[n] for n in names))
    return FitResult(
        domain=saved["domain"],
        names=names,
        params=FrozenMap(params),
        stderr=FrozenMap({n: number(v) for n, v in saved["stderr"].items()}),
        ci95=FrozenMap({n: tuple(number(b) for b in v) for n, v in saved["ci95"].items()}),
        ci_method=FrozenMap(saved["ci_method"]),
        covar=FrozenMap(
            {
                p: FrozenMap({q: number(v) for q, v in row.items()})
                for p, row in saved["covar"].items()
            }
        ),
        correl=FrozenMap(
            {
                p: FrozenMap({q: number(v) for q, v in row.items()})
                for p, row in saved["correl"].items()
            }
        ),
        fixed=tuple(saved["fixed"]),
        at_bound=FrozenMap(saved["at_bound"]),
        success=bool(saved["success"]),
        message=saved["message"],
        nfev=int(saved["nfev"]),
        ndata=int(saved["ndata"]),
        nfree=int(saved["nfree"]),
        chisqr=number(saved["chisqr"]),
        redchi=number(saved["redchi"]),
        aic=number(saved["aic"]),
        bic=number(saved["bic"]),
        rsquared=number(saved["rsquared"]),
        x=x,
        data=y,
        best_fit=best,
        residuals=y - best,
        weights=np.ones_like(x),
        velocity=saved["velocity"],
        window=tuple(saved["window"]),
        sigma_known=bool(saved["sigma_known"]),
        name=saved.get("name"),
    )


def _creep_from_record(record, run):
    """The :class:`granflow.CurveFitResult` of a saved creep record, arrays rebuilt."""
    from granflow._fitcore import FrozenMap
    from granflow.creep import CurveFitResult

    saved = record["fit"]
    rows = _increasing_time(run, ("slip", "force"))
    rows = rows[run.t[rows] >= record["creep_start"]]
    t = run.t[rows] - run.t[rows[0]]
    slip = run.slip[rows] - run.slip[rows[0]]
    B, tau = saved["params"]["B"], saved["params"]["tau_c"]
    best = B * np.log1p(t / tau)
    return CurveFitResult(
        model=saved["model"],
        formula=saved["formula"],
        names=tuple(saved["params"]),
        units=FrozenMap(saved["units"]),
        params=FrozenMap(saved["params"]),
        stderr=FrozenMap(saved["stderr"]),
        ci95=FrozenMap({k: tuple(v) for k, v in saved["ci95"].items()}),
        covar=FrozenMap({k: FrozenMap(v) for k, v in saved["covar"].items()}),
        success=bool(saved["success"]),
        message=saved["message"],
        ndata=int(saved["ndata"]),
        nfree=int(saved["nfree"]),
        chisqr=saved["chisqr"],
        redchi=saved["redchi"],
        aic=saved["aic"],
        bic=saved["bic"],
        sigma_known=bool(saved["sigma_known"]),
        x=t,
        data=slip,
        best_fit=best,
        residuals=slip - best,
    )


# --------------------------------------------------------------------------- joint analyses


@dataclass(eq=False)
class _Startup:
    """A successful start-up run with its window and its fit (rebuilt from the record)."""

    item: _Item
    data: StartupData
    fit: object

    @property
    def load(self):
        return _rounded(self.item.run.normal_load)

    @property
    def velocity(self):
        return _rounded(self.item.run.nominal_velocity)

    @property
    def pair(self):
        return (self.data.slip, self.data.force)


@dataclass(eq=False)
class _Context:
    """What the joint stage found: the JSON parts and the objects figures are drawn from."""

    items: list
    startups: list
    analyses: dict = field(default_factory=dict)
    material: dict = field(default_factory=dict)
    predictions: dict = field(default_factory=dict)
    warnings: list = field(default_factory=list)
    constants: object = None  # MaterialConstants
    covariance: object = None  # 3 x 3 array over (mu_a, mu_d, alpha)
    material_velocity: float | None = None
    collapse: object = None
    amontons: object = None
    stability: object = None
    posterior: object = None
    representative: _Startup | None = None
    ramp_params: dict = field(default_factory=dict)  # item name -> Params
    switch_params: dict = field(default_factory=dict)


def _attempt(context, key, function):
    """``function()``, or None with a warning naming the analysis and the reason."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ConvergenceWarning)
            return function()
    except GranflowError as exc:
        context.analyses[key] = {"error": str(exc)}
        context.warnings.append(f"{key.replace('_', ' ')}: {exc}")
        return None


def _velocity_collapse(context):
    from granflow.joint import velocity_collapse

    groups = {}
    for startup in context.startups:
        groups.setdefault(startup.load, []).append(startup)
    best = None
    for load, members in groups.items():
        distinct = len({m.velocity for m in members})
        if distinct >= 2 and (best is None or (distinct, len(members)) > best[0]):
            best = ((distinct, len(members)), load, members)
    if best is None:
        return
    _, load, members = best
    result = _attempt(
        context,
        "velocity_collapse",
        lambda: velocity_collapse(
            [m.pair for m in members], velocities=[m.item.run.nominal_velocity for m in members]
        ),
    )
    if result is None:
        return
    context.collapse = result
    context.analyses["velocity_collapse"] = {
        "normal_load": load,
        "runs": [m.item.name for m in members],
        **result.to_dict(),
    }


def _set_material(context, names, params, stderr, ci95, covariance, source, **extra):
    from granflow.params import MaterialConstants

    context.material = {
        name: _estimate(params[key], stderr[key], ci95[key]) for name, key in names.items()
    }
    context.material.update(source=source, reason=None, **extra)
    context.covariance = covariance
    try:
        context.constants = MaterialConstants(
            mu_a=context.material["mu_a"]["value"],
            mu_d=context.material["mu_d"]["value"],
            alpha=context.material["alpha"]["value"],
        )
    except GranflowError as exc:
        context.warnings.append(f"material constants out of their domain: {exc}")


def _material(context):
    """Amontons over loads at the most common velocity; one load: a joint fit over the load."""
    from granflow.joint import fit_amontons, fit_joint

    if not context.startups:
        context.material = _no_material("no start-up run could be fitted")
        return
    loaded = [s for s in context.startups if s.load is not None and s.load > 0]
    if not loaded:
        context.material = _no_material("no normal load is given for the start-up runs")
        return
    velocity = _most_common([s.velocity for s in loaded])
    chosen = [s for s in loaded if s.velocity == velocity]
    context.material_velocity = velocity
    loads = sorted({s.load for s in chosen})
    names = ("mu_a", "mu_d", "alpha")
    if len(loads) >= 2:
        result = _attempt(
            context,
            "amontons",
            lambda: fit_amontons(
                [s.pair for s in chosen],
                normal_loads=[s.item.run.normal_load for s in chosen],
                velocities=[s.item.run.nominal_velocity for s in chosen],
            ),
        )
        if result is None:
            context.material = _no_material("the Amontons joint fit failed")
            return
        context.amontons = result
        joint = result.joint
        context.analyses["amontons"] = {
            "velocity": velocity,
            "runs": [s.item.name for s in chosen],
            **result.to_dict(),
        }
        if not joint.success:
            context.warnings.append(f"Amontons joint fit: {joint.message}")
        covariance = np.array([[joint.covar[p][q] for q in names] for p in names])
        _set_material(
            context,
            {n: n for n in names},
            joint.params,
            joint.stderr,
            joint.ci95,
            covariance,
            "amontons joint fit",
            runs=len(chosen),
            normal_loads=loads,
            velocity=velocity,
        )
        return
    load = float(np.mean([s.item.run.normal_load for s in chosen]))
    result = _attempt(
        context,
        "joint_fit",
        lambda: fit_joint([s.pair for s in chosen], shared=("a", "alpha", "Fd"), per_run=("x0",)),
    )
    if result is None:
        context.material = _no_material("the joint fit at the single load failed")
        return
    context.analyses["joint_fit"] = {
        "normal_load": load,
        "velocity": velocity,
        "runs": [s.item.name for s in chosen],
        **result.to_dict(),
    }
    keys = {"mu_a": "a", "mu_d": "Fd", "alpha": "alpha"}
    scale = {"mu_a": 1.0 / load, "mu_d": 1.0 / load, "alpha": 1.0}
    params = {n: result.params[keys[n]] * scale[n] for n in names}
    stderr = {n: result.stderr[keys[n]] * scale[n] for n in names}
    ci95 = {n: tuple(b * scale[n] for b in result.ci95[keys[n]]) for n in names}
    covariance = np.array(
        [[result.covar[keys[p]][keys[q]] * scale[p] * scale[q] for q in names] for p in names]
    )
    _set_material(
        context,
        {n: n for n in names},
        params,
        stderr,
        ci95,
        covariance,
        f"joint fit at the single load {load * 1e3:.6g} mN, divided by the load",
        runs=len(chosen),
        normal_loads=[_rounded(load)],
        velocity=velocity,
    )
    if not result.success:
        context.warnings.append(f"joint fit at one load: {result.message}")


def _preparation_spread(context):
    from granflow.joint import preparation_spread

    groups = {}
    for startup in context.startups:
        key = (startup.load, startup.velocity, startup.item.run.meta.get("preparation"))
        groups.setdefault(key, []).append(startup)
    rows = []
    for (load, velocity, preparation), members in groups.items():
        if len(members) < 2:
            continue
        spread = _attempt(
            context, "preparation_spread", lambda m=members: preparation_spread([s.fit for s in m])
        )
        if spread is not None:
            rows.append(
                {
                    "normal_load": load,
                    "velocity": velocity,
                    "preparation": preparation,
                    "runs": [s.item.name for s in members],
                    **spread.to_dict(),
                }
            )
    if rows:
        context.analyses["preparation_spread"] = rows


def _representative(context):
    if not context.startups:
        return None
    largest = _most_common([(s.load, s.velocity) for s in context.startups])
    return next(s for s in context.startups if (s.load, s.velocity) == largest)


def _model_comparison(context):
    from granflow.compare import compare_models

    chosen = context.representative
    if chosen is None:
        return
    result = _attempt(context, "model_comparison", lambda: compare_models(chosen.pair))
    if result is not None:
        context.analyses["model_comparison"] = {"run": chosen.item.name, **result.to_dict()}


def _mcmc(context, seed):
    from granflow.mcmc import sample_posterior

    chosen = context.representative
    if chosen is None:
        context.warnings.append("mcmc: no start-up fit to sample")
        return
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", ConvergenceWarning)
        posterior = _attempt(context, "mcmc", lambda: sample_posterior(chosen.fit, seed=seed))
    context.warnings += [f"mcmc: {w.message}" for w in caught if w.category is ConvergenceWarning]
    if posterior is not None:
        context.posterior = posterior
        context.analyses["mcmc"] = {"run": chosen.item.name, **posterior.to_dict()}


# --------------------------------------------------------------------------- predictions


def _peak_force(mu_a, mu_d, alpha, x0, load):
    from granflow.model import peak
    from granflow.params import Params

    return peak(Params(a=mu_a * load, alpha=alpha, Fd=mu_d * load, x0=x0)).force


def _x0_at(context, load):
    """Per-run x0 [m] of the start-ups at ``load`` (at the material's velocity when there
    are some), or of every start-up when none has that load; and where they came from."""
    at_load = [s for s in context.startups if s.load == load]
    same_velocity = [s for s in at_load if s.velocity == context.material_velocity]
    chosen, origin = (same_velocity or at_load), "start-up runs at this load"
    if not chosen:
        chosen = [s for s in context.startups if s.velocity == context.material_velocity]
        chosen, origin = chosen or context.startups, "all start-up runs (none at this load)"
    return [s.fit.params["x0"] for s in chosen], origin


def _yield_at(context, load):
    """Predicted static yield at one load, with its standard error and preparation spread."""
    from granflow.model import peak

    constants = context.constants
    x0_values, origin = _x0_at(context, load)
    if constants is None or not x0_values:
        return None
    x0 = float(np.mean(x0_values))
    x0_error = (
        float(np.std(x0_values, ddof=1) / math.sqrt(len(x0_values))) if len(x0_values) > 1 else 0.0
    )
    point = np.array([constants.mu_a, constants.mu_d, constants.alpha, x0])
    force = _peak_force(*point, load)
    gradient = np.empty(4)
    for k in range(4):
        step = 1e-6 * point[k]
        up, down = point.copy(), point.copy()
        up[k] += step
        down[k] -= step
        gradient[k] = (_peak_force(*up, load) - _peak_force(*down, load)) / (2 * step)
    variance = gradient[:3] @ context.covariance @ gradient[:3] + (gradient[3] * x0_error) ** 2
    stderr = math.sqrt(max(float(variance), 0.0))
    per_run = [_peak_force(*point[:3], value, load) for value in x0_values]
    params = constants.params_at(load, x0)
    top = peak(params, velocity=context.material_velocity)
    return {
        "normal_load": load,
        "repeats": len(x0_values),
        "x0": x0,
        "x0_stderr": x0_error,
        "x0_from": origin,
        "F_peak": force,
        "stderr": stderr,
        "ci95": [force - 1.959963984540054 * stderr, force + 1.959963984540054 * stderr],
        "spread": float(np.std(per_run, ddof=1)) if len(per_run) > 1 else 0.0,
        "F_peak_over_load": force / load,
        "x_peak": top.slip,
        "t_peak": top.time,
        "velocity": context.material_velocity,
    }


def _params_at(context, load):
    """Model parameters at a load from the material constants and the mean x0 there."""
    x0_values, _ = _x0_at(context, load)
    if context.constants is None or not x0_values or load is None:
        return None
    return context.constants.params_at(load, float(np.mean(x0_values)))


def _static_yield(context):
    loads = {s.load for s in context.startups if s.load is not None}
    loads |= {
        _rounded(item.run.normal_load)
        for item in context.items
        if item.run is not None and item.kind != "startup" and item.run.normal_load
    }
    if context.constants is None:
        context.predictions["static_yield"] = []
        context.predictions["static_yield_reason"] = context.material.get("reason")
        return
    rows = [_yield_at(context, load) for load in sorted(loads)]
    context.predictions["static_yield"] = [row for row in rows if row is not None]


def _yield_row(context, load):
    return next(
        (row for row in context.predictions.get("static_yield", []) if row["normal_load"] == load),
        None,
    )


def _compare_ramps(context):
    rows = []
    for item in context.items:
        if item.kind != "ramp" or item.record is None or item.record["status"] != "ok":
            continue
        load = _rounded(item.run.normal_load)
        failure = item.record["failure"]
        row = {"run": item.name, "normal_load": load, "observed": failure}
        predicted = _yield_row(context, load)
        if predicted is None:
            row["reason"] = "no predicted static yield at this load"
        else:
            row["predicted"] = {k: predicted[k] for k in ("F_peak", "stderr", "spread", "ci95")}
            params = _params_at(context, load)
            if params is not None:
                context.ramp_params[item.name] = params
        if predicted is not None and failure.get("observed"):
            width = math.hypot(predicted["stderr"], predicted["spread"])
            difference = failure["force"] - predicted["F_peak"]
            row["ratio"] = failure["force"] / predicted["F_peak"]
            row["z"] = difference / width if width > 0 else None
            row["consistent"] = bool(width > 0 and abs(difference) <= 2.0 * width)
        rows.append(row)
    if rows:
        context.analyses["stress_ramp"] = rows


def _compare_creep(context):
    rows = []
    for item in context.items:
        if item.kind != "creep" or item.record is None or item.record["status"] != "ok":
            continue
        load = _rounded(item.run.normal_load)
        record = item.record
        row = {
            "run": item.name,
            "normal_load": load,
            "stress": record["stress"],
            "B": record["fit"]["params"]["B"],
            "B_stderr": record["fit"]["stderr"]["B"],
            "tau_c": record["fit"]["params"]["tau_c"],
            "tau_c_stderr": record["fit"]["stderr"]["tau_c"],
        }
        predicted = _yield_row(context, load)
        if predicted is not None:
            row["stress_over_peak"] = record["stress"] / predicted["F_peak"]
        if context.constants is not None and load:
            row["stress_over_Fd"] = record["stress"] / (context.constants.mu_d * load)
        rows.append(row)
    if rows:
        context.analyses["creep"] = rows


def _compare_switches(context):
    from granflow.params import Params
    from granflow.protocol import Protocol, SwitchToForce, Velocity
    from granflow.simulate import simulate

    rows = []
    for item in context.items:
        if item.kind != "switch" or item.record is None or item.record["status"] != "ok":
            continue
        record, switch = item.record, item.record["switch"]
        row = {"run": item.name, "normal_load": _rounded(item.run.normal_load), **switch}
        fit = record.get("fit")
        if fit is not None and fit.get("success"):
            params, origin = Params(**fit["params"]), "the run's own start-up fit"
        else:
            params = _params_at(context, _rounded(item.run.normal_load))
            origin = "material constants at the run's load"
        if params is None or not switch.get("factor"):
            row["reason"] = "no parameters to predict the switch with"
            rows.append(row)
            continue
        context.switch_params[item.name] = params
        protocol = Protocol(
            [
                Velocity(switch["velocity"], max(switch["time"], 1e-9)),
                SwitchToForce(max(switch["hold"], 1.0), factor=switch["factor"]),
            ]
        )
        result = simulate(params, protocol)
        if result.failed:
            predicted = "failure"
        elif result.success and result.velocity[-1] == 0:
            predicted = "stop"
        else:
            predicted = "creep" if result.success else "error"
        row.update(
            params=params.to_dict(),
            params_from=origin,
            predicted_outcome=predicted,
            agree=predicted == switch["outcome"],
            predicted_message=result.message,
        )
        rows.append(row)
    if rows:
        context.analyses["switch"] = rows


class _Mapper:
    """Adapts the executor to ``stability_map(executor=...)``."""

    def __init__(self, executor):
        self.executor = executor

    def map(self, function, items):
        return self.executor.map(function, items)


def _stability(context, executor):
    from granflow.model import peak
    from granflow.stability import stability_map

    switches = [i for i in context.items if i.kind == "switch" and i.run is not None]
    if switches and switches[0].run.normal_load:
        load = _rounded(switches[0].run.normal_load)
    elif any(s.load for s in context.startups):
        load = _most_common([s.load for s in context.startups if s.load])
    else:
        load = None
    params = _params_at(context, load) if load is not None else None
    velocity = context.material_velocity
    if params is None and context.representative is not None:
        params = context.representative.fit.to_params()
        load = context.representative.load
        velocity = context.representative.velocity
    if params is None or not velocity:
        return
    t_peak = peak(params, velocity=velocity).time
    points = np.geomspace(0.25 * t_peak, 4.0 * t_peak, _MAP_POINTS)
    ratios = np.linspace(0.97, 1.09, _MAP_RATIOS)
    result = _attempt(
        context,
        "stability_map",
        lambda: stability_map(
            params, points, ratios, velocity=velocity, hold=_MAP_HOLD, executor=_Mapper(executor)
        ),
    )
    if result is not None:
        context.stability = result
        context.predictions["stability_map"] = {"normal_load": load, **result.to_dict()}


def _joint_stage(items, executor, *, mcmc, seed):
    startups = []
    for item in items:
        if item.kind == "startup" and item.record is not None and item.record["status"] == "ok":
            data = startup_data(item.run)
            startups.append(_Startup(item=item, data=data, fit=_fit_from_record(item.record, data)))
    context = _Context(items=items, startups=startups)
    context.representative = _representative(context)
    _velocity_collapse(context)
    _material(context)
    _preparation_spread(context)
    _model_comparison(context)
    if mcmc:
        _mcmc(context, seed)
    _static_yield(context)
    _compare_ramps(context)
    _compare_creep(context)
    _compare_switches(context)
    _stability(context, executor)
    return context


# --------------------------------------------------------------------------- tables


_TABLE_PARAMS = ("a", "alpha", "Fd", "x0", "B", "tau_c")


def _runs_table(entries):
    rows = []
    for entry in entries:
        row = {
            key: entry.get(key)
            for key in (
                "index",
                "name",
                "source",
                "interval",
                "test",
                "status",
                "reason",
                "normal_load",
                "velocity",
                "preparation",
                "points",
            )
        }
        fit = entry.get("fit") or {}
        for name in _TABLE_PARAMS:
            value = (fit.get("params") or {}).get(name)
            row[name] = value
            row[f"{name}_stderr"] = (
                (fit.get("stderr") or {}).get(name) if value is not None else None
            )
            low, high = (fit.get("ci95") or {}).get(name) or (None, None)
            row[f"{name}_ci95_low"], row[f"{name}_ci95_high"] = low, high
        row["redchi"] = fit.get("redchi")
        row["peak_force"] = (entry.get("peak") or {}).get("force")
        row["failure_force"] = (entry.get("failure") or {}).get("force")
        row["switch_outcome"] = (entry.get("switch") or {}).get("outcome")
        rows.append(row)
    return rows


def _loads_table(results):
    amontons = results["analyses"].get("amontons") or {}
    per_load = {row["normal_load"]: row for row in amontons.get("per_load", [])}
    yields = {row["normal_load"]: row for row in results["predictions"].get("static_yield", [])}
    rows = []
    for load in sorted(set(per_load) | set(yields)):
        row = {"normal_load": load}
        measured = per_load.get(load, {})
        row["repeats"] = measured.get("repeats")
        for key in ("a", "alpha", "alpha_v", "Fd"):
            mean, error = measured.get(key) or (None, None)
            row[f"{key}_mean"], row[f"{key}_stderr"] = mean, error
        predicted = yields.get(load, {})
        for key in ("x0", "x0_stderr", "F_peak", "stderr", "spread"):
            row[f"predicted_{key}" if key in ("stderr", "spread") else key] = predicted.get(key)
        rows.append(row)
    return rows


def _material_table(material):
    return [
        {
            "constant": name,
            "value": material[name]["value"],
            "stderr": material[name]["stderr"],
            "ci95_low": material[name]["ci95"][0],
            "ci95_high": material[name]["ci95"][1],
            "unit": "1/m" if name == "alpha" else "",
            "source": material.get("source"),
        }
        for name in ("mu_a", "mu_d", "alpha")
    ]


def _predictions_table(predictions):
    rows = []
    for row in predictions.get("static_yield", []):
        rows.append(
            {k: v for k, v in row.items() if k != "ci95"}
            | {
                "ci95_low": row["ci95"][0],
                "ci95_high": row["ci95"][1],
            }
        )
    return rows


def _write_tables(output, results, warnings_list):
    """CSV and Parquet of runs, loads, material and predictions; returns results["tables"]."""
    import pandas as pd

    folder = output / TABLES_DIR
    folder.mkdir(exist_ok=True)
    tables = {
        "runs": _runs_table(results["runs"]),
        "loads": _loads_table(results),
        "material": _material_table(results["material"]),
        "predictions": _predictions_table(results["predictions"]),
    }
    stability = results["predictions"].get("stability_map")
    if stability:
        tables["stability_map"] = [
            {
                "switch_point": point,
                "stress_ratio": ratio,
                "outcome": stability["outcome"][i][j],
                "stop_slip": stability["stop_slip"][i][j],
                "failure_time": stability["failure_time"][i][j],
            }
            for i, point in enumerate(stability["switch_points"])
            for j, ratio in enumerate(stability["stress_ratios"])
        ]
    try:
        import pyarrow  # noqa: F401

        parquet = True
    except ImportError:
        parquet = False
        warnings_list.append(
            "tables written as CSV only: Parquet needs pyarrow (pip install granflow[parquet])"
        )
    written = {}
    for name, rows in tables.items():
        frame = pd.DataFrame(rows)
        paths = {"csv": f"{TABLES_DIR}/{name}.csv"}
        _write_atomic(
            output / paths["csv"],
            lambda temporary, f=frame: f.to_csv(temporary, index=False, float_format="%.17g"),
        )
        if parquet:
            paths["parquet"] = f"{TABLES_DIR}/{name}.parquet"
            _write_atomic(
                output / paths["parquet"],
                lambda temporary, f=frame: f.astype(
                    {c: "string" for c in f.columns if f[c].dtype == object}
                ).to_parquet(temporary, index=False),
            )
        written[name] = paths
    return written


# --------------------------------------------------------------------------- figures and report


def _figure_specs(context):
    """(name, title, caption, draw) for each figure the campaign allows; draw() -> Figure."""
    import matplotlib.pyplot as plt

    from granflow import plotting

    specs = []
    paper = getattr(plotting, "plot_startup", None)
    startups = context.startups
    if startups:
        chosen = [
            s
            for s in startups
            if (s.load, s.velocity)
            == (context.representative.load, context.representative.velocity)
        ][:6]

        def startup():
            figure, (ax, residual) = plt.subplots(
                2, 1, sharex=True, figsize=(6.0, 5.0), height_ratios=(3, 1), layout="constrained"
            )
            if paper is not None:
                paper(
                    [s.item.run for s in chosen], [s.fit for s in chosen], ax, residual_ax=residual
                )
            else:
                context.representative.fit.plot(ax, residual_ax=residual)
            return figure

        specs.append(
            (
                "startup",
                "Start-up curves and fits",
                f"Friction force during start-up at {_display_load(context.representative.load)} "
                "with the fits of Eq. 3 and their residuals (Fig. 2a).",
                startup,
            )
        )
    if context.collapse is not None:
        specs.append(
            (
                "collapse",
                "Velocity collapse",
                "Start-up curves at several velocities against slip, with the shared fit "
                "(Fig. 2b).",
                lambda: plotting.plot_collapse(context.collapse).figure,
            )
        )
    if context.amontons is not None:
        specs.append(
            (
                "amontons",
                "Amontons' law",
                "a, αv and F_d against the normal load, means with standard errors over the "
                "repeats and lines through the origin (Fig. 2c).",
                lambda: plotting.plot_amontons(context.amontons)[0].figure,
            )
        )
    ramp = getattr(plotting, "plot_stress_ramp", None)
    for item in context.items:
        if (
            ramp is not None
            and item.kind == "ramp"
            and item.record
            and item.record["status"] == "ok"
        ):
            params = context.ramp_params.get(item.name)
            specs.append(
                (
                    "stress_ramp",
                    "Stress ramp",
                    "Slip and stress against time under a stress ramp, with the predicted static "
                    "yield (Fig. 3a).",
                    lambda i=item, p=params: _figure_of(ramp(i.run, p)),
                )
            )
            break
    creep = getattr(plotting, "plot_creep", None)
    creeps = [
        i for i in context.items if i.kind == "creep" and i.record and i.record["status"] == "ok"
    ]
    if creep is not None and creeps:
        specs.append(
            (
                "creep",
                "Creep",
                "Slip against time under constant stresses below the peak, with logarithmic "
                "fits (Fig. 3b).",
                lambda: _figure_of(
                    creep(
                        [i.run for i in creeps],
                        [_creep_from_record(i.record, i.run) for i in creeps],
                    )
                ),
            )
        )
    switch = getattr(plotting, "plot_switch", None)
    for item in context.items:
        if (
            switch is not None
            and item.kind == "switch"
            and item.record
            and item.record["status"] == "ok"
        ):
            params = context.switch_params.get(item.name)
            specs.append(
                (
                    "switch",
                    "Switch from rate to stress control",
                    "Force and slip against time, the switch marked, with the rate-controlled "
                    "curve of the fitted parameters (Fig. 3c).",
                    lambda i=item, p=params: _figure_of(switch(i.run, p)),
                )
            )
            break
    if context.stability is not None:
        specs.append(
            (
                "stability_map",
                "Stability map",
                "Predicted outcome of switching to stress control, over the switch time and the "
                "ratio of imposed to current force (quasi-static, slip clock).",
                lambda: plotting.plot_stability_map(context.stability).figure,
            )
        )
    if context.posterior is not None:
        specs.append(
            (
                "corner",
                "Posterior (MCMC)",
                f"Posterior of the Eq. 3 fit of {context.representative.item.name} (emcee), "
                "with the least-squares values marked.",
                lambda: plotting.plot_corner(context.posterior),
            )
        )
    return specs


def _display_load(load):
    return "an unknown load" if load is None else f"F_N = {load * 1e3:.4g} mN"


def _figure_of(axes):
    """The Figure of whatever a plot function returned (Axes, array of Axes, Figure)."""
    if hasattr(axes, "savefig"):
        return axes
    if hasattr(axes, "figure"):
        return axes.figure
    return np.ravel(axes)[0].figure


def _save_figure(figure, folder, stem):
    try:
        from granflow.plotting import save_figure
    except ImportError:
        paths = {}
        for suffix, options in (("png", {"dpi": 150}), ("svg", {})):
            paths[suffix] = folder / f"{stem}.{suffix}"
            figure.savefig(paths[suffix], **options)
        return paths
    return save_figure(figure, folder, stem)


def _make_figures(output, context, warnings_list):
    """Draw every figure the campaign allows into OUTPUT/figures; returns results["figures"]."""
    import matplotlib.pyplot as plt

    folder = output / FIGURES_DIR
    folder.mkdir(exist_ok=True)
    figures = []
    with tempfile.TemporaryDirectory(prefix=".figures-", dir=output) as scratch:
        for name, title, caption, draw in _figure_specs(context):
            try:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    figure = draw()
                    paths = _save_figure(figure, Path(scratch), name)
                plt.close(figure)
            except Exception as exc:  # a figure that fails must not cost the results
                warnings_list.append(
                    f"figure {name!r} could not be drawn: {type(exc).__name__}: {exc}"
                )
                plt.close("all")
                continue
            entry = {"name": name, "title": title, "caption": caption}
            for suffix, path in sorted(paths.items()):
                os.replace(path, folder / f"{name}.{suffix}")
                entry[suffix] = f"{FIGURES_DIR}/{name}.{suffix}"
            figures.append(entry)
    return figures


def _report_renderer():
    try:
        from granflow.report import render_report
    except ImportError:
        return None
    return render_report


def _write_report(output, results, render):
    """Render report.html atomically (into a temporary file, then moved into place)."""
    return _write_atomic(
        output / REPORT_FILE, lambda temporary: render(results, output, path=temporary)
    )


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
        lines = [
            f"campaign: {campaign['runs']} runs"
            + (" (synthetic data)" if results["synthetic"] else "")
            + f", {campaign['analysed']} analysed, {campaign['failed']} failed "
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
            observed = row["observed"]
            if observed.get("observed") and "predicted" in row:
                lines.append(
                    f"stress ramp {row['run']}: failed at {observed['force'] * 1e3:.4g} mN, "
                    f"predicted {row['predicted']['F_peak'] * 1e3:.4g} mN"
                    + (" (consistent)" if row.get("consistent") else " (not consistent)")
                )
        for row in results["analyses"].get("switch", []):
            if "predicted_outcome" in row:
                lines.append(
                    f"switch {row['run']}: observed {row['outcome']}, predicted "
                    f"{row['predicted_outcome']}" + (" (agree)" if row["agree"] else " (DISAGREE)")
                )
        if results["warnings"]:
            lines.append(f"warnings: {len(results['warnings'])} (see results.json or the report)")
        if self.failed_runs:
            lines.append(f"failed runs ({len(self.failed_runs)}):")
            for entry in self.failed_runs[:10]:
                lines.append(f"  {entry['name']}: {entry['reason']}")
            if len(self.failed_runs) > 10:
                lines.append(f"  ... and {len(self.failed_runs) - 10} more in results.json")
        lines.append(f"output: {self.output}")
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
        listed = [f.get(k) for f in previous.get("figures", []) for k in ("png", "svg")]
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
        from granflow.demo import TRUTH_FILE
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
    speeds = sorted(
        {_rounded(i.run.nominal_velocity) for i in runs if i.run.nominal_velocity is not None}
    )
    preparations = sorted(
        {str(i.run.meta["preparation"]) for i in runs if "preparation" in i.run.meta}
    )
    summary = {
        "manifest": None if manifest is None else str(manifest.resolve()),
        "entries": len(items),
        "runs": len(items),
        "analysed": len(ok),
        "failed": len(items) - len(ok),
        "tests": {kind: sum(1 for i in runs if i.kind == kind) for kind in _ANALYSES},
        "normal_loads": loads,
        "velocities": speeds,
        "preparations": preparations,
    }
    path, truth = _truth(manifest)
    synthetic = bool(truth and truth.get("synthetic", True)) or any(
        "synthetic" in str(i.run.meta.get("notes", "")).lower() for i in runs
    )
    summary["synthetic"] = synthetic
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
    return summary


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
        the extra ``granflow[dask]``.
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
    >>> result = granflow.analyze("campaign/manifest.yaml", "out", jobs=2)  # doctest: +SKIP
    >>> result.material["alpha"]["value"], result.exit_code  # doctest: +SKIP
    """
    started = datetime.datetime.now(datetime.UTC)
    clock = time.perf_counter()
    jobs = _check_jobs(jobs)
    if isinstance(seed, bool) or not isinstance(seed, int | np.integer):
        raise InvalidParameterError(f"seed must be an integer, got {seed!r}")
    if mcmc:
        from granflow.mcmc import _emcee

        _emcee()
    output = Path(output)
    output.mkdir(parents=True, exist_ok=True)
    (output / RUNS_DIR).mkdir(exist_ok=True)
    reporter = _Progress(quiet, progress)
    stages = {}
    items, manifest, inputs = _load(source)
    stages["read_s"] = time.perf_counter() - clock
    _remove_leftovers(output)
    if not resume:
        for path in _own_files(output):
            with contextlib.suppress(OSError):
                path.unlink()
    startup_velocities = [
        item.run.nominal_velocity
        for item in items
        if item.run is not None and classify(item.run) == "startup" and item.run.nominal_velocity
    ]
    reference = (
        float(np.median(startup_velocities)) if startup_velocities else _DEFAULT_REFERENCE_VELOCITY
    )
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
            continue
        todo.append((item, options))
    executor = _Executor(jobs, scheduler)
    fitted = 0
    try:
        if reused:
            reporter.line(f"reusing {reused} saved run results from {output / RUNS_DIR}")
        reporter.start(len(todo))
        tasks = [(item.run, item.kind, options) for item, options in todo]
        clock_runs = time.perf_counter()
        for position, result in executor.run(analyse_run, tasks):
            item = todo[position][0]
            if isinstance(result, Exception):  # the worker died: not saved, so retried
                item.record = {
                    "status": "failed",
                    "reason": f"the worker failed: {type(result).__name__}: {result}",
                    "warnings": [],
                }
            else:
                record = json.loads(_dump({_MARKER: ANALYSIS_VERSION, "key": item.key, **result}))
                _write_json(output / RUNS_DIR / f"{item.key}.json", record)
                item.record = record
            fitted += 1
            reporter.step(item.name)
        stages["runs_s"] = time.perf_counter() - clock_runs
        reporter.line("joint analyses and predictions")
        clock_joint = time.perf_counter()
        context = _joint_stage(items, executor, mcmc=mcmc, seed=int(seed))
        stages["joint_s"] = time.perf_counter() - clock_joint
        description = executor.description
    finally:
        executor.close()
    results = _assemble(items, manifest, inputs, context, mcmc, int(seed), reference)
    clock_out = time.perf_counter()
    results["tables"] = _write_tables(output, results, results["warnings"])
    reporter.line("figures")
    results["figures"] = _make_figures(output, context, results["warnings"])
    render = _report_renderer()
    if render is None:
        results["warnings"].append("no HTML report: granflow.report is not available")
    keys = {item.key for item in items if item.key}
    for path in (output / RUNS_DIR).glob("*.json"):
        if path.stem not in keys and _MARKER in (_read_json(path) or {}):
            with contextlib.suppress(OSError):
                path.unlink()
    stages["outputs_s"] = time.perf_counter() - clock_out
    results["timing"] = {
        "started": started.isoformat(timespec="seconds"),
        "finished": None,
        "elapsed_s": None,
        "jobs": None if scheduler is not None else jobs,
        "scheduler": description if scheduler is not None else None,
        "executor": description,
        "fitted_now": fitted,
        "reused": reused,
        "stages_s": stages,
    }
    results = json_safe(results)
    report = None
    if render is not None:
        reporter.line("report")
        _finish_timing(results, clock)
        report = _write_report(output, results, render)
    _finish_timing(results, clock)
    _write_json(output / RESULTS_FILE, results)
    return AnalysisResult(
        output=output, results=results, fitted_now=fitted, reused=reused, report=report
    )


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
    campaign = _campaign_summary(items, manifest, context.material)
    return {
        "granflow_version": granflow.__version__,
        "synthetic": campaign["synthetic"],
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
                "failure_factor": FAILURE_FACTOR,
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
