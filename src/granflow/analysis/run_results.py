"""The result of one run of a campaign: frozen values, one type per kind of test.

:func:`granflow.analysis.runs.analyse_run` returns one of :class:`StartupResult`,
:class:`CreepResult`, :class:`RampResult`, :class:`SwitchResult` or, for a run that could not
be analysed, :class:`FailedRun`. Each holds the real fit objects (:class:`granflow.FitResult`,
:class:`granflow.CurveFitResult`), has a JSON-safe ``to_dict()`` and a ``from_dict()`` that
inverts it (through :meth:`granflow.FitResult.from_dict` and
:meth:`granflow.CurveFitResult.from_dict`): ``OUTPUT/runs/<key>.json`` holds
``to_dict(include_arrays=True)`` (a start-up's fitted points and weights too), so that
``resume=True`` rebuilds the same objects a fresh analysis makes; ``results.json`` lists
``to_dict()`` (the fits without their arrays). Two results are equal when their
``to_dict()`` are.
"""

from dataclasses import dataclass, field
from typing import ClassVar

from granflow._json import json_safe
from granflow.analysis.values import FieldValue, Value
from granflow.fitting.creep import CurveFitResult
from granflow.fitting.results import FrozenMap, number
from granflow.fitting.single import FitResult
from granflow.model.friction import Peak

__all__ = [
    "CreepResult",
    "FailedRun",
    "ObservedPeak",
    "RampFailure",
    "RampResult",
    "StartupResult",
    "StartupWindow",
    "SwitchEvent",
    "SwitchResult",
    "run_result_from_dict",
]


def optional_number(value):
    """A float from JSON, None staying None."""
    return None if value is None else float(value)


# --------------------------------------------------------------------------- start-up


@dataclass(frozen=True, eq=False)
class StartupWindow(FieldValue):
    """The fit window of a start-up run (see :func:`granflow.analysis.startup_data`).

    Attributes
    ----------
    abscissa : {"slip", "velocity*time"}
    elastic_points : int
        Leading points left out as the elastic loading ramp.
    start, stop : float
        First and last abscissa of the window [m].
    points : int
        Points in the window.
    non_finite : int
        Rows of the run left out because their time, slip or force is NaN or infinite.
    """

    abscissa: str
    elastic_points: int
    start: float
    stop: float
    points: int
    non_finite: int = 0


@dataclass(frozen=True, eq=False)
class ObservedPeak(FieldValue):
    """The largest force of a start-up curve (running mean over 5 points) and its slip.

    Attributes
    ----------
    force : float
        [N]
    slip : float
        [m]
    """

    force: float
    slip: float


def _peak_from_dict(saved):
    if saved is None:
        return None
    return Peak(
        slip=number(saved["slip"]),
        force=number(saved["force"]),
        time=optional_number(saved["time"]),
        velocity=optional_number(saved["velocity"]),
    )


@dataclass(frozen=True, eq=False)
class StartupResult(Value):
    """A start-up run: Eq. 3 fitted in slip over the fit window.

    Attributes
    ----------
    fit : granflow.FitResult
    window : StartupWindow
    peak : granflow.Peak or None
        The peak of the fitted curve (None when the fit has none).
    observed_peak : ObservedPeak
    warnings : tuple of str
    """

    fit: FitResult
    window: StartupWindow
    peak: Peak | None
    observed_peak: ObservedPeak
    warnings: tuple = ()

    kind = "startup"

    def fields(self, include_arrays=False):
        """The start-up fields of :meth:`to_dict` (without warnings and status)."""
        return {
            "fit": self.fit.to_dict(include_arrays=include_arrays),
            "window": self.window.to_dict(),
            "peak": None if self.peak is None else json_safe(self.peak.to_dict()),
            "observed_peak": self.observed_peak.to_dict(),
        }

    def to_dict(self, include_arrays=False):
        """JSON-safe mapping (the fitted points too with ``include_arrays``)."""
        fields = self.fields(include_arrays)
        return {
            "fit": fields["fit"],
            "window": fields["window"],
            "warnings": list(self.warnings),
            "peak": fields["peak"],
            "observed_peak": fields["observed_peak"],
            "status": "ok",
            "reason": None,
        }

    @classmethod
    def from_dict(cls, saved):
        """The result of :meth:`to_dict`."""
        return cls(
            fit=FitResult.from_dict(saved["fit"]),
            window=StartupWindow.from_dict(saved["window"]),
            peak=_peak_from_dict(saved["peak"]),
            observed_peak=ObservedPeak.from_dict(saved["observed_peak"]),
            warnings=tuple(saved.get("warnings", ())),
        )


# --------------------------------------------------------------------------- creep


@dataclass(frozen=True, eq=False)
class CreepResult(FieldValue):
    """A creep test: δ = B ln(1 + t/τ_c) fitted from the point the force reached its level.

    Attributes
    ----------
    fit : granflow.CurveFitResult
    stress : float
        The imposed force level (median of the second half) [N].
    creep_start : float
        Time of the run at which the fit starts [s].
    creep_slip : float
        Slip from there to the end [m].
    duration : float
        Time from there to the end [s].
    warnings : tuple of str
    """

    fit: CurveFitResult
    stress: float
    creep_start: float
    creep_slip: float
    duration: float
    warnings: tuple = ()

    kind = "creep"
    JSON_EXTRA: ClassVar = {"status": "ok", "reason": None}


# --------------------------------------------------------------------------- stress ramp


@dataclass(frozen=True, eq=False)
class RampFailure(FieldValue):
    """The observed failure of a stress ramp.

    Attributes
    ----------
    criterion : str
        How the runaway was found.
    index : int
        Row of the last point before the runaway.
    time : float
        Its time [s].
    slip : float or None
        Its slip [m] (None when not measured).
    force : float
        The failure force: the largest force the layer held [N].
    runaway_time : float
        Time of the first runaway point [s].
    """

    criterion: str
    index: int
    time: float
    slip: float | None
    force: float
    runaway_time: float


@dataclass(frozen=True, eq=False)
class RampResult(Value):
    """A stress ramp: the observed failure.

    Attributes
    ----------
    failure : RampFailure or None
        None when no failure was observed.
    loading_rate : float or None
        Slope of the force against time up to the runaway [N/s] (None with fewer than two
        points).
    warnings : tuple of str
    """

    failure: RampFailure | None
    loading_rate: float | None = None
    warnings: tuple = ()

    kind = "ramp"

    def to_dict(self, include_arrays=False):
        """JSON-safe mapping."""
        out = {"warnings": list(self.warnings)}
        if self.loading_rate is not None:
            out["loading_rate"] = self.loading_rate
        out["failure"] = None if self.failure is None else self.failure.to_dict()
        return json_safe({**out, "status": "ok", "reason": None})

    @classmethod
    def from_dict(cls, saved):
        """The result of :meth:`to_dict`."""
        failure = saved.get("failure")
        return cls(
            failure=None if failure is None else RampFailure.from_dict(failure),
            loading_rate=optional_number(saved.get("loading_rate")),
            warnings=tuple(saved.get("warnings", ())),
        )


# --------------------------------------------------------------------------- switch


@dataclass(frozen=True, eq=False)
class SwitchEvent(FieldValue):
    """The switch from rate to stress control, and its observed outcome.

    Attributes
    ----------
    switch_time : float
        [s]
    found_by : str
        ``"manifest switch_time"`` or ``"velocity departs from the nominal one"``.
    index : int
        First row under stress control.
    velocity : float
        Nominal velocity before the switch [m/s].
    switch_force : float
        Force at the switch [N].
    imposed_force : float
        Median force under stress control [N].
    factor : float or None
        imposed_force / switch_force (None without a positive switch force).
    hold_time : float
        Time under stress control [s].
    outcome : {"failure", "stop", "creep"}
    """

    switch_time: float
    found_by: str
    index: int
    velocity: float
    switch_force: float
    imposed_force: float
    factor: float | None
    hold_time: float
    outcome: str


@dataclass(frozen=True, eq=False)
class SwitchResult(Value):
    """A switch from rate to stress control: the switch, and the start-up fit before it.

    Attributes
    ----------
    switch : SwitchEvent
    startup : StartupResult or None
        The fit of the rate-controlled part (None when it could not be fitted).
    fit_error : str or None
        Why the rate-controlled part could not be fitted.
    warnings : tuple of str
    """

    switch: SwitchEvent
    startup: StartupResult | None
    fit_error: str | None = None
    warnings: tuple = ()

    kind = "switch"

    @property
    def fit(self):
        """The start-up fit before the switch (:class:`granflow.FitResult`), or None."""
        return None if self.startup is None else self.startup.fit

    def to_dict(self, include_arrays=False):
        """JSON-safe mapping (the fitted points too with ``include_arrays``)."""
        out = {"switch": self.switch.to_dict(), "warnings": list(self.warnings)}
        if self.startup is None:
            out.update(fit=None, fit_error=self.fit_error)
        else:
            out.update(self.startup.fields(include_arrays))
        return {**out, "status": "ok", "reason": None}

    @classmethod
    def from_dict(cls, saved):
        """The result of :meth:`to_dict`."""
        startup = None if saved.get("fit") is None else StartupResult.from_dict(saved)
        return cls(
            switch=SwitchEvent.from_dict(saved["switch"]),
            startup=startup,
            fit_error=saved.get("fit_error"),
            warnings=tuple(saved.get("warnings", ())),
        )


# --------------------------------------------------------------------------- failure


@dataclass(frozen=True, eq=False)
class FailedRun(Value):
    """A run that could not be analysed.

    Attributes
    ----------
    reason : str
        Why.
    found : mapping
        What was found before the failure, JSON-safe (a start-up's fit and window, a creep
        test's fit and level; the fits in their compact form); empty when nothing was.
    warnings : tuple of str
    """

    reason: str
    found: FrozenMap = field(default_factory=FrozenMap)
    warnings: tuple = ()

    kind = None

    def to_dict(self, include_arrays=False):
        """JSON-safe mapping: what was found, then status ``"failed"`` and the reason."""
        found = {k: v for k, v in self.found.items() if k != "warnings"}
        return {**found, "warnings": list(self.warnings), "status": "failed", "reason": self.reason}

    @classmethod
    def from_dict(cls, saved):
        """The failure of :meth:`to_dict`."""
        skip = ("status", "reason", "warnings")
        return cls(
            reason=saved["reason"],
            found=FrozenMap({k: v for k, v in saved.items() if k not in skip}),
            warnings=tuple(saved.get("warnings", ())),
        )


_KINDS = {cls.kind: cls for cls in (StartupResult, CreepResult, RampResult, SwitchResult)}


def run_result_from_dict(kind, saved):
    """The result of a run of test ``kind`` from its ``to_dict()``: a failure when its status
    is ``"failed"``, else the result type of ``kind``."""
    if saved.get("status") == "failed":
        return FailedRun.from_dict(saved)
    return _KINDS[kind].from_dict(saved)
