"""Run a load-point velocity history through a rate-and-state spring-slider.

The protocol's rate-controlled segments (:class:`~granflow.Velocity`,
:class:`~granflow.VelocitySteps`, :class:`~granflow.VelocityTable`, :class:`~granflow.Hold`)
give the load-point velocity, piece by linear piece; the whole history runs in one call of
compiled code (:func:`run`), on the integrator of :mod:`granflow.simulation.ode` (Rodas4 with
the analytic Jacobian), so that a fit can call it many times at little cost beyond the
integration itself. Time is the protocol's time, 0 when the protocol starts.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import TYPE_CHECKING

import numpy as np

from granflow import _validate as check
from granflow.errors import InvalidParameterError
from granflow.simulation import equations as eq
from granflow.simulation import ode
from granflow.simulation.options import check_choice
from granflow.simulation.protocol import Protocol
from granflow.simulation.results import Event
from granflow.simulation.rsf.model import RateState
from granflow.simulation.rsf.pieces import absolute_tolerances, load_point, protocol_pieces, run
from granflow.simulation.rsf.result import RateStateResult

if TYPE_CHECKING:
    from granflow._typing import ArrayLike
    from granflow.simulation.protocol import Protocol
    from granflow.simulation.rsf.model import RateState
    from granflow.simulation.rsf.result import RateStateResult
    from granflow.simulation.segments import Segment

__all__ = ["simulate"]

_METHODS = {"rodas4": ode.RODAS4, "dop853": ode.DOP853}
_MESSAGES = {
    ode.STEP_TOO_SMALL: "the step size fell below the resolution of the time",
    ode.WORK_EXCEEDED: "gave up after max_evaluations right-hand-side evaluations",
}


@eq.compiled
def _velocities(p, states):
    """The slider's velocity at each row of ``states`` (a model with a spring)."""
    out = np.empty(states.shape[0])
    for i in range(states.shape[0]):
        out[i] = eq.rsf_velocity(0.0, states[i], p)[0]
    return out


def _times(t_eval, pieces, points):
    if t_eval is None:
        return np.unique(np.concatenate([np.linspace(a, b, points + 1) for a, b, *_ in pieces]))
    times = check.real_array(t_eval, "t_eval", "s").ravel()
    end = pieces[-1, 1]
    if times.size == 0:
        raise InvalidParameterError("t_eval must not be empty")
    if np.any(np.diff(times) < 0):
        raise InvalidParameterError("t_eval must be sorted (non-decreasing)")
    if times[0] < 0 or times[-1] > end:
        raise InvalidParameterError(
            f"t_eval must lie within the protocol, 0 .. {end:g} s, got {times[0]:g} .. "
            f"{times[-1]:g} s"
        )
    return times


def simulate(
    model: RateState,
    protocol: Protocol | Iterable[Segment],
    *,
    t_eval: ArrayLike | None = None,
    initial_velocity: float | None = None,
    initial_states: Sequence[float] | None = None,
    points: int = 200,
    rtol: float = 1e-10,
    max_evaluations: int = 10000000,
    method: str = "rodas4",
) -> RateStateResult:
    """Slide a rate-and-state spring-slider through a load-point velocity history.

    Parameters
    ----------
    model : RateState
    protocol : Protocol or sequence of segments
        Rate-controlled segments only; the load point's velocity [m/s].
    t_eval : array_like, optional
        Output times [s] (protocol time, sorted, within the protocol); default ``points``
        per piece.
    initial_velocity : float, optional
        The slider's velocity at t = 0 [m/s]; default the first piece's load-point velocity.
    initial_states : sequence of float, optional
        theta_i at t = 0 [s]; default the steady state at ``initial_velocity``. Without a
        spring theta may start at 0.
    points : int
        Output points per piece when ``t_eval`` is not given.
    rtol : float
        Relative tolerance of the integration.
    max_evaluations : int
        Bound on the work (right-hand-side evaluations); past it the result is unsuccessful.
    method : {"rodas4", "dop853"}
        The integrator: Rodas4 (default; stiff systems, analytic Jacobian) or DOP853
        (explicit, order 8: fewer steps where the system is not stiff, such as slow loading
        on a soft spring).

    Returns
    -------
    RateStateResult

    Examples
    --------
    >>> import numpy as np
    >>> import granflow as gf
    >>> from granflow import rsf
    >>> model = rsf.RateState(0.6, 0.005, 1.0, 1e-3, [rsf.State(0.01, 10.0, "aging")])
    >>> steps = gf.Protocol([gf.Velocity(1.0, 10.0), gf.Velocity(10.0, 300.0)])
    >>> result = rsf.simulate(model, steps, t_eval=np.arange(0.0, 311.0))
    >>> bool(abs(result.friction[-1] - model.steady_state_friction(10.0)) < 1e-6)
    True
    """
    if not isinstance(model, RateState):
        raise InvalidParameterError(f"model must be an rsf.RateState, got {type(model).__name__}")
    if not isinstance(protocol, Protocol):
        protocol = Protocol(protocol)
    check_choice(method, "method", tuple(_METHODS))
    rtol = check.positive(rtol, "rtol")
    points = int(check.positive(points, "points"))
    max_evaluations = int(check.positive(max_evaluations, "max_evaluations"))
    pieces, owners = protocol_pieces(protocol, spring=model.stiffness is not None)
    times = _times(t_eval, pieces, points)
    if initial_velocity is None:
        initial_velocity = pieces[0, 2]
        if initial_velocity <= 0:
            raise InvalidParameterError(
                "initial_velocity is missing: the protocol starts at rest, so there is no "
                "steady state to start from"
            )
    v0 = check.positive(initial_velocity, "initial_velocity", "m/s")
    if initial_states is None:
        thetas = model.steady_state(v0)
    else:
        thetas = check.real_array(initial_states, "initial_states", "s").ravel()
        if thetas.size != len(model.states):
            raise InvalidParameterError(
                f"initial_states must hold {len(model.states)} values, got {thetas.size}"
            )
        if np.any(thetas < 0) or (model.stiffness is not None and np.any(thetas <= 0)):
            raise InvalidParameterError(
                f"initial_states must be positive (0 only without a spring), got {thetas.min():g} s"
            )
    spring = model.stiffness is not None
    mu_init = float(model.friction(v0, thetas)) - model.mu0 if spring else 0.0
    y0 = np.array([mu_init, *thetas, 0.0])
    ends = pieces[:, 2] + pieces[:, 3] * (pieces[:, 1] - pieces[:, 0])
    v_scale = max(v0, float(np.max(pieces[:, 2])), float(np.max(ends)))
    atol = absolute_tolerances(model, rtol, v_scale)
    p = model.parameters()
    capacity = 4 * len(pieces) + 64
    status, last, out, peak_t, peak_y, found, counters = run(
        _METHODS[method],
        p,
        pieces,
        y0,
        times,
        rtol,
        atol,
        max_evaluations,
        True,
        model.stiffness is not None,
        capacity,
    )
    done = ~np.isnan(out[:, 0])
    times, out = times[done], out[done]
    piece_of = np.minimum(np.searchsorted(pieces[:, 1], times, side="left"), len(pieces) - 1)
    load_point_velocity = load_point(pieces, times)[1]
    thetas_out = out[:, 1:-1].T
    if model.stiffness is None:
        velocity = load_point_velocity
        friction = model.friction(velocity, thetas_out)
    else:
        velocity = _velocities(p, out)
        friction = out[:, 0] + model.mu0
    events = []
    for k in range(int(found)):
        when, state = float(peak_t[k]), peak_y[k]
        owner = int(owners[min(int(np.searchsorted(pieces[:, 1], when)), len(pieces) - 1)])
        mu = float(state[0]) + model.mu0
        events.append(
            Event("peak", when, float(state[-1]), mu, float(state[1]), owner, "friction maximum")
        )
    success = status == ode.DONE
    message = "completed"
    if not success:
        owner = int(owners[last])
        message = f"segment {owner + 1}: {_MESSAGES.get(int(status), 'integration failed')}"
    return RateStateResult(
        t=times,
        slip=out[:, -1],
        velocity=velocity,
        friction=friction,
        states=thetas_out,
        load_point_velocity=load_point_velocity,
        segment=owners[piece_of],
        events=tuple(events),
        success=success,
        message=message,
        model=model,
        protocol=protocol,
        options={
            "rtol": rtol,
            "max_evaluations": max_evaluations,
            "evaluations": int(counters[ode.COUNT_EVALUATIONS]),
            "initial_velocity": v0,
            "method": method,
        },
    )
