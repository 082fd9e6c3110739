"""The options of a simulation, as frozen value objects checked when they are made.

:func:`granflow.simulate` takes plain keywords and builds these; each check names the
argument and its unit ("mass must be positive, got -1 kg"), with the same words as the
keywords of :func:`~granflow.simulate`.

* :class:`Aging`: which clock the layer ages on, and the age and state of a fresh layer.
* :class:`Drive`: the drive's inertia, damping and spring, and the velocity thresholds of
  failure and stop.
* :class:`DirectEffect`: the direct (rate) effect of rate-and-state friction.
* :class:`Numerics`: output points, tolerances and bounds on the work.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from granflow import _validate as check
from granflow.errors import InvalidParameterError
from granflow.model.geometry import Annulus

__all__ = [
    "CLOCKS",
    "DEFAULT_DAMPING",
    "DEFAULT_MASS",
    "DEFAULT_REFERENCE_VELOCITY",
    "MOTOR_INERTIA",
    "Aging",
    "DirectEffect",
    "Drive",
    "Numerics",
    "check_choice",
]

#: Moment of inertia of an MCR 302-like rheometer motor and tool [kg m^2].
MOTOR_INERTIA = 1e-5
#: Default effective mass at the contact: MOTOR_INERTIA / r_m**2 of Annulus.paper(), 0.0533 kg.
DEFAULT_MASS = MOTOR_INERTIA / Annulus.paper().mean_radius ** 2
#: Default viscous damping of the drive [N s/m]: light, about 6 % of critical damping for the
#: default mass on the rising branch of the paper's layer (dF/dx ~ 300 N/m).
DEFAULT_DAMPING = 0.5
#: Velocity scale [m/s] used when a protocol imposes no velocity: for t0 = x0 / v and for the
#: default failure threshold (1000 times it, 1 mm/s).
DEFAULT_REFERENCE_VELOCITY = 1e-6
#: The clocks the layer may age on.
CLOCKS = ("slip", "time")


def check_choice(value, name, allowed):
    """``value`` if it is one of ``allowed``, else an InvalidParameterError naming ``name``."""
    if value not in allowed:
        raise InvalidParameterError(
            f"{name} must be one of {', '.join(repr(a) for a in allowed)}, got {value!r}"
        )
    return value


def _set(instance, name, value):
    object.__setattr__(instance, name, value)


def _positive(value, name, unit=""):
    """:func:`granflow._validate.positive`, with a fast path for a plain finite float."""
    if type(value) is float and 0.0 < value < math.inf:
        return value
    return check.positive(value, name, unit)


def _non_negative(value, name, unit=""):
    """:func:`granflow._validate.non_negative`, with a fast path for a plain finite float."""
    if type(value) is float and 0.0 <= value < math.inf:
        return value
    return check.non_negative(value, name, unit)


def _positive_int(value, name):
    """A positive number as int (as the keywords of simulate have always been read)."""
    if type(value) is int and value > 0:
        return value
    return int(check.positive(value, name))


@dataclass(frozen=True, slots=True)
class Aging:
    """How the layer ages, and where a fresh (or re-prepared) layer starts.

    Parameters
    ----------
    clock : {"slip", "time"}
        Aging along the slip (nothing evolves at rest) or in time since preparation.
    t0 : float
        Age of a fresh layer [s]; positive.
    F_init : float
        Friction state of a fresh layer [N]; non-negative.

    Examples
    --------
    >>> Aging("time", t0=0.23, F_init=4e-3).clock
    'time'
    """

    clock: str
    t0: float
    F_init: float

    def __post_init__(self):
        check_choice(self.clock, "clock", CLOCKS)
        _set(self, "t0", _positive(self.t0, "t0", "s"))
        _set(self, "F_init", _non_negative(self.F_init, "F_init", "N"))


@dataclass(frozen=True, slots=True)
class Drive:
    """The drive that loads the layer: its inertia, damping and spring, and two thresholds.

    Parameters
    ----------
    v_fail : float
        Failure threshold on the sliding velocity [m/s]; positive.
    v_stop : float
        Below this sliding velocity [m/s] the inertial layer sticks again; positive.
    mass : float, optional
        Effective mass of drive and tool at the contact [kg]; positive. None: no inertia
        (the quasi-static limit).
    damping : float, optional
        Viscous damping of the drive [N s/m]; non-negative; given with ``mass`` only.
    stiffness : float, optional
        Machine stiffness K [N/m] between a rate-controlled drive and the layer; positive;
        given with ``mass`` only. None: a rigid drive.

    Examples
    --------
    >>> Drive(v_fail=1e-3, v_stop=1e-15, mass=0.05, damping=0.5).inertial
    True
    """

    v_fail: float
    v_stop: float
    mass: float | None = None
    damping: float | None = None
    stiffness: float | None = None

    def __post_init__(self):
        _set(self, "v_fail", _positive(self.v_fail, "v_fail", "m/s"))
        _set(self, "v_stop", _positive(self.v_stop, "v_stop", "m/s"))
        if self.mass is None:
            for name in ("damping", "stiffness"):
                if getattr(self, name) is not None:
                    raise InvalidParameterError(
                        f"{name} applies to an inertial drive only (give mass as well)"
                    )
            return
        _set(self, "mass", _positive(self.mass, "mass", "kg"))
        if self.damping is None:
            raise InvalidParameterError("damping is missing: an inertial drive needs it [N s/m]")
        _set(self, "damping", _non_negative(self.damping, "damping", "N s/m"))
        if self.stiffness is not None:
            _set(self, "stiffness", _positive(self.stiffness, "stiffness", "N/m"))

    @property
    def inertial(self):
        """Whether the drive has a mass (the dynamic method)."""
        return self.mass is not None


@dataclass(frozen=True, slots=True)
class DirectEffect:
    """The direct (rate) effect of rate-and-state friction, regularised at v -> 0.

    While sliding, the friction force is ``A asinh(v / (2 v_ref) exp(F / A))``, which is
    ``F + A ln(v / v_ref)`` for ``v >> v_ref exp(-F/A)`` and vanishes smoothly at v = 0, so
    the layer creeps under any force (logarithmically below the peak: Fig. 3b).

    Parameters
    ----------
    amplitude : float
        A [N]; positive, typically a few percent of a.
    velocity : float, optional
        Reference velocity v_ref [m/s] at which the friction equals F; default the
        protocol's velocity scale.
    """

    amplitude: float
    velocity: float | None = None

    def __post_init__(self):
        _set(self, "amplitude", _positive(self.amplitude, "amplitude", "N"))
        if self.velocity is not None:
            _set(self, "velocity", _positive(self.velocity, "velocity", "m/s"))

    def to_dict(self) -> dict[str, float | None]:
        return {"amplitude": self.amplitude, "velocity": self.velocity}

    @classmethod
    def from_dict(cls, mapping: Mapping[str, Any]) -> DirectEffect:
        """Inverse of :meth:`to_dict`."""
        return cls(mapping["amplitude"], mapping.get("velocity"))


@dataclass(frozen=True, slots=True)
class Numerics:
    """Output resolution, tolerances and the bounds on the work of one run.

    Parameters
    ----------
    points : int
        Output points per segment (about; events and jumps are added); at least 2.
    rtol : float
        Relative tolerance of the integrations [-]; positive.
    solver : str or scipy.integrate.OdeSolver subclass
        solve_ivp method of the dynamic integration.
    max_evaluations : int
        Right-hand-side evaluations before a run gives up; positive.
    max_transitions : int
        Stick-slip transitions before a run gives up; positive.
    max_wall : float, optional
        Wall time [s] before a run gives up; positive. None (the default): no wall-clock
        limit, so that the outcome never depends on the machine (the work is bounded by
        ``max_evaluations`` and ``max_transitions``).
    """

    points: int = 200
    rtol: float = 1e-9
    solver: str = "LSODA"
    max_evaluations: int = 2_000_000
    max_transitions: int = 10_000
    max_wall: float | None = None

    def __post_init__(self):
        points = self.points
        if isinstance(points, bool) or not isinstance(points, int | np.integer) or points < 2:
            raise InvalidParameterError(f"points must be an integer of at least 2, got {points!r}")
        _set(self, "points", int(points))
        _set(self, "rtol", _positive(self.rtol, "rtol"))
        _set(self, "max_evaluations", _positive_int(self.max_evaluations, "max_evaluations"))
        _set(self, "max_transitions", _positive_int(self.max_transitions, "max_transitions"))
        if self.max_wall is not None:
            _set(self, "max_wall", _positive(self.max_wall, "max_wall", "s"))

    @property
    def implicit(self):
        """Whether the solver uses a Jacobian (LSODA, Radau, BDF)."""
        return self.solver in ("LSODA", "Radau", "BDF")
