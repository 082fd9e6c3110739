"""The result of a rate-and-state fit (:func:`granflow.rsf.fit`)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from granflow.families import family_of
from granflow.fitting.results import (
    FrozenMap,
    arrays,
    decode,
    encode,
    read_arrays,
)
from granflow.fitting.statistics import (
    FitOutcome,
    comparison_row,
    decoded,
    estimates,
    fit_report,
    statistics,
)

if TYPE_CHECKING:
    from matplotlib.axes import Axes

    from granflow.families import Likelihood

__all__ = ["RateStateFitResult"]


@dataclass(frozen=True, eq=False)
class RateStateFitResult(FitOutcome):
    """A rate-and-state fit of velocity steps.

    Attributes
    ----------
    params, stderr : mapping of str to float
        ``a``, ``b``, ``Dc`` [m] (``b1``, ``Dc1``, ``b2``, ``Dc2`` with two states),
        ``stiffness`` [1/m], ``mu0`` and ``slope`` [1/m] (``mu0_1``, ``slope_1``, ... per
        window in joint fits), with standard errors.
    ci95 : mapping of str to (float, float)
        95 % intervals: profile likelihood for a, b and Dc (see ``ci_method``), Wald else.
    covar, ndata, nfree, chisqr, redchi, aic, bic, success, message, sigma_known
        As in :class:`granflow.FitResult`.
    laws : tuple of str
        The evolution law of each state.
    names : tuple of str
    units : mapping of str to str
    fixed : tuple of str
        The parameters held at a value.
    ci_method : mapping of str to str
        ``"profile"``, ``"wald"`` or ``"fixed"`` per parameter.
    windows : tuple of (float, float)
        The fit windows [s].
    v_ref : tuple of float
        Per window, the load-point velocity where its simulation starts [m/s] (mu0 is the
        steady friction there): the record's first by default, a given window's first.
    noise : float
        The record's high-frequency scatter [-] (about its running mean over 25 points).
    correlation_time : float
        The residuals' integrated correlation time [points] (1 for white noise).
    t, data, best_fit, residuals, load_point_velocity : numpy.ndarray
        The fitted points [s], friction, model, data - model, load-point velocity [m/s].
    load_point_displacement : numpy.ndarray
        Load-point displacement since the protocol's start at the fitted points [m].
    source : str
        The file, where known.
    harmonics : int
        Harmonics of the fitted apparatus ripple (parameters ``wavelength`` [m], ``cos1``,
        ``sin1``, ...; see :func:`granflow.rsf.fit`'s ``periodic``); 0 without one.
    periodicity : mapping
        The check of the residuals for a ripple periodic in load-point displacement
        (:func:`granflow.fitting.rsf_periodic.periodicity_check`): ``wavelength`` [m],
        ``amplitude`` [-], ``rms`` [-], ``fraction``, ``false_alarm``, ``significant``;
        empty where the load point moves too little to tell.
    correlated_noise : bool
        Whether the covariance and the intervals were scaled by the correlation time
        (correlated noise); False: the noise was taken as white.
    load_point_history : numpy.ndarray, shape (pieces, 4)
        The protocol the record was fitted through: per piece its start [s], end [s],
        load-point velocity at the start [m/s] and slope [m/s^2] (what
        :meth:`log_likelihood` simulates again).
    sigma : float or None
        The known noise of the friction [-] (``sigma_known``), else None.
    shared_start : bool
        Whether the windows were simulated from the record's first time in one shared run
        (the default windows of several steps), rather than each from its own start.
    convergence : mapping
        The checks of the optimiser's end (:func:`granflow.fitting.rsf_convergence.verify`),
        in chi-square units: ``gradient`` (the largest decrease a Newton step in one
        parameter predicts), ``predicted`` (a Gauss-Newton step's), ``restart`` (what a
        restart from the perturbed optimum gained), ``tolerance`` (what each must stay
        below), ``rough`` (the Gauss-Newton promise lay in the residuals' roughness),
        ``chisqr``, ``restarts`` and ``passed``; empty for a result read from a file.
    """

    laws: tuple
    names: tuple
    units: FrozenMap
    fixed: tuple
    ci_method: FrozenMap
    windows: tuple
    v_ref: tuple
    noise: float
    correlation_time: float
    t: np.ndarray
    data: np.ndarray
    best_fit: np.ndarray
    residuals: np.ndarray
    load_point_velocity: np.ndarray
    load_point_displacement: np.ndarray
    source: str = ""
    harmonics: int = 0
    periodicity: FrozenMap = field(default_factory=lambda: FrozenMap({}))
    correlated_noise: bool = False
    load_point_history: np.ndarray = field(default_factory=lambda: np.empty((0, 4)))
    sigma: float | None = None
    shared_start: bool = False
    convergence: FrozenMap = field(default_factory=lambda: FrozenMap({}))

    ARRAYS = (
        "t",
        "data",
        "best_fit",
        "residuals",
        "load_point_velocity",
        "load_point_displacement",
        "load_point_history",
    )

    def __repr__(self) -> str:
        shown = [n for n in ("a", "b", "Dc", "b1", "Dc1", "b2", "Dc2") if n in self.params]
        values = ", ".join(f"{n}={self.params[n]:.4g}" for n in shown)
        return f"RateStateFitResult({'+'.join(self.laws)}, success={self.success}, {values})"

    @property
    def a_minus_b(self) -> float:
        """a - sum of b [-]."""
        return self.params["a"] - sum(
            self.params[n] for n in self.names if n == "b" or (n[:1] == "b" and n[1:].isdigit())
        )

    @property
    def a_minus_b_stderr(self) -> float:
        """Standard error of a - b [-] from the covariance (0 for held parameters)."""
        bs = [n for n in self.names if n == "b" or (n[:1] == "b" and n[1:].isdigit())]
        weights = {"a": 1.0, **dict.fromkeys(bs, -1.0)}
        free = [n for n in weights if n in self.covar]
        variance = sum(weights[p] * weights[q] * self.covar[p][q] for p in free for q in free)
        return float(np.sqrt(max(variance, 0.0)))

    @property
    def residual_rms(self) -> float:
        """Root mean square of the residuals [-]."""
        return float(np.sqrt(np.mean(self.residuals**2)))

    @property
    def ripple(self) -> np.ndarray:
        """The fitted apparatus ripple at the fitted points [-] (zeros without one)."""
        if not self.harmonics:
            return np.zeros(self.t.shape)
        from granflow.fitting.rsf_periodic import harmonic_names, periodic_terms

        amplitudes = [self.params[n] for n in harmonic_names(self.harmonics)]
        return periodic_terms(self.load_point_displacement, self.params["wavelength"], amplitudes)

    def ripple_amplitudes(self) -> dict[str, float]:
        """Amplitude [-] of each harmonic of the fitted ripple, ``sqrt(cos_h^2 + sin_h^2)``,
        by harmonic (``"1"``, ``"2"``, ...); empty without one."""
        return {
            str(h): float(np.hypot(self.params[f"cos{h}"], self.params[f"sin{h}"]))
            for h in range(1, self.harmonics + 1)
        }

    def _ripple_rows(self):
        rows = []
        if self.harmonics:
            amplitudes = ", ".join(
                f"{value:.3g} (h={h})" for h, value in self.ripple_amplitudes().items()
            )
            rows.append(
                (
                    "ripple",
                    f"wavelength {self.params['wavelength'] * 1e6:.4g} +/- "
                    f"{self.stderr['wavelength'] * 1e6:.2g} µm, amplitudes {amplitudes}",
                )
            )
        check = self.periodicity
        if check:
            verdict = "significant" if check["significant"] else "not significant"
            line = (
                f"{'left: ' if self.harmonics else ''}wavelength "
                f"{check['wavelength'] * 1e6:.4g} µm, amplitude {check['amplitude']:.3g}, "
                f"{100 * check['fraction']:.0f}% of the residual variance, false alarm "
                f"{check['false_alarm']:.2g} ({verdict})"
            )
            if check["significant"] and not self.harmonics:
                line += "; consider periodic=True"
            rows.append(("periodic residual", line))
        return rows

    def _noise_text(self):
        if self.correlated_noise:
            return (
                f"correlated: uncertainties scaled by the correlation time "
                f"(x{np.sqrt(max(self.correlation_time, 1.0)):.3g} in standard error)"
            )
        return "white (uncertainties not scaled)"

    def _report_rows(self) -> dict[str, list[tuple[str, object]]]:
        """The rows :meth:`report` and :meth:`_repr_html_` add to the fit statistics."""
        from granflow._format import format_number, format_value_error

        return {
            "extra": [("windows [s]", ", ".join(f"{lo:g}..{hi:g}" for lo, hi in self.windows))],
            "after": [
                ("residual RMS", format_number(self.residual_rms, significant=3)),
                ("HF scatter", format_number(self.noise, significant=3)),
                ("correlation time", f"{self.correlation_time:.3g} points"),
                ("noise", self._noise_text()),
                ("a - b", format_value_error(self.a_minus_b, self.a_minus_b_stderr)),
                *self._ripple_rows(),
            ],
        }

    def report(self) -> str:
        """A text report in the manner of lmfit's ``fit_report``: every value with the digits
        its error justifies, lengths in µm."""
        return fit_report(
            self, title=f"Rate-and-state fit ({', '.join(self.laws)} law)", **self._report_rows()
        )

    def _repr_html_(self) -> str:
        """The fit as HTML tables (Jupyter), built from its fields: statistics, variables in
        display units (Dc in µm) with their intervals, correlations."""
        from granflow._html import fit_html

        title = f"RateStateFitResult: {'+'.join(self.laws)} law" + (
            f" of {self.source}" if self.source else ""
        )
        return fit_html(self, title=title, **self._report_rows())

    def log_likelihood(self) -> Likelihood:
        """The likelihood of the free parameters, the fit's model simulated again from the
        result's points, protocol, windows and held values
        (:func:`granflow.fitting.rsf_posterior.rate_state_likelihood`)."""
        from granflow.fitting.rsf_posterior import rate_state_likelihood

        return rate_state_likelihood(self)

    def comparison_row(self) -> dict[str, Any]:
        """The fit's row of a model comparison (model ``rsf_<law>``)."""
        law = "+".join(self.laws)
        return comparison_row(self, f"rsf_{law}", f"rate-and-state, {law} law, spring k")

    def to_dict(self, include_arrays: bool = True) -> dict[str, Any]:
        """JSON-safe mapping, with its ``family``; :meth:`from_dict` inverts it."""
        return encode(
            {
                "family": family_of(self),
                "laws": list(self.laws),
                "names": list(self.names),
                **estimates(self),
                "units": dict(self.units),
                "fixed": list(self.fixed),
                "ci_method": dict(self.ci_method),
                "windows": [list(w) for w in self.windows],
                "v_ref": list(self.v_ref),
                "noise": self.noise,
                "correlation_time": self.correlation_time,
                "source": self.source,
                "harmonics": self.harmonics,
                "periodicity": dict(self.periodicity),
                "correlated_noise": self.correlated_noise,
                "sigma": self.sigma,
                "shared_start": self.shared_start,
                "convergence": dict(self.convergence),
                **statistics(self),
                **arrays(self, include_arrays),
            }
        )

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> RateStateFitResult:
        """The result a :meth:`to_dict` output (or its JSON) describes."""
        d = decode(d, cls)
        return cls(
            **decoded(d),
            laws=tuple(d["laws"]),
            names=tuple(d["names"]),
            units=FrozenMap(d["units"]),
            fixed=tuple(d["fixed"]),
            ci_method=FrozenMap(d["ci_method"]),
            windows=tuple(tuple(float(v) for v in w) for w in d["windows"]),
            v_ref=tuple(float(v) for v in d["v_ref"]),
            noise=float(d["noise"]),
            correlation_time=float(d["correlation_time"]),
            source=d.get("source", ""),
            harmonics=int(d.get("harmonics", 0)),
            periodicity=FrozenMap(d.get("periodicity", {})),
            correlated_noise=bool(d.get("correlated_noise", False)),
            sigma=None if d.get("sigma") is None else float(d["sigma"]),
            shared_start=bool(d.get("shared_start", False)),
            convergence=FrozenMap(d.get("convergence", {})),
            **read_arrays(cls, d),
        )

    def plot(self, axes: Sequence[Axes] | None = None) -> tuple[Axes, Axes]:
        """The data with the fit (top) and the residuals (bottom); returns the two Axes
        (:func:`granflow.plotting.rsf.plot_rsf_fit`).

        ``axes``: two matplotlib Axes to draw into (default: a new figure).
        """
        from granflow.plotting.rsf import plot_rsf_fit

        return plot_rsf_fit(self, axes)
