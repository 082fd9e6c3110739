"""Forecasts scored as forecasts are scored: proper scores of the whole distribution of the
failure time, its reliability, its sharpness and its skill over a reference method.

Every forecast is read as one distribution of the failure time on ``[until, horizon]``
(:class:`TimeDistribution`), the same way for every method:

* its CDF is the forecast's own table (``cdf``: times [s] and probabilities [-], the table
  behind its interval and ``probability_within``), joined by straight lines from 0 at the
  cut (``until``: the layer has not failed by then) to 1 at a far horizon,
  ``until * (1 + horizon)`` (default ``horizon = 4``: four times the record's length
  beyond the cut);
* so the probability a forecast leaves beyond its last node (a record that does not bound
  the failure) is spread evenly up to the horizon; nodes beyond the horizon are moved to it
  (their probability is then a point mass there); probability placed before the cut is a
  point mass at the cut;
* a forecast without a distribution (declined, or no date) is the uninformative one:
  uniform on ``[until, horizon]``, its interval the whole range. Declining is not free: it
  scores as saying nothing.

The scores, each a mean over the records with its standard error (smaller is better except
coverage): the CRPS [s] (``scoringrules.crps_quantile`` over 1000 quantile levels: the mean
pinball loss, which converges to the CRPS as the levels fill (0, 1)); the logarithmic score
[-] (minus the natural log of the density [1/s] at the truth; a density below a millionth of
the uninformative one's counts as that); the interval score [s] of the forecast's own
interval, its ends held to ``[until, horizon]`` (``scoringrules.interval_score``, alpha =
1 - level). Coverage [-] and sharpness [s] (the median width) are those of the intervals the
forecasts gave (the issued ones); the PIT is the CDF at the truth (uniform where the
forecasts are calibrated), and the reliability of ``probability_within`` is read at
horizons that are fractions of the cut time.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from granflow.errors import InvalidDataError

__all__ = ["HORIZON", "WITHIN", "Scores", "TimeDistribution", "score", "skill"]

#: The far horizon beyond the cut, in units of the cut time: the distribution ends at
#: ``until * (1 + HORIZON)``.
HORIZON = 4.0
#: ``probability_within`` is read at these horizons, as fractions of the cut time.
WITHIN = (0.05, 0.1, 0.2, 0.4, 0.8)
_LEVELS = (np.arange(1000) + 0.5) / 1000.0  # the CRPS's quantile levels
_DENSITY_FLOOR = 1e-6  # of the uninformative forecast's density


@dataclass(frozen=True)
class TimeDistribution:
    """A forecast's failure time as a piecewise-linear CDF on ``[until, end]``.

    Attributes
    ----------
    time : numpy.ndarray
        Nodes [s], non-decreasing, from ``until`` to ``end`` (a repeated node is a point
        mass).
    probability : numpy.ndarray
        The CDF at the nodes [-], non-decreasing from 0 to 1.
    until, end : float
        The cut and the far horizon [s].
    issued : bool
        Whether the forecast gave a distribution (False: the uninformative one).
    """

    time: np.ndarray
    probability: np.ndarray
    until: float
    end: float
    issued: bool

    @classmethod
    def of(cls, forecast: Any, horizon: float = HORIZON) -> TimeDistribution:
        """The distribution of a forecast (anything with ``until``, ``cdf`` and optionally
        ``declined``), by the rules of the module's docstring."""
        until = float(forecast.until)
        if not (math.isfinite(until) and until > 0):
            raise InvalidDataError(f"a scored forecast's cut must be positive [s], got {until}")
        end = until * (1.0 + horizon)
        table = getattr(forecast, "cdf", None) or {}
        times = np.asarray(table.get("time", []), dtype=float)
        values = np.asarray(table.get("probability", []), dtype=float)
        keep = np.isfinite(times) & np.isfinite(values)
        times, values = times[keep], values[keep]
        issued = bool(times.size) and not getattr(forecast, "declined", False)
        if not issued or not np.any(values > 0):
            return cls(np.array([until, end]), np.array([0.0, 1.0]), until, end, False)
        order = np.argsort(times, kind="stable")
        times = times[order]
        values = np.maximum.accumulate(np.clip(values[order], 0.0, 1.0))
        # the table's CDF at the cut and at the horizon: point masses there
        at_cut = float(np.interp(until, times, values, left=0.0))
        at_end = float(np.interp(end, times, values, left=0.0))
        inside = (times > until) & (times < end)
        tail = ([end, end], [at_end, 1.0]) if times[-1] >= end else ([end], [1.0])
        nodes = np.concatenate([[until, until], times[inside], tail[0]])
        probability = np.concatenate([[0.0, at_cut], values[inside], tail[1]])
        return cls(nodes, probability, until, end, True)

    def cdf(self, x: Any) -> Any:
        """P(T <= x) [-] at ``x`` [s] (the right-continuous value at a point mass)."""
        x = np.asarray(x, dtype=float)
        index = np.searchsorted(self.time, x, side="right")
        out = np.interp(x, self.time, self.probability)
        # at a repeated node the CDF has jumped already: the largest value there
        at_node = (index > 0) & (self.time[np.maximum(index - 1, 0)] == x)
        out = np.where(at_node, self.probability[np.maximum(index - 1, 0)], out)
        out = np.where(x < self.until, 0.0, np.where(x >= self.end, 1.0, out))
        return float(out) if out.ndim == 0 else out

    def quantile(self, p: Any) -> Any:
        """The time [s] at which the CDF reaches ``p`` (the left-continuous inverse)."""
        p = np.asarray(p, dtype=float)
        index = np.clip(np.searchsorted(self.probability, p, side="left"), 1, self.time.size - 1)
        p0, p1 = self.probability[index - 1], self.probability[index]
        t0, t1 = self.time[index - 1], self.time[index]
        weight = np.where(p1 > p0, (p - p0) / np.where(p1 > p0, p1 - p0, 1.0), 1.0)
        out = t0 + np.clip(weight, 0.0, 1.0) * (t1 - t0)
        out = np.where(p <= 0.0, self.until, out)
        return float(out) if out.ndim == 0 else out

    def density(self, x: float) -> float:
        """The density [1/s] at ``x`` [s]: the CDF's slope on the segment that holds x (0
        outside the range or on a flat segment)."""
        if not self.until < x < self.end:
            return 0.0
        k = int(np.searchsorted(self.time, x, side="right"))
        width = self.time[k] - self.time[k - 1]
        if not width > 0:
            return 0.0
        return float((self.probability[k] - self.probability[k - 1]) / width)


def _mean_se(values):
    values = np.asarray(values, dtype=float)
    if not values.size:
        return math.nan, math.nan
    se = float(np.std(values, ddof=1) / math.sqrt(values.size)) if values.size > 1 else math.nan
    return float(np.mean(values)), se


@dataclass(frozen=True)
class Scores:
    """The scores of a set of forecasts against the truths.

    Attributes
    ----------
    count : int
        Forecasts scored.
    issued : int
        Forecasts that gave a distribution and an interval (not declined).
    declined : float
        The share of forecasts that declined or gave no date [-].
    crps, crps_se : float
        Mean continuous ranked probability score and its standard error [s].
    log_score, log_score_se : float
        Mean logarithmic score (minus the log density [1/s] at the truth) and its error [-].
    interval_score, interval_score_se : float
        Mean interval score of the ``level`` intervals and its error [s].
    coverage, coverage_se : float
        The share of the issued intervals that hold the truth and its binomial error [-].
    sharpness : float
        The median width of the issued intervals (held to the horizon) [s].
    pit : numpy.ndarray
        The CDF at the truth of each forecast [-].
    pit_histogram : numpy.ndarray
        Counts of the issued forecasts' PIT in ten equal bins of [0, 1].
    reliability : list of tuple
        ``(mean predicted probability, observed frequency, count)`` of
        ``probability_within`` at :data:`WITHIN`, binned in tenths of the prediction.
    level : float
        The intervals' level [-].
    crps_values, log_values, interval_values : numpy.ndarray
        Each forecast's scores (for paired comparisons: :func:`skill`).
    issued_mask : numpy.ndarray
        Which forecasts were issued.
    """

    count: int
    issued: int
    declined: float
    crps: float
    crps_se: float
    log_score: float
    log_score_se: float
    interval_score: float
    interval_score_se: float
    coverage: float
    coverage_se: float
    sharpness: float
    level: float
    pit: np.ndarray = field(repr=False)
    pit_histogram: np.ndarray = field(repr=False)
    reliability: list = field(repr=False)
    crps_values: np.ndarray = field(repr=False)
    log_values: np.ndarray = field(repr=False)
    interval_values: np.ndarray = field(repr=False)
    issued_mask: np.ndarray = field(repr=False)

    def skill(self, reference: Scores) -> tuple[float, float]:
        """The CRPS skill over ``reference`` (scores of the same records): see
        :func:`skill`."""
        return skill(self, reference)


def skill(scores: Scores, reference: Scores) -> tuple[float, float]:
    """``(1 - CRPS / CRPS_reference, standard error)`` [-] over the same records, paired:
    positive where ``scores`` beat the reference. The error is the delta method's, from the
    records' paired CRPS."""
    a, b = np.asarray(scores.crps_values), np.asarray(reference.crps_values)
    if a.shape != b.shape:
        raise InvalidDataError(
            f"skill needs the scores of the same records: {a.size} against {b.size}"
        )
    if not a.size or not np.mean(b) > 0:
        return math.nan, math.nan
    ratio = float(np.mean(a) / np.mean(b))
    if a.size < 2:
        return 1.0 - ratio, math.nan
    # the ratio of means: its variance from the residuals a - ratio b
    residual = a - ratio * b
    se = float(np.std(residual, ddof=1) / math.sqrt(a.size) / np.mean(b))
    return 1.0 - ratio, se


def _checked(forecasts, truths):
    forecasts = list(forecasts)
    truths = np.asarray(truths, dtype=float).ravel()
    if len(forecasts) != truths.size:
        raise InvalidDataError(
            f"score needs one truth per forecast: {len(forecasts)} forecasts, {truths.size} truths"
        )
    if not np.all(np.isfinite(truths)):
        raise InvalidDataError("the truths (failure times [s]) must be finite")
    return forecasts, truths


def _interval(forecast, distribution):
    """The forecast's interval held to [until, end]; the whole range where it gave none."""
    if not distribution.issued:
        return distribution.until, distribution.end
    low, high = (float(v) for v in forecast.time_interval)
    if not math.isfinite(low):
        return distribution.until, distribution.end
    high = high if math.isfinite(high) else distribution.end
    return (
        min(max(low, distribution.until), distribution.end),
        min(max(high, distribution.until), distribution.end),
    )


def score(
    forecasts: Sequence[Any],
    truths: Any,
    *,
    horizon: float = HORIZON,
    within: Sequence[float] = WITHIN,
) -> Scores:
    """Score failure forecasts against the true failure times.

    Parameters
    ----------
    forecasts : sequence
        :class:`~granflow.FailureForecast` s (or any forecast with ``until``, ``cdf``,
        ``time_interval`` and ``level``: the baselines of
        :mod:`granflow.forecast.references`, a :class:`~granflow.PeakForecast`).
    truths : array_like
        The true failure times [s], one per forecast, on the records' clock.
    horizon : float
        The far horizon beyond the cut, in units of the cut time (see the module's
        docstring); default 4.
    within : sequence of float
        Horizons at which ``probability_within`` is judged, as fractions of the cut time.

    Returns
    -------
    Scores

    Examples
    --------
    >>> from granflow.forecast import score
    >>> from granflow.forecast.scoring import TimeDistribution
    >>> class Uniform:  # a forecast: failure uniform between 110 and 130 s
    ...     until, level, time_interval, declined = 100.0, 0.9, (111.0, 129.0), False
    ...     cdf = {"time": [110.0, 130.0], "probability": [0.0, 1.0]}
    >>> s = score([Uniform()], [120.0])
    >>> round(s.crps, 3)  # (130 - 110) / 12 at the middle of a uniform
    1.667
    """
    import scoringrules as sr

    forecasts, truths = _checked(forecasts, truths)
    if not forecasts:
        raise InvalidDataError("score needs at least one forecast")
    distributions = [TimeDistribution.of(f, horizon) for f in forecasts]
    quantiles = np.array([d.quantile(_LEVELS) for d in distributions])
    crps = np.asarray(sr.crps_quantile(truths, quantiles, _LEVELS), dtype=float).reshape(-1)
    logs, ends, transforms = [], [], []
    for forecast, distribution, truth in zip(forecasts, distributions, truths, strict=True):
        floor = _DENSITY_FLOOR / (distribution.end - distribution.until)
        logs.append(-math.log(max(distribution.density(truth), floor)))
        ends.append(_interval(forecast, distribution))
        transforms.append(distribution.cdf(truth))
    lows, highs = np.array(ends).T
    alphas = np.array([1.0 - float(f.level) for f in forecasts])
    interval = np.empty(truths.size)
    for alpha in np.unique(alphas):  # one call per level (an array of alphas is an axis)
        chosen = alphas == alpha
        interval[chosen] = np.asarray(
            sr.interval_score(truths[chosen], lows[chosen], highs[chosen], float(alpha)),
            dtype=float,
        ).reshape(-1)
    issued = np.array([d.issued for d in distributions])
    covered = (lows <= truths) & (truths <= highs)
    if issued.any():
        share = float(np.mean(covered[issued]))
        share_se = math.sqrt(max(share * (1 - share), 1e-12) / int(issued.sum()))
        sharpness = float(np.median((highs - lows)[issued]))
    else:
        share = share_se = sharpness = math.nan
    pit = np.array(transforms)
    histogram = np.histogram(pit[issued], bins=10, range=(0.0, 1.0))[0]
    levels = {float(f.level) for f in forecasts}
    return Scores(
        count=len(forecasts),
        issued=int(issued.sum()),
        declined=float(1.0 - np.mean(issued)),
        crps=_mean_se(crps)[0],
        crps_se=_mean_se(crps)[1],
        log_score=_mean_se(logs)[0],
        log_score_se=_mean_se(logs)[1],
        interval_score=_mean_se(interval)[0],
        interval_score_se=_mean_se(interval)[1],
        coverage=share,
        coverage_se=share_se,
        sharpness=sharpness,
        level=levels.pop() if len(levels) == 1 else math.nan,
        pit=pit,
        pit_histogram=histogram,
        reliability=_reliability(distributions, truths, within),
        crps_values=crps,
        log_values=np.array(logs),
        interval_values=interval,
        issued_mask=issued,
    )


def _reliability(distributions, truths, within, bins=10):
    """(mean prediction, observed frequency, count) per tenth of the predictions of the
    failure within ``h * until`` after the cut, over every forecast and horizon h."""
    pairs = np.array(
        [
            (d.cdf(d.until * (1.0 + h)), float(truth <= d.until * (1.0 + h)))
            for d, truth in zip(distributions, truths, strict=True)
            for h in within
        ],
        dtype=float,
    ).reshape(-1, 2)
    index = np.clip((pairs[:, 0] * bins).astype(int), 0, bins - 1)
    rows = []
    for k in range(bins):
        chosen = pairs[index == k]
        if chosen.size:
            rows.append((float(chosen[:, 0].mean()), float(chosen[:, 1].mean()), len(chosen)))
    return rows
