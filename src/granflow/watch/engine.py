"""The watch's engine: samples in, forecasts, alarms and log records out.

A :class:`Watch` takes what a source gives (:class:`~granflow.io.follow.Rows` and
:class:`~granflow.io.follow.Notice`), keeps one :class:`Stream` per interval of each file
(a new interval or test starts a new forecast), and at each :meth:`Watch.forecast` updates
the forecast of every stream that received samples: a :class:`~granflow.RunningForecast`
with a bounded, pooled record (``max_points``), so that an update costs the same after a
minute or a day. Each forecast and each event is one log record (a JSON-safe dict; see
:data:`LOG_FIELDS`), handed to the ``emit`` callback in order.

What each stream is forecast with: ``test`` ("ramp", "staircase", "creep", "startup")
where given, else the file's control mode (its metadata, or which of force and velocity the
first rows hold steadier): force control gets the failure forecast, rate control the peak
(static yield) forecast. "creep" fits the direct effect (the creep forecast, slower).

The alarm: ``P(failure within horizon)`` from the forecast's own distribution
(:meth:`~granflow.forecast.results.FailureForecast.probability_within`) reaching the
threshold raises it, once the record holds ``min_rows`` samples and the forecast bounds the
failure (an interval open above is no ground for an alarm), and has stayed there for
``confirm`` seconds of record where that is set; falling below clears it. Where
the force stops rising during a ramp (held), the quasi-static layer cannot fail while it is
held: the probability is 0 and the record says why. Rows with missing or damaged values are
never fitted: they are left out, and the notice that names them is in the log.
"""

from __future__ import annotations

import math
import time as clock
from dataclasses import dataclass
from typing import Any

import numpy as np

from granflow.errors import GranflowError, InvalidParameterError

__all__ = ["LOG_FIELDS", "TESTS", "Settings", "Stream", "Watch"]

TESTS = ("ramp", "staircase", "creep", "startup")
#: Fields of every log record (None where unknown; an open interval end is None).
LOG_FIELDS = (
    "event",
    "source",
    "interval",
    "t",
    "rows",
    "kind",
    "force_interval",
    "time_interval",
    "probability_within_horizon",
    "alarm",
    "message",
)
_MIN_ROWS = 12  # a forecast needs 12 points
_RECENT = 64  # rows kept for the slip rate
_HELD_WINDOW = 0.1  # the last tenth of a ramp tells whether the force still rises
_HELD_RATIO = 0.2  # held: the recent rate under a fifth of the ramp's


@dataclass(frozen=True)
class Settings:
    """What a watch does.

    Attributes
    ----------
    horizon : float
        The alarm's horizon [s].
    alarm : float
        The probability of failure within the horizon that raises the alarm [-].
    test : str or None
        One of :data:`TESTS`, or None: from the file's control mode.
    level : float
        Level of the forecast intervals [-].
    max_points : int
        Points of the pooled record each forecast fits (:class:`~granflow.forecast.pooling.Pool`).
    prior : optional
        The campaign's :class:`~granflow.forecast.Prior`.
    min_rows : int
        Samples a forecast needs before it may raise the alarm (default 100): the forecasts
        are calibrated on records of 100 samples and more (the calibration study's smallest,
        200 samples to failure cut at half); on a dozen samples they can be far too sure.
    warm_start : bool
        Warm-start each update from the last (:class:`~granflow.RunningForecast`); off by
        default: on a growing ramp the warm-started forecast was seen to stay on an open,
        undated profile where the one-shot forecast of the same points gives a date.
    confirm : float
        How long [s] of record the probability must stay at or above ``alarm`` (on every
        forecast of that stretch) before the alarm is raised; 0 (default): at the first
        forecast that reaches it. A forecast made every few seconds can be over-sure once
        and not again; waiting for a second look removes most such alarms, at the cost of
        that much lead (``benchmarks/README.md``, the watch's fleet).
    """

    horizon: float = 60.0
    alarm: float = 0.5
    test: str | None = None
    level: float = 0.9
    max_points: int = 2048
    prior: Any = None
    warm_start: bool = False
    min_rows: int = 100
    confirm: float = 0.0

    def __post_init__(self):
        if not (math.isfinite(self.horizon) and self.horizon > 0):
            raise InvalidParameterError(f"horizon must be positive, got {self.horizon:g} s")
        if not 0 < self.alarm <= 1:
            raise InvalidParameterError(
                f"alarm must be a probability in (0, 1], got {self.alarm:g}"
            )
        if not (math.isfinite(self.confirm) and self.confirm >= 0):
            raise InvalidParameterError(f"confirm must be zero or positive, got {self.confirm:g} s")
        if self.test is not None and self.test not in TESTS:
            raise InvalidParameterError(
                f"test must be one of {', '.join(TESTS)}, got {self.test!r}"
            )


def _spread(values):
    """Relative spread (std / |mean|) of finite values; inf for fewer than two."""
    finite = values[np.isfinite(values)]
    if finite.size < 2:
        return math.inf
    scale = float(np.abs(finite).mean())
    return float(finite.std() / scale) if scale > 0 else 0.0


def _pair(pair):
    """A JSON pair: infinite or NaN ends are None."""
    return [float(v) if v is not None and math.isfinite(v) else None for v in pair]


def _number(value):
    return float(value) if value is not None and math.isfinite(value) else None


def held(t, force):
    """Whether a ramp's force has stopped rising: over the record's last tenth (at least 12
    points) its fitted rate is under a fifth of the whole record's, and the difference is
    beyond the rates' errors (three standard errors)."""
    if t.size < 4 * _MIN_ROWS:
        return False
    recent = t >= t[-1] - _HELD_WINDOW * (t[-1] - t[0])
    if np.count_nonzero(recent) < _MIN_ROWS:
        recent = np.zeros(t.size, bool)
        recent[-_MIN_ROWS:] = True
    (rate, _), cov = np.polyfit(t, force, 1, cov=True)
    (late, _), late_cov = np.polyfit(t[recent], force[recent], 1, cov=True)
    error = math.sqrt(max(cov[0, 0] + late_cov[0, 0], 0.0))
    return bool(rate > 0 and late < _HELD_RATIO * rate and rate - late > 3.0 * error)


class Stream:
    """One interval of one file, followed: its pooled record and running forecast, its
    alarm, and what the page draws.

    Attributes
    ----------
    source : str
        The file.
    interval : int
        The interval's ordinal in the file.
    kind : str or None
        "failure" or "peak", once decided (at the first forecast).
    rows : int
        Samples taken.
    """

    def __init__(self, source, interval, test, settings):
        from granflow.forecast.pooling import Pool

        self.source = source
        self.interval = interval
        self.test = test
        self.settings = settings
        self.kind = None
        self.control = None
        self.velocity = None
        self.metadata = {}
        self.rows = 0
        self.dropped = 0
        self.t = math.nan
        self.running = None
        self.forecast = None
        self.probability = None
        self.alarm = False
        self.since = None  # record time [s] since which every forecast reached the alarm
        self.message = ""
        self.failed = None  # the observed failure time [s]
        self.held = False
        self.error = None
        self.left = None  # a sentence about rows the last update left out
        self.history = []  # (t, time, low, high, probability) of each forecast
        self.display = Pool(("t", "slip", "force"), 512)
        self._waiting = {"t": [], "slip": [], "velocity": [], "force": []}
        self._recent = np.empty((0, 3))  # t, slip, force of the last rows
        self._fresh = False

    def take(self, rows):
        """Add new rows; returns a sentence when rows were left out (no time or force, or a
        time not after the last), else None. Rows without a slip are left out of a failure
        forecast when it runs (:meth:`update`)."""
        t = np.asarray(rows.t, float)
        columns = {"t": t, "slip": rows.slip, "velocity": rows.velocity, "force": rows.force}
        usable = np.isfinite(t) & np.isfinite(columns["force"])
        last = self.t if math.isfinite(self.t) else -math.inf
        after = t > np.maximum.accumulate(np.concatenate([[last], t]))[:-1]
        keep = usable & after
        left = int(t.size - np.count_nonzero(keep))
        if self.control is None:
            self.control = rows.control
        if not self.metadata:
            self.metadata = dict(rows.metadata)
        if self.velocity is None and isinstance(rows.metadata.get("velocity"), float):
            self.velocity = rows.metadata["velocity"]
        for name, values in columns.items():
            self._waiting[name].append(np.asarray(values, float)[keep])
        if np.any(keep):
            self.rows += int(np.count_nonzero(keep))
            self.t = float(t[keep][-1])
            kept = np.column_stack([t[keep], columns["slip"][keep], columns["force"][keep]])
            self._recent = np.concatenate([self._recent, kept])[-_RECENT:]
            display = {"t": kept[:, 0], "slip": kept[:, 1], "force": kept[:, 2]}
            self.display.add(display)
            self._fresh = True
        if not left:
            return None
        self.dropped += left
        parts = []
        if np.any(~usable):
            parts.append(f"{int(np.count_nonzero(~usable))} without a usable time or force")
        if np.any(usable & ~after):
            parts.append(f"{int(np.count_nonzero(usable & ~after))} not after the last time")
        return f"{left} rows left out of the forecast ({'; '.join(parts)})"

    @property
    def fresh(self):
        """Whether samples arrived since the last forecast."""
        return self._fresh

    def bounded(self):
        """Whether the last forecast bounds the failure: F_peak's interval (and so the
        failure time's) has an upper end. An open one puts half its probability at no
        date, and what is left near its lower end: its probability within the horizon is no
        ground for an alarm."""
        if self.forecast is None:
            return False
        return math.isfinite(self.forecast.force_interval[1])

    def slip_rate(self):
        """The slip rate over the last rows [m/s] (a fitted line), NaN with fewer than 3."""
        if self._recent.shape[0] < 3 or np.ptp(self._recent[:, 0]) <= 0:
            return math.nan
        return float(np.polyfit(self._recent[:, 0], self._recent[:, 1], 1)[0])

    def latest(self):
        """(force [N], slip [m]) of the last row, NaN before any."""
        if not self._recent.shape[0]:
            return math.nan, math.nan
        return float(self._recent[-1, 2]), float(self._recent[-1, 1])

    def _decide(self, waiting):
        """The forecast's kind, from the test or the control mode."""
        from granflow.forecast.running import RunningForecast

        test = self.settings.test
        if test is not None:
            kind = "peak" if test == "startup" else "failure"
        elif self.control is not None:
            kind = "peak" if self.control == "rate" else "failure"
        else:
            force_spread = _spread(waiting["force"])
            kind = "failure" if force_spread < _spread(waiting["velocity"]) else "peak"
        if kind == "peak" and self.velocity is None:
            finite = waiting["velocity"][np.isfinite(waiting["velocity"])]
            if finite.size:
                self.velocity = float(np.median(finite))
        self.kind = kind
        from granflow.watch.prior import prior_for

        prior, self.message = prior_for(self.settings.prior, self.metadata)
        options = {"level": self.settings.level, "max_points": self.settings.max_points}
        options["warm_start"] = self.settings.warm_start
        options["prior"] = prior
        if kind == "peak":
            if not (self.velocity and self.velocity > 0):
                raise InvalidParameterError(
                    f"{self.source}, interval {self.interval}: a start-up's forecast needs its "
                    "velocity, and the file gives none (no speed column, no nominal velocity)"
                )
            self.running = RunningForecast("peak", velocity=self.velocity, **options)
        else:
            direct = True if test == "creep" else None
            self.running = RunningForecast("failure", direct_effect=direct, **options)

    def update(self):
        """Re-forecast with the rows that arrived; returns the forecast (None while too
        short) or raises :class:`granflow.GranflowError`."""
        waiting = {name: np.concatenate(parts) for name, parts in self._waiting.items()}
        if self.running is None:
            if waiting["t"].size < _MIN_ROWS:
                return None
            self._decide(waiting)
        self._waiting = {name: [] for name in self._waiting}
        self._fresh = False
        if self.kind == "failure":
            slipped = np.isfinite(waiting["slip"])
            if not slipped.all():
                count = int(np.count_nonzero(~slipped))
                self.dropped += count
                self.left = f"{count} rows left out of the forecast (no usable slip)"
                waiting = {name: values[slipped] for name, values in waiting.items()}
        if not waiting["t"].size:
            return self.forecast
        if self.kind == "peak":
            forecast = self.running.update(waiting["t"], waiting["force"])
        else:
            forecast = self.running.update(waiting["t"], waiting["slip"], waiting["force"])
        if forecast is None:
            return None
        self.forecast = forecast
        if self.kind == "failure":
            self._judge(forecast)
        return forecast

    def _judge(self, forecast):
        """The probability of failure within the horizon, the held force, the failure."""
        self.held = forecast.loading.kind == "ramp" and held(self.running.t, self.running.force)
        if forecast.observed_failure is not None:
            self.failed = float(forecast.observed_failure)
        if self.held:
            self.probability = 0.0
            level = float(np.median(self.running.force[-_MIN_ROWS:]))
            self.message = (
                f"the force is held at {level * 1e3:.4g} mN: quasi-statically the layer does "
                "not fail while it is held"
            )
        elif forecast.time is None and not forecast.cdf["time"]:
            self.probability = 0.0
            self.message = forecast.message
        else:
            self.probability = float(forecast.probability_within(self.settings.horizon))
            self.message = forecast.message
        interval = (None, None) if self.held else forecast.time_interval
        point = None if self.held else _number(forecast.time)
        self.history.append((self.t, point, *_pair(interval), self.probability))
        if len(self.history) > 2000:
            self.history = self.history[::2]

    def record(self, event, message=""):
        """A log record of this stream's state."""
        forecast = self.forecast
        entry = {
            "event": event,
            "source": self.source,
            "interval": self.interval,
            "t": _number(self.t),
            "rows": self.rows,
            "kind": self.kind,
            "force_interval": _pair(forecast.force_interval) if forecast else [None, None],
            "alarm": self.alarm,
            "message": message or self.message,
        }
        if self.kind != "peak":
            entry["time_interval"] = (
                _pair(forecast.time_interval) if forecast and not self.held else [None, None]
            )
            entry["probability_within_horizon"] = self.probability
            entry["time"] = _number(forecast.time) if forecast and not self.held else None
            entry["time_left"] = entry["time"] - self.t if entry["time"] is not None else None
            entry["force"] = _number(forecast.force) if forecast else None
            entry["held"] = self.held
            entry["observed_failure"] = self.failed
        else:
            entry["peak_force"] = _number(forecast.force) if forecast else None
            entry["peak_time"] = _number(forecast.time) if forecast else None
            entry["peak_time_interval"] = _pair(forecast.time_interval) if forecast else None
        entry["horizon"] = self.settings.horizon
        return entry

    def view(self):
        """What the panel and the page show (JSON-safe)."""
        force, slip = self.latest()
        entry = self.record("state")
        entry.update(
            force_now=_number(force),
            slip_now=_number(slip),
            slip_rate=_number(self.slip_rate()),
            threshold=self.settings.alarm,
            level=self.settings.level,
            record={
                name: [round(float(v), 12) for v in self.display.column(name)]
                for name in ("t", "slip", "force")
            },
            history=[list(row) for row in self.history],
        )
        return entry


class Watch:
    """Follow streams, forecast them, raise and clear alarms; every record to ``emit``.

    Parameters
    ----------
    settings : Settings
        Horizon, alarm threshold, test, level, pooled points, prior.
    emit : callable
        ``emit(record)`` for each log record (a JSON-safe dict), in order.
    on_alarm : callable, optional
        ``on_alarm(record)`` when an alarm is raised.
    """

    def __init__(self, settings, emit, on_alarm=None):
        self.settings = settings
        self.emit = emit
        self.on_alarm = on_alarm
        self.streams = {}
        self.current = None  # the stream that last received rows
        self.notices = []  # the last notices, for the panel and the page
        self.changes = 0  # counts rows taken and records made: the view is redrawn on change

    def _say(self, record):
        self.changes += 1
        self.emit(record)
        if record["event"] != "forecast":
            self.notices = ([*self.notices, record])[-12:]

    def _file_record(self, event, source, message, interval=0):
        stream = self.current
        if stream is not None and stream.source == source and not interval:
            return stream.record(event, message)
        return {
            "event": event,
            "source": source,
            "interval": interval,
            "t": None,
            "rows": 0,
            "kind": None,
            "force_interval": [None, None],
            "alarm": False,
            "message": message,
            "horizon": self.settings.horizon,
        }

    def take(self, events):
        """Take a source's events (Rows and Notice, in order)."""
        from granflow.io.follow import Notice

        for event in events:
            if isinstance(event, Notice):
                self.notice(event.source, event.kind, event.message, event.interval)
                continue
            key = (event.source, event.interval)
            stream = self.streams.get(key)
            if stream is None:
                stream = Stream(event.source, event.interval, self.settings.test, self.settings)
                self.streams[key] = stream
            self.current = stream
            self.changes += 1
            left = stream.take(event)
            if left:
                self._say(stream.record("left out", left))

    def notice(self, source, kind, message, interval=0):
        """Log a notice about a file (or one of its intervals)."""
        stream = self.streams.get((source, interval))
        if kind in ("truncated", "replaced"):
            for key in [key for key in self.streams if key[0] == source]:
                self.streams[key].alarm = False
                del self.streams[key]
            self.current = None
        if stream is not None and kind not in ("truncated", "replaced"):
            self._say(stream.record(kind, message))
        else:
            self._say(self._file_record(kind, source, message, interval))

    def forecast(self):
        """Update the forecast of every stream that received rows; returns their records."""
        records = []
        for stream in list(self.streams.values()):
            if not stream.fresh or stream.failed is not None:
                continue
            try:
                forecast = stream.update()
            except GranflowError as exc:
                if str(exc) != stream.error:
                    stream.error = str(exc)
                    self._say(stream.record("error", str(exc)))
                continue
            if stream.left:
                self._say(stream.record("left out", stream.left))
                stream.left = None
            if forecast is None:
                continue
            records.append(self._after(stream))
        return records

    def _after(self, stream):
        """The forecast's record, then the alarm's and the failure's when they change."""
        record = stream.record("forecast")
        self._say(record)
        if stream.kind == "failure":
            raised = (
                stream.probability is not None
                and stream.probability >= self.settings.alarm
                and stream.rows >= self.settings.min_rows
                and stream.bounded()
            )
            if not raised:
                stream.since = None
            elif stream.since is None:
                stream.since = stream.t
            confirmed = raised and stream.t - stream.since >= self.settings.confirm
            if confirmed and not stream.alarm and stream.failed is None:
                stream.alarm = True
                alarm = stream.record(
                    "alarm",
                    f"P(failure within {self.settings.horizon:g} s) = {stream.probability:.2f} "
                    f">= {self.settings.alarm:g}",
                )
                self._say(alarm)
                if self.on_alarm is not None:
                    self.on_alarm(alarm)
            elif not raised and stream.alarm:
                stream.alarm = False
                self._say(
                    stream.record(
                        "clear",
                        f"P(failure within {self.settings.horizon:g} s) = "
                        f"{stream.probability:.2f} < {self.settings.alarm:g}",
                    )
                )
            if stream.failed is not None:
                self._say(
                    stream.record(
                        "failure",
                        f"the record shows the failure at {stream.failed:.6g} s: no more "
                        "forecasts for this interval",
                    )
                )
        return record

    def view(self):
        """The state of the watch for the panel and the page (JSON-safe)."""
        stream = self.current
        return {
            "stream": None if stream is None else stream.view(),
            "streams": [
                {"source": s.source, "interval": s.interval, "rows": s.rows, "alarm": s.alarm}
                for s in self.streams.values()
            ],
            "notices": [
                {"event": n["event"], "t": n["t"], "message": n["message"]} for n in self.notices
            ],
            "horizon": self.settings.horizon,
            "threshold": self.settings.alarm,
            "clock": clock.time(),
        }
