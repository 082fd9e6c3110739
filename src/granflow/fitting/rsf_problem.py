"""The engine's problem of a rate-and-state fit, and the fit with the apparatus ripple.

:class:`Setup` holds what the problems of one :func:`granflow.rsf.fit` share (the data, the
windows, the parameter names, the held values, the search ranges) and builds the
:class:`granflow.fitting.engine.Problem` with or without the ripple periodic in load-point
displacement (:mod:`granflow.fitting.rsf_periodic`): one curve per window, the compiled
spring-slider of :mod:`granflow.fitting.rsf_forward` plus ``slope`` times the load-point
displacement plus the ripple. :func:`with_periodic` goes from the fit without the ripple to
the fit with it.
"""

import math

import numpy as np

from granflow.errors import InvalidDataError
from granflow.fitting.engine import Curve, GlobalParameter, Model, Problem, Solution
from granflow.fitting.rsf_periodic import (
    best_wavelength,
    fit_amplitudes,
    harmonic_names,
    periodic_terms,
)

__all__ = ["Setup", "with_periodic"]

_MAX_STEPS = 240  # Levenberg-Marquardt steps of the fit with the ripple


class Setup:
    """What the engine's problems of one fit share: the data, the windows, the names of the
    rate-and-state parameters (``names``), the held values and the search ranges."""

    def __init__(
        self, data, record, ranges, names, local_names, count, fixed, search, sigma, bounds=None
    ):
        self.t, self.friction = data
        self.record, self.ranges = record, ranges
        self.names, self.local_names, self.count = list(names), local_names, count
        self.fixed, self.search, self.sigma = fixed, search, sigma
        #: the caller's search ranges by name (min, max); an infinite side, or a lower bound
        #: at or below 0 of a positive parameter, keeps the default
        self.bounds = dict(bounds or {})
        #: passes of the model over the fit windows so far (values or values and Jacobian,
        #: every point or every few): the fit's count of model evaluations
        self.evaluations = 0

    def names_with(self, harmonics):
        """The parameter names of a fit with ``harmonics`` periodic terms (0: none)."""
        periodic = ["wavelength", *harmonic_names(harmonics)] if harmonics else []
        return self.names + periodic

    def problem(self, start, harmonics):
        """The engine's :class:`Problem` (one curve per window; slots a, stiffness, b.., Dc..,
        mu0, slope, then wavelength, cos1, sin1, ...), its parameters at ``start``."""
        count, record, fixed = self.count, self.record, self.fixed
        names = self.names_with(harmonics)
        periodic = names[len(self.names) :]
        slots = (
            "a",
            "stiffness",
            *[f"{p}{i}" for i in range(1, count + 1) for p in ("b", "Dc")],
            "mu0",
            "slope",
            *periodic,
        )
        rsf_slots = 2 + 2 * count
        log = tuple(s in ("a", "stiffness", "wavelength") or s.startswith("Dc") for s in slots)
        lookup = {float(w.t[0]): w for w in record}
        first = record[0]
        free_slots = set()
        for mn, sn in self.local_names:
            if mn not in fixed:
                free_slots.add("mu0")
            if sn not in fixed:
                free_slots.add("slope")
        for s, n in zip(slots[:rsf_slots], self.names[:rsf_slots], strict=True):
            if n not in fixed:
                free_slots.add(s)

        def unpack(values):
            a, k = values[0], values[1]
            pairs = [(values[2 + 2 * i], values[3 + 2 * i]) for i in range(count)]
            return values[rsf_slots], a, k, pairs, values[rsf_slots + 1]

        def position(window, z):
            if z.size == window.t.size:
                return window.position
            return np.interp(z, window.t, window.position)

        def function(z, *values):
            window = lookup[float(z[0])]
            self.evaluations += window is first
            mu0, a, k, pairs, slope = unpack(values)
            out = window.friction(mu0, a, k, pairs, 0.0, local=z - window.start)
            if slope:
                out = out + slope * np.interp(z, window.t, window.displacement)
            if periodic:
                extra = values[rsf_slots + 2 :]
                out = out + periodic_terms(position(window, z), extra[0], extra[1:])
            return out

        def jacobian(z, *values):
            window = lookup[float(z[0])]
            self.evaluations += window is first
            mu0, a, k, pairs, slope = unpack(values)
            wanted = [("k" if s == "stiffness" else s) for s in slots if s in free_slots]
            base, columns = window.jacobian(mu0, a, k, pairs, slope, wanted)
            J = np.zeros((z.size, len(slots)))
            for m, s in enumerate(slots[: rsf_slots + 2]):
                key = "k" if s == "stiffness" else s
                if key in columns:
                    J[:, m] = columns[key]
            if periodic:
                extra = values[rsf_slots + 2 :]
                term, columns = periodic_terms(
                    position(window, z), extra[0], extra[1:], with_jacobian=True
                )
                base = base + term
                J[:, rsf_slots + 2 :] = columns
            return base, J

        model = Model(slots=slots, function=function, jacobian=jacobian, log=log)
        parameters = []
        for i, name in enumerate(names):
            positive = name in ("a", "stiffness", "wavelength") or name.startswith("Dc")
            lower, upper = self.search[name[:2]] if positive else (-math.inf, math.inf)
            low, high = self.bounds.get(name, (-math.inf, math.inf))
            lower = low if math.isfinite(low) and (low > 0 or not positive) else lower
            upper = high if math.isfinite(high) else upper
            parameters.append(
                GlobalParameter(
                    name=name,
                    value=min(max(float(start[i]), lower), upper),
                    log=positive,
                    fixed=name in fixed,
                    lower=lower,
                    upper=upper,
                )
            )
        weights = 1.0 / self.sigma if self.sigma is not None else 1.0
        curves = []
        for (lo, hi, _), (mn, sn) in zip(self.ranges, self.local_names, strict=True):
            links = [
                names.index(s if s in names else {"b1": "b", "Dc1": "Dc"}.get(s, s))
                for s in slots[:rsf_slots]
            ]
            links += [names.index(mn), names.index(sn), *(names.index(n) for n in periodic)]
            curves.append(
                Curve(
                    self.t[lo:hi],
                    self.friction[lo:hi],
                    np.full(hi - lo, weights),
                    tuple((i, 1.0) for i in links),
                )
            )
        return Problem(curves, parameters, model)


def with_periodic(setup, problem, solution, periodic, harmonics, position):
    """The fit with the periodic term, from the fit without it: the wavelength is the given
    one, or the periodogram's peak of its residuals against load-point displacement; the
    amplitudes are the linear least-squares ones of those residuals at that wavelength (so
    every parameter starts next to its optimum, and no guess is needed); then
    Levenberg-Marquardt over all of them. Returns (names, problem, solution)."""
    values = problem.values(solution.x)
    residuals = np.concatenate([c.y for c in problem.curves]) - np.concatenate(
        problem.best_fit(values)
    )
    if "wavelength" in setup.fixed:
        wavelength = float(setup.fixed["wavelength"])
    elif periodic is True:
        wavelength = best_wavelength(position, residuals, harmonics)
        if wavelength is None:
            raise InvalidDataError(
                f"the load point moves {np.ptp(position):.3g} m in the fit windows: too "
                "little for three periods of a wavelength the sampling resolves; give "
                "periodic=<wavelength [m]>"
            )
    else:
        wavelength = float(periodic)
    amplitudes = fit_amplitudes(position, residuals, wavelength, harmonics)
    names = setup.names_with(harmonics)
    start = dict(zip(setup.names, values, strict=True))
    start.update(zip(names[len(setup.names) :], [wavelength, *amplitudes], strict=True))
    start.update({n: v for n, v in setup.fixed.items() if n in start})
    full = setup.problem([start[n] for n in names], harmonics)
    before = setup.evaluations
    u, _, converged, steps, hessian = full.lm(
        full.internal([start[n] for n in names]), max_iter=_MAX_STEPS, rtol=1e-9
    )
    nfev = solution.nfev + setup.evaluations - before
    if converged and solution.status > 0:
        message = f"{solution.message}, then with the periodic term"
        return names, full, Solution(u, 1, message, nfev, hessian)
    if converged:  # the ripple's fit converged; the one it started from had not
        message = f"without the periodic term: {solution.message}; with it: converged"
    else:
        message = f"Levenberg-Marquardt did not converge with the periodic term in {steps} steps"
        if solution.status <= 0:
            message += f" (nor without it: {solution.message})"
    return names, full, Solution(u, 0, message, nfev, hessian)
