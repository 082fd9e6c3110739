"""The interface every stepper implements, and the rigid drive under an imposed velocity.

A stepper advances a :class:`~granflow.simulation.state.RunState` through the pieces of one
protocol segment: :meth:`Stepper.rate` for a piece of imposed velocity (a start-up, a velocity
table, a hold), :meth:`Stepper.force` for a piece of imposed force (a creep, a ramp, a
switch). :meth:`Stepper.segment` is the one entry point the driver calls.

Under an imposed velocity without a spring the drive is rigid and inertia plays no part:
:func:`rigid_rate` serves both the quasi-static and the dynamic stepper.
"""

import numpy as np
from scipy.integrate import solve_ivp

from granflow.simulation.curve import Curve, offset_of, offsets
from granflow.simulation.direct import direct_friction
from granflow.simulation.state import IntegrationError, WorkExceededError

__all__ = ["Stepper", "rigid_rate"]


class Stepper:
    """Base of the steppers: runs a segment piece by piece through :meth:`rate` / :meth:`force`.

    Parameters
    ----------
    state : RunState
        The run to advance (changed in place).
    drive : Drive
    effect : DirectEffect or None
    """

    #: Whether the stepper integrates the drive's inertia (it accepts mass, damping, stiffness).
    inertial = False

    def __init__(self, state, drive, effect):
        self.state = state
        self.drive = drive
        self.effect = effect

    def segment(self, segment):
        """Run every piece of ``segment`` until it ends or the layer fails."""
        state = self.state
        if segment.control == "rate":
            for piece in segment.pieces():
                self.rate(piece)
                if piece.reset:
                    state.reset()
                if state.failure:
                    return
            return
        for piece in segment.pieces(state.applied):
            self.force(piece)
            if state.failure:
                return
            state.applied = piece.end

    def rate(self, piece):
        """Advance through a :class:`~granflow.simulation.segments.RatePiece`."""
        raise NotImplementedError

    def force(self, piece):
        """Advance through a :class:`~granflow.simulation.segments.ForcePiece`."""
        raise NotImplementedError


def rigid_rate(state, piece, effect):
    """A rigid drive imposes the velocity of ``piece``: both clocks, closed form where it can."""
    p = state.params
    d = piece.duration
    v_a, v_b = piece.start, piece.end
    u = offsets(d, state.points)
    x_s, F_s, tau_s, t_s = state.x, state.F, state.tau, state.t
    accel = (v_b - v_a) / d

    def slip_at(offset):
        return x_s + v_a * offset + 0.5 * accel * offset**2

    peak_offset = None
    if v_a == 0 and v_b == 0:
        F = None
    elif not state.time_clock or v_a == v_b:
        # slip clock: F(x); time clock at constant v: the same curve in z = v tau
        if not state.time_clock:
            curve = Curve(p, x_s, F_s)
            z_of = slip_at
        else:
            curve = Curve(p, v_a * tau_s, F_s)

            def z_of(offset):
                return v_a * (tau_s + offset)

        z_end = z_of(d)
        if curve.peak is not None and curve.peak[0] <= z_end:
            peak_offset = offset_of(curve.peak[0], z_of, d)
            u = np.union1d(u, [peak_offset])
        F = curve.values(z_of(u))
    else:
        F, peak_offset, u = _time_clock_ode(state, piece, u)
    if F is None:  # rest
        F = F_s + p.a * np.log((tau_s + u) / tau_s) if state.time_clock else np.full(u.shape, F_s)
    velocity = v_a + accel * u
    x = slip_at(u)
    force = F if effect is None else direct_friction(effect, velocity, F)
    if v_a == 0 and v_b == 0:  # the drive stands still: its force stays
        force = np.full(u.shape, state.applied)
    state.record(t_s + u, x, velocity, force, F, tau_s + u, state.displacement + (x - x_s))
    if peak_offset is not None:
        i = int(np.searchsorted(u, peak_offset))
        state.event("peak", t_s + u[i], x[i], force[i], F[i], "maximum of the friction")
    state.t, state.x, state.F, state.tau = t_s + d, float(x[-1]), float(F[-1]), tau_s + d
    state.v = v_b
    state.displacement += float(x[-1]) - x_s
    state.applied = float(force[-1])
    state.sliding = v_b > 0


def _time_clock_ode(state, piece, u):
    """Time clock under a velocity that changes linearly: integrate Eq. 2 in time."""
    p = state.params
    d = piece.duration
    v_a, accel = piece.start, (piece.end - piece.start) / piece.duration
    tau_s = state.tau

    def rhs(offset, y):
        _count(state)
        return [p.a / (tau_s + offset) - p.alpha * (v_a + accel * offset) * (y[0] - p.Fd)]

    def turning(offset, y):
        return rhs(offset, y)[0]

    turning.direction = -1
    sol = solve_ivp(
        rhs,
        (0.0, d),
        [state.F],
        method="LSODA",
        rtol=1e-11,
        atol=1e-14 * max(p.a, p.Fd, 1e-300),
        dense_output=True,
        events=turning,
    )
    if sol.status == -1:
        raise IntegrationError(sol.message)
    peak_offset = float(sol.t_events[0][0]) if sol.t_events[0].size else None
    if peak_offset is not None:
        u = np.union1d(u, [peak_offset])
    return sol.sol(u)[0], peak_offset, u


def _count(state):
    """Count one evaluation against max_evaluations (never against wall time: a run must
    give the same answer on a quiet and on a busy machine)."""
    state.evaluations += 1
    if state.evaluations > state.numerics.max_evaluations:
        raise WorkExceededError(
            f"gave up after {state.evaluations} right-hand-side evaluations (max_evaluations)"
        )
