"""The frozen results of a forecast: each with ``to_dict``/``from_dict`` and ``report()``.

Clocks (the one-clock rule): a peak forecast's ``time`` is the start-up's record time (the
model's t, 0 when shearing starts) and its ``slip`` the slip since the start of shear, which
is the model's x = v t. A failure forecast's ``time`` is the force-controlled record's time
(0 when loading starts) and its ``slip`` the record's slip (0 at the start; the model's
coordinate is x = x0 + slip).
"""

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from granflow._html import HtmlReport
from granflow.fitting.results import Codec, FrozenMap
from granflow.forecast.loading import Loading
from granflow.forecast.series import ForecastSeries

if TYPE_CHECKING:
    import pandas as pd

__all__ = ["BaselineForecast", "FailureForecast", "ForecastSeries", "PeakForecast"]

PEAK_CLOCK = "start-up: record time = model t; slip since the start of shear = model x = v t"
FAILURE_CLOCK = "force control from rest: record time from 0; record slip = x - x0 (slip clock)"


#: How each method is named where it is shown.
METHOD_NAMES = {
    "model": "model (Eq. 2, quasi-static)",
    "inverse velocity": "inverse velocity (Fukuzono)",
    "voight": "Voight's law",
}


def _fmt(value, scale, unit, digits=4):
    from granflow._format import format_number

    if value is None or (isinstance(value, float) and math.isnan(value)):
        return "n/a"
    return f"{format_number(value, scale, digits)} {unit}".rstrip()


def _fmt_interval(pair, scale, unit):
    """``[low, high] unit`` with digits enough that the two ends differ."""
    from granflow._format import format_interval

    text = format_interval(list(pair), scale).replace("—", "n/a")
    return f"{text} {unit}".rstrip()


def _card(title, rows, notes=()):
    """An HTML card built from fields: a title, a table of (quantity, value, interval, unit)
    rows in display units, and notes."""
    from granflow._html import Html, result_html, table, text

    header = ("quantity", "value", "interval", "unit")
    parts = [table(rows, header=header, numeric=(1, 2))]
    parts += [Html(f"<p>{text(note)}</p>") for note in notes if note]
    return result_html(title, parts)


def _within(cdf, until, seconds):
    """CDF of a tabulated time distribution at ``until + seconds`` [s] (0 before its first
    node; its last value after its last)."""
    import numbers

    if not isinstance(seconds, numbers.Real) or isinstance(seconds, bool):
        from granflow.errors import InvalidDataError

        raise InvalidDataError(f"seconds must be a number [s], got {seconds!r}")
    seconds = float(seconds)
    if not seconds >= 0:
        from granflow.errors import InvalidDataError

        raise InvalidDataError(f"seconds must be zero or positive [s], got {seconds:g}")
    times, probability = cdf.get("time", []), cdf.get("probability", [])
    if not times:
        return 0.0
    when = until + seconds
    value = float(np.interp(when, times, probability, left=0.0, right=probability[-1]))
    return min(max(value, 0.0), 1.0)


class _Fitted:
    """What every model-based forecast shares with the fits: ``to_params()`` and the noise
    under its fits' name, ``sigma`` (``noise`` still answers, with a warning)."""

    params: Mapping[str, float]
    sigma: float

    def to_params(self) -> Any:
        """The best-fit parameters as :class:`granflow.Params` (slip domain, SI); None where
        the forecast has none."""
        from granflow.model.params import Params

        if not all(name in self.params for name in ("a", "alpha", "Fd", "x0")):
            return None
        return Params(**{name: self.params[name] for name in ("a", "alpha", "Fd", "x0")})

    @property
    def noise(self) -> float:
        """Deprecated name of :attr:`sigma`."""
        import warnings

        warnings.warn(
            "the forecasts' .noise is deprecated: read .sigma (the same standard deviation, "
            "as the fits name it)",
            DeprecationWarning,
            stacklevel=2,
        )
        return self.sigma

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> Any:
        """Inverse of :meth:`to_dict` (also of one written when ``sigma`` was ``noise``)."""
        if "noise" in d and "sigma" not in d:
            d = {("sigma" if key == "noise" else key): value for key, value in d.items()}
        return super().from_dict(d)  # type: ignore[misc]


@dataclass(frozen=True, eq=False)
class PeakForecast(_Fitted, HtmlReport, Codec):
    """The static yield of a rate-controlled start-up, forecast from its beginning.

    Attributes
    ----------
    force, force_interval : float, tuple
        Peak force F_peak and its predictive interval [N].
    slip, slip_interval : float, tuple
        Slip at the peak since the start of shear (the model's x_peak) and interval [m].
    time, time_interval : float, tuple
        Time of the peak on the record's clock and interval [s].
    velocity : float
        The start-up's velocity [m/s].
    until : float
        The cut: the last record time used [s].
    level : float
        Level of the intervals [-] (0.9: 90 %).
    params : mapping
        Best-fit a [N], alpha [1/m], Fd [N], x0 [m] (:meth:`to_params` gives the Params).
    sigma : float
        Force noise standard deviation used [N].
    n_points : int
        Points fitted.
    prior : dict or None
        The prior used (:meth:`Prior.to_dict`), if any.
    message : str
        What limits the forecast, or "".
    cdf : dict
        The distribution of the peak's time: "time" [s] and "probability" [-], the CDF at
        those times (read by :meth:`probability_within`).
    """

    force: float
    force_interval: tuple[float, float]
    slip: float
    slip_interval: tuple[float, float]
    time: float
    time_interval: tuple[float, float]
    velocity: float
    until: float
    level: float
    params: FrozenMap
    sigma: float
    n_points: int
    prior: dict | None = None
    message: str = ""
    clock: str = PEAK_CLOCK
    cdf: dict = dataclasses.field(default_factory=lambda: {"time": [], "probability": []})

    def probability_within(self, seconds: float) -> float:
        """The probability [-] that the peak comes within ``seconds`` [s] after the last
        sample used (``until``), from the distribution behind the intervals."""
        return _within(self.cdf, self.until, seconds)

    def __repr__(self):
        return (
            f"PeakForecast(force={self.force:.5g} N {self.force_interval}, "
            f"time={self.time:.4g} s, until={self.until:.4g} s)"
        )

    def _repr_html_(self) -> str:
        """An HTML card built from the fields (Jupyter), in display units."""
        from granflow._format import format_number

        pct = f"{self.level:.0%}"
        rows = [
            (
                "F_peak",
                _fmt(self.force, 1e3, ""),
                _fmt_interval(self.force_interval, 1e3, ""),
                "mN",
            ),
            ("x_peak", _fmt(self.slip, 1e6, ""), _fmt_interval(self.slip_interval, 1e6, ""), "µm"),
            ("t_peak", _fmt(self.time, 1, ""), _fmt_interval(self.time_interval, 1, ""), "s"),
        ]
        title = (
            f"PeakForecast from the start-up up to t = {format_number(self.until)} s "
            f"({self.n_points} points, v = {format_number(self.velocity, 1e6)} µm/s); "
            f"intervals {pct}"
        )
        return _card(title, rows, [f"clock: {self.clock}", self.message])

    def report(self) -> str:
        """A short text report in display units (mN, µm, s)."""
        pct = f"{self.level:.0%}"
        lines = [
            f"[[Peak forecast]] from the start-up up to t = {self.until:.4g} s "
            f"({self.n_points} points, v = {self.velocity * 1e6:.4g} µm/s)",
            f"    F_peak = {_fmt(self.force, 1e3, 'mN')}  {pct}: "
            f"{_fmt_interval(self.force_interval, 1e3, 'mN')}",
            f"    x_peak = {_fmt(self.slip, 1e6, 'µm')}  {pct}: "
            f"{_fmt_interval(self.slip_interval, 1e6, 'µm')}",
            f"    t_peak = {_fmt(self.time, 1, 's')}  {pct}: "
            f"{_fmt_interval(self.time_interval, 1, 's')}",
            f"    prior: {self.prior or 'none'}; clock: {self.clock}",
        ]
        if self.message:
            lines.append(f"    note: {self.message}")
        return "\n".join(lines)


@dataclass(frozen=True, eq=False)
class FailureForecast(_Fitted, HtmlReport, Codec):
    """The failure of a force-controlled layer, forecast from its slow slip.

    Attributes
    ----------
    time, time_interval : float or None, tuple
        Failure time on the record's clock and its predictive interval [s]; None (and an
        interval of NaN) when the record shows no sign of approaching failure.
    force, force_interval : float or None, tuple
        Failure strength F_peak and its interval [N] (under a staircase the step that breaks
        the layer is at or above it; with the direct effect the force at failure lies above
        it under a fast ramp and below it after a long hold).
    slip, slip_interval : float or None, tuple
        Record slip at failure (x_peak - x0) and its interval [m].
    until : float
        The cut: the last record time used [s].
    level : float
        Level of the intervals [-].
    loading : Loading
        The imposed force history read from the record and its continuation.
    params : mapping
        Best-fit a [N], alpha [1/m], Fd [N], x0 [m] (empty without a fit); with the direct
        effect also A [N] and v_ref [m/s]. :meth:`to_params` gives the Params.
    sigma : float
        Slip noise standard deviation used [m] (NaN without a fit).
    n_points : int
        Points fitted.
    approaching : bool
        Whether the record shows failure approaching (False: ``time`` is None).
    prior : dict or None
        The prior used, if any.
    message : str
        Why there is no date, or what limits the forecast; "" otherwise.
    steps : dict or None
        Under a quasi-static staircase (None otherwise): the layer fails at the start of a
        step, so the forecast is a probability for each step beyond the record, from the
        confidence distribution of the failure's force (its profile likelihood). Lists
        "step" (number of the step, the record's first as 1), "level" [N], "earliest" and
        "latest" (the range of its start [s]), "probability" [-], "below" [-], the
        probability of the earlier steps left out (together less than 1e-4), and
        "beyond" [-], the probability above the last step listed (NaN where the record
        does not bound the failure from above). ``time_interval`` is then the smallest
        run of whole steps about the most likely ones whose probability reaches ``level``:
        an outcome this discrete is held more often than ``level`` (see :meth:`step_table`
        and :attr:`time_probability`).
    cdf : dict
        The distribution of the failure time behind every interval and probability: "time"
        [s] and "probability" [-], its CDF at those times; below 1 at the last time where the
        record does not bound the failure (the rest lies beyond). Read by
        :meth:`probability_within`.
    observed_failure : float or None
        Where the record itself shows the failure (its slip running away): the failure time
        [s], the middle of the sampling interval in which it came; None where the record
        has not failed. The forecast then uses the samples before it only.
    observed : dict or None
        The observed failure's "window" (last sample before, first after [s]), "force" [N]
        and "index" (the last sample before).
    declined : bool
        Whether the forecast declined to give a date because the record does not follow
        the model.
    """

    time: float | None
    time_interval: tuple[float, float]
    force: float | None
    force_interval: tuple[float, float]
    slip: float | None
    slip_interval: tuple[float, float]
    until: float
    level: float
    loading: Loading
    params: FrozenMap
    sigma: float
    n_points: int
    approaching: bool
    prior: dict | None = None
    message: str = ""
    method: str = "model"
    clock: str = FAILURE_CLOCK
    steps: dict | None = None
    cdf: dict = dataclasses.field(default_factory=lambda: {"time": [], "probability": []})
    observed_failure: float | None = None
    observed: dict | None = None
    declined: bool = False

    def probability_within(self, seconds: float) -> float:
        """The probability [-] that the layer fails within ``seconds`` [s] after the last
        sample used (``until``): the failure time's CDF (the distribution behind the
        interval; under a staircase the sum of the steps' probabilities, each spread over
        the window of its start). Near 0 where the record shows no failure ahead; 1 where
        the record has already failed by then."""
        if self.observed_failure is not None and self.until + seconds >= self.observed_failure:
            return 1.0
        return _within(self.cdf, self.until, seconds)

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> Any:
        """Inverse of :meth:`to_dict`."""
        out = super().from_dict(d)
        if out.steps is None:
            return out
        steps = {key: list(value) for key, value in out.steps.items() if isinstance(value, list)}
        steps["step"] = [int(v) for v in steps["step"]]
        for key in ("below", "beyond"):
            value = out.steps.get(key)
            steps[key] = math.nan if value is None else float(value)
        return dataclasses.replace(out, steps=steps)

    @property
    def time_probability(self) -> float:
        """The forecast probability [-] that the layer fails inside ``time_interval``: under a
        staircase the sum over its whole steps (at least ``level``), else ``level``; NaN
        without a date."""
        if self.time is None:
            return math.nan
        if self.steps is None:
            return self.level
        low, high = self.time_interval
        if math.isinf(high):
            return math.nan
        inside = [
            p
            for p, start, end in zip(
                self.steps["probability"], self.steps["earliest"], self.steps["latest"], strict=True
            )
            if low <= start and end <= high
        ]
        return float(sum(inside))

    def step_table(self) -> "pd.DataFrame":
        """The staircase's steps as a pandas DataFrame: step, level [N], earliest and latest
        start [s], probability [-]; empty where the forecast has no steps."""
        import pandas as pd

        columns = ["step", "level", "earliest", "latest", "probability"]
        if self.steps is None:
            return pd.DataFrame(columns=columns)
        return pd.DataFrame({name: self.steps[name] for name in columns})

    def __repr__(self):
        when = "no failure in sight" if self.time is None else f"time={self.time:.5g} s"
        return f"FailureForecast({when}, interval={self.time_interval}, until={self.until:.4g} s)"

    def _repr_html_(self) -> str:
        """An HTML card built from the fields (Jupyter): t_f, F_f and the slip at failure
        with their intervals in display units, and the staircase's likely steps."""
        from granflow._format import format_number

        pct = f"{self.level:.0%}"
        method = METHOD_NAMES.get(self.method, self.method)
        title = (
            f"FailureForecast ({method}) from the record up to t = "
            f"{format_number(self.until)} s ({self.n_points} points, loading: "
            f"{self.loading.kind}); intervals {pct}"
        )
        if self.time is None:
            return _card(title, [], [f"no failure forecast: {self.message}"])
        rows = [
            (
                "failure time t_f",
                _fmt(self.time, 1, ""),
                _fmt_interval(self.time_interval, 1, ""),
                "s",
            ),
            (
                "failure force F_f",
                _fmt(self.force, 1e3, ""),
                _fmt_interval(self.force_interval, 1e3, ""),
                "mN",
            ),
            (
                "slip at failure",
                _fmt(self.slip, 1e6, ""),
                _fmt_interval(self.slip_interval, 1e6, ""),
                "µm",
            ),
        ]
        notes = [f"clock: {self.clock}", self.message]
        if self.steps is not None:
            notes.insert(0, self._steps_line())
        return _card(title, rows, notes)

    def _steps_line(self) -> str:
        """The staircase's likely steps in words."""
        likely = [
            f"step {n} at {0.5 * (lo + hi):.4g} s: {p:.1%}"
            for n, lo, hi, p in zip(
                self.steps["step"],
                self.steps["earliest"],
                self.steps["latest"],
                self.steps["probability"],
                strict=True,
            )
            if p >= 0.01
        ]
        line = f"fails at the start of {'; '.join(likely) or 'a later step'}"
        if math.isfinite(self.time_probability):
            line += f"; the interval's steps hold {self.time_probability:.1%}"
        return line

    def report(self) -> str:
        """A short text report in display units (mN, µm, s)."""
        pct = f"{self.level:.0%}"
        lines = [
            f"[[Failure forecast]] ({METHOD_NAMES.get(self.method, self.method)}) from the "
            f"record up to t = {self.until:.4g} s "
            f"({self.n_points} points, loading: {self.loading.kind})",
        ]
        if self.observed_failure is not None:
            window = (self.observed or {}).get("window", (math.nan, math.nan))
            force = (self.observed or {}).get("force", math.nan)
            lines.append(
                f"    observed failure: t = {self.observed_failure:.4g} s (between "
                f"{window[0]:.4g} and {window[1]:.4g} s, at {_fmt(force, 1e3, 'mN')}); the "
                "forecast uses the samples before it"
            )
        if self.time is None:
            lines.append(f"    no failure forecast: {self.message}")
            return "\n".join(lines)
        lines += [
            f"    t_f = {_fmt(self.time, 1, 's')}  {pct}: "
            f"{_fmt_interval(self.time_interval, 1, 's')}",
            f"    F_f = {_fmt(self.force, 1e3, 'mN')}  {pct}: "
            f"{_fmt_interval(self.force_interval, 1e3, 'mN')}",
            f"    slip at failure = {_fmt(self.slip, 1e6, 'µm')}  {pct}: "
            f"{_fmt_interval(self.slip_interval, 1e6, 'µm')}",
            f"    prior: {self.prior or 'none'}; clock: {self.clock}",
        ]
        if self.steps is not None:
            lines.append(f"    {self._steps_line()}")
        if self.message:
            lines.append(f"    note: {self.message}")
        return "\n".join(lines)


@dataclass(frozen=True, eq=False)
class BaselineForecast(HtmlReport, Codec):
    """A failure time from the slip rate alone (inverse velocity or Voight's law).

    Attributes
    ----------
    method : str
        "inverse velocity" (Fukuzono: 1/v linear in time) or "voight" (dv/dt = A v^alpha).
    time, time_interval : float or None, tuple
        Failure time [s] on the record's clock and its interval (from the regression's
        uncertainty); None when 1/v does not fall.
    until : float
        The cut [s].
    level : float
        Level of the interval [-].
    exponent : float
        Voight's alpha [-] (2 for the inverse-velocity method's straight line).
    n_points : int
        Velocity points used.
    approaching : bool
        Whether 1/v falls towards zero.
    message : str
        Why there is no date; "" otherwise.
    cdf : dict
        The distribution of the failure time where the method gives one (the references of
        :mod:`granflow.forecast.references`): "time" [s] and "probability" [-], its CDF
        there, below 1 at the last time where the record does not bound the failure; empty
        otherwise. Read by :meth:`probability_within` and :func:`granflow.forecast.score`.
    """

    method: str
    time: float | None
    time_interval: tuple[float, float]
    until: float
    level: float
    exponent: float
    n_points: int
    approaching: bool
    message: str = ""
    cdf: dict = dataclasses.field(default_factory=lambda: {"time": [], "probability": []})

    def probability_within(self, seconds: float) -> float:
        """The probability [-] that failure comes within ``seconds`` [s] after the cut, from
        ``cdf`` (0 where the method gives no distribution)."""
        return _within(self.cdf, self.until, seconds)

    def _repr_html_(self) -> str:
        """An HTML card built from the fields (Jupyter)."""
        method = METHOD_NAMES.get(self.method, self.method)
        title = f"BaselineForecast ({method}) up to t = {self.until:.4g} s"
        if self.time is None:
            return _card(title, [], [f"no failure forecast: {self.message}"])
        rows = [
            (
                "failure time t_f",
                _fmt(self.time, 1, ""),
                _fmt_interval(self.time_interval, 1, ""),
                "s",
            ),
            ("exponent α", f"{self.exponent:.3g}", "", ""),
        ]
        return _card(title, rows, [self.message])

    def report(self) -> str:
        """One line."""
        name = METHOD_NAMES.get(self.method, self.method)
        if self.time is None:
            return f"[[{name}]] no failure forecast: {self.message}"
        return (
            f"[[{name}]] t_f = {self.time:.4g} s, {self.level:.0%}: "
            f"{_fmt_interval(self.time_interval, 1, 's')} (alpha = {self.exponent:.3g})"
        )
