"""The joint stage of :func:`granflow.analyze`: analyses over runs, as pure functions.

Runs in the calling process after the per-run work, from the per-run results (the same
objects whether a run was fitted now or its saved result was rebuilt), so that its output
does not depend on which runs were reused. Each function takes values and returns values
(:mod:`granflow.analysis.joint_results`) together with :class:`Notes` (the analyses that
failed and the warnings, in the order found); :func:`granflow.analysis.stage.joint_stage`
chains them with the predictions of :mod:`granflow.analysis.predictions`. Rules in
:mod:`granflow.analysis`.
"""

import math
import warnings
from collections import Counter
from dataclasses import dataclass

import numpy as np

from granflow.analysis.joint_results import (
    MATERIAL_CONSTANTS,
    Estimate,
    FitJudgement,
    GoodnessOfFit,
    JointAnalysis,
    Material,
)
from granflow.analysis.runs import StartupData, startup_data
from granflow.errors import ConvergenceWarning, GranflowError
from granflow.fitting.results import FrozenMap

__all__ = [
    "MaterialBasis",
    "Notes",
    "Startup",
    "attempt",
    "figure_preparations",
    "goodness_of_fit",
    "material_constants",
    "mcmc_analysis",
    "model_comparison",
    "most_common",
    "plateau_noise",
    "preparation_of",
    "preparation_spreads",
    "representative",
    "rounded",
    "startups_of",
    "switch_startups",
    "velocity_collapse",
]


def rounded(value):
    """A load or velocity rounded to 6 significant digits (for grouping), or None."""
    if value is None:
        return None
    value = float(value)
    return float(f"{value:.6g}") if math.isfinite(value) and value != 0 else value


def most_common(values):
    """The most frequent value (ties: the first seen)."""
    counts = Counter(values)
    best = max(counts.values())
    return next(value for value in values if counts[value] == best)


@dataclass(frozen=True)
class Notes:
    """What a step of the joint stage has to say besides its value.

    Attributes
    ----------
    errors : tuple of (str, str)
        (analysis, reason) of each analysis that failed.
    warnings : tuple of str
        In the order found.
    """

    errors: tuple = ()
    warnings: tuple = ()

    def __add__(self, other):
        return Notes(self.errors + other.errors, self.warnings + other.warnings)

    @classmethod
    def warning(cls, text):
        """Notes holding one warning."""
        return cls(warnings=(text,))


def attempt(key, function):
    """``(function(), Notes())``, or ``(None, notes)`` naming the analysis ``key`` and why it
    failed (a :class:`granflow.GranflowError`); convergence warnings are silenced."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ConvergenceWarning)
            return function(), Notes()
    except GranflowError as exc:
        return None, Notes(errors=((key, str(exc)),), warnings=(f"{key.replace('_', ' ')}: {exc}",))


@dataclass(frozen=True, eq=False)
class Startup:
    """A successful start-up run: its entry, its fit window and its fit.

    Attributes
    ----------
    entry : granflow.analysis.result.RunEntry
        The run's entry (with the run's data).
    data : StartupData
        The fitted points.
    """

    entry: object
    data: StartupData

    @property
    def name(self):
        """The run's name."""
        return self.entry.name

    @property
    def run(self):
        """The run (:class:`granflow.Run`)."""
        return self.entry.run

    @property
    def fit(self):
        """The fit (:class:`granflow.FitResult`)."""
        return self.entry.result.fit

    @property
    def load(self):
        """The normal load, rounded for grouping [N] (None when not given)."""
        return rounded(self.run.normal_load)

    @property
    def velocity(self):
        """The nominal velocity, rounded for grouping [m/s]."""
        return rounded(self.run.nominal_velocity)

    @property
    def pair(self):
        """``(slip, force)`` of the fit window, for the joint fits."""
        return (self.data.slip, self.data.force)


def startups_of(entries):
    """The successful start-up runs of the campaign, in manifest order."""
    return tuple(
        Startup(entry=entry, data=startup_data(entry.run))
        for entry in entries
        if entry.test == "startup" and entry.ok
    )


def switch_startups(entries):
    """The rate-controlled part of each switch whose start-up was fitted, as a
    :class:`Startup` (its data the points before the switch), in manifest order."""
    found = []
    for entry in entries:
        if entry.test != "switch" or not entry.ok or entry.result.startup is None:
            continue
        before = entry.run.select(np.arange(len(entry.run)) < entry.result.switch.index)
        found.append(Startup(entry=entry, data=startup_data(before)))
    return tuple(found)


def representative(startups):
    """The first start-up of the largest (load, velocity) group, or None."""
    if not startups:
        return None
    largest = most_common([(s.load, s.velocity) for s in startups])
    return next(s for s in startups if (s.load, s.velocity) == largest)


def preparation_of(startup):
    """The preparation state a start-up is a repeat of, or None.

    The rule: the run's ``preparation_state`` (the manifest field naming the protocol it was
    prepared by) when given, else its ``preparation`` label; runs at one load and velocity
    with the same one are repeats of one preparation state.
    """
    meta = startup.run.meta
    state = meta.get("preparation_state")
    return str(state) if state not in (None, "") else meta.get("preparation")


# --------------------------------------------------------------------------- analyses


def velocity_collapse(startups):
    """The velocity collapse of one preparation: the runs at one load and of one preparation
    (:func:`preparation_of`) with the most distinct velocities (at least two)."""
    from granflow.fitting.joint import velocity_collapse as collapse

    groups = {}
    for startup in startups:
        groups.setdefault((startup.load, preparation_of(startup)), []).append(startup)
    best = None
    for (load, _), members in groups.items():
        distinct = len({m.velocity for m in members})
        if distinct >= 2 and (best is None or (distinct, len(members)) > best[0]):
            best = ((distinct, len(members)), load, members)
    if best is None:
        return None, Notes()
    _, load, members = best
    result, notes = attempt(
        "velocity_collapse",
        lambda: collapse(
            [m.pair for m in members], velocities=[m.run.nominal_velocity for m in members]
        ),
    )
    if result is None:
        return None, notes
    conditions = {"normal_load": load, "runs": [m.name for m in members]}
    return JointAnalysis(FrozenMap(conditions), result), notes


@dataclass(frozen=True, eq=False)
class MaterialBasis:
    """The material constants as the predictions use them.

    Attributes
    ----------
    material : Material
    constants : granflow.MaterialConstants or None
        None when not determined or out of their domain.
    covariance : numpy.ndarray or None
        3 x 3 covariance over (mu_a, mu_d, alpha).
    velocity : float or None
        The velocity of the runs they come from [m/s].
    """

    material: Material
    constants: object = None
    covariance: np.ndarray | None = None
    velocity: float | None = None


def _basis(params, stderr, ci95, covariance, source, velocity, **extra):
    """The basis of determined constants, and a warning when they are out of their domain."""
    from granflow.model.params import MaterialConstants

    estimates = {n: Estimate(params[n], stderr[n], tuple(ci95[n])) for n in MATERIAL_CONSTANTS}
    material = Material(**estimates, source=source, reason=None, velocity=velocity, **extra)
    try:
        constants = MaterialConstants(**{n: params[n] for n in MATERIAL_CONSTANTS})
    except GranflowError as exc:
        return (
            MaterialBasis(material, None, covariance, velocity),
            Notes.warning(f"material constants out of their domain: {exc}"),
        )
    return MaterialBasis(material, constants, covariance, velocity), Notes()


def material_constants(startups):
    """Amontons over loads at the most common velocity; one load: a joint fit over the load.

    Returns
    -------
    (MaterialBasis, JointAnalysis or None, str, Notes)
        The constants, the analysis they come from and its name (``"amontons"`` or
        ``"joint_fit"``), and the notes.
    """
    from granflow.fitting.joint import fit_amontons, fit_joint

    if not startups:
        return MaterialBasis(Material(reason="no start-up run could be fitted")), None, "", Notes()
    loaded = [s for s in startups if s.load is not None and s.load > 0]
    if not loaded:
        reason = "no normal load is given for the start-up runs"
        return MaterialBasis(Material(reason=reason)), None, "", Notes()
    velocity = most_common([s.velocity for s in loaded])
    chosen = [s for s in loaded if s.velocity == velocity]
    loads = sorted({s.load for s in chosen})
    names = MATERIAL_CONSTANTS
    runs = [s.name for s in chosen]
    if len(loads) >= 2:
        result, notes = attempt(
            "amontons",
            lambda: fit_amontons(
                [s.pair for s in chosen],
                normal_loads=[s.run.normal_load for s in chosen],
                velocities=[s.run.nominal_velocity for s in chosen],
            ),
        )
        if result is None:
            failed = Material(reason="the Amontons joint fit failed")
            return MaterialBasis(failed, velocity=velocity), None, "amontons", notes
        analysis = JointAnalysis(FrozenMap({"velocity": velocity, "runs": runs}), result)
        joint = result.joint
        if not joint.success:
            notes += Notes(
                errors=(("amontons", f"the Amontons joint fit failed: {joint.message}"),)
            )
            notes += Notes.warning(f"Amontons joint fit: {joint.message}")
        covariance = np.array([[joint.covar[p][q] for q in names] for p in names])
        basis, more = _basis(
            joint.params,
            joint.stderr,
            joint.ci95,
            covariance,
            "amontons joint fit",
            velocity,
            runs=len(chosen),
            normal_loads=tuple(loads),
        )
        return basis, analysis, "amontons", notes + more
    load = float(np.mean([s.run.normal_load for s in chosen]))
    result, notes = attempt(
        "joint_fit",
        lambda: fit_joint([s.pair for s in chosen], shared=("a", "alpha", "Fd"), per_run=("x0",)),
    )
    if result is None:
        failed = Material(reason="the joint fit at the single load failed")
        return MaterialBasis(failed, velocity=velocity), None, "joint_fit", notes
    conditions = {"normal_load": load, "velocity": velocity, "runs": runs}
    analysis = JointAnalysis(FrozenMap(conditions), result)
    keys = {"mu_a": "a", "mu_d": "Fd", "alpha": "alpha"}
    scale = {"mu_a": 1.0 / load, "mu_d": 1.0 / load, "alpha": 1.0}
    params = {n: result.params[keys[n]] * scale[n] for n in names}
    stderr = {n: result.stderr[keys[n]] * scale[n] for n in names}
    ci95 = {n: tuple(b * scale[n] for b in result.ci95[keys[n]]) for n in names}
    covariance = np.array(
        [[result.covar[keys[p]][keys[q]] * scale[p] * scale[q] for q in names] for p in names]
    )
    basis, more = _basis(
        params,
        stderr,
        ci95,
        covariance,
        f"joint fit at the single load {load * 1e3:.6g} mN, divided by the load",
        velocity,
        runs=len(chosen),
        normal_loads=(rounded(load),),
    )
    notes += more
    if not result.success:
        reason = f"the joint fit at one load failed: {result.message}"
        notes += Notes(errors=(("joint_fit", reason),))
        notes += Notes.warning(f"joint fit at one load: {result.message}")
    return basis, analysis, "joint_fit", notes


def _held(members):
    """x0 of each repeat with a, α and F_d held common: a joint fit of the repeats with
    ``a``, ``alpha``, ``Fd`` shared and ``x0`` per run, as a JSON-safe mapping (or None)."""
    from granflow.fitting.tied import fit_joint

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            joint = fit_joint([m.pair for m in members], shared=("a", "alpha", "Fd"))
    except GranflowError:
        return None
    starts = np.array([joint.params[f"x0_{i}"] for i in range(len(members))])
    errors = [joint.stderr.get(f"x0_{i}") for i in range(len(members))]
    mean = float(np.mean(starts))
    std = float(np.std(starts, ddof=1)) if starts.size > 1 else math.nan
    return {
        **{n: [joint.params[n], joint.stderr.get(n)] for n in ("a", "alpha", "Fd")},
        "x0": [float(v) for v in starts],
        "x0_stderr": [None if e is None else float(e) for e in errors],
        "x0_spread": {
            "mean": mean,
            "std": std,
            "relative": std / mean if mean else math.nan,
            "min": float(starts.min()),
            "max": float(starts.max()),
        },
        "redchi": joint.redchi,
        "success": bool(joint.success),
    }


def preparation_spreads(startups):
    """The spread over the repeats of each preparation state (two or more runs at one load
    and velocity with the same :func:`preparation_of`), with x0 also from a joint fit that
    holds a, α and F_d common to the repeats (``held``)."""
    from granflow.fitting.joint import preparation_spread

    groups = {}
    for startup in startups:
        key = (startup.load, startup.velocity, preparation_of(startup))
        groups.setdefault(key, []).append(startup)
    rows, notes = [], Notes()
    for (load, velocity, preparation), members in groups.items():
        if len(members) < 2:
            continue
        spread, more = attempt(
            "preparation_spread", lambda m=members: preparation_spread([s.fit for s in m])
        )
        notes += more
        if spread is not None:
            conditions = {
                "normal_load": load,
                "velocity": velocity,
                "preparation": preparation,
                "runs": [s.name for s in members],
                "held": _held(members),
            }
            rows.append(JointAnalysis(FrozenMap(conditions), spread))
    return tuple(rows), notes


def figure_preparations(startups, spreads, count=3):
    """The start-ups Fig. 2a shows: ``count`` repeats of one preparation state, those with the
    most different x0 (the smallest, the largest and the ones nearest evenly between).

    The repeats are those of the first preparation spread (manifest order) when there is one,
    else the runs at the load and velocity of :func:`representative`.
    """
    by_name = {s.name: s for s in startups}
    members = []
    for spread in spreads:
        members = [by_name[n] for n in spread.conditions.get("runs", ()) if n in by_name]
        if len(members) >= 2:
            break
    if len(members) < 2:
        chosen = representative(startups)
        if chosen is None:
            return ()
        members = [s for s in startups if (s.load, s.velocity) == (chosen.load, chosen.velocity)]
    if len(members) <= count:
        return tuple(members)
    ranked = sorted(members, key=lambda s: s.fit.params.get("x0", s.fit.params.get("t0", 0.0)))
    picks = sorted({round(i * (len(ranked) - 1) / (count - 1)) for i in range(count)})
    return tuple(ranked[i] for i in picks)


#: The plateau is the last part of a start-up's fit window (in slip) [fraction].
PLATEAU_FRACTION = 0.5
#: A normalised χ² above this marks a fit that does not reach the noise (the noise estimate
#: of a 200-point plateau is itself uncertain by about 6 %).
CHI2_LIMIT = 2.0


def plateau_noise(force):
    """The force noise [N] of a start-up from its plateau: the last
    :data:`PLATEAU_FRACTION` of the points, by successive differences
    (σ² = Σ(ΔF)² / 2(n − 1)), which the slow decay towards F_d hardly touches.

    Returns nan with fewer than 10 plateau points.
    """
    force = np.asarray(force, dtype=float)
    force = force[np.isfinite(force)]
    tail = force[int(len(force) * (1.0 - PLATEAU_FRACTION)) :]
    if tail.size < 10:
        return math.nan
    return float(np.sqrt(np.sum(np.diff(tail) ** 2) / (2.0 * (tail.size - 1))))


def goodness_of_fit(startups):
    """Each start-up fit against the noise of its own plateau.

    The normalised χ² is the fit's χ² over σ² (the plateau noise, :func:`plateau_noise`)
    per degree of freedom: about 1 when the model leaves only noise, above
    :data:`CHI2_LIMIT` when it misses the curve. A fit with a known sigma keeps its own χ²ᵣ.

    Parameters
    ----------
    startups : sequence of Startup
        The start-ups, and the rate-controlled parts of the switches (:func:`judged_fits`).

    Returns
    -------
    GoodnessOfFit or None
        None without a fit to judge.
    """
    rows = {}
    for startup in startups:
        fit = startup.fit
        dof = fit.ndata - fit.nfree
        if fit.sigma_known:
            noise, chi2 = math.nan, float(fit.redchi)
        else:
            noise = plateau_noise(startup.data.force)
            chi2 = fit.chisqr / (noise**2 * dof) if noise > 0 and dof > 0 else math.nan
        rows[startup.name] = FitJudgement(noise=noise, chi2=chi2)
    values = [row.chi2 for row in rows.values() if math.isfinite(row.chi2)]
    if not values:
        return None
    return GoodnessOfFit(
        runs=FrozenMap(rows),
        median=float(np.median(values)),
        min=float(min(values)),
        max=float(max(values)),
        limit=CHI2_LIMIT,
        poor=tuple(name for name, row in rows.items() if row.chi2 > CHI2_LIMIT),
        method=f"noise from the plateau (last {PLATEAU_FRACTION:.0%} of each fit window, "
        "successive differences); χ² per degree of freedom over that noise",
    )


def model_comparison(chosen):
    """Eq. 3 against the other models on the representative start-up (None without one)."""
    from granflow.fitting.compare import compare_models

    if chosen is None:
        return None, Notes()
    result, notes = attempt("model_comparison", lambda: compare_models(chosen.pair))
    if result is None:
        return None, notes
    return JointAnalysis(FrozenMap({"run": chosen.name}), result), notes


def mcmc_analysis(chosen, seed):
    """The posterior of the representative start-up fit (emcee, seeded)."""
    from granflow.fitting.mcmc import sample_posterior

    if chosen is None:
        return None, Notes.warning("mcmc: no start-up fit to sample")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", ConvergenceWarning)
        posterior, notes = attempt("mcmc", lambda: sample_posterior(chosen.fit, seed=seed))
    found = [f"mcmc: {w.message}" for w in caught if w.category is ConvergenceWarning]
    notes += Notes(warnings=tuple(found))
    if posterior is None:
        return None, notes
    return JointAnalysis(FrozenMap({"run": chosen.name}), posterior), notes
