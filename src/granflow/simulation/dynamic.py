"""The dynamic stepper: the drive's inertia integrated with stick, slide and failure events.

While sliding under an imposed force, ``m dv/dt = sigma - F_friction - c v``, ``dx/dt = v``
and Eq. 2 for F, integrated with ``scipy.integrate.solve_ivp`` and events: *failure* when v
rises through ``v_fail`` (terminal), *stop* when v falls through ``v_stop``, after which the
layer sticks while ``sigma <= F + c v_stop``, and *slide* when the force exceeds that again.
With a machine stiffness K a spring sits between a rate-controlled drive and the layer
(spring-block slider): ``m dv/dt = K s - F_friction - c v``, ``ds/dt = v_drive - v``. Under an
imposed velocity without a spring the drive is rigid and the quasi-static answer is exact.
"""

import numpy as np
from scipy.integrate import solve_ivp

from granflow.simulation.direct import direct_derivatives, direct_scalar
from granflow.simulation.state import IntegrationError
from granflow.simulation.stepper import Stepper, rigid_rate

__all__ = ["DynamicStepper"]

_TIME_TOLERANCE = 1e-12  # relative, for "the piece has ended"


class _Equations:
    """The slider's equations over one piece, y = (x, v, F, s), as closures for solve_ivp.

    ``rate``: the drive imposes a velocity through the spring (s its extension), else it
    imposes the piece's force directly.
    """

    def __init__(self, state, drive, effect, piece, *, rate):
        p = state.params
        a, alpha, Fd = p.a, p.alpha, p.Fd
        m, c, K = drive.mass, drive.damping, drive.stiffness
        v_fail, v_stop = drive.v_fail, drive.v_stop
        time_clock = state.time_clock
        t_a = state.t
        slope = (piece.end - piece.start) / piece.duration
        start = piece.start
        tau_shift = state.tau - t_a
        amplitude = None if effect is None else effect.amplitude
        v_ref = None if effect is None else effect.velocity
        count = state.count

        def drive_velocity(t):
            return start + slope * (t - t_a) if rate else 0.0

        def drive_force(t, y):
            return K * y[3] if rate else start + slope * (t - t_a)

        def slide_rhs(t, y):
            count()
            x, v, F, s = y
            if time_clock:
                dF = a / (t + tau_shift) - alpha * v * (F - Fd)
            else:
                dF = v * (a / x - alpha * (F - Fd))
            friction = F if amplitude is None else direct_scalar(amplitude, v_ref, v, F)
            drive = K * s if rate else start + slope * (t - t_a)
            return [v, (drive - friction - c * v) / m, dF, (drive_velocity(t) - v) if rate else 0.0]

        def slide_jacobian(t, y):
            x, v, F, _ = y
            if amplitude is None:
                d_friction_dv, d_friction_dF = 0.0, 1.0
            else:
                d_friction_dv, d_friction_dF = direct_derivatives(amplitude, v_ref, v, F)
            if time_clock:
                dF_dx, dF_dv = 0.0, -alpha * (F - Fd)
            else:
                dF_dx, dF_dv = -v * a / x**2, a / x - alpha * (F - Fd)
            return [
                [0.0, 1.0, 0.0, 0.0],
                [0.0, -(d_friction_dv + c) / m, -d_friction_dF / m, K / m if rate else 0.0],
                [dF_dx, dF_dv, -alpha * v, 0.0],
                [0.0, -1.0 if rate else 0.0, 0.0, 0.0],
            ]

        def stuck_rhs(t, y):
            count()
            return [0.0, 0.0, a / (t + tau_shift) if time_clock else 0.0, drive_velocity(t)]

        def failure(t, y):
            return y[1] - v_fail

        def stop(t, y):
            return y[1] - v_stop

        def unstick(t, y):
            return drive_force(t, y) - y[2] - c * v_stop

        failure.terminal, failure.direction = True, 1
        stop.terminal, stop.direction = True, -1
        unstick.terminal, unstick.direction = True, 1

        self.drive_force = drive_force
        self.slide_rhs, self.slide_jacobian, self.stuck_rhs = slide_rhs, slide_jacobian, stuck_rhs
        self.failure, self.stop, self.unstick = failure, stop, unstick
        self.slide_events = [failure] if effect is not None else [failure, stop]
        self.tau_shift = tau_shift
        self.x_shift = state.displacement - state.x  # displacement = x + x_shift in the piece
        self.y0 = np.array([state.x, state.v, state.F, state.applied / K if K else 0.0])
        self.atol = np.array(
            [
                p.x0 * 1e-9,
                v_stop * 1e-3,
                1e-13 * max(a, Fd),
                (1e-13 * max(a, Fd) / K) if K else 1.0,
            ]
        )


class DynamicStepper(Stepper):
    """Inertia, damping and an optional machine spring, integrated between events."""

    inertial = True

    def rate(self, piece):
        if self.drive.stiffness is not None:
            self._integrate(piece, rate=True)
        else:
            rigid_rate(self.state, piece, self.effect)

    def force(self, piece):
        self._integrate(piece, rate=False)

    def _integrate(self, piece, *, rate):
        """Integrate m dv/dt = drive - friction - c v with stick, slide and failure events."""
        state, effect, v_stop = self.state, self.effect, self.drive.v_stop
        equations = _Equations(state, self.drive, effect, piece, rate=rate)
        t = state.t
        t_b = t + piece.duration
        end = t_b - _TIME_TOLERANCE * max(abs(t_b), 1.0)
        y = equations.y0
        sliding = effect is not None or y[1] > v_stop or equations.unstick(t, y) > 0
        if sliding and effect is None and y[1] <= v_stop:
            force = equations.drive_force(t, y)
            state.event("slide", t, y[0], force, y[2], "the force exceeds the strength")
        if not rate:
            state.record(t, state.x, state.v, piece.start, state.F, state.tau, state.displacement)
        while t < end:
            state.transition()
            sol = self._phase(equations, sliding, t, t_b, y)
            t_end = float(sol.t[-1])
            if t_end > t:
                self._record(equations, sol, t, t_end, piece.duration)
            y = np.array(sol.y[:, -1])
            t = t_end
            if sol.status != 1:
                continue
            force_now = equations.drive_force(t, y)
            fired = [i for i, times in enumerate(sol.t_events) if times.size]
            kind = (equations.slide_events if sliding else [equations.unstick])[fired[0]]
            if kind is equations.failure:
                self._finish(equations, t, y, force_now)
                v_fail = self.drive.v_fail
                state.fail(
                    t, y[0], force_now, y[2], f"the velocity exceeded v_fail = {v_fail:.4g} m/s"
                )
                return
            if kind is equations.stop:
                y[1] = 0.0
                sliding = False
                state.event("stop", t, y[0], force_now, y[2], "the layer sticks")
            else:
                sliding = True
                state.event("slide", t, y[0], force_now, y[2], "the force exceeds the strength")
        force_end = equations.drive_force(t, y) if rate else piece.end
        self._finish(equations, t_b if t >= end else t, y, force_end)
        state.sliding = sliding and y[1] > 0

    def _phase(self, equations, sliding, t, t_b, y):
        """One sliding or stuck phase, from t until t_b or the first event."""
        numerics = self.state.numerics
        if sliding:
            jacobian = {"jac": equations.slide_jacobian} if numerics.implicit else {}
            rhs, method, events = equations.slide_rhs, numerics.solver, equations.slide_events
        else:
            jacobian = {}
            rhs, method, events = equations.stuck_rhs, "LSODA", [equations.unstick]
        sol = solve_ivp(
            rhs,
            (t, t_b),
            y,
            method=method,
            rtol=numerics.rtol,
            atol=equations.atol,
            dense_output=True,
            events=events,
            **jacobian,
        )
        if sol.status == -1:
            raise IntegrationError(sol.message)
        return sol

    def _record(self, equations, sol, t, t_end, duration):
        """Record a phase: even output plus (some of) the solver's own steps."""
        state = self.state
        n = max(3, int(state.points * (t_end - t) / duration) + 2)
        times = np.linspace(t, t_end, n)
        # the solver's own steps crowd where the motion is fast: keep (some of) them
        stride = max(1, sol.t.size // (4 * state.points))
        times = np.union1d(times, sol.t[::stride])
        ys = sol.sol(times)
        ys[:, -1] = sol.y[:, -1]
        force = equations.drive_force(times, ys)
        state.record(
            times,
            ys[0],
            ys[1],
            force,
            ys[2],
            times + equations.tau_shift,
            ys[0] + equations.x_shift,
        )

    def _finish(self, equations, t, y, force):
        state = self.state
        state.t = t
        state.tau = t + equations.tau_shift
        state.x, state.v, state.F = float(y[0]), float(y[1]), float(y[2])
        state.displacement = state.x + equations.x_shift
        state.applied = float(force)
