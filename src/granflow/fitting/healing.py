r"""Friction healing in slide-hold-slide records: the peak on re-sliding against the hold time.

:func:`healing` measures, for each hold of a record
(:class:`~granflow.io.slide_hold_slide.SlideHoldSlideRecord`), the peak friction on
re-sliding above the steady friction before the hold, Δμ_peak, and fits the healing rate
β = dΔμ_peak / d log10 t_h by least squares with its 95 % interval.

What the models predict
-----------------------
**Rate-and-state, aging law** (Dieterich): at rest the state grows as time,
θ(t_h) = Dc/v + t_h, so a slider that re-slides at v before it slips much peaks at
Δμ_peak ≈ b ln(1 + t_h/t_c) with t_c = Dc/v (:func:`aging_law_healing`): for t_h ≫ t_c,
β = b ln 10 per decade. Creep of the slider during the hold (a compliant machine) lowers it.
**Slip law** (Ruina): at rest nothing evolves (dθ/dt = 0 at v = 0); it heals only by the
slip of the creeping slider during the hold, much less.

**The paper's model** (Farain & Bonn, Eq. 1 and 2). Its aging term is a/t, with t the time
since the sample was prepared (Eq. 1: F grows as a ln(t/τ) at rest); shear only pulls F back
towards F_d (the rejuvenation α v (F − F_d)); it does not reset t. Under the *time clock* a hold
that starts at the sample's age t_s (F = F_s, the friction just before it) integrates
dF/dt = a/t to F(t_s + t_h) = F_s + a ln(1 + t_h/t_s). On re-sliding, with the drive imposing v
on the layer (the paper's rate control, no machine spring), dF/dt = a/(t_s + t_h) − αv(F − F_d)
is negative at once (F − F_d ≥ a ln(1 + t_h/t_s) > 0 and a/(t_s + t_h) < a/t_s ≤ the pull of
the steady state), so the peak is the friction at the re-slide's onset:

    ΔF_peak = a ln(1 + t_h/t_s),    Δμ_peak = μ_a ln(1 + t_h/t_s),   μ_a = a/F_N

(:func:`paper_healing`). It is logarithmic in the hold time only for holds longer than the
sample's age, with β = μ_a ln 10 per decade there; for holds shorter than the age it is linear,
Δμ_peak ≈ μ_a t_h/t_s, and its local rate is β(t_h) = μ_a ln 10 · t_h/(t_s + t_h)
(:func:`paper_beta`). Where rate-and-state's cut-off t_c = Dc/v is set by the sliding, the
paper's t_s is the sample's whole age: an old sample heals little in a hold of minutes, which
is what the paper observed (Fig. S1: no change of the overshoot over rests of minutes). Under
the *slip clock* (the default reading of :mod:`granflow.simulation`) nothing evolves at rest
and Δμ_peak = 0. :func:`healing` also fits the time-clock prediction to the measured peaks
(``paper_mu_a`` and ``paper_age``, the sample's age at the record's start), each hold
starting at its own age.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from granflow._codec import Codec
from granflow.errors import InvalidDataError, InvalidParameterError

__all__ = [
    "HealingResult",
    "aging_law_healing",
    "healing",
    "model_healing",
    "paper_beta",
    "paper_healing",
    "scatter",
]

#: A peak is located by a parabola through the points within this share of its height.
TOP_SHARE = 0.05
_LN10 = math.log(10.0)


def paper_healing(hold_times: Any, mu_a: float, age: Any) -> np.ndarray:
    """The paper's time-clock prediction: Δμ_peak = μ_a ln(1 + t_h / t_s).

    Parameters
    ----------
    hold_times : array_like
        Hold times t_h [s].
    mu_a : float
        Aging amplitude over the normal load, a / F_N [-].
    age : float or array_like
        The sample's age at each hold's start, t_s [s] (time since its preparation); positive.

    Returns
    -------
    numpy.ndarray
        Δμ_peak [-].

    Examples
    --------
    >>> float(paper_healing(1000.0, 0.06, 1000.0)) == 0.06 * math.log(2.0)
    True
    """
    t_h = np.asarray(hold_times, dtype=float)
    t_s = np.asarray(age, dtype=float)
    if np.any(~(t_s > 0)):
        raise InvalidParameterError("age must be positive [s]")
    return mu_a * np.log1p(t_h / t_s)


def paper_beta(hold_times: Any, mu_a: float, age: Any) -> np.ndarray:
    """The local healing rate of :func:`paper_healing`, dΔμ_peak/d log10 t_h [-/decade]:
    μ_a ln 10 · t_h / (t_s + t_h), which tends to μ_a ln 10 for holds longer than the age."""
    t_h = np.asarray(hold_times, dtype=float)
    return mu_a * _LN10 * t_h / (np.asarray(age, dtype=float) + t_h)


def aging_law_healing(hold_times: Any, b: float, cutoff: float) -> np.ndarray:
    """Rate-and-state's aging law on a rigid machine: Δμ_peak = b ln(1 + t_h / t_c) [-],
    with the cut-off t_c = Dc / v [s] (β = b ln 10 per decade for t_h ≫ t_c)."""
    return b * np.log1p(np.asarray(hold_times, dtype=float) / cutoff)


@dataclass(frozen=True, eq=False)
class HealingResult(Codec):
    """The healing of a slide-hold-slide record.

    Attributes
    ----------
    hold_times : tuple of float
        Each hold's duration t_h [s].
    delta_mu_peak : tuple of float
        Peak friction on re-sliding minus the steady friction before the hold [-].
    steady_friction : tuple of float
        The mean friction over the window's steady sliding before each hold [-].
    peak_times : tuple of float
        When each peak is reached [s].
    beta, beta_stderr : float
        The healing rate dΔμ_peak / d log10 t_h [-/decade] and its standard error.
    beta_ci95 : (float, float)
        Its 95 % interval: β ± t(0.975, n − 2) × stderr (Student t on the straight line's
        residuals; NaN with fewer than three holds).
    intercept : float
        Δμ_peak of the line at t_h = 1 s [-].
    paper_mu_a : float
        The paper's time-clock prediction fitted to the peaks: μ_a = a / F_N [-] ...
    paper_age : float
        ... and the sample's age at the record's start [s] (:func:`paper_healing`, each hold
        at the age ``paper_age + hold start``).
    hold_starts : tuple of float
        Each hold's start [s].
    source : str
        The record's file, where known.
    """

    hold_times: tuple[float, ...]
    delta_mu_peak: tuple[float, ...]
    steady_friction: tuple[float, ...]
    peak_times: tuple[float, ...]
    beta: float
    beta_stderr: float
    beta_ci95: tuple[float, ...]
    intercept: float
    paper_mu_a: float
    paper_age: float
    hold_starts: tuple[float, ...] = ()
    source: str = ""

    method: ClassVar[str] = (
        "ordinary least squares of Δμ_peak on log10 t_h; 95 % interval from Student's t"
    )
    JSON_EXTRA: ClassVar[Mapping[str, Any]] = {"method": method}

    def __repr__(self) -> str:
        return f"HealingResult({len(self.hold_times)} holds, beta={self.beta:.4g}/decade)"

    def summary(self) -> str:
        """One line: the healing rate with its interval, and the holds."""
        low, high = self.beta_ci95
        return (
            f"healing: beta = {self.beta:.4g} per decade of hold time (95 %: {low:.4g} .. "
            f"{high:.4g}) over {len(self.hold_times)} holds of {min(self.hold_times):.3g} .. "
            f"{max(self.hold_times):.3g} s"
        )

    def paper_prediction(self, hold_times: Any = None, hold_starts: Any = None) -> np.ndarray:
        """The fitted time-clock prediction of the paper at ``hold_times`` [s] (default the
        record's), each hold starting at ``hold_starts`` [s, record time; default the
        record's, or the last hold's start for other hold times]."""
        t_h = np.asarray(self.hold_times if hold_times is None else hold_times, dtype=float)
        if hold_starts is None:
            starts = self.hold_starts if hold_times is None else self.hold_starts[-1:]
            hold_starts = np.asarray(starts, dtype=float)
        return paper_healing(t_h, self.paper_mu_a, self.paper_age + np.asarray(hold_starts))


def scatter(friction: np.ndarray) -> float:
    """The point-to-point noise of a friction record [-]: 1.4826 × the median absolute
    deviation of its first differences, over √2."""
    steps = np.diff(friction)
    if steps.size < 2:
        return 0.0
    return float(1.4826 * np.median(np.abs(steps - np.median(steps))) / math.sqrt(2.0))


def _peak(t, friction, steady, noise):
    """(time, value) of the friction peak of a re-slide: the vertex of the parabola through
    the points around the highest one that lie within ``TOP_SHARE`` of the peak's height above
    ``steady`` (or three times the ``noise``, if more) below it, at least two on either side;
    the highest point itself where the parabola does not open downwards or its vertex lies
    outside those points."""
    top = int(np.argmax(friction))
    depth = max(TOP_SHARE * (friction[top] - steady), 3.0 * noise)
    low = friction >= friction[top] - depth
    lo, hi = top, top + 1
    while lo > 0 and low[lo - 1]:
        lo -= 1
    while hi < t.size and low[hi]:
        hi += 1
    lo, hi = max(min(lo, top - 2), 0), min(max(hi, top + 3), t.size)
    if hi - lo >= 5:
        centre = t[top]
        c2, c1, c0 = np.polyfit(t[lo:hi] - centre, friction[lo:hi], 2)
        if c2 < 0:
            vertex = -c1 / (2 * c2)
            if t[lo] - centre <= vertex <= t[hi - 1] - centre:
                return float(centre + vertex), float(c0 - c1 * c1 / (4 * c2))
    return float(t[top]), float(friction[top])


def _line_fit(x, y):
    """(slope, stderr, (low, high), intercept) of y on x by least squares, Student t."""
    from scipy import stats

    n = x.size
    xm = x.mean()
    sxx = float(np.sum((x - xm) ** 2))
    if n < 2 or sxx <= 0:
        raise InvalidDataError("healing needs holds of at least two different durations")
    slope = float(np.sum((x - xm) * (y - y.mean())) / sxx)
    intercept = float(y.mean() - slope * xm)
    if n < 3:
        return slope, math.nan, (math.nan, math.nan), intercept
    residual = y - (intercept + slope * x)
    stderr = math.sqrt(float(residual @ residual) / (n - 2) / sxx)
    half = float(stats.t.ppf(0.975, n - 2)) * stderr
    return slope, stderr, (slope - half, slope + half), intercept


def _paper_fit(hold_times, hold_starts, delta):
    """(μ_a, age at the record's start [s]) of :func:`paper_healing` by least squares: μ_a
    linear for each age, the age searched over 1e-3 .. 1e9 s in log10."""
    from scipy.optimize import minimize_scalar

    def solve(log_age):
        shape = np.log1p(hold_times / (10.0**log_age + hold_starts))
        mu_a = float(shape @ delta / (shape @ shape))
        return mu_a, float(np.sum((delta - mu_a * shape) ** 2))

    grid = np.linspace(-3.0, 9.0, 49)
    best = grid[int(np.argmin([solve(g)[1] for g in grid]))]
    found = minimize_scalar(
        lambda g: solve(g)[1],
        bounds=(max(best - 0.25, -3.0), min(best + 0.25, 9.0)),
        method="bounded",
    )
    return solve(found.x)[0], float(10.0**found.x)


def healing(record: Any) -> HealingResult:
    """Healing of a slide-hold-slide record: Δμ_peak per hold and β = dΔμ_peak/d log10 t_h.

    For each hold, the steady friction is the mean friction from the start of its fit
    window (the last quarter of the slide before it) to the hold's start; the peak is the
    highest friction of the re-slide (from the hold's end to the next hold or the record's
    end), refined by the vertex of a parabola through the points around it within 5 % of the
    peak's height (or three times the record's point-to-point scatter, :func:`scatter`, if
    more) below it, so that noise biases it less than the highest point does. β is the slope
    of the least-squares
    line of Δμ_peak against log10 t_h; its 95 % interval is β ± t(0.975, n − 2) × its standard
    error from the line's residuals (n holds), so a curved healing law widens it.

    Parameters
    ----------
    record : SlideHoldSlideRecord
        A record of :func:`granflow.rsf.read_slide_hold_slide`.

    Returns
    -------
    HealingResult

    Examples
    --------
    >>> from granflow import rsf
    >>> h = rsf.healing(rsf.read_slide_hold_slide("shs.txt"))  # doctest: +SKIP
    >>> h.beta, h.beta_ci95  # doctest: +SKIP
    """
    for name in ("t", "friction", "hold_starts", "hold_ends", "windows"):
        if not hasattr(record, name):
            raise InvalidParameterError(
                f"record must be a slide-hold-slide record (rsf.read_slide_hold_slide), "
                f"got {type(record).__name__} without {name!r}"
            )
    t = np.asarray(record.t, dtype=float)
    friction = np.asarray(record.friction, dtype=float)
    starts, ends = list(record.hold_starts), list(record.hold_ends)
    steady, peaks, times = [], [], []
    noise = scatter(friction)
    for index, (start, end) in enumerate(zip(starts, ends, strict=True)):
        before = (t >= record.windows[index][0]) & (t < start)
        stop = starts[index + 1] if index + 1 < len(starts) else t[-1]
        after = (t > end) & (t <= stop)
        if before.sum() < 2 or after.sum() < 2:
            raise InvalidDataError(
                f"hold {index + 1} (from {start:g} s): too few points of sliding before or after it"
            )
        steady.append(float(friction[before].mean()))
        peak_time, peak = _peak(t[after], friction[after], steady[-1], noise)
        times.append(peak_time)
        peaks.append(peak)
    hold_times = np.array(ends) - np.array(starts)
    delta = np.array(peaks) - np.array(steady)
    beta, stderr, ci95, intercept = _line_fit(np.log10(hold_times), delta)
    mu_a, age = _paper_fit(hold_times, np.array(starts), delta)
    return HealingResult(
        hold_times=tuple(float(h) for h in hold_times),
        delta_mu_peak=tuple(float(d) for d in delta),
        steady_friction=tuple(steady),
        peak_times=tuple(times),
        beta=beta,
        beta_stderr=stderr,
        beta_ci95=ci95,
        intercept=intercept,
        paper_mu_a=mu_a,
        paper_age=age,
        hold_starts=tuple(float(s) for s in starts),
        source=str(getattr(record, "meta", {}).get("source", "")),
    )


def model_healing(
    fit: Any,
    hold_times: Sequence[float],
    *,
    velocity: float,
    slide: float | None = None,
    points: int = 400,
) -> np.ndarray:
    """Δμ_peak of a fitted rate-and-state slider at ``hold_times``: each hold simulated
    (:func:`granflow.rsf.simulate`) from steady sliding at ``velocity`` and re-slid over
    ``slide`` [m] (default 10 Dc beyond twice the elastic loading of the largest healing,
    2 b ln(1 + v t_h / Dc) / k), the peak taken as in :func:`healing`.

    Parameters
    ----------
    fit : RateStateFitResult
        A fit of :func:`granflow.rsf.fit` (one state; ``a``, ``b``, ``Dc``, ``stiffness``).
    hold_times : sequence of float
        Hold times [s].
    velocity : float
        Sliding velocity before and after the hold [m/s].
    slide : float, optional
        The re-slide's length [m].
    points : int
        Output points of the re-slide.

    Returns
    -------
    numpy.ndarray
        Δμ_peak [-] per hold time.
    """
    from granflow.simulation.protocol import Protocol
    from granflow.simulation.rsf.model import RateState, State
    from granflow.simulation.rsf.simulate import simulate
    from granflow.simulation.segments import Hold, Velocity

    params = fit.params
    if len(fit.laws) != 1 or any(name not in params for name in ("a", "b", "Dc", "stiffness")):
        raise InvalidParameterError(
            "fit must be a one-state rate-and-state fit with a, b, Dc and stiffness"
        )
    law = fit.laws[0]
    model = RateState(
        0.0, params["a"], velocity, params["stiffness"], [State(params["b"], params["Dc"], law)]
    )
    if slide is None:  # past the peak: the elastic loading of the largest healing, then 10 Dc
        largest = params["b"] * math.log1p(velocity * max(hold_times) / params["Dc"])
        slide = 10.0 * params["Dc"] + 2.0 * largest / params["stiffness"]
    length = float(slide)
    lead = 2.0 * params["Dc"] / velocity
    out = []
    for hold in hold_times:
        steps = Protocol(
            [Velocity(velocity, lead), Hold(float(hold)), Velocity(velocity, length / velocity)]
        )
        t = np.concatenate(
            [[0.5 * lead, lead], lead + hold + np.linspace(0.0, length / velocity, points)[1:]]
        )
        mu = simulate(model, steps, t_eval=t).friction
        out.append(_peak(t[2:], mu[2:], mu[1], 0.0)[1] - mu[1])
    return np.array(out)
