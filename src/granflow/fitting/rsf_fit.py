"""Rate-and-state fits of velocity steps: a, b and Dc with honest intervals, no guess needed.

:func:`fit` fits the compiled rate-and-state spring-slider (:mod:`granflow.fitting.rsf_forward`)
to a friction record through its load-point velocity history, on the engine every granflow fit
uses (:class:`granflow.fitting.engine.Problem`: Levenberg-Marquardt in log coordinates for a,
Dc and k; covariance and profile-likelihood intervals of :mod:`granflow.fitting.profile`).

Starting values come from the data: the friction just before the step is mu0, the change of
steady-state friction over ln(v2 / v1) is a - b, the extreme right after the step over
ln(v2 / v1) is a (the direct effect), the slip over which the friction relaxes from that
extreme to 1/e of the way to its new steady state is Dc, and the rise towards the extreme
gives the stiffness. Levenberg-Marquardt runs from the best few of a small grid around them.

Several steps of one record are fitted jointly: one window per step (by default the record
cut half-way between steps), each window starting at steady sliding with its own mu0 (and
trend), sharing a, b, Dc and k.

An apparatus ripple periodic in load-point displacement (``periodic=``) is fitted after the
fit without it, from its residuals (:func:`granflow.fitting.rsf_problem.with_periodic`), and
every fit's residuals are checked for one (:mod:`granflow.fitting.rsf_periodic`).
"""

from __future__ import annotations

import dataclasses
import itertools
import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from granflow import _validate as check
from granflow.errors import InvalidDataError, InvalidParameterError
from granflow.fitting.engine import Solution
from granflow.fitting.profile import profile_interval
from granflow.fitting.results import FrozenMap, read_only
from granflow.fitting.rsf_forward import Window, noise_scatter
from granflow.fitting.rsf_periodic import harmonic_names, periodicity_check
from granflow.fitting.rsf_problem import Setup, with_periodic
from granflow.fitting.rsf_result import RateStateFitResult
from granflow.fitting.statistics import WALD_Z, fit_statistics
from granflow.simulation.protocol import Protocol
from granflow.simulation.rsf.model import LAWS

__all__ = ["CORRELATED_ABOVE", "correlation_time", "fit"]

_GRID_A = (1.0, 0.5, 2.0)
_GRID_DC = (1.0, 0.25, 4.0)
_GRID_K = (1.0, 4.0)
_STARTS_RUN = 3
#: With ``correlated_noise="auto"``: residuals correlated over more points than this are
#: correlated noise (the batch-means estimate of white noise is 1 +- 0.3).
CORRELATED_ABOVE = 2.0
_MAX_STEPS = 60  # Levenberg-Marquardt steps from one start
#: Search ranges of the positive parameters (by their first two letters): a [-], Dc [m],
#: stiffness [1/m]; wide, but they keep a step in log coordinates from under- or overflowing.
_RANGES = {
    "a": (1e-7, 1.0),
    "Dc": (1e-12, 1.0),
    "st": (1e-3, 1e15),
    "wa": (1e-9, 1.0),
}  # Levenberg-Marquardt runs from this many of the best-ranked starts


def _state_names(count):
    return [("b", "Dc")] if count == 1 else [(f"b{i}", f"Dc{i}") for i in range(1, count + 1)]


def _data(t, friction, protocol):
    """(t, friction, protocol, meta) from arrays, a Run, or a VelocityStepRecord."""
    from granflow.model.run import Run

    meta = {}
    if hasattr(t, "protocol") and hasattr(t, "displacement"):  # a VelocityStepRecord
        record = t
        protocol = record.protocol if protocol is None else protocol
        return record.t, record.friction, protocol, dict(record.meta)
    if isinstance(t, Run):
        run = t
        if isinstance(friction, Protocol) and protocol is None:
            protocol, friction = friction, None
        if friction is not None:
            raise InvalidParameterError("give a Run or (t, friction), not both")
        load = run.meta.get("normal_load")
        friction = run.force / load if load else run.force
        meta = {"source": run.meta.get("source")}
        t = run.t
    if protocol is None:
        raise InvalidParameterError("protocol is missing: the load-point velocity history")
    t = check.real_array(t, "t", "s").ravel()
    friction = check.real_array(friction, "friction", "").ravel()
    if t.shape != friction.shape:
        raise InvalidDataError(f"t and friction differ in length: {t.size} and {friction.size}")
    if np.any(np.diff(t) <= 0):
        index = int(np.argmax(np.diff(t) <= 0))
        raise InvalidDataError(f"t must increase strictly, but t[{index + 1}] <= t[{index}]")
    if not isinstance(protocol, Protocol):
        protocol = Protocol(protocol)
    return t, friction, protocol, meta


def _pieces(protocol):
    """(start, end, velocity at start, slope) per piece of a rate-controlled protocol."""
    rows, start = [], 0.0
    for index, segment in enumerate(protocol):
        if segment.control != "rate":
            raise InvalidParameterError(
                f"protocol segment {index + 1} ({segment.type_name}) is not rate-controlled: "
                "a velocity-step fit needs the load-point velocity history"
            )
        for piece in segment.pieces():
            slope = (piece.end - piece.start) / piece.duration
            rows.append((start, start + piece.duration, piece.start, slope))
            start += piece.duration
    return np.array(rows, dtype=float)


def _windows(t, pieces, windows):
    """(first, stop, start time) of each fit window: given (the simulation starts at the
    window's start, steady sliding there), or one per step, cut half-way between steps."""
    if windows is not None:
        out = []
        for number, (lo, hi) in enumerate(windows, start=1):
            inside = np.flatnonzero((t >= lo) & (t <= hi))
            if inside.size < 10:
                raise InvalidParameterError(
                    f"window {number} ({lo:g} .. {hi:g} s) holds {inside.size} points; "
                    "a fit needs at least 10"
                )
            out.append((int(inside[0]), int(inside[-1]) + 1, max(float(lo), 0.0)))
        return out
    velocity = pieces[:, 2]
    steps = [
        pieces[i, 0]
        for i in range(1, len(pieces))
        if abs(
            velocity[i]
            - (velocity[i - 1] + pieces[i - 1, 3] * (pieces[i - 1, 1] - pieces[i - 1, 0]))
        )
        > 1e-3 * max(abs(velocity[i]), abs(velocity[i - 1]))
    ]
    cuts = [t[0]] + [0.5 * (s1 + s2) for s1, s2 in itertools.pairwise(steps)] + [t[-1]]
    out = []
    for lo, hi in itertools.pairwise(cuts):
        inside = np.flatnonzero((t >= lo) & (t <= hi if hi == t[-1] else t < hi))
        out.append((int(inside[0]), int(inside[-1]) + 1, float(t[inside[0]])))
    return out


def _smooth(y, width):
    if width <= 1:
        return y
    kernel = np.ones(width) / width
    padded = np.concatenate([np.full(width // 2, y[0]), y, np.full(width - 1 - width // 2, y[-1])])
    return np.convolve(padded, kernel, mode="valid")


def _step_estimates(window, y):
    """Starting values (mu0, a, b, Dc, k) read from the largest step of one window."""
    pieces = window.pieces
    tail = y[-max(5, y.size // 10) :]
    if len(pieces) < 2:
        return float(np.median(y[: max(5, y.size // 10)])), None
    ends = pieces[:, 2] + pieces[:, 3] * (pieces[:, 1] - pieces[:, 0])
    ratios = [
        abs(math.log(max(pieces[i, 2], 1e-300) / max(ends[i - 1], 1e-300)))
        for i in range(1, len(pieces))
    ]
    j = 1 + int(np.argmax(ratios))
    s, v1, v2 = pieces[j, 0], ends[j - 1], pieces[j, 2]
    local = window.local
    before = y[local < s]
    after = y[local >= s]
    t_after = local[local >= s] - s
    if after.size < 10 or v1 <= 0 or v2 <= 0:
        return float(np.median(y[: max(5, y.size // 10)])), None
    # a start-up (no data before the step): friction starts from steady sliding at v1
    mu_before = float(np.median(before[-max(3, before.size // 5) :])) if before.size else y[0]
    mu_after = (
        float(np.median(tail))
        if j == len(pieces) - 1
        else float(np.median(after[-max(5, after.size // 10) :]))
    )
    log_ratio = math.log(v2 / v1)
    a_minus_b = (mu_after - mu_before) / log_ratio
    smooth = _smooth(after, max(1, after.size // 100))
    half = smooth[: max(3, smooth.size // 2)]
    sign = 1.0 if log_ratio > 0 else -1.0
    peak_index = int(np.argmax(sign * half))
    peak = float(half[peak_index])
    direct = (peak - mu_before) / log_ratio
    a = max(direct, abs(a_minus_b), 1e-5)
    b = a - a_minus_b
    # evolution distance: from the extreme to 1/e of the way to the new steady state
    span = peak - mu_after
    later = np.flatnonzero(np.abs(smooth[peak_index:] - mu_after) < abs(span) / math.e)
    duration = t_after[-1] - t_after[peak_index]
    if later.size and abs(span) > 0:
        relax = t_after[peak_index + later[0]] - t_after[peak_index]
    else:
        relax = duration / 5
    Dc = v2 * max(relax, duration / 1000, 1e-12)
    # stiffness: friction rises at k (v2 - v1) until the slider catches up
    rise = np.flatnonzero(
        sign * (smooth[: peak_index + 1] - mu_before) > 0.5 * abs(peak - mu_before)
    )
    t_half = t_after[rise[0]] if rise.size and t_after[rise[0]] > 0 else max(t_after[1], 1e-12)
    k = 0.5 * abs(peak - mu_before) / (abs(v2 - v1) * t_half)
    k = max(k, 10 * abs(b - a) / Dc if b > a else 0.0, 1e-12)
    return mu_before, (a, b, Dc, k)


def fit(
    t: Any,
    friction: Any = None,
    protocol: Protocol | None = None,
    *,
    law: str = "aging",
    states: int = 1,
    fixed: Mapping[str, float] | None = None,
    detrend: bool = False,
    windows: Sequence[tuple[float, float]] | None = None,
    sigma: float | None = None,
    profile: bool = True,
    correlated_noise: bool | str = False,
    periodic: bool | float | None = None,
    harmonics: int = 2,
) -> RateStateFitResult:
    """Fit a rate-and-state spring-slider to velocity steps, with no initial guess.

    Parameters
    ----------
    t : array_like, Run or VelocityStepRecord
        Times of the friction record [s] (the protocol's time: 0 where the protocol starts);
        or a :class:`~granflow.Run` (friction = force / ``meta["normal_load"]`` when given,
        else its force column) or a record of :func:`granflow.io.read_velocity_steps` (which
        brings its protocol).
    friction : array_like, optional
        Friction coefficient [-] at ``t``.
    protocol : Protocol, optional
        The load-point velocity history [m/s] (rate-controlled segments).
    law : str or sequence of str
        The state evolution law (``"aging"``, ``"slip"``, ``"prz"``), one per state.
    states : int
        One or two state variables.
    fixed : mapping, optional
        Parameters held at a value, by name: ``stiffness`` [1/m], ``mu0``, ``a``, ``b``,
        ``Dc`` [m] (``b1``, ``Dc1``, ``b2``, ``Dc2`` with two states), ``slope`` [1/m].
    detrend : bool
        Fit a linear trend of friction in load-point displacement (parameter ``slope``).
    windows : sequence of (float, float), optional
        Fit windows [s]; several windows are fitted jointly (a, b, Dc, k shared; mu0 and slope
        per window, named ``mu0_1``, ``slope_1``, ...). Default: one window per step.
    sigma : float, optional
        Known noise of the friction [-]; default: the residual variance.
    profile : bool
        Profile-likelihood 95 % intervals of a, b and Dc (default); Wald otherwise.
    correlated_noise : bool or "auto"
        Scale the covariance and the profile threshold by the residuals' integrated
        correlation time (:func:`correlation_time`; at least 1): for real records, whose
        residuals (instrument filters, slow wander) are not white. ``"auto"``: scale when
        the residuals are correlated over more than :data:`CORRELATED_ABOVE` points (what
        ``granflow fit --model rsf`` does). Default False: white noise, the right choice for
        simulated records only; on a real record it gives intervals too narrow by the
        square root of the correlation time (the result's ``correlation_time`` and its
        message say so).
    periodic : bool or float, optional
        Fit an apparatus ripple periodic in load-point displacement d (a drive screw, a gear)
        jointly with the friction: ``sum_h cos_h cos(2 pi h d / wavelength) + sin_h
        sin(2 pi h d / wavelength)``, h = 1 .. ``harmonics``, d since the protocol's start
        [m] (:mod:`granflow.fitting.rsf_periodic`). ``True``: the wavelength starts at the
        peak of the periodogram of the residuals of the fit without it; a float: it starts
        at this wavelength [m]. Either way it is fitted, with the amplitudes (parameters
        ``wavelength`` [m], ``cos1``, ``sin1``, ``cos2``, ``sin2``, ... [-]); hold it with
        ``fixed={"wavelength": ...}``. Default (None, False): no ripple term; the result's
        ``periodicity`` then says whether the residuals hold one.
    harmonics : int
        Harmonics of the ripple (fitted with ``periodic``, and searched by the check).

    Returns
    -------
    RateStateFitResult

    Examples
    --------
    >>> import numpy as np, granflow as gf
    >>> from granflow import rsf
    >>> truth = rsf.RateState(0.6, 0.01, 1e-6, 2e3, [rsf.State(0.015, 20e-6)])
    >>> steps = gf.Protocol([gf.Velocity(1e-6, 50.0), gf.Velocity(1e-5, 30.0)])
    >>> t = np.linspace(0.0, 80.0, 801)
    >>> mu = rsf.simulate(truth, steps, t_eval=t).friction
    >>> result = rsf.fit(t, mu, steps, law="aging", fixed={"stiffness": 2e3})
    >>> a, b, Dc = (result.params[name] for name in ("a", "b", "Dc"))
    >>> round(a, 5), round(b, 5), round(Dc * 1e6, 3)
    (0.01, 0.015, 20.0)
    """
    t, friction, protocol, meta = _data(t, friction, protocol)
    if correlated_noise not in (True, False, "auto"):
        raise InvalidParameterError(
            f"correlated_noise must be True, False or 'auto', got {correlated_noise!r}"
        )
    count = int(states)
    if count not in (1, 2):
        raise InvalidParameterError(f"states must be 1 or 2, got {states!r}")
    laws = (law,) * count if isinstance(law, str) else tuple(law)
    if len(laws) != count:
        raise InvalidParameterError(f"law must name {count} laws (one per state), got {law!r}")
    for name in laws:
        if name not in LAWS or name == "nagata":
            raise InvalidParameterError(
                f"law must be 'aging', 'slip' or 'prz', got {name!r} (nagata needs c)"
            )
    if harmonics is True or not isinstance(harmonics, int | np.integer) or harmonics < 1:
        raise InvalidParameterError(f"harmonics must be a positive integer, got {harmonics!r}")
    harmonics = int(harmonics)
    if isinstance(periodic, np.bool_):
        periodic = bool(periodic)
    if periodic is None or periodic is False:
        terms = 0
    elif periodic is True:
        terms = harmonics
    else:
        periodic = check.positive(periodic, "periodic", "m")
        low, high = _RANGES["wa"]
        if not low <= periodic <= high:
            raise InvalidParameterError(
                f"periodic must be a wavelength from {low:g} to {high:g} m, got {periodic!r}"
            )
        terms = harmonics
    pieces = _pieces(protocol)
    if t[0] < 0 or t[-1] > pieces[-1, 1] * (1 + 1e-12):
        raise InvalidDataError(
            f"t runs {t[0]:g} .. {t[-1]:g} s, outside the protocol's 0 .. {pieces[-1, 1]:g} s"
        )
    ranges = _windows(t, pieces, windows)
    record = [Window(t[lo:hi], pieces, laws, start) for lo, hi, start in ranges]
    if any(w.v_ref <= 0 for w in record):
        raise InvalidDataError("a window starts at rest: no steady state to start from")
    names_states = _state_names(count)
    multi = len(record) > 1
    local_names = [
        (f"mu0_{i}", f"slope_{i}") if multi else ("mu0", "slope") for i in range(1, len(record) + 1)
    ]
    shared = ["a", "stiffness", *[n for pair in names_states for n in pair]]
    names = shared + [n for pair in local_names for n in pair]
    fixed = dict(fixed or {})
    known = names + (["wavelength", *harmonic_names(terms)] if terms else [])
    unknown = sorted(set(fixed) - set(known))
    if unknown:
        raise InvalidParameterError(f"fixed names unknown parameters {unknown}; known: {known}")
    if not detrend:
        for _, slope in local_names:
            fixed.setdefault(slope, 0.0)
    for name in ("a", "stiffness", "wavelength", *[dc for _, dc in names_states]):
        if name in fixed:
            check.positive(fixed[name], name)
    if "wavelength" in fixed:
        low, high = _RANGES["wa"]
        if not low <= fixed["wavelength"] <= high:
            raise InvalidParameterError(
                f"fixed wavelength must lie from {low:g} to {high:g} m, got {fixed['wavelength']!r}"
            )
    noise = noise_scatter(friction)

    # starting values from the data
    estimates = [
        _step_estimates(w, friction[lo:hi]) for w, (lo, hi, _) in zip(record, ranges, strict=True)
    ]
    found = [e[1] for e in estimates if e[1] is not None]
    if not found:
        raise InvalidDataError("no velocity step in the fit windows: nothing to fit a, b, Dc to")
    a0, b0, Dc0, k0 = found[int(np.argmax([abs(f[0]) for f in found]))]
    starts = []
    for fa in _GRID_A:
        for fd in _GRID_DC:
            for fk in _GRID_K:
                a = fa * a0
                state_values = [(a - (a0 - b0), fd * Dc0)]
                if count == 2:
                    state_values = [
                        (0.5 * (a - (a0 - b0)), fd * Dc0),
                        (0.5 * (a - (a0 - b0)), 10 * fd * Dc0),
                    ]
                values = {"a": a, "stiffness": fk * k0}
                for (bn, dn), (b, dc) in zip(names_states, state_values, strict=True):
                    values[bn], values[dn] = b, dc
                for (mn, sn), (mu0, _) in zip(local_names, estimates, strict=True):
                    values[mn], values[sn] = mu0, 0.0
                values.update(fixed)
                starts.append([values[n] for n in names])

    search = dict(_RANGES)
    # the rise after a step unresolved by the sampling gives a lower bound of k: allow 1e4
    # times more (a machine stiffer than that is rigid at any sampling), not an overflow
    search["st"] = (_RANGES["st"][0], min(_RANGES["st"][1], 1e4 * k0))
    setup = Setup((t, friction), record, ranges, names, local_names, count, fixed, search, sigma)
    scaled_noise = noise * (1.0 if sigma is None else 1.0 / sigma)
    problem = setup.problem(starts[0], harmonics=0)
    solution = _multistart(problem, starts, scaled_noise)
    # model evaluations, not Levenberg-Marquardt steps (a step may try several)
    solution = dataclasses.replace(solution, nfev=setup.evaluations)
    load_point = np.concatenate([w.position for w in record])
    if terms:
        names, problem, solution = with_periodic(
            setup, problem, solution, periodic, terms, load_point
        )
    values = problem.values(solution.x)
    stats = fit_statistics(
        problem, values, names, sigma_known=sigma is not None, hessian=solution.hessian
    )
    tau = correlation_time(stats.residuals)
    if correlated_noise == "auto":
        correlated_noise = tau > CORRELATED_ABOVE
    inflation = max(tau, 1.0) if correlated_noise else 1.0
    stderr = {n: e * math.sqrt(inflation) for n, e in stats.stderr.items()}
    covar = {p: {q: c * inflation for q, c in row.items()} for p, row in stats.covar.items()}
    ci95 = {
        n: (stats.params[n] - WALD_Z * e, stats.params[n] + WALD_Z * e) for n, e in stderr.items()
    }
    method = {n: "wald" for n in names}
    exact = True
    variance = (1.0 if sigma is not None else stats.redchi) * inflation
    profile_failed = []
    # identifiability, judged on the white-noise error (before any correlation scaling)
    k_error = stats.stderr["stiffness"]
    loose = "stiffness" not in fixed and not k_error < 0.3 * stats.params["stiffness"]
    if profile and loose:
        # the elastic rise after a step is not resolved by the sampling: profiles of a, b and
        # Dc would let k run away to a rigid machine; their Wald intervals stay
        profile_failed += ["a", *[n for pair in names_states for n in pair]]
    elif profile and stats.invertible and solution.status > 0:
        position = {i: k for k, i in enumerate(problem.free)}
        for name in ("a", *[n for pair in names_states for n in pair]):
            index = names.index(name)
            if index not in position:
                continue
            p = problem.parameters[index]
            halfwidth = WALD_Z * stderr[name] / (values[index] if p.log else p.scale)
            interval, ok = profile_interval(
                problem, values, index, variance, stats.chisqr, halfwidth, solution.hessian
            )
            if all(math.isfinite(end) for end in interval):
                ci95[name] = interval
                method[name] = "profile"
                exact = exact and ok
            else:  # the profile ran off (a parameter it leans on is unbounded): keep Wald's
                profile_failed.append(name)
    for name in fixed:
        method[name] = "fixed"
    message = solution.message
    if not stats.invertible:
        message += "; singular covariance"
    if not exact:
        message += "; a profile interval ran into a bound"
    if loose:
        message += (
            "; the stiffness is poorly determined (the rise after a step is not resolved): "
            "Wald intervals; consider fixed={'stiffness': ...} (--fix stiffness=VALUE on the "
            "command line)"
        )
    elif profile_failed:
        message += f"; Wald intervals for {', '.join(profile_failed)} (the profile ran off)"
    if correlated_noise:
        message += f"; covariance scaled by the residuals' correlation time, {tau:.3g} points"
    elif tau > CORRELATED_ABOVE:
        message += (
            f"; the residuals are correlated over {tau:.3g} points but the noise was taken as "
            "white: the intervals are too narrow (correlated_noise=True or 'auto')"
        )
    units = {
        n: (
            "1/m"
            if n.startswith(("stiffness", "slope"))
            else "m"
            if n.startswith(("Dc", "wavelength"))
            else ""
        )
        for n in names
    }
    velocity = np.concatenate([w.velocity for w in record])
    result = RateStateFitResult(
        **stats.summary(
            ci95=FrozenMap(ci95),
            stderr=FrozenMap(stderr),
            covar=FrozenMap({p: FrozenMap(row) for p, row in covar.items()}),
        ),
        success=bool(
            solution.status > 0 and stats.invertible and np.all(np.isfinite(stats.best_fit))
        ),
        message=message,
        sigma_known=sigma is not None,
        laws=laws,
        names=tuple(names),
        units=FrozenMap(units),
        fixed=tuple(n for n in names if n in fixed),
        ci_method=FrozenMap(method),
        windows=tuple((start, float(t[hi - 1])) for _, hi, start in ranges),
        v_ref=tuple(w.v_ref for w in record),
        noise=noise,
        correlation_time=tau,
        t=read_only(np.concatenate([t[lo:hi] for lo, hi, _ in ranges])),
        data=read_only(np.concatenate([friction[lo:hi] for lo, hi, _ in ranges])),
        best_fit=read_only(stats.best_fit),
        residuals=read_only(stats.residuals),
        load_point_velocity=read_only(velocity),
        load_point_displacement=read_only(load_point),
        source=str(meta.get("source") or ""),
        harmonics=terms,
        periodicity=FrozenMap(periodicity_check(load_point, stats.residuals, harmonics)),
        correlated_noise=bool(correlated_noise),
        load_point_history=read_only(pieces),
        sigma=None if sigma is None else float(sigma),
    )
    return result


def correlation_time(residuals, blocks=20):
    """The residuals' integrated correlation time [points], by batch means: the variance of
    the means of ``blocks`` consecutive blocks times the block length, over the variance of
    the residuals (1 for white noise)."""
    r = np.asarray(residuals, dtype=float)
    length = r.size // blocks
    if length < 2 or not np.var(r) > 0:
        return 1.0
    means = r[: length * blocks].reshape(blocks, length).mean(axis=1)
    return float(np.var(means, ddof=1) * length / np.var(r))


def _multistart(problem, starts, noise):
    """Levenberg-Marquardt from the start read from the data, then from the best-ranked
    others (by chi-square at every 4th point), until chi-square is what the record's scatter
    ``noise`` allows (5 standard deviations of chi-square), or two runs agree on the minimum,
    or :data:`_STARTS_RUN` more have run. The lowest chi-square wins."""
    dof = max(problem.ndata - len(problem.free), 1)
    plausible = (1.0 + 10.0 / math.sqrt(dof)) * dof * noise**2
    best, nfev, tried, minima = None, 0, 0, []

    def run(u_start):
        """One Levenberg-Marquardt run; True when the search may stop."""
        nonlocal best, nfev, tried
        u, cost, converged, steps, hessian = problem.lm(u_start, max_iter=_MAX_STEPS, rtol=1e-9)
        nfev, tried = nfev + steps, tried + 1
        if not math.isfinite(cost):
            return False
        if best is None or cost < best[1]:
            best = (u, cost, converged, hessian)
        if any(abs(cost - m) <= 1e-6 * cost for m in minima):
            # a second start ends at the same chi-square: that is the minimum, even where
            # Levenberg-Marquardt still creeps along a bound
            best = (best[0], best[1], True, best[3])
            return True
        minima.append(cost)
        return converged and cost <= plausible  # the residuals are the noise

    if not run(problem.internal(list(starts[0]))):
        ranked = []
        for start in starts[1:]:
            u = problem.internal(list(start))
            cost = problem.chisqr(problem.values(u), stride=4)
            ranked.append((cost if math.isfinite(cost) else math.inf, len(ranked), u))
        nfev += len(ranked)
        ranked.sort(key=lambda item: (item[0], item[1]))
        for _, _, u_start in ranked[:_STARTS_RUN]:
            if run(u_start):
                break
    if best is None:
        u = problem.internal(list(starts[0]))
        return Solution(u, 0, "the model could not be evaluated at any start", nfev)
    u, cost, converged, hessian = best
    if converged:
        message = f"converged (Levenberg-Marquardt from {tried} of {len(starts)} starts)"
        return Solution(u, 1, message, nfev, hessian)
    return Solution(
        u, 0, f"Levenberg-Marquardt did not converge in {_MAX_STEPS} steps", nfev, hessian
    )
