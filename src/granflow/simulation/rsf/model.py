"""Rate-and-state friction models: the state variables, their laws and the spring-slider.

Friction ``mu = mu0 + a ln(v / v_ref) + sum_i b_i ln(v_ref theta_i / Dc_i) + eta v`` with one
or more state variables theta_i [s], each evolving by its own law:

``"aging"`` (Dieterich)
    ``dtheta/dt = 1 - v theta / Dc``
``"slip"`` (Ruina)
    ``dtheta/dt = -(v theta / Dc) ln(v theta / Dc)``
``"prz"`` (Perrin, Rice and Zheng)
    ``dtheta/dt = 1 - (v theta / (2 Dc))^2``, with ``b ln(v_ref theta / (2 Dc))`` in the
    friction, so that its steady state is that of the others
``"nagata"``
    ``dtheta/dt = 1 - v theta / Dc - (c / b) theta dmu/dt``

A spring of stiffness k (friction per unit slip) joins the load point to the slider,
``dmu/dt = k (v_lp - v)``; without one (``stiffness=None``) the slider moves with the load
point. ``eta v`` is the optional radiation damping. Every law has the steady state
``theta_ss = Dc / v`` (``2 Dc / v`` for prz) and ``mu_ss = mu0 + (a - sum b) ln(v / v_ref)
+ eta v``. The equations are scale-free: any consistent units work (SI by default).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from granflow import _validate as check
from granflow.errors import InvalidParameterError
from granflow.simulation import equations as eq

if TYPE_CHECKING:
    from granflow._typing import FloatArray, FloatOrArray

__all__ = ["LAWS", "RateState", "State"]

#: The state evolution laws by name.
LAWS = tuple(eq.LAWS)


@dataclass(frozen=True, slots=True)
class State:
    """One state variable of a rate-and-state model.

    Parameters
    ----------
    b : float
        Its amplitude in the friction [-]; finite.
    Dc : float
        Its characteristic slip [m]; positive.
    law : {"aging", "slip", "prz", "nagata"}
        Its evolution law.
    c : float, optional
        The Nagata coefficient [-] (``law="nagata"`` only, where it is required);
        non-negative.

    Examples
    --------
    >>> State(b=0.01, Dc=10e-6, law="slip").law
    'slip'
    """

    b: float
    Dc: float
    law: str = "aging"
    c: float | None = None

    def __post_init__(self):
        object.__setattr__(self, "b", check.real_scalar(self.b, "b"))
        if self.b == 0 and self.law == "nagata":
            raise InvalidParameterError("b must not be 0 with law='nagata' (the law has c / b)")
        object.__setattr__(self, "Dc", check.positive(self.Dc, "Dc", "m"))
        if self.law not in LAWS:
            raise InvalidParameterError(
                f"law must be one of {', '.join(repr(law) for law in LAWS)}, got {self.law!r}"
            )
        if self.law == "nagata":
            if self.c is None:
                raise InvalidParameterError("c is missing: law='nagata' needs it")
            object.__setattr__(self, "c", check.non_negative(self.c, "c"))
        elif self.c is not None:
            raise InvalidParameterError(f"c applies to law='nagata' only, not {self.law!r}")

    @property
    def scale(self) -> float:
        """The slip in the friction term [m]: Dc, or 2 Dc for prz."""
        return 2.0 * self.Dc if self.law == "prz" else self.Dc

    def steady_state(self, velocity: FloatOrArray) -> FloatOrArray:
        """theta at steady sliding at ``velocity`` [s]: Dc / v (2 Dc / v for prz)."""
        return self.scale / np.asarray(velocity, dtype=float)

    def to_dict(self) -> dict[str, Any]:
        return {"b": self.b, "Dc": self.Dc, "law": self.law, "c": self.c}


@dataclass(frozen=True, slots=True)
class RateState:
    """A rate-and-state spring-slider.

    Parameters
    ----------
    mu0 : float
        Friction at steady sliding at ``v_ref`` [-]; finite.
    a : float
        Direct-effect amplitude [-]; positive.
    v_ref : float
        Reference velocity [m/s]; positive.
    stiffness : float, optional
        Spring stiffness k between load point and slider [1/m] (friction per unit slip);
        positive. None: the slider moves with the load point.
    states : sequence of State
        One or more state variables.
    radiation_damping : float
        eta [s/m]: ``eta v`` is added to the friction; non-negative (default 0).

    Examples
    --------
    >>> model = RateState(0.6, 0.005, 1e-6, 1e3, [State(0.01, 10e-6, "aging")])
    >>> round(model.steady_state_friction(1e-5), 6)  # mu0 + (a - b) ln(10)
    0.588487
    """

    mu0: float
    a: float
    v_ref: float
    stiffness: float | None = None
    states: Sequence[State] = ()  # stored as a tuple
    radiation_damping: float = 0.0

    def __post_init__(self):
        object.__setattr__(self, "mu0", check.real_scalar(self.mu0, "mu0"))
        object.__setattr__(self, "a", check.positive(self.a, "a"))
        object.__setattr__(self, "v_ref", check.positive(self.v_ref, "v_ref", "m/s"))
        if self.stiffness is not None:
            object.__setattr__(self, "stiffness", check.positive(self.stiffness, "stiffness"))
        states = self.states
        if isinstance(states, State):
            states = (states,)
        try:
            states = tuple(states)
        except TypeError:
            raise InvalidParameterError(
                f"states must be a sequence of rsf.State, got {type(self.states).__name__}"
            ) from None
        if not states:
            raise InvalidParameterError("states must hold at least one rsf.State")
        for item in states:
            if not isinstance(item, State):
                raise InvalidParameterError(
                    f"states must hold rsf.State objects, got {type(item).__name__}"
                )
        object.__setattr__(self, "states", states)
        eta = check.non_negative(self.radiation_damping, "radiation_damping", "s/m")
        object.__setattr__(self, "radiation_damping", eta)

    @property
    def b(self) -> float:
        """The sum of the state amplitudes [-]."""
        return sum(state.b for state in self.states)

    def steady_state_friction(self, velocity: FloatOrArray) -> FloatOrArray:
        """mu_ss(v) = mu0 + (a - sum b) ln(v / v_ref) + eta v [-]."""
        v = np.asarray(velocity, dtype=float)
        value = self.mu0 + (self.a - self.b) * np.log(v / self.v_ref) + self.radiation_damping * v
        return float(value) if value.ndim == 0 else value

    def steady_state(self, velocity: FloatOrArray) -> FloatArray:
        """The state variables at steady sliding at ``velocity`` [s], one per state."""
        return np.array([state.steady_state(velocity) for state in self.states])

    def friction(self, velocity: FloatOrArray, thetas: FloatArray | Sequence[FloatOrArray]) -> Any:
        """The friction at slider ``velocity`` [m/s] and states ``thetas`` [s] (any shape)."""
        v = np.asarray(velocity, dtype=float)
        value = self.mu0 + self.a * np.log(v / self.v_ref) + self.radiation_damping * v
        with np.errstate(divide="ignore"):
            for state, theta in zip(self.states, thetas, strict=True):
                value = value + state.b * np.log(self.v_ref * np.asarray(theta) / state.scale)
        return value

    def parameters(self) -> FloatArray:
        """The parameter vector of the compiled equations (the piece fields left at 0)."""
        p = np.zeros(eq.STATE_BASE + 4 * len(self.states))
        p[eq.MU0], p[eq.RSF_A], p[eq.RSF_V_REF] = self.mu0, self.a, self.v_ref
        p[eq.RSF_K] = self.stiffness or 0.0
        p[eq.ETA] = self.radiation_damping
        p[eq.N_STATES] = len(self.states)
        for i, state in enumerate(self.states):
            base = eq.STATE_BASE + 4 * i
            p[base : base + 4] = (state.b, state.Dc, eq.LAWS[state.law], state.c or 0.0)
        return p

    def to_dict(self) -> dict[str, Any]:
        return {
            "mu0": self.mu0,
            "a": self.a,
            "v_ref": self.v_ref,
            "stiffness": self.stiffness,
            "states": [state.to_dict() for state in self.states],
            "radiation_damping": self.radiation_damping,
        }

    @classmethod
    def from_dict(cls, mapping: Mapping[str, Any]) -> RateState:
        """Inverse of :meth:`to_dict`."""
        return cls(
            mapping["mu0"],
            mapping["a"],
            mapping["v_ref"],
            mapping.get("stiffness"),
            tuple(State(**item) for item in mapping["states"]),
            mapping.get("radiation_damping", 0.0),
        )
