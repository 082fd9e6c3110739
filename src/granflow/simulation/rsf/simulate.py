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
from granflow.errors import InvalidParameterError, InvalidProtocolError
from granflow.simulation import equations as eq
from granflow.simulation import ode
from granflow.simulation.options import check_choice
from granflow.simulation.protocol import Protocol
from granflow.simulation.results import Event
from granflow.simulation.rsf.model import RateState
from granflow.simulation.rsf.result import RateStateResult

if TYPE_CHECKING:
    from granflow._typing import ArrayLike
    from granflow.simulation.protocol import Protocol
    from granflow.simulation.rsf.model import RateState
    from granflow.simulation.rsf.result import RateStateResult
    from granflow.simulation.segments import Segment

__all__ = ["run", "simulate"]

_METHODS = {"rodas4": ode.RODAS4, "dop853": ode.DOP853}
_MESSAGES = {
    ode.STEP_TOO_SMALL: "the step size fell below the resolution of the time",
    ode.WORK_EXCEEDED: "gave up after max_evaluations right-hand-side evaluations",
}


@eq.compiled
def run(method, p, pieces, y0, t_eval, rtol, atol, max_evaluations, peaks, capacity):
    """Integrate the rate-and-state equations through every piece.

    Parameters
    ----------
    method : int
        :data:`granflow.simulation.ode.RODAS4` or :data:`~granflow.simulation.ode.DOP853`.
    p : ndarray
        Parameter vector (:meth:`RateState.parameters`); not modified.
    pieces : ndarray, shape (m, 4)
        Per piece: start time, end time, load-point velocity at the start, its slope.
    y0 : ndarray
        ``(mu - mu0, theta_1 .. theta_n, slip)`` at the first piece's start.
    t_eval : ndarray
        Increasing output times within the pieces.
    rtol : float
    atol : ndarray
    max_evaluations : int
    peaks : bool
        Whether to locate the friction peaks (v falling through the load-point velocity).
    capacity : int
        At most this many peaks are kept.

    Returns
    -------
    status, index of the last piece run, states at t_eval (NaN past the end), peak times,
    peak states, number of peaks, counters
    """
    p = p.copy()
    y = y0.copy()
    n = y.size
    out_y = np.full((t_eval.size, n), np.nan)
    counters = ode.new_counters()
    ev_t = np.empty(capacity)
    ev_y = np.empty((capacity, n))
    ev_k = np.empty(capacity, dtype=np.int64)
    directions = np.zeros(eq.EVENTS, dtype=np.int64)
    if peaks:
        directions[0] = -1
    terminal = np.zeros(eq.EVENTS, dtype=np.bool_)
    no_t = np.empty(0)
    no_y = np.empty((0, n))
    status = ode.DONE
    index = 0
    for index in range(pieces.shape[0]):
        p[eq.RSF_T_START] = pieces[index, 0]
        p[eq.RSF_START] = pieces[index, 2]
        p[eq.RSF_SLOPE] = pieces[index, 3]
        status, _, _ = ode.solve(
            method,
            eq.RATE_STATE,
            p,
            pieces[index, 0],
            y,
            pieces[index, 1],
            rtol,
            atol,
            0.0,
            max_evaluations,
            directions,
            terminal,
            t_eval,
            out_y,
            True,
            no_t,
            no_y,
            ev_t,
            ev_y,
            ev_k,
            counters,
        )
        if status != ode.DONE:
            break
    return status, index, out_y, ev_t, ev_y, counters[ode.COUNT_EVENTS], counters


@eq.compiled
def _velocities(p, states):
    """The slider's velocity at each row of ``states`` (a model with a spring)."""
    out = np.empty(states.shape[0])
    for i in range(states.shape[0]):
        out[i] = eq.rsf_velocity(0.0, states[i], p)[0]
    return out


def _pieces(model, protocol):
    """(pieces array, segment index per piece) of the protocol's load-point history."""
    rows, owners = [], []
    t = 0.0
    for index, segment in enumerate(protocol):
        where = f"segment {index + 1} ({segment.type_name})"
        if segment.control != "rate":
            raise InvalidProtocolError(
                f"{where}: rate-and-state models take load-point velocity histories only "
                "(Velocity, VelocitySteps, VelocityTable, Hold)"
            )
        if getattr(segment, "reset", False):
            raise InvalidProtocolError(f"{where}: Hold(reset=True) has no meaning here")
        for piece in segment.pieces():
            if model.stiffness is None and min(piece.start, piece.end) <= 0:
                raise InvalidParameterError(
                    f"stiffness is missing: {where} stops the load point, which a slider "
                    "without a spring cannot follow (its friction would be -inf)"
                )
            slope = (piece.end - piece.start) / piece.duration
            rows.append((t, t + piece.duration, piece.start, slope))
            owners.append(index)
            t += piece.duration
    return np.array(rows, dtype=float), np.array(owners, dtype=np.int64)


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
    pieces, owners = _pieces(model, protocol)
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
    tiny = 1e-3 * rtol
    atol = np.array(
        [tiny * model.a]
        + [tiny * state.Dc / v_scale for state in model.states]
        + [tiny * min(state.Dc for state in model.states)]
    )
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
        model.stiffness is not None,
        capacity,
    )
    done = ~np.isnan(out[:, 0])
    times, out = times[done], out[done]
    piece_of = np.minimum(np.searchsorted(pieces[:, 1], times, side="left"), len(pieces) - 1)
    load_point = pieces[piece_of, 2] + pieces[piece_of, 3] * (times - pieces[piece_of, 0])
    thetas_out = out[:, 1:-1].T
    if model.stiffness is None:
        velocity = load_point
        friction = model.friction(velocity, thetas_out)
    else:
        velocity = _velocities(p, out)
        friction = out[:, 0] + model.mu0
    events = []
    for k in range(int(found)):
        when, state = float(peak_t[k]), peak_y[k]
        owner = int(owners[min(np.searchsorted(pieces[:, 1], when), len(pieces) - 1)])
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
        load_point_velocity=load_point,
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
