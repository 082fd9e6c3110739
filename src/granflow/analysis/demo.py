"""A synthetic measurement campaign that mirrors the paper, written as instrument exports.

:func:`make_demo_campaign` generates the experiments of Farain & Bonn with known material
constants (Amontons: ``a = mu_a F_N``, ``Fd = mu_d F_N``, one ``alpha``), adds seeded Gaussian
noise, writes the runs as RheoCompass- and TRIOS-style exports (English, French and German
labels; UTF-16, UTF-8 and cp1252; decimal dot and comma; several units) with a manifest, and
records the truth in ``synthetic_truth.json``. Everything is labelled synthetic: the project
and sample names in the files, the manifest notes and the truth file.

The campaign (``F_N`` normal load, ``v`` sliding velocity):

* **Fig. 2a** -- three preparations at 55 mN and 0.86 um/s, with the paper's t0 = 0.23, 0.39
  and 0.55 s (x0 = v t0); same a, alpha and Fd.
* **Fig. 2b** -- one preparation at 55 mN sheared at 0.43, 0.86, 1.72, 4.3 and 8.6 um/s
  (1 min rest between tests): the same curve in slip, over the same slip range.
* **Fig. 2c** -- five loads (20, 45, 70, 95, 120 mN), eight repeats each at 0.86 um/s, x0 drawn
  per repeat from 0.2-0.5 um (the paper's t0 of 0.23-0.55 s at 0.86 um/s).
* **Fig. 3a** -- a linear stress ramp on a fresh layer at 55 mN, simulated quasi-statically
  with :func:`granflow.simulate`: the layer creeps up the rising branch and fails at the peak.
* **Fig. 3b** -- two creep tests at 55 mN, one below F_d and one between F_d and F_peak,
  simulated with :class:`granflow.DirectEffect` (logarithmic creep). The stress is applied
  over a short loading ramp that is not exported: the interval starts when the constant
  stress begins, with the slip measured from there.
* **Fig. 3c** -- a start-up at 0.86 um/s switched at t = 80 s (after the peak) to a constant
  force 2 % above the current one (:class:`granflow.SwitchToForce`): it fails at once.

Start-ups are sampled at one point per 0.86 um of slip (1 point/s at 0.86 um/s; faster at the
higher velocities, so every run of Fig. 2b covers the same slip, 344 um, in 401 points). Time
starts at the model's origin (the slip is ``v t``; the first point, t = 0, holds the initial
force and lies before t0; the next one, 0.86 um of slip, lies after x0). After a failure the
exports show ten more points of flow at a fixed 100 um/s: a stand-in for the rheometer
spinning up, which the model does not describe. Force noise is 0.03 mN on every point; the
slip of stress-controlled runs carries 1 nm of noise (rate-controlled slip is the imposed
``v t``).

Overwriting rule: the target ``DIRECTORY/exports`` must be missing or empty, unless
``DIRECTORY/synthetic_truth.json`` marks the folder as a previous demo (a JSON object with
``"synthetic": true``); then the demo's own files are written again (same names) and any other
file is left alone. Otherwise :class:`~granflow.errors.InvalidParameterError` is raised and
nothing is written.
"""

from __future__ import annotations

import json
import math
import numbers
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import yaml

from granflow import __version__
from granflow._json import json_safe
from granflow.analysis.files import TRUTH_FILE
from granflow.errors import InvalidParameterError
from granflow.io import write_rheocompass, write_trios
from granflow.model.friction import friction_slip, initial_force, peak, rhs_slip
from granflow.model.params import Params
from granflow.model.run import Run
from granflow.simulation.driver import DirectEffect, simulate
from granflow.simulation.protocol import Force, ForceRamp, Protocol, SwitchToForce, Velocity

if TYPE_CHECKING:
    from granflow._typing import PathLike

__all__ = [
    "ALPHA",
    "EXPORTS_FOLDER",
    "MANIFEST_FILE",
    "MU_A",
    "MU_D",
    "NOISE",
    "SLIP_NOISE",
    "TRUTH_FILE",
    "make_demo_campaign",
]

#: Folder (inside the target directory) that holds the exports and the manifest.
EXPORTS_FOLDER = "exports"
#: Name of the manifest inside :data:`EXPORTS_FOLDER`.
MANIFEST_FILE = "manifest.yaml"

#: Material constants of the synthetic PMMA layer: a = MU_A F_N, Fd = MU_D F_N [-].
MU_A = 0.06
MU_D = 0.2
#: Shear-rejuvenation constant [1/m] (between the paper's 4.2e4 and 6.7e4).
ALPHA = 5.0e4
#: Standard deviation of the force noise [N] (0.03 mN).
NOISE = 3.0e-5
#: Standard deviation of the slip noise of stress-controlled runs [m].
SLIP_NOISE = 1.0e-9

_VELOCITY = 0.86e-6  # m/s, the paper's velocity (1e-5 rev/s)
_SLIP_STEP = _VELOCITY * 1.0  # m between points of a start-up: 1 point/s at 0.86 um/s
_STARTUP_POINTS = 401  # 0..400 s at 0.86 um/s: 344 um of slip, peak and tail
_FIG_LOAD = 0.055  # N: the tube of Figs. 2a, 2b and 3 (a = 3.3 mN, as in the paper)
_PAPER_T0 = (0.23, 0.39, 0.55)  # s, the paper's Fig. 2a preparations
# The preparation states (protocols) of the manifest: the Fig. 2a preparations are repeats of
# one protocol, and so are the load series' repeats (at each load).
_FIG2A_STATE = "sieved and poured (Fig. 2a)"
_SERIES_STATE = "sieved and poured (load series)"
_X0_RANGE = (0.2e-6, 0.5e-6)  # m, x0 of the other preparations, drawn uniformly
_VELOCITIES = (0.43e-6, 0.86e-6, 1.72e-6, 4.3e-6, 8.6e-6)  # m/s
_REST_TIME = 60.0  # s between the tests of the velocity series
_LOADS = (0.020, 0.045, 0.070, 0.095, 0.120)  # N
_REPEATS = 8
_RAMP_RATE = 0.065e-3  # N/s; fails after about 200 s at 55 mN
_RAMP_DURATION = 300.0  # s
_CREEP_LEVELS = (-0.5, 0.5)  # stress as Fd + level (F_peak - Fd): one below Fd, one above
_CREEP_AMPLITUDE = 2.0e-5  # N, direct-effect amplitude A (0.6 % of a at 55 mN)
_CREEP_LOADING = 5.0  # s, loading ramp before the constant stress (not exported)
_CREEP_DURATION = 1800.0  # s at constant stress
_SWITCH_TIME = 80.0  # s
_SWITCH_FACTOR = 1.02
_SWITCH_DURATION = 60.0  # s of force control after the switch
_FLOW_VELOCITY = 1.0e-4  # m/s after a failure (not modelled)
_FLOW_POINTS = 10
_SAMPLE = "synthetic PMMA beads 40 um (granflow demo)"
_PROJECT = "granflow demo: SYNTHETIC data"
_NOTES = "synthetic"


@dataclass(frozen=True)
class _ExportFile:
    """One export: its name, writer, writer options and the test name it shows."""

    name: str
    writer: str
    title: str
    options: dict = field(default_factory=dict)


# What each file exercises in the readers: format, language, encoding, decimal mark, units.
_FILES = {
    "fig2a": _ExportFile(
        "fig2a_preparations_en.txt",
        "rheocompass",
        "synthetic start-ups, three preparations",
        {"language": "en", "encoding": "utf-16"},
    ),
    "fig2b": _ExportFile(
        "fig2b_velocities_fr.csv",
        "rheocompass",
        "synthetic start-ups, five velocities",
        {
            "language": "fr",
            "encoding": "utf-8-sig",
            "decimal": ",",
            "units": {"torque": "µN·m", "speed": "rad/s", "angle": "rad"},
        },
    ),
    0.020: _ExportFile("loads_020mN_trios.txt", "trios", "", {"encoding": "utf-8"}),
    0.045: _ExportFile(
        "loads_045mN_de.txt",
        "rheocompass",
        "synthetic start-ups at 45 mN",
        {
            "language": "de",
            "encoding": "cp1252",
            "decimal": ",",
            "units": {"time": "min", "torque": "N m", "angle": "°"},
        },
    ),
    0.070: _ExportFile(
        "loads_070mN_en.txt",
        "rheocompass",
        "synthetic start-ups at 70 mN",
        {"language": "en", "encoding": "utf-16-le", "units": {"torque": "µNm", "speed": "1/s"}},
    ),
    0.095: _ExportFile(
        "loads_095mN_trios.txt", "trios", "", {"encoding": "utf-8-sig", "units": {"torque": "mN.m"}}
    ),
    0.120: _ExportFile(
        "loads_120mN_fr.txt",
        "rheocompass",
        "synthetic start-ups at 120 mN",
        {"language": "fr", "encoding": "utf-16", "decimal": ","},
    ),
    "ramp": _ExportFile("fig3a_stress_ramp_trios.txt", "trios", "", {"encoding": "utf-8"}),
    "creep": _ExportFile(
        "fig3b_creep_de.txt",
        "rheocompass",
        "synthetic creep",
        {"language": "de", "encoding": "utf-8", "units": {"torque": "µN·m", "angle": "µrad"}},
    ),
    "switch": _ExportFile(
        "fig3c_switch_fr.txt",
        "rheocompass",
        "synthetic switch from rate to stress control",
        {"language": "fr", "encoding": "cp1252", "decimal": ","},
    ),
}


@dataclass(frozen=True)
class _Planned:
    """One run of the campaign: where it goes, what test it is, and its truth."""

    file: object
    run: object
    test: str
    truth: dict
    notes: str = _NOTES


def _check_seed(seed):
    if isinstance(seed, bool) or not isinstance(seed, numbers.Integral) or seed < 0:
        raise InvalidParameterError(f"seed must be a non-negative integer, got {seed!r}")
    return int(seed)


def _is_demo(truth_path):
    """Whether ``truth_path`` is a truth file written by a previous demo."""
    try:
        document = json.loads(truth_path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, ValueError):
        return False
    return isinstance(document, dict) and document.get("synthetic") is True


def _check_target(directory):
    """Refuse to write over anything that is not a previous demo (see the module docstring)."""
    if directory.exists() and not directory.is_dir():
        raise InvalidParameterError(f"directory {directory} exists and is not a folder")
    exports = directory / EXPORTS_FOLDER
    truth = directory / TRUTH_FILE
    if exports.exists() and not exports.is_dir():
        raise InvalidParameterError(f"{exports} exists and is not a folder")
    occupied = exports.is_dir() and any(exports.iterdir())
    if (occupied or truth.exists()) and not _is_demo(truth):
        what = f"{exports} is not empty" if occupied else f"{truth} exists"
        raise InvalidParameterError(
            f"{what} and {truth} does not mark it as a granflow demo (a JSON object with "
            '"synthetic": true); refusing to overwrite it: choose a new or empty directory'
        )


# --------------------------------------------------------------------------- the runs


def _params(normal_load, x0):
    return Params(a=MU_A * normal_load, alpha=ALPHA, Fd=MU_D * normal_load, x0=x0)


def _truth(params, normal_load, velocity, preparation, control="rate", state=None):
    """The truth every run shares: load, velocity, parameters and the overshoot."""
    top = peak(params)
    return {
        "normal_load": normal_load,
        "velocity": velocity,
        "preparation": preparation,
        "preparation_state": state,
        "control": control,
        "x0": params.x0,
        "t0": None if velocity is None else params.x0 / velocity,
        "a": params.a,
        "alpha": params.alpha,
        "Fd": params.Fd,
        "F_peak": top.force,
        "x_peak": top.slip,
    }


def _meta(normal_load, preparation, velocity=None, rest_time=None):
    meta = {"sample": _SAMPLE, "preparation": preparation, "normal_load": normal_load}
    if rest_time is not None:
        meta["rest_time"] = rest_time
    if velocity is not None:
        meta["velocity"] = velocity
    return meta


def _rate_force(params, slip):
    """Friction along an imposed slip ``slip`` (from 0); before x0 the initial force holds."""
    force = np.full(slip.shape, initial_force(params))
    started = slip >= params.x0
    force[started] = friction_slip(slip[started], params)
    return force


def _startup(params, velocity, rng, meta):
    """A rate-controlled start-up: slip v t on a grid of one point per 0.86 um of slip."""
    slip = _SLIP_STEP * np.arange(_STARTUP_POINTS)
    force = _rate_force(params, slip) + NOISE * rng.standard_normal(slip.size)
    velocities = np.full(slip.size, velocity)
    return Run(t=slip / velocity, slip=slip, velocity=velocities, force=force, meta=meta)


def _failure(result, what):
    if not result.failed:
        raise RuntimeError(f"the demo's {what} did not fail: {result.message}")
    event = result.failure
    slip = float(result.displacement[-1])
    return {"time": event.time, "slip": slip, "force": event.force}


def _with_flow(t, slip, velocity, force, failure, imposed):
    """Append the points after a failure: sliding at the flow velocity (not modelled)."""
    after = t[-1] + np.arange(1.0, _FLOW_POINTS + 1.0)  # the instrument's clock goes on
    return (
        np.concatenate([t, after]),
        np.concatenate([slip, failure["slip"] + _FLOW_VELOCITY * (after - failure["time"])]),
        np.concatenate([velocity, np.full(after.size, _FLOW_VELOCITY)]),
        np.concatenate([force, imposed(after)]),
    )


def _stress_run(t, slip, velocity, force, rng, meta):
    slip = slip + SLIP_NOISE * rng.standard_normal(slip.size)
    force = force + NOISE * rng.standard_normal(force.size)
    return Run(t=t, slip=slip, velocity=velocity, force=force, control="stress", meta=meta)


def _stress_ramp(params, rng, meta):
    """Fig. 3a: a linear force ramp from zero; the layer fails at the peak."""
    ramp = ForceRamp(rate=_RAMP_RATE, duration=_RAMP_DURATION, start=0.0)
    result = simulate(params, Protocol([ramp]), points=2000)
    failure = _failure(result, "stress ramp")
    t = np.arange(0.0, math.ceil(failure["time"]))
    slip = np.interp(t, result.t, result.displacement)
    velocity = np.interp(t, result.t, result.velocity)
    columns = _with_flow(t, slip, velocity, _RAMP_RATE * t, failure, lambda s: _RAMP_RATE * s)
    truth = {
        "rate": _RAMP_RATE,
        "simulation": "granflow.simulate, ForceRamp, quasistatic, slip clock",
        "failure": failure,
        "flow_velocity": _FLOW_VELOCITY,
    }
    return _stress_run(*columns, rng, meta), truth


def _creep(params, level, rng, meta):
    """Fig. 3b: a constant force below the peak; the direct effect makes the layer creep."""
    protocol = Protocol(
        [
            ForceRamp(rate=level / _CREEP_LOADING, duration=_CREEP_LOADING, start=0.0),
            Force(level=level, duration=_CREEP_DURATION),
        ]
    )
    effect = DirectEffect(amplitude=_CREEP_AMPLITUDE, velocity=_VELOCITY)
    points = int(_CREEP_DURATION) + 1  # the simulator's even grid then falls on whole seconds
    result = simulate(params, protocol, direct_effect=effect, points=points)
    if result.failed or not result.success:
        raise RuntimeError(f"the demo's creep test at {level:g} N did not creep: {result.message}")
    hold = np.flatnonzero(result.segment == 1)
    t_hold, slip_hold = result.t[hold], result.displacement[hold]
    t = np.arange(0.0, _CREEP_DURATION + 0.5)
    slip = np.interp(t + _CREEP_LOADING, t_hold, slip_hold) - slip_hold[0]
    velocity = np.interp(t + _CREEP_LOADING, t_hold, result.velocity[hold])
    run = _stress_run(t, slip, velocity, np.full(t.size, level), rng, meta)
    # along the rising branch of slope F' = dF/dx, slip ~ (A / F') ln(1 + t / tau_c)
    slope = float(rhs_slip(result.slip[hold[0]], result.state[hold[0]], params))
    truth = {
        "stress": level,
        "direct_effect": {"amplitude": effect.amplitude, "velocity": effect.velocity},
        "simulation": "granflow.simulate, ForceRamp then Force, quasistatic with the direct "
        "effect, slip clock; the loading ramp is not exported",
        "loading_time": _CREEP_LOADING,
        "loading_slip": float(slip_hold[0]),
        "creep_slip": float(slip[-1]),
        "creep_B_approx": effect.amplitude / slope,
    }
    return run, truth


def _switch(params, rng, meta):
    """Fig. 3c: rate control until 80 s (after the peak), then a force 2 % above: failure.

    The simulator's clock is the exported one (the start-up enters the model at t0 with slip
    x0 = v t0), so the switch is at 80 s on both.
    """
    protocol = Protocol(
        [
            Velocity(velocity=_VELOCITY, duration=_SWITCH_TIME),
            SwitchToForce(duration=_SWITCH_DURATION, factor=_SWITCH_FACTOR),
        ]
    )
    result = simulate(params, protocol)
    failure = _failure(result, "switch experiment")
    level = failure["force"]
    t = np.arange(0.0, _SWITCH_TIME + 0.5)
    slip = _VELOCITY * t
    columns = _with_flow(
        t,
        slip,
        np.full(t.size, _VELOCITY),
        _rate_force(params, slip),
        failure,
        lambda s: np.full(s.size, level),
    )
    truth = {
        "switch_time": _SWITCH_TIME,
        "switch_factor": _SWITCH_FACTOR,
        "force_at_switch": level / _SWITCH_FACTOR,
        "switch_force": level,
        "simulation": "granflow.simulate, Velocity then SwitchToForce, quasistatic, slip clock",
        "failure": failure,
        "flow_velocity": _FLOW_VELOCITY,
    }
    t, slip, velocity, force = columns
    force = force + NOISE * rng.standard_normal(force.size)
    run = Run(t=t, slip=slip, velocity=velocity, force=force, control="stress", meta=meta)
    return run, truth


def _campaign(rng):
    """Every run of the campaign, in manifest order."""
    planned = []
    for label, t0 in zip("ABC", _PAPER_T0, strict=True):
        params = _params(_FIG_LOAD, t0 * _VELOCITY)
        preparation = f"fig2a-{label}"
        run = _startup(params, _VELOCITY, rng, _meta(_FIG_LOAD, preparation, _VELOCITY))
        truth = _truth(params, _FIG_LOAD, _VELOCITY, preparation, state=_FIG2A_STATE)
        planned.append(_Planned("fig2a", run, "startup", truth))

    params = _params(_FIG_LOAD, float(rng.uniform(*_X0_RANGE)))
    for velocity in _VELOCITIES:
        meta = _meta(_FIG_LOAD, "fig2b", velocity, _REST_TIME)
        run = _startup(params, velocity, rng, meta)
        truth = {**_truth(params, _FIG_LOAD, velocity, "fig2b"), "rest_time": _REST_TIME}
        planned.append(_Planned("fig2b", run, "startup", truth))

    for load in _LOADS:
        for repeat in range(1, _REPEATS + 1):
            params = _params(load, float(rng.uniform(*_X0_RANGE)))
            preparation = f"load{load * 1e3:03.0f}-{repeat}"
            run = _startup(params, _VELOCITY, rng, _meta(load, preparation, _VELOCITY))
            truth = _truth(params, load, _VELOCITY, preparation, state=_SERIES_STATE)
            planned.append(_Planned(load, run, "startup", truth))

    params = _params(_FIG_LOAD, float(rng.uniform(*_X0_RANGE)))
    run, extra = _stress_ramp(params, rng, _meta(_FIG_LOAD, "fig3a"))
    truth = {**_truth(params, _FIG_LOAD, None, "fig3a", "stress"), **extra}
    planned.append(_Planned("ramp", run, "ramp", truth))

    for number, position in enumerate(_CREEP_LEVELS, start=1):
        params = _params(_FIG_LOAD, float(rng.uniform(*_X0_RANGE)))
        base = _truth(params, _FIG_LOAD, None, f"fig3b-{number}", "stress")
        level = params.Fd + position * (base["F_peak"] - params.Fd)
        run, extra = _creep(params, level, rng, _meta(_FIG_LOAD, f"fig3b-{number}"))
        planned.append(_Planned("creep", run, "creep", {**base, **extra}))

    params = _params(_FIG_LOAD, float(rng.uniform(*_X0_RANGE)))
    run, extra = _switch(params, rng, _meta(_FIG_LOAD, "fig3c", _VELOCITY))
    truth = {**_truth(params, _FIG_LOAD, _VELOCITY, "fig3c", "stress"), **extra}
    planned.append(_Planned("switch", run, "switch", truth))
    return planned


# --------------------------------------------------------------------------- the files


def _quantity(value, scale, unit):
    return f"{value / scale:.6g} {unit}"


def _manifest_entry(plan, interval):
    truth = plan.truth
    entry = {
        "file": _FILES[plan.file].name,
        "interval": interval,
        "test": plan.test,
        "normal_load": _quantity(truth["normal_load"], 1e-3, "mN"),
    }
    if truth["velocity"] is not None:
        entry["velocity"] = _quantity(truth["velocity"], 1e-6, "um/s")
    if "rest_time" in truth:
        entry["rest_time"] = _quantity(truth["rest_time"], 1.0, "s")
    entry["preparation"] = truth["preparation"]
    if truth.get("preparation_state"):
        entry["preparation_state"] = truth["preparation_state"]
    entry.update(sample=_SAMPLE, notes=plan.notes)
    if plan.test == "switch":
        entry["switch_time"] = f"{_SWITCH_TIME:g} s"
    return entry


def _write_exports(exports, planned):
    """Write every export file.

    Returns the (manifest entry, run truth) pairs in campaign order and the truth's file list.
    """
    entries, files = {}, []
    for key, spec in _FILES.items():
        members = [plan for plan in planned if plan.file == key]
        runs = [plan.run for plan in members]
        if spec.writer == "rheocompass":
            write_rheocompass(
                exports / spec.name, runs, project=_PROJECT, test=spec.title, **spec.options
            )
        else:
            write_trios(exports / spec.name, runs, sample=_SAMPLE, **spec.options)
        for interval, plan in enumerate(members, start=1):
            where = {"file": spec.name, "interval": interval, "test": plan.test}
            entries[planned.index(plan)] = (
                _manifest_entry(plan, interval),
                {**where, **plan.truth},
            )
        options = {"language": "en", "decimal": ".", **spec.options}
        files.append({"file": spec.name, "format": spec.writer, "runs": len(runs), **options})
    return [entries[index] for index in sorted(entries)], files


_MANIFEST_HEADER = """\
# SYNTHETIC campaign written by granflow.demo.make_demo_campaign (seed {seed}).
# Not measured data: the model of Farain & Bonn with known constants and added noise;
# the truth is in ../{truth}.
"""


def make_demo_campaign(directory: PathLike, *, seed: int = 0) -> Path:
    """Write a synthetic campaign that mirrors the paper as instrument exports + a manifest.

    The runs, the files and the overwriting rule are described in :mod:`granflow.demo`. The
    same seed gives byte-identical files.

    Parameters
    ----------
    directory : str or pathlib.Path
        Target folder (created if missing). The exports and ``manifest.yaml`` go to
        ``directory/exports/``, the truth to ``directory/synthetic_truth.json``.
    seed : int
        Seed of ``numpy.random.default_rng`` for the noise and the drawn x0; non-negative.

    Returns
    -------
    pathlib.Path
        The manifest, ``directory/exports/manifest.yaml``.

    Raises
    ------
    InvalidParameterError
        A negative or non-integer seed; ``directory/exports`` not empty (or
        ``directory/synthetic_truth.json`` present) without a previous demo's truth file.

    Notes
    -----
    ``synthetic_truth.json`` holds ``"synthetic": true``, ``seed``, the material constants
    ``mu_a``, ``mu_d`` [-] and ``alpha`` [1/m], the force ``noise`` [N] and ``slip_noise``
    [m], the export ``files`` (format, language, encoding, decimal mark, units) and one entry
    per run in manifest order: ``file``, ``interval``, ``test``, ``control``,
    ``normal_load`` [N], ``velocity`` [m/s] (None under stress control), ``preparation``,
    ``x0`` [m], ``t0`` [s], ``a``, ``Fd``, ``F_peak`` [N], ``alpha`` [1/m], ``x_peak`` [m], and
    per test: the ramp ``rate`` [N/s] and its ``failure`` (time [s], slip [m], force [N]); the
    creep ``stress`` [N], ``direct_effect``, ``creep_B_approx`` [m] (A / F' at the start of
    the creep); the ``switch_time`` [s], ``switch_force`` [N] and ``failure``.

    ``x0`` and ``x_peak`` are the model's aging coordinate, which starts at 0 with the shear:
    for rate-controlled runs it is the exported slip (``v t``). The exported slip of the ramp
    and creep runs is measured from the start of the interval, as are the failure slips.

    Examples
    --------
    >>> import tempfile, granflow
    >>> from granflow.analysis.demo import make_demo_campaign
    >>> manifest = make_demo_campaign(tempfile.mkdtemp(), seed=1)
    >>> campaign = granflow.Campaign.from_manifest(manifest)
    >>> len(campaign), campaign.problems
    (52, ())
    """
    seed = _check_seed(seed)
    directory = Path(directory)
    _check_target(directory)
    planned = _campaign(np.random.default_rng(seed))
    exports = directory / EXPORTS_FOLDER
    exports.mkdir(parents=True, exist_ok=True)
    # the truth first: it marks the folder as a demo, so an interrupted run can be repeated
    truth_path = directory / TRUTH_FILE
    truth_path.write_text(json.dumps({"synthetic": True, "seed": seed}) + "\n", encoding="utf-8")
    written, files = _write_exports(exports, planned)
    manifest = exports / MANIFEST_FILE
    entries = [entry for entry, _ in written]
    text = yaml.safe_dump({"runs": entries}, sort_keys=False, allow_unicode=True, width=100)
    header = _MANIFEST_HEADER.format(seed=seed, truth=TRUTH_FILE)
    manifest.write_text(header + text, encoding="utf-8")
    truth = {
        "synthetic": True,
        "generator": "granflow.demo.make_demo_campaign",
        "granflow_version": __version__,
        "seed": seed,
        "mu_a": MU_A,
        "mu_d": MU_D,
        "alpha": ALPHA,
        "noise": NOISE,
        "slip_noise": SLIP_NOISE,
        "units": "SI: N, m, s, 1/m; alpha v in 1/s",
        "manifest": f"{EXPORTS_FOLDER}/{MANIFEST_FILE}",
        "files": files,
        "runs": [run_truth for _, run_truth in written],
    }
    text = json.dumps(json_safe(truth), indent=2, ensure_ascii=False) + "\n"
    truth_path.write_text(text, encoding="utf-8")
    # a ramp to failure (not in the manifest) for granflow watch --replay
    ramp = _stress_ramp(_params(_FIG_LOAD, 3e-7), np.random.default_rng([seed, 30]), {})[0]
    (directory / "watch").mkdir(exist_ok=True)
    write_rheocompass(directory / "watch" / "ramp.txt", ramp, project=_PROJECT, test="ramp")
    return manifest
