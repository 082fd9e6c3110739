"""The dynamic stepper: the drive's inertia integrated with stick, slide and failure events.

While sliding under an imposed force, ``m dv/dt = sigma - F_friction - c v``, ``dx/dt = v``
and Eq. 2 for F; *failure* when v rises through ``v_fail`` (terminal), *stop* when v falls
through ``v_stop``, after which the layer sticks while ``sigma <= F + c v_stop``, and *slide*
when the force exceeds that again. With a machine stiffness K a spring sits between a
rate-controlled drive and the layer (spring-block slider): ``m dv/dt = K s - F_friction - c v``,
``ds/dt = v_drive - v``. Under an imposed velocity without a spring the drive is rigid and the
quasi-static answer is exact (:func:`~granflow.simulation.stepper.rigid_rate`).

The equations are those of :mod:`granflow.simulation.equations`, integrated by the one
compiled integrator (:func:`granflow.simulation.ode.solve`); the whole piece, its phases and
its events run in compiled code (:func:`run_piece`), so a stick-slip piece with thousands of
transitions costs no Python call per phase. The work is bounded by right-hand-side
evaluations and transitions, never by wall time: a run gives the same answer on a quiet and
on a busy machine.
"""

import numpy as np

from granflow.simulation import equations as eq
from granflow.simulation import ode
from granflow.simulation.state import IntegrationError, WorkExceededError
from granflow.simulation.stepper import Stepper, rigid_rate

__all__ = ["DynamicStepper", "run_piece", "slider_parameters"]

_TIME_TOLERANCE = 1e-12  # relative, for "the piece has ended"
#: Outcomes of :func:`run_piece` beyond those of :func:`granflow.simulation.ode.solve`.
FAILED, TOO_MANY_TRANSITIONS = 2, -3
#: Event codes of :func:`run_piece`: the slider's event functions.
_FAILURE, _STOP, _SLIDE = 0, 1, 2
_KINDS = {_STOP: "stop", _SLIDE: "slide"}


@eq.compiled
def run_piece(
    p,
    y,
    t,
    t_b,
    sliding,
    stops,
    rtol,
    atol,
    max_evaluations,
    transitions,
    out_t,
    out_y,
    rec_t,
    rec_y,
    ev_t,
    ev_y,
    ev_k,
    counters,
):
    """Integrate one piece of the drive from (t, y) to t_b through slide and stick phases.

    ``y`` is overwritten with the state at the end; the output grid ``out_t``, the step
    record and the events (time, state before any reset, code) are filled as in
    :func:`granflow.simulation.ode.solve`. ``transitions`` bounds the phases.

    Returns
    -------
    status, t, sliding, transitions left, events found
    """
    end = t_b - 1e-12 * max(abs(t_b), 1.0)
    slide_directions = np.array([1, -1 if stops else 0, 0], dtype=np.int64)
    stuck_directions = np.array([0, 0, 1], dtype=np.int64)
    terminal = np.ones(eq.EVENTS, dtype=np.bool_)
    no_t = np.empty(0)
    no_y = np.empty((0, y.size))
    no_k = np.empty(0, dtype=np.int64)
    # the direct effect makes slow creep stiff; without it the slider is an oscillator
    method = ode.DOP853 if stops else ode.RODAS4
    found = 0
    h = 0.0
    status = ode.DONE
    while t < end:
        if transitions <= 0:
            return TOO_MANY_TRANSITIONS, t, sliding, transitions, found
        transitions -= 1
        kind = eq.SLIDE if sliding else eq.STUCK
        directions = slide_directions if sliding else stuck_directions
        status, t, h = ode.solve(
            method,
            kind,
            p,
            t,
            y,
            t_b,
            rtol,
            atol,
            h,
            max_evaluations,
            directions,
            terminal,
            out_t,
            out_y,
            False,
            rec_t,
            rec_y,
            no_t,
            no_y,
            no_k,
            counters,
        )
        if status != ode.EVENT:
            break
        fired = counters[ode.COUNT_FIRED]
        if found < ev_t.size:
            ev_t[found] = t
            ev_y[found, :] = y
            ev_k[found] = fired
            found += 1
        if fired == _FAILURE:
            return FAILED, t, sliding, transitions, found
        if fired == _STOP:
            y[1] = 0.0
            sliding = False
        else:
            sliding = True
        status = ode.DONE
    return status, t, sliding, transitions, found


def slider_parameters(state, drive, effect, piece, *, rate):
    """The parameter vector of the slider's equations over ``piece`` from ``state``."""
    p = np.zeros(eq.SLIDER_PARAMETERS)
    params = state.params
    p[eq.A], p[eq.ALPHA], p[eq.FD] = params.a, params.alpha, params.Fd
    p[eq.MASS], p[eq.DAMPING] = drive.mass, drive.damping
    p[eq.STIFFNESS] = drive.stiffness or 0.0
    p[eq.RATE] = 1.0 if rate else 0.0
    p[eq.TIME_CLOCK] = 1.0 if state.time_clock else 0.0
    p[eq.TAU_SHIFT] = state.tau - state.t
    p[eq.T_START] = state.t
    p[eq.START] = piece.start
    p[eq.SLOPE] = (piece.end - piece.start) / piece.duration
    if effect is not None:
        p[eq.AMPLITUDE], p[eq.V_REF] = effect.amplitude, effect.velocity
    p[eq.V_FAIL], p[eq.V_STOP] = drive.v_fail, drive.v_stop
    return p


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
        state, effect, drive = self.state, self.effect, self.drive
        numerics = state.numerics
        p = slider_parameters(state, drive, effect, piece, rate=rate)
        params = state.params
        K = drive.stiffness
        t = state.t
        t_b = t + piece.duration
        y = np.array([state.x, state.v, state.F, state.applied / K if K else 0.0])
        tau_shift, x_shift = p[eq.TAU_SHIFT], state.displacement - state.x
        scale = max(params.a, params.Fd)
        atol = np.array(
            [params.x0 * 1e-9, drive.v_stop * 1e-3, 1e-13 * scale, 1e-13 * scale / K if K else 1.0]
        )
        g = np.empty(eq.EVENTS)
        eq.events(eq.SLIDE, t, y, p, g)
        sliding = effect is not None or y[1] > drive.v_stop or g[_SLIDE] > 0
        force_now = eq.slider_drive_force(t, y, p)
        if sliding and effect is None and y[1] <= drive.v_stop:
            state.event("slide", t, y[0], force_now, y[2], "the force exceeds the strength")
        state.record(t, y[0], y[1], force_now, y[2], t + tau_shift, y[0] + x_shift)
        out_t = np.linspace(t, t_b, state.points + 1)[1:]
        out_y = np.empty((out_t.size, 4))
        rec_t, rec_y = np.empty(4 * state.points), np.empty((4 * state.points, 4))
        left = numerics.max_transitions - state.phases
        ev_t, ev_y = np.empty(max(left, 0) + 1), np.empty((max(left, 0) + 1, 4))
        ev_k = np.empty(max(left, 0) + 1, dtype=np.int64)
        counters = ode.new_counters()
        status, t, sliding, remaining, found = run_piece(
            p,
            y,
            t,
            t_b,
            sliding,
            effect is None,
            numerics.rtol,
            atol,
            numerics.max_evaluations - state.evaluations,
            left,
            out_t,
            out_y,
            rec_t,
            rec_y,
            ev_t,
            ev_y,
            ev_k,
            counters,
        )
        state.phases += left - remaining
        state.evaluations += int(counters[ode.COUNT_EVALUATIONS])
        filled, recorded = counters[ode.COUNT_OUT], counters[ode.COUNT_RECORDED]
        times = np.concatenate([out_t[:filled], rec_t[:recorded], ev_t[:found]])
        states = np.concatenate([out_y[:filled], rec_y[:recorded], ev_y[:found]])
        times, first = np.unique(times, return_index=True)
        states = states[first].T
        force = K * states[3] if rate else piece.start + p[eq.SLOPE] * (times - p[eq.T_START])
        state.record(
            times, states[0], states[1], force, states[2], times + tau_shift, states[0] + x_shift
        )
        for index in range(found):
            code, when, at = int(ev_k[index]), float(ev_t[index]), ev_y[index]
            if code != _FAILURE:
                message = "the layer sticks" if code == _STOP else "the force exceeds the strength"
                force_at = eq.slider_drive_force(when, at, p)
                state.event(_KINDS[code], when, at[0], force_at, at[2], message)
        force_end = eq.slider_drive_force(t, y, p) if rate or t < t_b else piece.end
        self._finish(t, y, force_end, tau_shift, x_shift)
        if status == FAILED:
            state.fail(
                t, y[0], force_end, y[2], f"the velocity exceeded v_fail = {drive.v_fail:.4g} m/s"
            )
            return
        if status == TOO_MANY_TRANSITIONS:
            raise WorkExceededError(
                f"gave up after {numerics.max_transitions} stick-slip transitions (max_transitions)"
            )
        if status == ode.WORK_EXCEEDED:
            raise WorkExceededError(
                f"gave up after {state.evaluations} right-hand-side evaluations (max_evaluations)"
            )
        if status == ode.STEP_TOO_SMALL:
            raise IntegrationError(f"the step size fell below the resolution of t = {t:.6g} s")
        state.sliding = sliding and y[1] > 0

    def _finish(self, t, y, force, tau_shift, x_shift):
        state = self.state
        state.t = t
        state.tau = t + tau_shift
        state.x, state.v, state.F = float(y[0]), float(y[1]), float(y[2])
        state.displacement = state.x + x_shift
        state.applied = float(force)
