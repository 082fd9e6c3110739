"""Joint fits of Eq. 3 over many runs, with parameters tied by name, and the paper's analyses.

* :func:`fit_joint` -- runs share some parameters (``alpha``), keep others per run (``x0_3``)
  or per group (``alpha_v1``);
* :func:`velocity_collapse` -- Fig. 2b: one shared curve in slip against per-velocity a and
  alpha, with a likelihood-ratio test of "a and alpha do not depend on the velocity";
* :func:`fit_amontons` -- Fig. 2c: a = mu_a F_N and Fd = mu_d F_N with alpha shared, plus the
  per-load summary of repeats and lines through the origin;
* :func:`preparation_spread` -- the spread of x0 (t0) over repeats, its correlation with the
  peak force, and the spread of Fd.

Every run is fitted alone first (no initial guess needed); those fits start the joint fit
(:mod:`granflow.fitting.tied`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
from scipy.stats import chi2 as chi2_distribution
from scipy.stats import pearsonr
from scipy.stats import t as student

from granflow._html import HtmlReport
from granflow.errors import InvalidParameterError
from granflow.fitting.amontons_test import AmontonsTest, amontons_test
from granflow.fitting.results import (
    FrozenMap,
    ValueEquality,
    decode,
    encode,
    intervals,
    number,
    numbers,
)
from granflow.fitting.single import FitResult, fit
from granflow.fitting.tied import (
    JointFitResult,
    JointSpec,
    fit_joint,
    individual_fits,
    run_names,
    solve_joint,
)
from granflow.model.friction import peak
from granflow.model.run import Run

if TYPE_CHECKING:
    from granflow._typing import ArrayLike

__all__ = [
    "AmontonsResult",
    "CollapseResult",
    "JointFitResult",
    "PreparationSpread",
    "fit_amontons",
    "fit_joint",
    "preparation_spread",
    "velocity_collapse",
]

# --------------------------------------------------------------------------- velocity collapse


@dataclass(frozen=True, eq=False)
class CollapseResult(HtmlReport, ValueEquality):
    """Velocity collapse (Fig. 2b): shared fit, per-velocity fit and a likelihood-ratio test.

    Attributes
    ----------
    velocities : tuple of float
        The distinct velocities [m/s]; group ``v<i>`` is ``velocities[i]``.
    shared : JointFitResult
        a, alpha, Fd shared by every run; x0 per run.
    per_velocity : JointFitResult
        a and alpha per velocity (``a_v0``, ``alpha_v0``, ...), Fd shared, x0 per run.
    statistic : float
        Likelihood-ratio statistic: ``n ln(chi2_shared / chi2_per_velocity)`` (noise
        estimated) or ``chi2_shared - chi2_per_velocity`` (known sigma).
    df : int
        Degrees of freedom, 2 (number of velocities - 1).
    p_value : float
        Chance of a statistic this large if a and alpha do not depend on the velocity.
    collapses : bool
        True when the test does not reject the collapse at the 5 % level.
    """

    velocities: tuple
    shared: JointFitResult
    per_velocity: JointFitResult
    statistic: float
    df: int
    p_value: float
    collapses: bool

    def __repr__(self):
        verdict = "collapses" if self.collapses else "does not collapse"
        return f"CollapseResult({len(self.velocities)} velocities, {verdict}, p={self.p_value:.3g})"

    def report(self) -> str:
        """Summary of the test, then the per-velocity values."""
        lines = [
            "[[Velocity collapse]]",
            f"    velocities    = {', '.join(f'{v * 1e6:.4g}' for v in self.velocities)} µm/s",
            f"    LR statistic  = {self.statistic:.4g} (df = {self.df})",
            f"    p-value       = {self.p_value:.4g}",
            f"    collapse      = {'not rejected' if self.collapses else 'rejected'} at 5 %",
        ]
        for i, v in enumerate(self.velocities):
            p, e = self.per_velocity.params, self.per_velocity.stderr
            lines.append(
                f"    v = {v * 1e6:.4g} µm/s: a = {p[f'a_v{i}']:.5g} +/- {e[f'a_v{i}']:.2g} N, "
                f"alpha = {p[f'alpha_v{i}']:.5g} +/- {e[f'alpha_v{i}']:.2g} 1/m"
            )
        return "\n".join(lines)

    def to_dict(self, include_arrays: bool = True) -> dict[str, Any]:
        """JSON-safe mapping; :meth:`from_dict` inverts it.

        Parameters
        ----------
        include_arrays : bool
            Include the per-point arrays of the fits it holds (False: a compact summary,
            which :meth:`from_dict` rebuilds with empty arrays).
        """
        return encode(
            {
                "velocities": list(self.velocities),
                "shared": self.shared.to_dict(include_arrays=include_arrays),
                "per_velocity": self.per_velocity.to_dict(include_arrays=include_arrays),
                "statistic": self.statistic,
                "df": self.df,
                "p_value": self.p_value,
                "collapses": self.collapses,
            }
        )

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> CollapseResult:
        """The result a :meth:`to_dict` output (or its JSON) describes."""
        d = decode(d, cls)
        return cls(
            velocities=tuple(number(v) for v in d["velocities"]),
            shared=JointFitResult.from_dict(d["shared"]),
            per_velocity=JointFitResult.from_dict(d["per_velocity"]),
            statistic=number(d["statistic"]),
            df=d["df"],
            p_value=number(d["p_value"]),
            collapses=d["collapses"],
        )


def _likelihood_ratio(null, alternative):
    if null.sigma_known:
        return max(null.chisqr - alternative.chisqr, 0.0)
    return max(null.ndata * math.log(null.chisqr / alternative.chisqr), 0.0)


def velocity_collapse(
    datasets: Sequence[Any],
    velocities: Sequence[float] | None = None,
    *,
    sigma: float | None = None,
    window: tuple[float, float] | None = None,
) -> CollapseResult:
    """Test whether runs at several velocities follow one curve in slip (Fig. 2b).

    Parameters
    ----------
    datasets : sequence
        Runs or ``(slip, force)`` pairs (slip domain).
    velocities : sequence of float, optional
        The velocity of each run [m/s]; default each Run's ``nominal_velocity``.
    sigma : float, optional
        Known noise [N].
    window : (float, float), optional
        Fit window in slip [m].

    Returns
    -------
    CollapseResult
    """
    datasets = list(datasets)
    if velocities is None:
        if not all(isinstance(d, Run) for d in datasets):
            raise InvalidParameterError("give velocities, or Runs with a nominal velocity")
        velocities = [d.nominal_velocity for d in datasets]
    if len(velocities) != len(datasets):
        raise InvalidParameterError(
            f"velocities has {len(velocities)} values for {len(datasets)} runs"
        )
    distinct = sorted({float(v) for v in velocities})
    if len(distinct) < 2:
        raise InvalidParameterError("velocity_collapse needs runs at two velocities or more")
    labels = [f"v{distinct.index(float(v))}" for v in velocities]
    null = fit_joint(datasets, sigma=sigma, window=window)
    alternative = fit_joint(
        datasets,
        shared=("Fd",),
        per_group=("a", "alpha"),
        per_run=("x0",),
        groups=labels,
        sigma=sigma,
        window=window,
    )
    statistic = _likelihood_ratio(null, alternative)
    df = 2 * (len(distinct) - 1)
    p_value = float(chi2_distribution.sf(statistic, df))
    return CollapseResult(
        velocities=tuple(distinct),
        shared=null,
        per_velocity=alternative,
        statistic=float(statistic),
        df=df,
        p_value=p_value,
        collapses=p_value >= 0.05,
    )


# --------------------------------------------------------------------------- Amontons


@dataclass(frozen=True, eq=False)
class AmontonsResult(HtmlReport, ValueEquality):
    """Amontons' law over normal loads (Fig. 2c).

    Attributes
    ----------
    joint : JointFitResult
        ``mu_a``, ``mu_d`` [-] and ``alpha`` shared, ``x0_<i>`` per run.
    per_load : tuple of mapping
        Per distinct load: ``normal_load`` [N], ``repeats``, and the mean and standard error
        over the repeats' separate fits of ``a`` [N], ``alpha`` [1/m], ``alpha_v`` [1/s]
        (when velocities are known, else None) and ``Fd`` [N].
    lines : mapping
        Lines through the origin of the separate fits' ``"a"`` and ``"Fd"`` against the load:
        each maps to (slope, standard error), i.e. mu_a and mu_d [-] with uncertainties.
    lines_ci95 : mapping
        ``"a"`` and ``"Fd"`` to the 95 % interval of the slope: slope +/- t * stderr with
        Student's t at the line's degrees of freedom (runs - 1), wider than +/- 1.96 stderr.
    test : AmontonsTest or None
        The test of the law on the per-load means (``test.statistic``, ``test.p_value``,
        ``test.holds``, each relation in ``test.relations``;
        :func:`granflow.fitting.amontons_test.amontons_test`); None with fewer than three
        loads with repeats.

    The lines are least squares through the origin over every run (each repeat a point, so a
    load's mean weighs by its repeats), and their standard error comes from the scatter of
    the runs about the line, s^2 = sum (y - slope F_N)^2 / (runs - 1): it holds both the
    scatter of the repeats and any departure of the loads' means from a line, and it needs no
    per-load weights, which from a few repeats are too uncertain to use (inverse variances
    from 3 repeats make the intervals hold the truth in only about 3 of 4 campaigns).
    """

    joint: JointFitResult
    per_load: tuple
    lines: FrozenMap
    lines_ci95: FrozenMap = field(default_factory=FrozenMap)
    test: AmontonsTest | None = None

    def __repr__(self):
        slopes = ", ".join(f"{key}={slope:.4g}*F_N" for key, (slope, _) in self.lines.items())
        return f"AmontonsResult({len(self.per_load)} loads, {slopes})"

    def report(self) -> str:
        """The per-load table and the lines through the origin."""
        lines = ["[[Amontons]]", self.joint.report(), "[[Per load: mean +/- standard error]]"]
        for row in self.per_load:
            lines.append(
                f"    F_N = {row['normal_load'] * 1e3:.4g} mN (n = {row['repeats']}): "
                f"a = {row['a'][0] * 1e3:.4g} +/- {row['a'][1] * 1e3:.2g} mN, "
                f"alpha = {row['alpha'][0]:.4g} +/- {row['alpha'][1]:.2g} 1/m, "
                f"Fd = {row['Fd'][0] * 1e3:.4g} +/- {row['Fd'][1] * 1e3:.2g} mN"
            )
        for key, (slope, error) in self.lines.items():
            low, high = self.lines_ci95.get(key, (math.nan, math.nan))
            lines.append(
                f"    {key} = ({slope:.5g} +/- {error:.2g}) F_N  95%: [{low:.5g}, {high:.5g}]"
            )
        if self.test is not None:
            verdict = "holds" if self.test.holds else "rejected"
            lines.append(f"[[Test of the law: {verdict} at the 5 % level]]")
            for relation in self.test.relations:
                lines.append(
                    f"    {relation.name} = chi2 {relation.statistic:.3g} with {relation.df} "
                    f"d.o.f., p = {relation.p_value:.2g}"
                )
            lines.append(f"    p (Bonferroni, 3 relations) = {self.test.p_value:.2g}")
        return "\n".join(lines)

    def to_dict(self, include_arrays: bool = True) -> dict[str, Any]:
        """JSON-safe mapping; :meth:`from_dict` inverts it.

        Parameters
        ----------
        include_arrays : bool
            Include the per-point arrays of the fits it holds (False: a compact summary,
            which :meth:`from_dict` rebuilds with empty arrays).
        """
        return encode(
            {
                "joint": self.joint.to_dict(include_arrays=include_arrays),
                "per_load": [dict(row) for row in self.per_load],
                "lines": {k: list(v) for k, v in self.lines.items()},
                "lines_ci95": {k: list(v) for k, v in self.lines_ci95.items()},
                "test": None if self.test is None else self.test.to_dict(),
            }
        )

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> AmontonsResult:
        """The result a :meth:`to_dict` output (or its JSON) describes."""
        d = decode(d, cls)
        per_load = []
        for row in d["per_load"]:
            per_load.append(FrozenMap({key: _load_entry(key, value) for key, value in row.items()}))
        return cls(
            joint=JointFitResult.from_dict(d["joint"]),
            per_load=tuple(per_load),
            lines=intervals(d["lines"]),
            lines_ci95=intervals(d.get("lines_ci95", {})),
            test=None if d.get("test") is None else AmontonsTest.from_dict(d["test"]),
        )


def _load_entry(key, value):
    """One entry of a per-load row read back from JSON."""
    if key == "repeats" or value is None:
        return value
    if key == "normal_load":
        return number(value)
    return tuple(number(v) for v in value)


def _mean_and_error(values):
    values = np.asarray(values, dtype=float)
    if values.size < 2:
        return (float(values.mean()), math.nan)
    return (float(values.mean()), float(values.std(ddof=1) / math.sqrt(values.size)))


def _line_through_origin(loads, values):
    """Least-squares slope through the origin of every run's value against its load, its
    standard error from the runs' scatter about the line and its 95 % Student-t interval
    (see :class:`AmontonsResult`): ``((slope, stderr), (low, high))``."""
    loads, values = np.asarray(loads, dtype=float), np.asarray(values, dtype=float)
    moment = float(np.sum(loads**2))
    slope = float(np.sum(loads * values) / moment)
    dof = loads.size - 1
    if dof < 1:
        return (slope, math.nan), (math.nan, math.nan)
    variance = float(np.sum((values - slope * loads) ** 2)) / dof
    error = math.sqrt(variance / moment)
    half = float(student.ppf(0.975, dof)) * error
    return (slope, error), (slope - half, slope + half)


def fit_amontons(
    datasets: Sequence[Any],
    normal_loads: Sequence[float] | None = None,
    *,
    velocities: Sequence[float] | None = None,
    sigma: float | None = None,
    window: tuple[float, float] | None = None,
) -> AmontonsResult:
    """Joint fit with a = mu_a F_N and Fd = mu_d F_N, alpha shared, x0 per run (Fig. 2c).

    Parameters
    ----------
    datasets : sequence
        Runs or ``(slip, force)`` pairs (slip domain).
    normal_loads : sequence of float, optional
        Normal load of each run [N]; default each Run's ``normal_load``.
    velocities : sequence of float, optional
        Velocity of each run [m/s], for the per-load alpha v; default the Runs' nominal
        velocity when there is one.
    sigma : float, optional
        Known noise [N].
    window : (float, float), optional
        Fit window in slip [m].

    Returns
    -------
    AmontonsResult
    """
    datasets = list(datasets)
    if normal_loads is None:
        if not all(isinstance(d, Run) and d.normal_load for d in datasets):
            raise InvalidParameterError("give normal_loads, or Runs with a normal_load")
        normal_loads = [d.normal_load for d in datasets]
    if len(normal_loads) != len(datasets):
        raise InvalidParameterError(
            f"normal_loads has {len(normal_loads)} values for {len(datasets)} runs"
        )
    loads = [float(v) for v in normal_loads]
    if any(not (v > 0 and math.isfinite(v)) for v in loads):
        raise InvalidParameterError("normal loads must be positive and finite")
    if velocities is None and all(isinstance(d, Run) for d in datasets):
        velocities = [d.nominal_velocity for d in datasets]
    prepared, fits = individual_fits(datasets, "slip", sigma, window)
    spec = JointSpec(globals={}, links=[])
    spec.globals["mu_a"] = (
        0,
        float(np.median([f.params["a"] / F for f, F in zip(fits, loads, strict=True)])),
    )
    spec.globals["alpha"] = (1, float(np.median([f.params["alpha"] for f in fits])))
    spec.globals["mu_d"] = (
        2,
        float(np.median([f.params["Fd"] / F for f, F in zip(fits, loads, strict=True)])),
    )
    order = ["mu_a", "alpha", "mu_d"]
    for index, (result, load) in enumerate(zip(fits, loads, strict=True)):
        spec.globals[f"x0_{index}"] = (3, result.params["x0"])
        order.append(f"x0_{index}")
        spec.links.append((("mu_a", load), ("alpha", 1.0), ("mu_d", load), (f"x0_{index}", 1.0)))
    fields = solve_joint(spec, prepared, fits, "slip", {}, sigma is not None, order)
    joint = JointFitResult(run_names=run_names(datasets, fits), **fields)
    per_load = []
    for load in sorted(set(loads)):
        members = [i for i, v in enumerate(loads) if v == load]
        row = {"normal_load": load, "repeats": len(members)}
        for key in ("a", "alpha", "Fd"):
            row[key] = _mean_and_error([fits[i].params[key] for i in members])
        if velocities is not None and all(velocities[i] for i in members):
            row["alpha_v"] = _mean_and_error(
                [fits[i].params["alpha"] * velocities[i] for i in members]
            )
        else:
            row["alpha_v"] = None
        per_load.append(FrozenMap(row))
    lines, lines_ci95 = {}, {}
    for key in ("a", "Fd"):
        lines[key], lines_ci95[key] = _line_through_origin(loads, [fit.params[key] for fit in fits])
    return AmontonsResult(
        joint=joint,
        per_load=tuple(per_load),
        lines=FrozenMap(lines),
        lines_ci95=FrozenMap(lines_ci95),
        test=amontons_test(per_load),
    )


# --------------------------------------------------------------------------- preparation


@dataclass(frozen=True, eq=False)
class PreparationSpread(HtmlReport, ValueEquality):
    """How repeats with nominally identical preparation differ.

    Attributes
    ----------
    domain : {"slip", "time"}
    repeats : int
    start : mapping
        Statistics of x0 [m] (or t0 [s]): ``mean``, ``std``, ``min``, ``max``, ``relative``
        (std / mean).
    Fd : mapping
        The same for Fd [N].
    peak_force : tuple of float
        Model peak force of each repeat [N].
    correlation : float
        Pearson correlation of x0 (t0) with the peak force.
    p_value : float
        Two-sided p-value of that correlation (nan with fewer than three repeats).
    """

    domain: str
    repeats: int
    start: FrozenMap
    Fd: FrozenMap
    peak_force: tuple
    correlation: float
    p_value: float

    def __repr__(self):
        name = "x0" if self.domain == "slip" else "t0"
        return (
            f"PreparationSpread({self.repeats} repeats, {name} std/mean = "
            f"{self.start['relative']:.3g}, corr({name}, peak force) = {self.correlation:+.3f})"
        )

    def report(self) -> str:
        """A short text summary."""
        name = "x0" if self.domain == "slip" else "t0"
        return "\n".join(
            [
                f"[[Preparation spread over {self.repeats} repeats]]",
                f"    {name}: mean {self.start['mean']:.4g}, std {self.start['std']:.3g} "
                f"({100 * self.start['relative']:.1f} %), range [{self.start['min']:.4g}, "
                f"{self.start['max']:.4g}]",
                f"    Fd: mean {self.Fd['mean']:.5g} N, std {self.Fd['std']:.3g} N "
                f"({100 * self.Fd['relative']:.2f} %)",
                f"    corr({name}, peak force) = {self.correlation:+.3f} (p = {self.p_value:.3g})",
            ]
        )

    def to_dict(self, include_arrays: bool = True) -> dict[str, Any]:
        """JSON-safe mapping; :meth:`from_dict` inverts it.

        Parameters
        ----------
        include_arrays : bool
            Accepted for every result alike; the spread holds no per-point arrays, so both
            forms are the same.
        """
        return encode(
            {
                "domain": self.domain,
                "repeats": self.repeats,
                "start": dict(self.start),
                "Fd": dict(self.Fd),
                "peak_force": list(self.peak_force),
                "correlation": self.correlation,
                "p_value": self.p_value,
            }
        )

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> PreparationSpread:
        """The result a :meth:`to_dict` output (or its JSON) describes."""
        d = decode(d, cls)
        return cls(
            domain=d["domain"],
            repeats=d["repeats"],
            start=numbers(d["start"]),
            Fd=numbers(d["Fd"]),
            peak_force=tuple(number(v) for v in d["peak_force"]),
            correlation=number(d["correlation"]),
            p_value=number(d["p_value"]),
        )


def _spread(values):
    values = np.asarray(values, dtype=float)
    mean = float(values.mean())
    std = float(values.std(ddof=1)) if values.size > 1 else 0.0
    return FrozenMap(
        {
            "mean": mean,
            "std": std,
            "min": float(values.min()),
            "max": float(values.max()),
            "relative": std / mean if mean else math.nan,
        }
    )


def preparation_spread(
    results: Sequence[FitResult | Run | tuple[ArrayLike, ArrayLike]], *, domain: str = "slip"
) -> PreparationSpread:
    """Spread of x0 (t0) and Fd over repeats, and how x0 correlates with the peak force.

    Parameters
    ----------
    results : sequence of FitResult, Run or (x, force)
        Fits of the repeats, or data to fit (with :func:`granflow.fit` in ``domain``).
    domain : {"slip", "time"}
        Used when data (not fits) are given.

    Returns
    -------
    PreparationSpread
    """
    fits = [r if isinstance(r, FitResult) else fit(r, domain=domain) for r in results]
    if len(fits) < 2:
        raise InvalidParameterError("preparation_spread needs at least two repeats")
    domains = {f.domain for f in fits}
    if len(domains) > 1:
        raise InvalidParameterError("the fits mix slip and time domains")
    domain = domains.pop()
    start_name = "x0" if domain == "slip" else "t0"
    peaks = []
    for result in fits:
        values = [result.params[n] for n in result.names]
        # the time domain is the slip domain with x -> t, so its peak has the same force
        peaks.append(peak(_unit_params(values)).force)
    starts = [f.params[start_name] for f in fits]
    if len(fits) >= 3 and np.std(starts) > 0 and np.std(peaks) > 0:
        correlation, p_value = pearsonr(starts, peaks)
    else:
        correlation, p_value = math.nan, math.nan
    return PreparationSpread(
        domain=domain,
        repeats=len(fits),
        start=_spread(starts),
        Fd=_spread([f.params["Fd"] for f in fits]),
        peak_force=tuple(float(p) for p in peaks),
        correlation=float(correlation),
        p_value=float(p_value),
    )


def _unit_params(values):
    from granflow.model.params import Params

    return Params(*values)
