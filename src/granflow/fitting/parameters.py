"""Named fit parameters, as lmfit's: a value, bounds, whether it varies and its unit.

A :class:`Parameter` is checked when it is made (a finite value inside ``[min, max]``,
``min < max``, the SI unit of its quantity); :class:`Parameters` is an ordered, read-only
collection of them. :func:`granflow.fit`, :func:`granflow.fit_joint` and
:func:`granflow.fit_creep` take them as ``params=``, the alternative to ``fixed=`` and
``bounds=``: a parameter with ``vary=False`` is held at its value, the others are searched
between ``min`` and ``max`` (an infinite side keeps the fit's default search range), starting
from their value. Each fit checks that every name belongs to its model.

Examples
--------
>>> import numpy as np, granflow
>>> from granflow.fitting import Parameter
>>> x = np.linspace(1e-6, 5e-4, 300)
>>> F = granflow.friction_slip(x, granflow.Params(3e-3, 4e4, 1e-2, 2e-7))
>>> result = granflow.fit((x, F), params=[Parameter("Fd", 1e-2, vary=False)])
>>> result.fixed, round(result.params["alpha"])
(('Fd',), 40000)
"""

import math
import numbers
from collections.abc import Iterable, Mapping
from dataclasses import dataclass

import numpy as np

from granflow import _validate as check
from granflow.errors import InvalidParameterError
from granflow.fitting.results import FrozenMap
from granflow.model.units import QUANTITIES

__all__ = [
    "Parameter",
    "Parameters",
    "Split",
    "as_parameters",
    "require_positive",
    "split",
    "unit_of",
]


def unit_of(name):
    """The SI unit of a fit parameter ("" when its quantity is not known).

    Per-run and per-group names of joint fits (``x0_3``, ``alpha_v1``) have the unit of the
    quantity before the last underscore.
    """
    quantity = _quantity_of(name)
    return "" if quantity is None else QUANTITIES[quantity].si


def _quantity_of(name):
    """The key of :data:`QUANTITIES` a parameter name stands for, or None."""
    if name in QUANTITIES:
        return name
    base = name.rpartition("_")[0]
    return base if base in QUANTITIES else None


def _bound(value, what, unit):
    """A bound as a float: a real number, infinities allowed, NaN not."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real | np.floating | np.integer):
        raise InvalidParameterError(f"{what} must be a real number in {unit or '1'}, got {value!r}")
    value = float(value)
    if math.isnan(value):
        raise InvalidParameterError(f"{what} must be a number, got nan")
    return value


@dataclass(frozen=True)
class Parameter:
    """One named fit parameter, checked when made.

    Parameters
    ----------
    name : str
        The parameter's name in the model (``"alpha"``; in joint fits ``"x0_3"``, ``"mu_a"``).
    value : float
        The value it is held at (``vary=False``) or the value to start from [SI unit of the
        parameter].
    min, max : float
        Bounds of the search range [SI unit]; ``-inf`` / ``inf`` keep the fit's default range
        on that side.
    vary : bool
        Whether the fit varies the parameter (False: held at ``value``).
    unit : str, optional
        The parameter's SI unit; default that of its quantity in
        :data:`granflow.model.units.QUANTITIES`. A unit other than the SI unit is refused
        (granflow works in SI units inside).

    Raises
    ------
    granflow.InvalidParameterError
        A name that is not an identifier, a value that is not a finite number or lies outside
        ``[min, max]``, ``min >= max``, a NaN bound, a unit that is not the SI unit.

    Examples
    --------
    >>> from granflow.fitting import Parameter
    >>> Parameter("alpha", 4e4, min=1e3, max=1e6)
    Parameter(name='alpha', value=40000.0, min=1000.0, max=1000000.0, vary=True, unit='1/m')
    """

    name: str
    value: float
    min: float = -math.inf
    max: float = math.inf
    vary: bool = True
    unit: str | None = None

    def __post_init__(self):
        if not isinstance(self.name, str) or not self.name.isidentifier():
            raise InvalidParameterError(
                f"a parameter name must be an identifier such as 'alpha', got {self.name!r}"
            )
        unit = unit_of(self.name) if self.unit is None else self.unit
        if not isinstance(unit, str):
            raise InvalidParameterError(
                f"unit of parameter {self.name!r} must be a string, got {unit!r}"
            )
        if _quantity_of(self.name) is not None and unit != unit_of(self.name):
            raise InvalidParameterError(
                f"unit of parameter {self.name!r} must be its SI unit {unit_of(self.name)!r} "
                f"(granflow works in SI units), got {unit!r}"
            )
        value = check.real_scalar(self.value, f"value of parameter {self.name!r}", unit)
        lower = _bound(self.min, f"min of parameter {self.name!r}", unit)
        upper = _bound(self.max, f"max of parameter {self.name!r}", unit)
        if not lower < upper:
            raise InvalidParameterError(
                f"parameter {self.name!r} must have min < max, got min={lower:g}, max={upper:g}"
            )
        if not lower <= value <= upper:
            raise InvalidParameterError(
                f"value of parameter {self.name!r} must lie inside [min, max] = "
                f"[{lower:g}, {upper:g}], got {value:g}"
            )
        if not isinstance(self.vary, bool | np.bool_):
            raise InvalidParameterError(
                f"vary of parameter {self.name!r} must be True or False, got {self.vary!r}"
            )
        for key, item in (("value", value), ("min", lower), ("max", upper)):
            object.__setattr__(self, key, item)
        object.__setattr__(self, "vary", bool(self.vary))
        object.__setattr__(self, "unit", unit)


class Parameters(FrozenMap):
    """An ordered, read-only collection of :class:`Parameter` by name (lmfit's ``Parameters``).

    Parameters
    ----------
    parameters : iterable of Parameter
        Each name at most once.

    Examples
    --------
    >>> from granflow.fitting import Parameter, Parameters
    >>> params = Parameters([Parameter("Fd", 1e-2, vary=False), Parameter("alpha", 4e4)])
    >>> list(params), params.valuesdict()["Fd"]
    (['Fd', 'alpha'], 0.01)
    """

    __slots__ = ()

    def __init__(self, parameters: Iterable[Parameter] = ()) -> None:
        if isinstance(parameters, Parameter | str) or not isinstance(parameters, Iterable):
            raise InvalidParameterError(
                f"Parameters takes an iterable of Parameter, got {type(parameters).__name__}"
            )
        items = {}
        for parameter in parameters:
            if not isinstance(parameter, Parameter):
                raise InvalidParameterError(
                    f"params must hold granflow.fitting.Parameter objects, got "
                    f"{type(parameter).__name__} {parameter!r}"
                )
            if parameter.name in items:
                raise InvalidParameterError(f"params: parameter {parameter.name!r} is given twice")
            items[parameter.name] = parameter
        super().__init__(items)

    def __repr__(self):
        return f"Parameters({list(self.values())!r})"

    def __reduce__(self):
        return (Parameters, (list(self.values()),))

    def valuesdict(self) -> dict[str, float]:
        """The values by name [SI]."""
        return {name: parameter.value for name, parameter in self.items()}


def as_parameters(params):
    """``params`` (a :class:`Parameters`, a sequence of :class:`Parameter` or a mapping of
    name to Parameter) as :class:`Parameters`."""
    if isinstance(params, Parameters):
        return params
    if isinstance(params, Mapping):
        for key, parameter in params.items():
            if isinstance(parameter, Parameter) and key != parameter.name:
                raise InvalidParameterError(
                    f"params: key {key!r} holds the parameter named {parameter.name!r}"
                )
        params = params.values()
    return Parameters(params)


@dataclass(frozen=True)
class Split:
    """What ``params=`` asks of a fit, by name: ``held`` values, search ``ranges`` (min, max;
    infinite sides keep the default) and ``starts`` of the varying parameters [SI]."""

    held: dict
    ranges: dict
    starts: dict


def split(params, names, model):
    """``params`` checked against the parameter ``names`` of ``model`` (a description such as
    "the slip domain"), split into held values, search ranges and starting values.

    Raises
    ------
    granflow.InvalidParameterError
        A name that is not a parameter of the model.
    """
    params = as_parameters(params)
    held, ranges, starts = {}, {}, {}
    for name, parameter in params.items():
        if name not in names:
            raise InvalidParameterError(
                f"params: unknown parameter {name!r} for {model}; the parameters are "
                f"{', '.join(names)}"
            )
        if not parameter.vary:
            held[name] = parameter.value
            continue
        starts[name] = parameter.value
        if math.isfinite(parameter.min) or math.isfinite(parameter.max):
            ranges[name] = (parameter.min, parameter.max)
    return Split(held, ranges, starts)


def require_positive(requested, names):
    """Raise unless every held or starting value in ``requested`` (a :class:`Split`) of the
    parameters ``names`` (those searched in log coordinates) is positive."""
    for name, value in {**requested.held, **requested.starts}.items():
        if name in names and value <= 0:
            raise InvalidParameterError(
                f"value of parameter {name!r} must be positive (it is searched in log "
                f"coordinates), got {value:g}"
            )
