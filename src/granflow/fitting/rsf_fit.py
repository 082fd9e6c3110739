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
cut half-way between steps, every window simulated from the record's start, where it slides
steadily), each window with its own mu0 (and trend), sharing a, b, Dc and k. Given windows
start their simulation at steady sliding at their own start.

The optimiser's end is checked, not trusted (:mod:`granflow.fitting.rsf_convergence`): the
gradient, the decrease a Gauss-Newton step predicts and a restart from the optimum must all
be below what the integration's accuracy and the noise make meaningful, or the fit is not a
success and its message names the check that failed.

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
from granflow.fitting.parameters import (
    Parameter,
    Parameters,
    Split,
    as_parameters,
    require_positive,
    split,
)
from granflow.fitting.profile import profile_interval
from granflow.fitting.results import FrozenMap, read_only
from granflow.fitting.rsf_convergence import integration_floor, verify
from granflow.fitting.rsf_forward import RELATIVE_TOLERANCE, noise_scatter
from granflow.fitting.rsf_optimise import MAX_STEPS, optimise
from granflow.fitting.rsf_periodic import harmonic_names, periodicity_check
from granflow.fitting.rsf_problem import Setup
from granflow.fitting.rsf_record import (
    fit_record,
    fit_windows,
    hold_estimates,
    record_data,
    step_estimates,
)
from granflow.fitting.rsf_result import RateStateFitResult
from granflow.fitting.statistics import WALD_Z, fit_statistics
from granflow.simulation.protocol import Protocol
from granflow.simulation.rsf.model import LAWS
from granflow.simulation.rsf.pieces import protocol_pieces

__all__ = ["CORRELATED_ABOVE", "correlation_time", "fit"]

_GRID_A = (1.0, 0.5, 2.0)
_GRID_DC = (1.0, 0.25, 4.0)
_GRID_K = (1.0, 4.0)
#: With ``correlated_noise="auto"``: residuals correlated over more points than this are
#: correlated noise (the batch-means estimate of white noise is 1 +- 0.3).
CORRELATED_ABOVE = 2.0
#: The integration's relative error in the friction, for the convergence checks' floor
#: (ten times the forward model's relative tolerance)
_INTEGRATION = 10 * RELATIVE_TOLERANCE
#: Search ranges of the positive parameters (by their first two letters): a [-], Dc [m],
#: stiffness [1/m]; wide, but they keep a step in log coordinates from under- or overflowing.
_RANGES = {
    "a": (1e-7, 1.0),
    "Dc": (1e-12, 1.0),
    "st": (1e-3, 1e15),
    "wa": (1e-9, 1.0),
}


def _laws(law, states):
    """The law of each state, checked."""
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
    return laws


def _ripple(periodic, harmonics):
    """(periodic, number of harmonics fitted: 0 without a ripple), checked."""
    if harmonics is True or not isinstance(harmonics, int | np.integer) or harmonics < 1:
        raise InvalidParameterError(f"harmonics must be a positive integer, got {harmonics!r}")
    if isinstance(periodic, np.bool_):
        periodic = bool(periodic)
    if periodic is None or periodic is False:
        return None, 0
    if periodic is not True:
        periodic = check.positive(periodic, "periodic", "m")
        low, high = _RANGES["wa"]
        if not low <= periodic <= high:
            raise InvalidParameterError(
                f"periodic must be a wavelength from {low:g} to {high:g} m, got {periodic!r}"
            )
    return periodic, int(harmonics)


class _Names:
    """The parameter names of a fit of ``count`` states over ``windows`` windows."""

    def __init__(self, count, windows):
        self.states = (
            [("b", "Dc")] if count == 1 else [(f"b{i}", f"Dc{i}") for i in range(1, count + 1)]
        )
        self.local = [
            (f"mu0_{i}", f"slope_{i}") if windows > 1 else ("mu0", "slope")
            for i in range(1, windows + 1)
        ]
        self.shared = ["a", "stiffness", *[n for pair in self.states for n in pair]]
        self.all = self.shared + [n for pair in self.local for n in pair]
        #: the parameters with profile-likelihood intervals
        self.profiled = ["a", *[n for pair in self.states for n in pair]]

    def known(self, terms):
        return self.all + (["wavelength", *harmonic_names(terms)] if terms else [])


def _requested(names, terms, fixed, params, detrend):
    """(held values, starting values, search ranges) by name from ``fixed`` and ``params``,
    checked: known names, each named once, positive values of the positive parameters."""
    known = names.known(terms)
    fixed = dict(fixed or {})
    unknown = sorted(set(fixed) - set(known))
    if unknown:
        raise InvalidParameterError(f"fixed names unknown parameters {unknown}; known: {known}")
    requested = Split({}, {}, {}) if params is None else split(params, known, "rsf.fit")
    both = sorted(set(fixed) & set(as_parameters(params or ())))
    if both:
        raise InvalidParameterError(
            f"{both} named in both fixed= and params=: say each parameter once"
        )
    held = {**fixed, **requested.held}
    if not detrend:
        for _, slope in names.local:
            if slope not in requested.starts:
                held.setdefault(slope, 0.0)
    positive = ("a", "stiffness", "wavelength", *[dc for _, dc in names.states])
    for name in positive:
        if name in held:
            check.positive(held[name], name)
    require_positive(requested, positive)
    if "wavelength" in held:
        low, high = _RANGES["wa"]
        if not low <= held["wavelength"] <= high:
            raise InvalidParameterError(
                f"fixed wavelength must lie from {low:g} to {high:g} m, got {held['wavelength']!r}"
            )
    return held, requested.starts, requested.ranges


def _starts(record, ranges, friction, names, held, given):
    """The starting points (values in the order of ``names.all``): the values read from the
    data (:func:`step_estimates`, or :func:`hold_estimates` without a step) and a grid
    around them; ``given`` starting values replace the data's in the first. Returns
    (starts, the data's stiffness estimate [1/m])."""
    estimates = []
    for w, (lo, hi, _) in zip(record, ranges, strict=True):
        mu0, found = step_estimates(w, friction[lo:hi])
        if found is None:
            found = hold_estimates(w, friction[lo:hi])
            mu0, found = (mu0, None) if found is None else found
        estimates.append((mu0, found))
    found = [e[1] for e in estimates if e[1] is not None]
    if not found:
        raise InvalidDataError(
            "no velocity step and no hold in the fit windows: nothing to fit a, b, Dc to"
        )
    a0, b0, Dc0, k0 = found[int(np.argmax([abs(f[0]) for f in found]))]
    starts = []
    for fa, fd, fk in itertools.product(_GRID_A, _GRID_DC, _GRID_K):
        a = fa * a0
        b = a - (a0 - b0)
        state_values = (
            [(b, fd * Dc0)]
            if len(names.states) == 1
            else [(b / 2, fd * Dc0), (b / 2, 10 * fd * Dc0)]
        )
        values = {"a": a, "stiffness": fk * k0}
        for (bn, dn), (b_i, dc) in zip(names.states, state_values, strict=True):
            values[bn], values[dn] = b_i, dc
        for (mn, sn), (mu0, _) in zip(names.local, estimates, strict=True):
            values[mn], values[sn] = mu0, 0.0
        if not starts:
            values.update(given)
        values.update(held)
        starts.append([values[n] for n in names.all])
    return starts, k0


@dataclasses.dataclass
class _Errors:
    """The standard errors, covariance and intervals of a fit, scaled for correlated noise."""

    stderr: dict
    covar: dict
    ci95: dict
    method: dict
    tau: float
    correlated: bool
    variance: float

    @classmethod
    def of(cls, stats, correlated_noise, sigma):
        tau = correlation_time(stats.residuals)
        if correlated_noise == "auto":
            correlated_noise = tau > CORRELATED_ABOVE
        inflation = max(tau, 1.0) if correlated_noise else 1.0
        stderr = {n: e * math.sqrt(inflation) for n, e in stats.stderr.items()}
        covar = {p: {q: c * inflation for q, c in row.items()} for p, row in stats.covar.items()}
        ci95 = {
            n: (stats.params[n] - WALD_Z * e, stats.params[n] + WALD_Z * e)
            for n, e in stderr.items()
        }
        variance = (1.0 if sigma is not None else stats.redchi) * inflation
        method = dict.fromkeys(stats.params, "wald")
        return cls(stderr, covar, ci95, method, tau, bool(correlated_noise), variance)


def _intervals(problem, solution, stats, errors, names, held, profile):
    """Profile-likelihood intervals of a, b and Dc into ``errors`` where they can be had;
    returns what the message must say: (loose stiffness, profiles that ran off, a profile
    that ran into a bound)."""
    values = problem.values(solution.x)
    # identifiability, judged on the white-noise error (before any correlation scaling)
    loose = "stiffness" not in held and not (
        stats.stderr["stiffness"] < 0.3 * stats.params["stiffness"]
    )
    failed, exact = [], True
    if profile and loose:
        # the elastic rise after a step is not resolved by the sampling: profiles of a, b and
        # Dc would let k run away to a rigid machine; their Wald intervals stay
        failed = list(names.profiled)
    elif profile and stats.invertible and solution.status > 0:
        position = {i: k for k, i in enumerate(problem.free)}
        fitted = [p.name for p in problem.parameters]
        for name in names.profiled:
            index = fitted.index(name)
            if index not in position:
                continue
            p = problem.parameters[index]
            halfwidth = WALD_Z * errors.stderr[name] / (values[index] if p.log else p.scale)
            interval, ok = profile_interval(
                problem, values, index, errors.variance, stats.chisqr, halfwidth, solution.hessian
            )
            if all(math.isfinite(end) for end in interval):
                errors.ci95[name] = interval
                errors.method[name] = "profile"
                exact = exact and ok
            else:  # the profile ran off (a parameter it leans on is unbounded): keep Wald's
                failed.append(name)
    for name in held:
        errors.method[name] = "fixed"
    return loose, failed, exact


def _message(solution, stats, errors, notes):
    """The result's message: how the optimiser ended and what the intervals rest on."""
    loose, failed, exact = notes
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
    elif failed:
        message += f"; Wald intervals for {', '.join(failed)} (the profile ran off)"
    if errors.correlated:
        message += (
            f"; covariance scaled by the residuals' correlation time, {errors.tau:.3g} points"
        )
    elif errors.tau > CORRELATED_ABOVE:
        message += (
            f"; the residuals are correlated over {errors.tau:.3g} points but the noise was "
            "taken as white: the intervals are too narrow (correlated_noise=True or 'auto')"
        )
    return message


def _unit(name):
    """The SI unit of a rate-and-state fit parameter."""
    if name.startswith(("stiffness", "slope")):
        return "1/m"
    return "m" if name.startswith(("Dc", "wavelength")) else ""


def fit(
    t: Any,
    friction: Any = None,
    protocol: Protocol | None = None,
    *,
    law: str = "aging",
    states: int = 1,
    fixed: Mapping[str, float] | None = None,
    params: Parameters | Sequence[Parameter] | None = None,
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
    params : Parameters or sequence of Parameter, optional
        The same names as :class:`granflow.fitting.Parameter` objects, as :func:`granflow.fit`
        takes them: ``vary=False`` holds one at its value, the others start from their value
        and are searched between ``min`` and ``max`` (an infinite side keeps the default
        range). A name may be given in ``fixed`` or ``params``, not both.
    detrend : bool
        Fit a linear trend of friction in load-point displacement (parameter ``slope``).
    windows : sequence of (float, float), optional
        Fit windows [s], each starting in steady sliding (before a hold, not in it); several
        windows are fitted jointly (a, b, Dc, k shared; mu0 and slope per window, named
        ``mu0_1``, ``slope_1``, ...). Default: the record's own ``windows`` where it brings
        them, else one window per step.
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
        ``success`` only where the optimiser's end passed the convergence checks (its
        ``convergence`` mapping holds them: ``gradient``, ``predicted``, ``restart``,
        ``tolerance``, in chi-square units).

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
    t, friction, protocol, meta, own_windows = record_data(t, friction, protocol)
    windows = own_windows if windows is None else windows
    if correlated_noise not in (True, False, "auto"):
        raise InvalidParameterError(
            f"correlated_noise must be True, False or 'auto', got {correlated_noise!r}"
        )
    laws = _laws(law, states)
    periodic, terms = _ripple(periodic, harmonics)
    pieces = protocol_pieces(protocol)[0]
    if t[0] < 0 or t[-1] > pieces[-1, 1] * (1 + 1e-12):
        raise InvalidDataError(
            f"t runs {t[0]:g} .. {t[-1]:g} s, outside the protocol's 0 .. {pieces[-1, 1]:g} s"
        )
    ranges = fit_windows(t, pieces, windows)
    record = fit_record(t, pieces, laws, ranges, shared=windows is None)
    names = _Names(len(laws), len(record))
    held, given, bounds = _requested(names, terms, fixed, params, detrend)
    starts, k0 = _starts(record, ranges, friction, names, held, given)
    search = dict(_RANGES)
    # the rise after a step unresolved by the sampling gives a lower bound of k: allow 1e4
    # times more (a machine stiffer than that is rigid at any sampling), not an overflow
    search["st"] = (_RANGES["st"][0], min(_RANGES["st"][1], 1e4 * k0))
    setup = Setup(
        (t, friction),
        record,
        ranges,
        names.all,
        names.local,
        len(laws),
        held,
        search,
        sigma,
        bounds,
    )
    noise = noise_scatter(friction)
    fitted, problem, solution = optimise(setup, starts, noise, sigma, periodic, terms)
    observed = np.concatenate([friction[lo:hi] for lo, hi, _ in ranges])
    floor = integration_floor(problem.ndata, float(np.ptp(observed)), _INTEGRATION, sigma)
    solution, convergence = verify(problem, solution, floor, MAX_STEPS)
    values = problem.values(solution.x)
    stats = fit_statistics(
        problem, values, fitted, sigma_known=sigma is not None, hessian=solution.hessian
    )
    errors = _Errors.of(stats, correlated_noise, sigma)
    notes = _intervals(problem, solution, stats, errors, names, held, profile)
    load_point = np.concatenate([w.position for w in record])
    result = RateStateFitResult(
        **stats.fit_fields(
            ci95=FrozenMap(errors.ci95),
            stderr=FrozenMap(errors.stderr),
            covar=FrozenMap({p: FrozenMap(row) for p, row in errors.covar.items()}),
        ),
        success=bool(
            solution.status > 0 and stats.invertible and np.all(np.isfinite(stats.best_fit))
        ),
        message=_message(solution, stats, errors, notes),
        sigma_known=sigma is not None,
        laws=laws,
        names=tuple(fitted),
        units=FrozenMap({n: _unit(n) for n in fitted}),
        fixed=tuple(n for n in fitted if n in held),
        ci_method=FrozenMap(errors.method),
        windows=tuple(
            (float(t[lo]) if windows is None else start, float(t[hi - 1]))
            for lo, hi, start in ranges
        ),
        v_ref=tuple(w.v_ref for w in record),
        noise=noise,
        correlation_time=errors.tau,
        t=read_only(np.concatenate([t[lo:hi] for lo, hi, _ in ranges])),
        data=read_only(observed),
        best_fit=read_only(stats.best_fit),
        residuals=read_only(stats.residuals),
        load_point_velocity=read_only(np.concatenate([w.velocity for w in record])),
        load_point_displacement=read_only(load_point),
        source=str(meta.get("source") or ""),
        harmonics=terms,
        periodicity=FrozenMap(periodicity_check(load_point, stats.residuals, harmonics)),
        correlated_noise=errors.correlated,
        convergence=FrozenMap(convergence),
        load_point_history=read_only(pieces),
        sigma=None if sigma is None else float(sigma),
        shared_start=windows is None and len(record) > 1,
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
