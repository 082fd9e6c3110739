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

from typing import TYPE_CHECKING

from granflow._lazy import attach

if TYPE_CHECKING:  # the public names as type checkers and editors see them
    from granflow.analysis.engine import analyze as analyze
    from granflow.analysis.result import AnalysisResult as AnalysisResult
    from granflow.errors import ConvergenceWarning as ConvergenceWarning
    from granflow.errors import FileFormatError as FileFormatError
    from granflow.errors import FitError as FitError
    from granflow.errors import GranflowError as GranflowError
    from granflow.errors import InvalidDataError as InvalidDataError
    from granflow.errors import InvalidParameterError as InvalidParameterError
    from granflow.errors import InvalidProtocolError as InvalidProtocolError
    from granflow.errors import OutputError as OutputError
    from granflow.fitting.batch import fit_many as fit_many
    from granflow.fitting.compare import ModelComparison as ModelComparison
    from granflow.fitting.compare import compare_models as compare_models
    from granflow.fitting.creep import CurveFitResult as CurveFitResult
    from granflow.fitting.creep import fit_creep as fit_creep
    from granflow.fitting.joint import AmontonsResult as AmontonsResult
    from granflow.fitting.joint import CollapseResult as CollapseResult
    from granflow.fitting.joint import PreparationSpread as PreparationSpread
    from granflow.fitting.joint import fit_amontons as fit_amontons
    from granflow.fitting.joint import preparation_spread as preparation_spread
    from granflow.fitting.joint import velocity_collapse as velocity_collapse
    from granflow.fitting.mcmc import PosteriorResult as PosteriorResult
    from granflow.fitting.mcmc import sample_posterior as sample_posterior
    from granflow.fitting.parameters import Parameter as Parameter
    from granflow.fitting.parameters import Parameters as Parameters
    from granflow.fitting.single import FitResult as FitResult
    from granflow.fitting.single import fit as fit
    from granflow.fitting.tied import JointFitResult as JointFitResult
    from granflow.fitting.tied import fit_joint as fit_joint
    from granflow.forecast.failure import forecast_failure as forecast_failure
    from granflow.forecast.peak import forecast_peak as forecast_peak
    from granflow.forecast.results import BaselineForecast as BaselineForecast
    from granflow.forecast.results import FailureForecast as FailureForecast
    from granflow.forecast.results import PeakForecast as PeakForecast
    from granflow.forecast.running import RunningForecast as RunningForecast
    from granflow.io.campaign import Campaign as Campaign
    from granflow.io.reader import read as read
    from granflow.io.reader import read_runs as read_runs
    from granflow.model.friction import NoPeakError as NoPeakError
    from granflow.model.friction import Peak as Peak
    from granflow.model.friction import friction_aging as friction_aging
    from granflow.model.friction import friction_asymptote as friction_asymptote
    from granflow.model.friction import friction_slip as friction_slip
    from granflow.model.friction import friction_slip_jacobian as friction_slip_jacobian
    from granflow.model.friction import friction_time as friction_time
    from granflow.model.friction import has_peak as has_peak
    from granflow.model.friction import initial_force as initial_force
    from granflow.model.friction import peak as peak
    from granflow.model.friction import rhs_slip as rhs_slip
    from granflow.model.friction import rhs_time as rhs_time
    from granflow.model.friction import steady_state as steady_state
    from granflow.model.geometry import Annulus as Annulus
    from granflow.model.params import MaterialConstants as MaterialConstants
    from granflow.model.params import Params as Params
    from granflow.model.protocol import Protocol as Protocol
    from granflow.model.run import Run as Run
    from granflow.model.segments import Force as Force
    from granflow.model.segments import ForceRamp as ForceRamp
    from granflow.model.segments import ForceSteps as ForceSteps
    from granflow.model.segments import ForceTable as ForceTable
    from granflow.model.segments import Hold as Hold
    from granflow.model.segments import SwitchToForce as SwitchToForce
    from granflow.model.segments import Velocity as Velocity
    from granflow.model.segments import VelocitySteps as VelocitySteps
    from granflow.model.segments import VelocityTable as VelocityTable
    from granflow.model.special import scaled_ei as scaled_ei
    from granflow.model.special import scaled_ei_diff as scaled_ei_diff
    from granflow.simulation.driver import simulate as simulate
    from granflow.simulation.options import DirectEffect as DirectEffect
    from granflow.simulation.results import Event as Event
    from granflow.simulation.results import SimulationResult as SimulationResult
    from granflow.simulation.stability import StabilityMap as StabilityMap
    from granflow.simulation.stability import stability_map as stability_map

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
            "OutputError",
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


def __dir__() -> list[str]:
    return sorted({*_dir(), *SUBPACKAGES, "rsf"})
