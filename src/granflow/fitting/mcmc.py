"""Bayesian posterior of a fit with emcee (the optional extra ``granflow[mcmc]``).

One path for every model family: the fit result's ``log_likelihood()``
(:class:`granflow.families.FamilyFit`) gives the free parameters, their least-squares values,
standard errors and default priors, and the log-likelihood, rebuilt from the result's own
data (so a result read back from JSON is sampled like the one fitted). Walkers move in log
coordinates for log-uniform parameters, so the prior is flat there.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from granflow._progress import progress_bar
from granflow._seeds import two_streams
from granflow.errors import ConvergenceWarning, InvalidParameterError
from granflow.families import FamilyFit
from granflow.fitting.results import (
    FrozenMap,
    ValueEquality,
    arrays,
    decode,
    encode,
    intervals,
    number,
    numbers,
    read_arrays,
)

if TYPE_CHECKING:
    from matplotlib.figure import Figure

    from granflow._typing import FloatArray

__all__ = ["PosteriorResult", "sample_posterior"]

_PRIOR_KINDS = ("log-uniform", "uniform")
_TAU_FACTOR = 50  # chains shorter than 50 autocorrelation times are flagged


def _emcee():
    try:
        import emcee
    except ImportError as exc:  # pragma: no cover - depends on the environment
        raise ImportError(
            "sample_posterior needs emcee: install the extra with "
            "`pip install granflow[mcmc]` (emcee and corner)"
        ) from exc
    return emcee


@dataclass(frozen=True, eq=False)
class PosteriorResult(ValueEquality):
    """Samples of the posterior of a fit.

    Attributes
    ----------
    names : tuple of str
        The sampled (free) parameters.
    chain : numpy.ndarray
        Samples after burn-in, shape (steps, walkers, parameters), natural SI units.
    medians, std : mapping of str to float
        Posterior median and standard deviation.
    ci68, ci95 : mapping of str to (float, float)
        Central 68 % and 95 % credible intervals.
    autocorr : mapping of str to float
        Integrated autocorrelation time [steps].
    acceptance_fraction : float
        Mean acceptance fraction of the walkers.
    converged : bool
        Whether the chain is longer than 50 autocorrelation times.
    least_squares : mapping of str to float
        The least-squares values the sampler started from.
    priors : mapping of str to (str, float, float)
    seed : int or None
    shape : (int, int, int)
        Steps, walkers and parameters of the chain sampled (taken from ``chain`` when not
        given; kept when the compact ``to_dict(include_arrays=False)`` leaves the chain out).
    """

    names: tuple
    chain: np.ndarray
    medians: FrozenMap
    std: FrozenMap
    ci68: FrozenMap
    ci95: FrozenMap
    autocorr: FrozenMap
    acceptance_fraction: float
    converged: bool
    least_squares: FrozenMap
    priors: FrozenMap
    seed: int | None
    shape: tuple[int, ...] = None  # type: ignore[assignment]  # __post_init__ fills it in

    #: The samples, which the compact ``to_dict(include_arrays=False)`` leaves out.
    ARRAYS = ("chain",)

    def __post_init__(self):
        if self.shape is None:
            object.__setattr__(self, "shape", tuple(self.chain.shape))

    @property
    def samples(self) -> FloatArray:
        """The chain flattened over walkers, shape (steps * walkers, parameters)."""
        return self.chain.reshape(-1, len(self.names))

    def __repr__(self):
        values = ", ".join(f"{n}={self.medians[n]:.4g}" for n in self.names)
        steps, walkers, _ = self.shape
        return f"PosteriorResult({steps} steps x {walkers} walkers, {values})"

    def report(self) -> str:
        """Medians with 68 % and 95 % intervals, autocorrelation times."""
        lines = [
            f"[[Posterior]] {self.shape[0]} steps x {self.shape[1]} walkers, "
            f"acceptance {self.acceptance_fraction:.2f}, "
            f"{'converged' if self.converged else 'CHAINS TOO SHORT'}"
        ]
        for n in self.names:
            lines.append(
                f"    {n:<5} = {self.medians[n]:.6g}  68%: [{self.ci68[n][0]:.6g}, "
                f"{self.ci68[n][1]:.6g}]  95%: [{self.ci95[n][0]:.6g}, {self.ci95[n][1]:.6g}]  "
                f"tau = {self.autocorr[n]:.1f}  (least squares {self.least_squares[n]:.6g})"
            )
        return "\n".join(lines)

    def _repr_html_(self) -> str:
        """Medians, intervals and autocorrelation times as an HTML table (Jupyter)."""
        from granflow._format import format_interval, format_number
        from granflow._html import result_html, table

        steps, walkers, _ = self.shape
        state = "converged" if self.converged else "chains too short"
        rows = [
            (
                name,
                format_number(self.medians[name], significant=5),
                format_interval(self.ci68[name], significant=5),
                format_interval(self.ci95[name], significant=5),
                f"{self.autocorr[name]:.1f}",
                format_number(self.least_squares[name], significant=5),
            )
            for name in self.names
        ]
        header = ("name", "median", "68 % interval", "95 % interval", "tau", "least squares")
        return result_html(
            f"PosteriorResult: {steps} steps × {walkers} walkers, acceptance "
            f"{self.acceptance_fraction:.2f}, {state}",
            [table(rows, header=header, numeric=(1, 4, 5))],
        )

    def to_dict(self, include_arrays: bool = True) -> dict[str, Any]:
        """JSON-safe mapping with the chain as nested lists; :meth:`from_dict` inverts it.

        Parameters
        ----------
        include_arrays : bool
            Include the chain (False: a compact summary with the statistics and the chain's
            shape, which :meth:`from_dict` rebuilds with an empty chain).
        """
        return encode(
            {
                "names": list(self.names),
                "medians": dict(self.medians),
                "std": dict(self.std),
                "ci68": {k: list(v) for k, v in self.ci68.items()},
                "ci95": {k: list(v) for k, v in self.ci95.items()},
                "autocorr": dict(self.autocorr),
                "acceptance_fraction": self.acceptance_fraction,
                "converged": self.converged,
                "least_squares": dict(self.least_squares),
                "priors": {k: list(v) for k, v in self.priors.items()},
                "seed": self.seed,
                "shape": list(self.shape),
                **arrays(self, include_arrays),
            }
        )

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> PosteriorResult:
        """The result a :meth:`to_dict` output (or its JSON) describes."""
        d = decode(d, cls)
        shape = tuple(int(size) for size in d["shape"])
        chain = read_arrays(cls, d)["chain"].reshape(shape if "chain" in d else (0, *shape[1:]))
        return cls(
            names=tuple(d["names"]),
            chain=chain,
            medians=numbers(d["medians"]),
            std=numbers(d["std"]),
            ci68=intervals(d["ci68"]),
            ci95=intervals(d["ci95"]),
            autocorr=numbers(d["autocorr"]),
            acceptance_fraction=number(d["acceptance_fraction"]),
            converged=d["converged"],
            least_squares=numbers(d["least_squares"]),
            priors=FrozenMap(
                {
                    name: (kind, number(low), number(high))
                    for name, (kind, low, high) in d["priors"].items()
                }
            ),
            seed=d["seed"],
            shape=shape,
        )

    def plot_corner(self, **kwargs: Any) -> Figure:
        """Corner plot of the samples; see :func:`granflow.plotting.plot_corner`."""
        from granflow.plotting.fits import plot_corner

        return plot_corner(self, **kwargs)


def priors_for(values, priors, default):
    """The prior (kind, low, high) of each free parameter: ``priors[name]`` where given
    (checked), else ``default(name, value)``; ``values`` maps the free parameters' names to
    their least-squares values, which every prior must hold."""
    chosen = {}
    priors = dict(priors or {})
    for name in priors:
        if name not in values:
            raise InvalidParameterError(
                f"priors: {name!r} is not a free parameter of the fit ({', '.join(values)})"
            )
    for name, value in values.items():
        if name in priors:
            kind, low, high = priors[name]
            if kind not in _PRIOR_KINDS:
                raise InvalidParameterError(
                    f"priors[{name!r}]: kind must be 'log-uniform' or 'uniform', got {kind!r}"
                )
            low, high = float(low), float(high)
            if not low < high or (kind == "log-uniform" and low <= 0):
                raise InvalidParameterError(f"priors[{name!r}]: need 0 < low < high for {kind}")
        else:
            kind, low, high = default(name, value)
        if not low <= value <= high:
            raise InvalidParameterError(
                f"priors[{name!r}]: the least-squares value {value:.6g} lies outside "
                f"[{low:.6g}, {high:.6g}]"
            )
        chosen[name] = (kind, low, high)
    return chosen


def sample_posterior(
    fit_result: FamilyFit,
    *,
    priors: Mapping[str, tuple[str, float, float]] | None = None,
    nwalkers: int = 32,
    nsteps: int = 2000,
    burn: int | None = None,
    seed: int | None = None,
    progress: bool | None = None,
) -> PosteriorResult:
    """Sample the posterior of a fit with emcee's affine-invariant ensemble.

    Parameters
    ----------
    fit_result : FamilyFit
        A fit result of any model family (:class:`granflow.families.FamilyFit`: a result of
        :func:`granflow.fit`, :func:`granflow.fit_creep` and the other families' fits),
        also one read back with ``from_dict``: its ``log_likelihood()`` is rebuilt from the
        result's stored data. Its free parameters are sampled, fixed ones stay.
    priors : mapping of str to (kind, low, high), optional
        ``kind`` is ``"log-uniform"`` or ``"uniform"``, bounds in SI. Default: the result's
        own (its likelihood's ``priors``); for Eq. 3 log-uniform on [value/1000,
        value*1000] for a, alpha (k), x0 (t0) and uniform on [0, 10 value] for Fd.
    nwalkers : int
        Walkers (at least twice the number of free parameters).
    nsteps : int
        Steps per walker.
    burn : int, optional
        Steps discarded at the start; default ``nsteps // 4``.
    seed : int, optional
        Seed of the initial positions and of the sampler: a seeded run is reproducible exactly.
    progress : bool or None
        A progress bar over the steps on stderr (tqdm: a widget in Jupyter): True, False, or
        None (default) for one when a person watches (a terminal or Jupyter).

    Returns
    -------
    PosteriorResult

    Warns
    -----
    ConvergenceWarning
        When the chain after burn-in is shorter than 50 autocorrelation times.

    Examples
    --------
    >>> import numpy as np, granflow
    >>> x = np.linspace(3e-7, 4e-4, 300)
    >>> p = granflow.Params(3e-3, 4e4, 10e-3, 2e-7)
    >>> y = granflow.friction_slip(x, p) + np.random.default_rng(0).normal(0, 5e-5, 300)
    >>> post = granflow.sample_posterior(granflow.fit((x, y)), nsteps=300, seed=1)  # doctest: +SKIP
    """
    if not isinstance(fit_result, FamilyFit):
        raise InvalidParameterError(
            "fit_result must be a fit result of a model family (a granflow.FitResult, "
            f"CurveFitResult, ...: granflow.families.FamilyFit), got {type(fit_result).__name__}"
        )
    likelihood = fit_result.log_likelihood()
    values = {name: likelihood.values[name] for name in likelihood.names}
    chosen = priors_for(values, priors, lambda name, _: likelihood.priors[name])
    sampling = (nwalkers, nsteps, burn, seed, progress)
    return sample(likelihood.function, chosen, values, likelihood.stderr, sampling)


def _checked(ndim, nwalkers, nsteps, burn):
    """(nwalkers, nsteps, burn) checked against ``ndim`` free parameters."""
    if isinstance(nwalkers, bool) or not isinstance(nwalkers, int) or nwalkers < 2 * ndim:
        raise InvalidParameterError(f"nwalkers must be an integer >= {2 * ndim}, got {nwalkers!r}")
    if isinstance(nsteps, bool) or not isinstance(nsteps, int) or nsteps < 10:
        raise InvalidParameterError(f"nsteps must be an integer >= 10, got {nsteps!r}")
    burn = nsteps // 4 if burn is None else int(burn)
    if not 0 <= burn < nsteps:
        raise InvalidParameterError(f"burn must lie in [0, nsteps), got {burn}")
    return nwalkers, nsteps, burn


def sample(log_likelihood, chosen, least_squares, spread, sampling):
    """Run emcee over the parameters of ``chosen`` (name: (kind, low, high) priors, in order)
    and summarise the chain.

    Parameters
    ----------
    log_likelihood : callable
        ``log_likelihood(values) -> float`` at the parameters' natural values (SI), in the
        order of ``chosen``.
    chosen : mapping of str to (str, float, float)
        The priors; walkers move in ln(value) for log-uniform ones (flat there).
    least_squares, spread : mapping of str to float
        The least-squares values (the walkers start about them) and their standard errors.
    sampling : tuple
        ``(nwalkers, nsteps, burn, seed, progress)`` as :func:`sample_posterior` takes them.
    """
    emcee = _emcee()
    free = list(chosen)
    ndim = len(free)
    nwalkers, nsteps, burn, seed, progress = sampling
    nwalkers, nsteps, burn = _checked(ndim, nwalkers, nsteps, burn)
    log_axis = np.array([chosen[n][0] == "log-uniform" for n in free])
    low = np.array([chosen[n][1] for n in free])
    high = np.array([chosen[n][2] for n in free])
    low_u = np.where(log_axis, np.log(np.where(log_axis, low, 1.0)), low)
    high_u = np.where(log_axis, np.log(np.where(log_axis, high, 1.0)), high)

    def natural(u):
        return np.where(log_axis, np.exp(u), u)

    def log_probability(u):
        if np.any(u < low_u) or np.any(u > high_u):
            return -np.inf
        value = log_likelihood(natural(u))
        return value if math.isfinite(value) else -np.inf

    start_rng, sampler_seed = two_streams(seed)
    best = np.array([least_squares[n] for n in free])
    centre = np.where(log_axis, np.log(np.maximum(best, 1e-300)), best)
    error = np.array([spread[n] for n in free])
    spread_u = np.where(log_axis, error / np.abs(best), error)
    spread_u = np.where(spread_u > 0, spread_u, 1e-6 * np.maximum(np.abs(centre), 1e-12))
    start = centre + 0.1 * spread_u * start_rng.standard_normal((nwalkers, ndim))
    start = np.clip(start, low_u, high_u)
    sampler = emcee.EnsembleSampler(nwalkers, ndim, log_probability)
    sampler.random_state = np.random.RandomState(int(sampler_seed)).get_state()
    bar = progress_bar(nsteps, progress=progress, desc="sampling", unit="step")
    try:
        for _ in sampler.sample(start, iterations=nsteps):  # what run_mcmc does, with a bar
            bar.update()
    finally:
        bar.close()
    chain_u = sampler.get_chain(discard=burn)
    chain = np.where(log_axis, np.exp(chain_u), chain_u)
    chain.flags.writeable = False
    flat = chain.reshape(-1, ndim)
    tau = emcee.autocorr.integrated_time(chain_u, tol=0)
    converged = bool(chain.shape[0] >= _TAU_FACTOR * np.max(tau))
    if not converged:
        warnings.warn(
            f"the chains after burn-in ({chain.shape[0]} steps) are shorter than "
            f"{_TAU_FACTOR} autocorrelation times (max tau = {np.max(tau):.1f} steps): "
            "run more steps before trusting the intervals",
            ConvergenceWarning,
            stacklevel=3,
        )
    percentiles = np.percentile(flat, [2.5, 16, 50, 84, 97.5], axis=0)
    return PosteriorResult(
        names=tuple(free),
        chain=chain,
        medians=FrozenMap({n: float(percentiles[2, i]) for i, n in enumerate(free)}),
        std=FrozenMap({n: float(flat[:, i].std(ddof=1)) for i, n in enumerate(free)}),
        ci68=FrozenMap(
            {n: (float(percentiles[1, i]), float(percentiles[3, i])) for i, n in enumerate(free)}
        ),
        ci95=FrozenMap(
            {n: (float(percentiles[0, i]), float(percentiles[4, i])) for i, n in enumerate(free)}
        ),
        autocorr=FrozenMap({n: float(tau[i]) for i, n in enumerate(free)}),
        acceptance_fraction=float(np.mean(sampler.acceptance_fraction)),
        converged=converged,
        least_squares=FrozenMap({n: least_squares[n] for n in free}),
        priors=FrozenMap(chosen),
        seed=seed,
    )
