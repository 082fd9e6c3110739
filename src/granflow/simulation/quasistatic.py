"""The quasi-static stepper: inertia neglected, as in the paper (SPEC §2), on either clock.

*Slip clock.* From a state (x_s, F_s) the layer, when it slides, follows the closed form
:class:`~granflow.simulation.curve.Curve`. Under a force sigma > F_s it slides to the first x
where F(x) = sigma on the rising branch (a stop), or fails if sigma exceeds the largest F
ahead. Under a ramp it creeps up the branch, ``x(t) = F^-1(sigma(t))``, and fails when sigma
reaches F_peak, exactly.

*Time clock.* Sliding at a fixed age only rejuvenates, so the largest F ahead is max(F, Fd);
while stuck the strength ages, ``F = F_s + a ln(tau / tau_s)``. Above the strength the layer
fails if sigma >= Fd, else slides by ``alpha dx = ln((Fd - F)/(Fd - sigma))`` and creeps with
F = sigma, integrated in closed form for a linear ramp.

With the direct effect the layer never sticks: the force balance gives the creep velocity,
which is integrated (both clocks).
"""

import math

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from granflow.simulation.curve import Curve, offsets
from granflow.simulation.direct import creep_velocity
from granflow.simulation.state import IntegrationError
from granflow.simulation.stepper import Stepper, rigid_rate

__all__ = ["QuasiStaticStepper"]

_REJUVENATION_ONLY = "sliding only lowers the strength towards Fd = {:.7g} N (time clock)"


class QuasiStaticStepper(Stepper):
    """No inertia: closed forms and root finding, or the creep velocity with a direct effect."""

    def __init__(self, state, drive, effect):
        super().__init__(state, drive, effect)
        if effect is not None:
            self._force = self._creep
        elif state.time_clock:
            self._force = self._time
        else:
            self._force = self._slip

    def rate(self, piece):
        rigid_rate(self.state, piece, self.effect)

    def force(self, piece):
        state = self.state
        if state.sliding and piece.start <= state.F and piece.rate <= 0:
            state.stop()
        self._force(piece)

    def _slip(self, piece):
        """Slip clock, no inertia: closed form and root finding only."""
        state = self.state
        sigma_a, rate, d = piece.start, piece.rate, piece.duration
        t_a, t_b = state.t, state.t + d
        curve = Curve(state.params, state.x, state.F)
        top, attained = curve.top()
        state.record(t_a, state.x, 0.0, sigma_a, state.F, state.tau, state.displacement)
        if sigma_a > state.F:
            state.event("slide", t_a, state.x, sigma_a, state.F, "the force exceeds the strength")
            if sigma_a > top or (sigma_a == top and not attained):
                state.runaway(
                    t_a, sigma_a, f"the force exceeds the largest friction ahead ({top:.7g} N)"
                )
                return
            x_new = curve.root(sigma_a)
            state.jump(x_new, curve(x_new), sigma_a)
            if rate <= 0:
                state.event("stop", t_a, state.x, sigma_a, state.F, "the layer sticks")
        if rate <= 0 or t_a + (state.F - sigma_a) / rate >= t_b:
            state.stuck(t_a, t_b, sigma_a, piece.end)
            state.sliding = False
            return
        t_u = t_a + max(state.F - sigma_a, 0.0) / rate
        if t_u > t_a:
            state.stuck(t_a, t_u, sigma_a, sigma_a + rate * (t_u - t_a))
            state.event("slide", t_u, state.x, state.F, state.F, "the force reaches the strength")
        t_f = t_a + (top - sigma_a) / rate
        if t_f <= t_u and curve.peak is None:  # on the falling branch: no creep, a runaway
            state.runaway(t_u, state.F, "the force exceeds the friction on the falling branch")
            return
        failing = t_f <= t_b
        t_end = t_f if failing else t_b
        sigma_end = top if failing else piece.end
        if failing and not attained:
            sigma_end = top * (1.0 - 1e-9)
        x_end = curve.peak[0] if (failing and curve.peak is not None and attained) else None
        if x_end is None:
            x_end = curve.root(sigma_end) if sigma_end > state.F else state.x
        x = state.x + (x_end - state.x) * np.union1d(
            np.linspace(0.0, 1.0, state.points), np.geomspace(1e-6, 1.0, state.points // 4)
        )
        F = curve.values(x)
        F[-1] = sigma_end if not failing else F[-1]
        times = np.clip(t_a + (F - sigma_a) / rate, t_u, t_end)
        times[-1] = t_end
        with np.errstate(divide="ignore"):
            velocity = rate / curve.slope(x, F)
        if failing:
            velocity[-1] = np.inf
        state.record(
            times, x, velocity, F, F, state.tau + (times - t_a), state.displacement + (x - state.x)
        )
        state.displacement += x_end - state.x
        state.t, state.x, state.F, state.tau = t_end, x_end, float(F[-1]), state.tau + (t_end - t_a)
        state.v = float(velocity[-1])
        state.sliding = True
        if failing:
            state.applied = sigma_end
            state.fail(
                t_end,
                x_end,
                sigma_end,
                state.F,
                "the force reached the largest friction ahead (the peak)",
            )

    def _time(self, piece):
        """Time clock, no inertia: aging while stuck, rejuvenation while sliding."""
        state = self.state
        p = state.params
        sigma_a, rate, d = piece.start, piece.rate, piece.duration
        t_a, t_b = state.t, state.t + d
        state.record(t_a, state.x, 0.0, sigma_a, state.F, state.tau, state.displacement)
        if sigma_a > state.F:
            state.event("slide", t_a, state.x, sigma_a, state.F, "the force exceeds the strength")
            if sigma_a >= p.Fd:
                state.runaway(t_a, sigma_a, _REJUVENATION_ONLY.format(p.Fd))
                return
            x_new = state.x + math.log((p.Fd - state.F) / (p.Fd - sigma_a)) / p.alpha
            state.jump(x_new, sigma_a, sigma_a)
            if rate <= p.a / state.tau:
                state.event("stop", t_a, state.x, sigma_a, state.F, "the layer sticks")
        # the gap between force and strength while stuck: convex in time
        F_s, tau_s = state.F, state.tau

        def gap(t):
            return sigma_a + rate * (t - t_a) - F_s - p.a * math.log((tau_s + t - t_a) / tau_s)

        t_u = None
        if rate > 0:
            t_low = t_a
            if rate < p.a / tau_s:  # the gap first falls, to its minimum at tau = a / rate
                t_low = min(t_a + p.a / rate - tau_s, t_b)
            if gap(t_low) >= 0 and t_low == t_a:
                t_u = t_a
            elif gap(t_b) > 0:
                t_u = brentq(gap, t_low, t_b, xtol=1e-14 * max(t_b, 1.0), rtol=1e-15)
        if t_u is None:
            state.stuck(t_a, t_b, sigma_a, piece.end)
            state.sliding = False
            return
        state.stuck(t_a, t_u, sigma_a, sigma_a + rate * (t_u - t_a))
        sigma_u = sigma_a + rate * (t_u - t_a)
        if t_u > t_a:
            state.event("slide", t_u, state.x, sigma_u, state.F, "the force reaches the strength")
        if sigma_u >= p.Fd:
            state.runaway(t_u, sigma_u, _REJUVENATION_ONLY.format(p.Fd))
            return
        # sliding with F = sigma: alpha dx/dtau = (rate - a/tau) / (Fd - sigma), closed form
        tau_u, gap_u = state.tau, p.Fd - sigma_u
        t_f = t_u + gap_u / rate
        failing = t_f <= t_b
        remaining = np.geomspace(1.0, 1e-9, state.points) if failing else None
        if failing:
            times = t_f - gap_u * remaining / rate
        else:
            times = t_u + offsets(t_b - t_u, state.points)
        tau = tau_u + (times - t_u)
        gap_now = p.Fd - (sigma_u + rate * (times - t_u))
        if failing:
            gap_now = gap_u * remaining
        total = gap_now + rate * tau  # C = Fd - sigma(tau) + rate tau, constant and positive
        C = total[0]
        x = (
            state.x
            + (-(1 - p.a / C) * np.log(gap_now / gap_u) - (p.a / C) * np.log(tau / tau_u)) / p.alpha
        )
        sigma = p.Fd - gap_now
        velocity = (rate - p.a / tau) / (p.alpha * gap_now)
        if failing:
            velocity[-1] = np.inf
        state.record(times, x, velocity, sigma, sigma, tau, state.displacement + (x - state.x))
        state.displacement += float(x[-1]) - state.x
        state.t, state.x, state.F, state.tau = (
            float(times[-1]),
            float(x[-1]),
            float(sigma[-1]),
            float(tau[-1]),
        )
        state.v = float(velocity[-1])
        state.sliding = True
        if failing:
            state.applied = float(sigma[-1])
            state.fail(
                state.t,
                state.x,
                state.applied,
                state.F,
                f"the force reached Fd = {p.Fd:.7g} N while creeping (time clock)",
            )

    def _creep(self, piece):
        """With the direct effect: the layer creeps at the force-balance velocity."""
        state = self.state
        count = state.count
        p = state.params
        effect, v_fail = self.effect, self.drive.v_fail
        sigma_a, rate, d = piece.start, piece.rate, piece.duration
        t_a, tau_a, D_a = state.t, state.tau, state.displacement
        time_clock = state.time_clock

        def velocity(offset, F):
            return creep_velocity(effect, sigma_a + rate * offset, F)

        def rhs(offset, y):
            count()
            x, F = y
            v = velocity(offset, F)
            if time_clock:
                return [v, p.a / (tau_a + offset) - p.alpha * v * (F - p.Fd)]
            return [v, v * (p.a / x - p.alpha * (F - p.Fd))]

        def failure(offset, y):
            return math.log(max(velocity(offset, y[1]), 1e-300)) - math.log(v_fail)

        failure.terminal, failure.direction = True, 1
        sol = solve_ivp(
            rhs,
            (0.0, d),
            [state.x, state.F],
            method="LSODA",
            rtol=state.numerics.rtol,
            atol=[p.x0 * 1e-10, 1e-13 * max(p.a, p.Fd)],
            dense_output=True,
            events=failure,
        )
        if sol.status == -1:
            raise IntegrationError(sol.message)
        finite = np.all(np.isfinite(sol.y), axis=0)
        if not finite.all():
            # v = v_ref exp((sigma - F) / A) past float range: the state follows it there
            # (a force step far above the friction on a small A), and no failure event can
            # be read from it
            raise IntegrationError(
                f"the creep velocity left float range near t = {t_a + sol.t[~finite][0]:.6g} s "
                f"(the force {sigma_a + rate * sol.t[~finite][0]:.6g} N against the friction, "
                f"A = {effect.amplitude:.4g} N)"
            )
        end = float(sol.t[-1])
        u = np.union1d(offsets(end, state.points), [end]) if end > 0 else np.array([0.0])
        x, F = sol.sol(u)
        v = np.array([velocity(o, f) for o, f in zip(u, F, strict=True)])
        state.record(t_a + u, x, v, sigma_a + rate * u, F, tau_a + u, D_a + (x - state.x))
        state.displacement = D_a + float(x[-1]) - state.x
        state.t, state.tau, state.x, state.F, state.v = (
            t_a + end,
            tau_a + end,
            float(x[-1]),
            float(F[-1]),
            float(v[-1]),
        )
        state.sliding = True
        if sol.status == 1:
            state.applied = sigma_a + rate * end
            state.fail(
                state.t,
                state.x,
                state.applied,
                state.F,
                f"the creep velocity exceeded v_fail = {v_fail:.4g} m/s",
            )
