"""A load-point velocity history as linear pieces, and the compiled run through them.

What :func:`granflow.rsf.simulate` and :func:`granflow.rsf.fit` share: the conversion of a
:class:`~granflow.Protocol` into a table of pieces (:func:`protocol_pieces`, with every check
in one place), the load point's displacement and velocity along it (:func:`load_point`) and
the compiled loop that integrates the rate-and-state equations piece by piece (:func:`run`,
on Rodas4 or DOP853 of :mod:`granflow.simulation.ode`). Time is the protocol's time, 0 where
the protocol starts.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from granflow.errors import InvalidParameterError, InvalidProtocolError
from granflow.simulation import equations as eq
from granflow.simulation import ode

if TYPE_CHECKING:
    from granflow._typing import FloatArray
    from granflow.simulation.protocol import Protocol
    from granflow.simulation.rsf.model import RateState

__all__ = ["absolute_tolerances", "load_point", "protocol_pieces", "run"]


def protocol_pieces(protocol: Protocol, *, spring: bool = True) -> tuple[FloatArray, np.ndarray]:
    """The protocol's load-point history as linear pieces.

    Parameters
    ----------
    protocol : Protocol
        Rate-controlled segments only (:class:`~granflow.Velocity`,
        :class:`~granflow.VelocitySteps`, :class:`~granflow.VelocityTable`,
        :class:`~granflow.Hold`) [m/s].
    spring : bool
        Whether a spring joins the load point to the slider; without one the load point may
        not stop (the slider would have to stop with it, at a friction of -inf).

    Returns
    -------
    pieces : numpy.ndarray, shape (m, 4)
        Per piece: start [s], end [s], load-point velocity at the start [m/s], its slope
        [m/s^2].
    owners : numpy.ndarray of int, shape (m,)
        The index of the segment each piece comes from.

    Raises
    ------
    granflow.InvalidProtocolError
        A segment that is not rate-controlled, or ``Hold(reset=True)``.
    granflow.InvalidParameterError
        A load point that stops with no spring.
    """
    rows, owners = [], []
    t = 0.0
    for index, segment in enumerate(protocol):
        where = f"segment {index + 1} ({segment.type_name})"
        if segment.control != "rate":
            raise InvalidProtocolError(
                f"{where} is not rate-controlled: rate-and-state models take load-point "
                "velocity histories only (Velocity, VelocitySteps, VelocityTable, Hold)"
            )
        if getattr(segment, "reset", False):
            raise InvalidProtocolError(f"{where}: Hold(reset=True) has no meaning here")
        for piece in segment.pieces():
            if not spring and min(piece.start, piece.end) <= 0:
                raise InvalidParameterError(
                    f"stiffness is missing: {where} stops the load point, which a slider "
                    "without a spring cannot follow (its friction would be -inf)"
                )
            slope = (piece.end - piece.start) / piece.duration
            rows.append((t, t + piece.duration, piece.start, slope))
            owners.append(index)
            t += piece.duration
    if not rows:
        raise InvalidProtocolError("protocol holds no segment: no load-point history")
    return np.array(rows, dtype=float), np.array(owners, dtype=np.int64)


def load_point(pieces: FloatArray, t: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Load-point displacement [m] since the first piece's start, and velocity [m/s], at the
    times ``t`` [s] (the clock of ``pieces``; before the first piece or after the last, the
    nearest piece's polynomial continues)."""
    pieces = np.asarray(pieces, dtype=float)
    t = np.asarray(t, dtype=float)
    duration = pieces[:, 1] - pieces[:, 0]
    ends = np.concatenate(
        [[0.0], np.cumsum((pieces[:, 2] + 0.5 * pieces[:, 3] * duration) * duration)]
    )
    index = np.clip(np.searchsorted(pieces[:, 1], t), 0, len(pieces) - 1)
    dt = t - pieces[index, 0]
    displacement = ends[index] + pieces[index, 2] * dt + 0.5 * pieces[index, 3] * dt**2
    return displacement, pieces[index, 2] + pieces[index, 3] * dt


def absolute_tolerances(model: RateState, rtol: float, v_scale: float) -> FloatArray:
    """Absolute tolerances of ``(mu - mu0, theta_i, slip)`` for a run at relative tolerance
    ``rtol``: a thousandth of it times a [-], Dc_i / ``v_scale`` [s] (the states at the
    fastest load-point velocity [m/s]) and the smallest Dc [m]."""
    tiny = 1e-3 * rtol
    return np.array(
        [tiny * model.a]
        + [tiny * state.Dc / v_scale for state in model.states]
        + [tiny * min(state.Dc for state in model.states)]
    )


@eq.compiled
def run(method, p, pieces, y0, t_eval, rtol, atol, max_evaluations, land, peaks, capacity):
    """Integrate the rate-and-state equations through every piece.

    Parameters
    ----------
    method : int
        :data:`granflow.simulation.ode.RODAS4` or :data:`~granflow.simulation.ode.DOP853`.
    p : ndarray
        Parameter vector (:meth:`RateState.parameters`); not modified.
    pieces : ndarray, shape (m, 4)
        Per piece: start time [s], end time [s], load-point velocity at the start [m/s], its
        slope [m/s^2].
    y0 : ndarray
        ``(mu - mu0, theta_1 .. theta_n, slip)`` at the first piece's start.
    t_eval : ndarray
        Increasing output times within the pieces [s].
    rtol : float
    atol : ndarray
    max_evaluations : int
    land : bool
        Whether the steps land on every output time (True) or the outputs come from the
        integrator's dense output (False: the cost follows the dynamics, not the sampling).
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
            land,
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
