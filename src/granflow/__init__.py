"""granflow: the onset of dense granular flow (the aging-rejuvenation model of Farain & Bonn).

Model evaluation, simulation of rheometer protocols, fits with uncertainties, instrument
readers and campaign reports. Every quantity is in SI units (N, m, s, 1/m).

The subpackages follow the flow of data: :mod:`granflow.model` (the ground floor),
:mod:`granflow.simulation`, :mod:`granflow.fitting` and :mod:`granflow.io` on it,
:mod:`granflow.analysis` (the campaign pipeline) on those, :mod:`granflow.cli` on top;
:mod:`granflow.plotting` is a leaf. The public names below and the subpackages
(``granflow.plotting`` after ``import granflow``) resolve on first use, so ``import granflow``
loads neither SciPy nor Numba nor matplotlib.
"""

from granflow._lazy import attach

__version__ = "0.1.0"

#: The subpackages, reachable as attributes (``granflow.plotting``) and imported on first use.
SUBPACKAGES = ("analysis", "cli", "fitting", "forecast", "io", "model", "plotting", "simulation")

__getattr__, _dir, _names = attach(
    __name__,
    {
        "granflow.analysis": ["AnalysisResult", "analyze"],
        "granflow.io": ["Campaign", "read", "read_runs"],
        "granflow.forecast": [
            "BaselineForecast",
            "FailureForecast",
            "PeakForecast",
            "RunningForecast",
            "forecast_failure",
            "forecast_peak",
        ],
        "granflow.errors": [
            "ConvergenceWarning",
            "FileFormatError",
            "FitError",
            "GranflowError",
            "InvalidDataError",
            "InvalidParameterError",
            "InvalidProtocolError",
        ],
        "granflow.fitting": [
            "AmontonsResult",
            "CollapseResult",
            "CurveFitResult",
            "FitResult",
            "JointFitResult",
            "ModelComparison",
            "Parameter",
            "Parameters",
            "PosteriorResult",
            "PreparationSpread",
            "compare_models",
            "fit",
            "fit_amontons",
            "fit_creep",
            "fit_joint",
            "fit_many",
            "preparation_spread",
            "sample_posterior",
            "velocity_collapse",
        ],
        "granflow.model": [
            "Annulus",
            "MaterialConstants",
            "NoPeakError",
            "Params",
            "Peak",
            "Run",
            "friction_aging",
            "friction_asymptote",
            "friction_slip",
            "friction_slip_jacobian",
            "friction_time",
            "has_peak",
            "initial_force",
            "peak",
            "rhs_slip",
            "rhs_time",
            "scaled_ei",
            "scaled_ei_diff",
            "steady_state",
        ],
        "granflow.simulation": [
            "DirectEffect",
            "Event",
            "Force",
            "ForceRamp",
            "ForceSteps",
            "ForceTable",
            "Hold",
            "Protocol",
            "SimulationResult",
            "StabilityMap",
            "SwitchToForce",
            "Velocity",
            "VelocitySteps",
            "VelocityTable",
            "simulate",
            "stability_map",
        ],
    },
)
__all__ = [*_names, "__version__"]


def __dir__():
    return sorted({*_dir(), *SUBPACKAGES, "rsf"})
