"""What :func:`granflow.rsf.simulate` returns: the recorded arrays, the peaks, the settings."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import TYPE_CHECKING, Any

import numpy as np

from granflow._html import HtmlReport
from granflow.simulation.protocol import Protocol
from granflow.simulation.results import Event
from granflow.simulation.rsf.model import RateState

if TYPE_CHECKING:
    import pandas as pd
    from matplotlib.axes import Axes

    from granflow._typing import FloatArray

__all__ = ["RateStateResult"]

_ARRAYS = ("t", "slip", "velocity", "friction", "load_point_velocity")
_UNITS = {"t": "s", "slip": "m", "velocity": "m/s", "friction": "", "load_point_velocity": "m/s"}


def _listed(values):
    return [float(v) if math.isfinite(v) else None for v in np.asarray(values).tolist()]


def _array(values):
    return np.array([math.nan if v is None else v for v in values], dtype=float)


@dataclass(frozen=True, eq=False)
class RateStateResult(HtmlReport):
    """The outcome of :func:`granflow.rsf.simulate`, shaped like ``SimulationResult``.

    Attributes
    ----------
    t : numpy.ndarray
        Time since the start of the protocol [s].
    slip : numpy.ndarray
        Slip of the slider since t = 0 [m].
    velocity : numpy.ndarray
        The slider's velocity [m/s].
    friction : numpy.ndarray
        Friction coefficient mu [-] (with ``eta v`` when there is radiation damping).
    states : numpy.ndarray, shape (n_states, len(t))
        The state variables theta_i [s].
    load_point_velocity : numpy.ndarray
        The imposed load-point velocity [m/s].
    segment : numpy.ndarray
        Index of the protocol segment of each point (int).
    events : tuple of Event
        The friction peaks (``kind="peak"``; ``force`` holds mu, ``state`` theta_1).
    success : bool
        False if the integration could not be completed.
    message : str
    model : RateState
    protocol : Protocol
    options : mapping
        rtol, max_evaluations, evaluations, initial_velocity.
    """

    t: np.ndarray
    slip: np.ndarray
    velocity: np.ndarray
    friction: np.ndarray
    states: np.ndarray
    load_point_velocity: np.ndarray
    segment: np.ndarray
    events: tuple
    success: bool
    message: str
    model: RateState
    protocol: Protocol
    options: Mapping[str, Any] = field(default_factory=dict)

    def __post_init__(self):
        for name in (*_ARRAYS, "states", "segment"):
            getattr(self, name).flags.writeable = False
        object.__setattr__(self, "options", MappingProxyType(dict(self.options)))

    def __repr__(self):
        outcome = "ok" if self.success else "aborted"
        return (
            f"RateStateResult({len(self.model.states)} states, {len(self.t)} points, "
            f"{len(self.events)} events, {outcome})"
        )

    @property
    def theta(self) -> FloatArray:
        """The first state variable [s]."""
        return self.states[0]

    def events_of(self, kind: str) -> tuple[Event, ...]:
        """The events of one kind, in time order."""
        return tuple(event for event in self.events if event.kind == kind)

    def to_frame(self) -> pd.DataFrame:
        """A pandas DataFrame: the arrays, then ``theta_1`` .. ``theta_n``; ``attrs`` holds
        the events, the model, the options and the units."""
        import pandas as pd

        columns = {name: getattr(self, name) for name in _ARRAYS}
        for i, theta in enumerate(self.states):
            columns[f"theta_{i + 1}"] = theta
        columns["segment"] = self.segment
        frame = pd.DataFrame(columns)
        frame.attrs["events"] = [event.to_dict() for event in self.events]
        frame.attrs["model"] = self.model.to_dict()
        frame.attrs["options"] = dict(self.options)
        frame.attrs["units"] = {
            **_UNITS,
            **{f"theta_{i + 1}": "s" for i in range(len(self.states))},
        }
        return frame

    def to_dict(self) -> dict[str, Any]:
        """JSON-safe mapping (non-finite numbers become None)."""
        return {
            "model": self.model.to_dict(),
            "protocol": self.protocol.to_dict(),
            "options": dict(self.options),
            "success": self.success,
            "message": self.message,
            "events": [event.to_dict() for event in self.events],
            **{name: _listed(getattr(self, name)) for name in _ARRAYS},
            "states": [_listed(theta) for theta in self.states],
            "segment": self.segment.tolist(),
        }

    @classmethod
    def from_dict(cls, mapping: Mapping[str, Any]) -> RateStateResult:
        """Inverse of :meth:`to_dict`."""
        return cls(
            **{name: _array(mapping[name]) for name in _ARRAYS},
            states=np.array([_array(theta) for theta in mapping["states"]]).reshape(
                len(mapping["states"]), -1
            ),
            segment=np.array(mapping["segment"], dtype=np.int64),
            events=tuple(Event.from_dict(item) for item in mapping["events"]),
            success=bool(mapping["success"]),
            message=mapping["message"],
            model=RateState.from_dict(mapping["model"]),
            protocol=Protocol.from_dict(mapping["protocol"]),
            options=mapping["options"],
        )

    def report(self) -> str:
        """A plain-text summary in the manner of lmfit's fit report."""
        model = self.model
        stiffness = "none (rigid)" if model.stiffness is None else f"{model.stiffness:.6g}"
        lines = [
            "[[Rate-and-state simulation]]",
            f"    mu0        = {model.mu0:.6g}",
            f"    a          = {model.a:.6g}",
            f"    v_ref      = {model.v_ref:.6g} m/s",
            f"    stiffness  = {stiffness}",
            f"    eta        = {model.radiation_damping:.6g} s/m",
        ]
        for i, state in enumerate(model.states):
            extra = f", c = {state.c:.6g}" if state.c is not None else ""
            lines.append(
                f"    state {i + 1:<4} = {state.law}: b = {state.b:.6g}, Dc = {state.Dc:.6g} m"
                f"{extra}"
            )
        lines += [
            f"    time       = {self.t[-1]:.6g} s of {self.protocol.duration:.6g} s",
            f"    success    = {self.success}",
            f"    message    = {self.message}",
            "[[Events]]",
        ]
        if not self.events:
            lines.append("    (none)")
        for event in self.events:
            lines.append(
                f"    {event.kind:<8} t = {event.time:<12.7g} s  slip = {event.slip:<12.7g} m  "
                f"mu = {event.force:.7g}"
            )
        return "\n".join(lines)

    def plot(self, ax: Axes | None = None) -> Axes:
        """Friction against time, with the steady state of the load-point velocity
        (:func:`granflow.plotting.rsf.plot_rsf_simulation`).

        Returns
        -------
        matplotlib.axes.Axes
        """
        from granflow.plotting.rsf import plot_rsf_simulation

        return plot_rsf_simulation(self, ax)
