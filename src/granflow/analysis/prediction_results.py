"""What the predictions of :func:`granflow.analyze` are: frozen values with ``to_dict`` and
``from_dict``.

:class:`Predictions` (static yield per load as :class:`YieldPrediction` rows, and the
stability map) and the comparisons of the stress-controlled runs with the model
(:class:`RampComparison`, :class:`CreepComparison`, :class:`SwitchComparison`), which
``results.json`` lists under ``analyses``. Equality compares ``to_dict()``.
"""

from dataclasses import dataclass, field

from granflow._json import json_safe
from granflow.analysis.values import Value, as_json
from granflow.fitting.creep import CurveFitResult
from granflow.fitting.results import FrozenMap
from granflow.simulation.stability import StabilityMap

__all__ = [
    "CreepComparison",
    "Predictions",
    "RampComparison",
    "StabilityPrediction",
    "SwitchComparison",
    "YieldPrediction",
]


# --------------------------------------------------------------------------- comparisons


def _optional_keys(values):
    """``values`` without the entries that are None."""
    return {k: v for k, v in values.items() if v is not None}


@dataclass(frozen=True, eq=False)
class RampComparison(Value):
    """A stress ramp's observed failure against the predicted static yield at its load.

    Attributes
    ----------
    run : str
    normal_load : float or None
        [N]
    observed : mapping or None
        ``failure_force`` [N], ``failure_time`` [s], ``failure_slip`` [m]; None without a
        failure.
    criterion : str or None
        How the failure was found.
    predicted_force : float or None
        Predicted F_peak [N] (None without a prediction at this load).
    predicted_time : float or None
        When the imposed force reaches it [s], the predicted failure (record's clock).
    F_peak_stderr, F_peak_spread : float or None
        Its standard error and the spread over the preparations [N].
    ratio, z : float or None
        observed / predicted, and the difference over the combined width.
    consistent : bool or None
        Whether they agree within two widths.
    reason : str or None
        Why there is no comparison.
    params : granflow.Params or None
        Model parameters at the load (for the figure; not in ``to_dict``).
    """

    run: str
    normal_load: float | None
    observed: FrozenMap | None = None
    criterion: str | None = None
    predicted_force: float | None = None
    predicted_time: float | None = None
    F_peak_stderr: float | None = None
    F_peak_spread: float | None = None
    ratio: float | None = None
    z: float | None = None
    consistent: bool | None = None
    reason: str | None = None
    params: object = field(default=None, compare=False)

    def to_dict(self):
        """The row of ``analyses["stress_ramp"]``."""
        out = {"run": self.run, "normal_load": self.normal_load}
        if self.observed is not None:
            out.update(observed=dict(self.observed), criterion=self.criterion)
        if self.predicted_force is not None:
            out.update(
                predicted={
                    "failure_force": self.predicted_force,
                    **(
                        {"failure_time": self.predicted_time}
                        if self.predicted_time is not None
                        else {}
                    ),
                },
                F_peak_stderr=self.F_peak_stderr,
                F_peak_spread=self.F_peak_spread,
            )
        if self.reason is not None:
            out["reason"] = self.reason
        elif self.consistent is not None:
            out.update(ratio=self.ratio, z=self.z, consistent=self.consistent)
        return json_safe(out)

    @classmethod
    def from_dict(cls, saved):
        """The row of :meth:`to_dict`."""
        observed = saved.get("observed")
        return cls(
            run=saved["run"],
            normal_load=saved["normal_load"],
            observed=None if observed is None else FrozenMap(observed),
            criterion=saved.get("criterion"),
            predicted_force=(saved.get("predicted") or {}).get("failure_force"),
            predicted_time=(saved.get("predicted") or {}).get("failure_time"),
            F_peak_stderr=saved.get("F_peak_stderr"),
            F_peak_spread=saved.get("F_peak_spread"),
            ratio=saved.get("ratio"),
            z=saved.get("z"),
            consistent=saved.get("consistent"),
            reason=saved.get("reason"),
        )


@dataclass(frozen=True, eq=False)
class CreepComparison(Value):
    """A creep test's stress against the predicted peak and the steady friction.

    Attributes
    ----------
    run : str
    normal_load : float or None
        [N]
    stress : float
        The imposed force [N].
    stress_over_peak, stress_over_Fd : float or None
        Its ratio to the predicted F_peak and to F_d = μ_d F_N.
    fit : granflow.CurveFitResult
        The run's creep fit.
    """

    run: str
    normal_load: float | None
    stress: float
    stress_over_peak: float | None = None
    stress_over_Fd: float | None = None
    fit: object = None

    def to_dict(self):
        """The row of ``analyses["creep"]``."""
        out = {"run": self.run, "normal_load": self.normal_load, "stress": self.stress}
        out.update(
            _optional_keys(
                {"stress_over_peak": self.stress_over_peak, "stress_over_Fd": self.stress_over_Fd}
            )
        )
        out["fit"] = as_json(self.fit, include_arrays=False)
        return json_safe(out)

    @classmethod
    def from_dict(cls, saved):
        """The row of :meth:`to_dict`."""
        return cls(
            run=saved["run"],
            normal_load=saved["normal_load"],
            stress=saved["stress"],
            stress_over_peak=saved.get("stress_over_peak"),
            stress_over_Fd=saved.get("stress_over_Fd"),
            fit=CurveFitResult.from_dict(saved["fit"]),
        )


@dataclass(frozen=True, eq=False)
class SwitchComparison(Value):
    """A switch's observed outcome against the simulated one.

    Attributes
    ----------
    run : str
    normal_load : float or None
        [N]
    observed : mapping
        ``outcome`` and ``imposed_force`` [N].
    switch_time : float
        [s]
    factor : float or None
        Imposed over switch force.
    switch_force : float
        [N]
    predicted : str or None
        The simulated outcome (None when it could not be predicted).
    agree : bool or None
    params_from : str or None
        Where the model parameters come from.
    simulation : str or None
        The simulator's message.
    reason : str or None
        Why there is no prediction.
    params : granflow.Params or None
        The model parameters used (in ``to_dict`` only with a prediction).
    """

    run: str
    normal_load: float | None
    observed: FrozenMap
    switch_time: float
    factor: float | None
    switch_force: float
    predicted: str | None = None
    agree: bool | None = None
    params_from: str | None = None
    simulation: str | None = None
    reason: str | None = None
    params: object = field(default=None, compare=False)

    def to_dict(self):
        """The row of ``analyses["switch"]``."""
        out = {
            "run": self.run,
            "normal_load": self.normal_load,
            "observed": dict(self.observed),
            "switch_time": self.switch_time,
            "factor": self.factor,
            "switch_force": self.switch_force,
        }
        if self.predicted is None:
            out["reason"] = self.reason
        else:
            out.update(
                predicted={"outcome": self.predicted},
                agree=self.agree,
                params_from=self.params_from,
                params=as_json(self.params),
                simulation=self.simulation,
            )
        return json_safe(out)

    @classmethod
    def from_dict(cls, saved):
        """The row of :meth:`to_dict` (its parameters as a mapping)."""
        from granflow.model.params import Params

        params = saved.get("params")
        return cls(
            run=saved["run"],
            normal_load=saved["normal_load"],
            observed=FrozenMap(saved["observed"]),
            switch_time=saved["switch_time"],
            factor=saved["factor"],
            switch_force=saved["switch_force"],
            predicted=(saved.get("predicted") or {}).get("outcome"),
            agree=saved.get("agree"),
            params_from=saved.get("params_from"),
            simulation=saved.get("simulation"),
            reason=saved.get("reason"),
            params=None if params is None else Params(**params),
        )


# --------------------------------------------------------------------------- predictions


@dataclass(frozen=True, eq=False)
class YieldPrediction(Value):
    """The predicted static yield at one load, from the material constants and the mean x0.

    Attributes
    ----------
    normal_load : float
        [N]
    repeats : int
        Start-ups whose x0 was averaged.
    x0 : float
        Their mean x0 [m].
    x0_stderr : float
        Its standard error [m].
    x0_from : str
        Which start-ups.
    F_peak, stderr : float
        Predicted peak force and its standard error [N].
    ci95 : (float, float)
        [N]
    F_peak_spread : float
        Spread of F_peak over the repeats' x0 [N].
    mu_peak : float
        F_peak / F_N.
    x_peak, t_peak : float or None
        Slip [m] and time [s] of the peak.
    velocity : float or None
        The material's velocity [m/s].
    """

    normal_load: float
    repeats: int
    x0: float
    x0_stderr: float
    x0_from: str
    F_peak: float
    stderr: float
    ci95: tuple
    F_peak_spread: float
    mu_peak: float
    x_peak: float | None
    t_peak: float | None
    velocity: float | None

    def to_dict(self):
        """The row of ``predictions["static_yield"]``."""
        return json_safe(
            {
                "normal_load": self.normal_load,
                "repeats": self.repeats,
                "x0": self.x0,
                "x0_estimate": {"stderr": self.x0_stderr, "from": self.x0_from},
                "F_peak": self.F_peak,
                "stderr": self.stderr,
                "ci95": list(self.ci95),
                "F_peak_spread": self.F_peak_spread,
                "mu_peak": self.mu_peak,
                "x_peak": self.x_peak,
                "t_peak": self.t_peak,
                "velocity": self.velocity,
            }
        )

    @classmethod
    def from_dict(cls, saved):
        """The row of :meth:`to_dict`."""
        names = ("normal_load", "repeats", "x0", "F_peak", "stderr", "F_peak_spread")
        return cls(
            **{name: saved[name] for name in names},
            x0_stderr=saved["x0_estimate"]["stderr"],
            x0_from=saved["x0_estimate"]["from"],
            ci95=tuple(saved["ci95"]),
            mu_peak=saved["mu_peak"],
            x_peak=saved["x_peak"],
            t_peak=saved["t_peak"],
            velocity=saved["velocity"],
        )


@dataclass(frozen=True, eq=False)
class StabilityPrediction(Value):
    """The stability map at a representative load.

    Attributes
    ----------
    normal_load : float or None
        [N]
    map : granflow.StabilityMap
        The map.
    """

    normal_load: float | None
    map: object

    def to_dict(self):
        """``{"normal_load", **map.to_dict()}``."""
        return json_safe({"normal_load": self.normal_load, **as_json(self.map)})

    @classmethod
    def from_dict(cls, saved):
        """The prediction of :meth:`to_dict`."""
        rest = {k: v for k, v in saved.items() if k != "normal_load"}
        return cls(normal_load=saved["normal_load"], map=StabilityMap.from_dict(rest))


@dataclass(frozen=True, eq=False)
class Predictions(Value):
    """What the material constants predict.

    Attributes
    ----------
    static_yield : tuple of YieldPrediction
        Per load, by increasing load.
    determined : bool
        Whether the material constants were determined (else ``static_yield_reason`` says
        why not).
    static_yield_reason : str or None
    stability_map : StabilityPrediction or None
    """

    static_yield: tuple = ()
    determined: bool = True
    static_yield_reason: str | None = None
    stability_map: StabilityPrediction | None = None

    def to_dict(self):
        """The ``predictions`` entry of ``results.json``."""
        out = {"static_yield": [row.to_dict() for row in self.static_yield]}
        if not self.determined:
            out["static_yield_reason"] = self.static_yield_reason
        if self.stability_map is not None:
            out["stability_map"] = self.stability_map.to_dict()
        return out

    @classmethod
    def from_dict(cls, saved):
        """The predictions of :meth:`to_dict`."""
        stability = saved.get("stability_map")
        return cls(
            static_yield=tuple(YieldPrediction.from_dict(row) for row in saved["static_yield"]),
            determined="static_yield_reason" not in saved,
            static_yield_reason=saved.get("static_yield_reason"),
            stability_map=None if stability is None else StabilityPrediction.from_dict(stability),
        )
