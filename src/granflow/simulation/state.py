"""The state of one run as the steppers advance it, and what they record.

:class:`RunState` holds the layer (aging coordinate x, friction state F, age tau), the drive
(velocity, applied force, total displacement), the recorded arrays and the events, and
bounds the work. The steppers move it; the moves every stepper shares (a stuck interval, a
quasi-static jump or runaway, a reset) live here, and so does the entry of the model into a
start-up (:meth:`RunState.enter`, the one-clock rule of :mod:`granflow.simulation`).

The work is bounded by counting it (right-hand-side evaluations, stick-slip transitions), so
that the answer never depends on the machine; a wall-clock limit is offered but off by
default, and a run stopped by it says so.
"""

import time as _time

import numpy as np

from granflow.simulation.curve import offsets
from granflow.simulation.results import ARRAYS, Event

__all__ = ["IntegrationError", "RunState", "WorkExceededError"]


class WorkExceededError(Exception):
    """The bounded work of a run (evaluations, transitions, or an opted-in wall time) was used
    up."""


class IntegrationError(Exception):
    """solve_ivp reported a failure."""


class RunState:
    """The layer and the drive at the current time of a run, and the output so far.

    Parameters
    ----------
    params : Params
    aging : Aging
    numerics : Numerics
    """

    def __init__(self, params, aging, numerics):
        self.params = params
        self.aging = aging
        self.numerics = numerics
        self.time_clock = aging.clock == "time"
        self.points = numerics.points
        self.t = 0.0
        self.x = params.x0
        self.tau = aging.t0
        self.F = aging.F_init
        self.v = 0.0
        self.applied = 0.0
        self.displacement = 0.0
        self.sliding = False
        self.segment_index = 0
        self.chunks = {name: [] for name in ARRAYS}
        self.events = []
        self.failure = None
        self.evaluations = 0
        self.started = None if numerics.max_wall is None else _time.perf_counter()
        self.phases = 0
        # the layer is still in its prepared state: a start-up enters the model at t0
        self.pristine = True
        self.origin = None  # (kind, shear_start, model_start, slip_offset) once known

    # -- recording

    def record(self, t, x, v, force, F, tau, displacement):
        n = np.size(t)
        for name, values in (
            ("t", t),
            ("slip", x),
            ("velocity", v),
            ("force", force),
            ("state", F),
            ("age", tau),
            ("displacement", displacement),
        ):
            self.chunks[name].append(np.broadcast_to(np.asarray(values, dtype=float), (n,)))
        self.chunks["segment"].append(np.full(n, self.segment_index, dtype=np.int64))

    def record_now(self):
        self.record(self.t, self.x, self.v, self.applied, self.F, self.tau, self.displacement)

    def arrays(self):
        """The recorded arrays, joined."""
        return {name: np.concatenate(self.chunks[name]) for name in ARRAYS}

    def event(self, kind, time, slip, force, state, message=""):
        item = Event(
            kind, float(time), float(slip), float(force), float(state), self.segment_index, message
        )
        self.events.append(item)
        return item

    def fail(self, time, slip, force, state, message):
        self.applied = float(force)
        self.failure = self.event("failure", time, slip, force, state, message)

    def count(self, evaluations=1):
        """Bound the work: evaluations (and the wall time, only when a limit was asked for)."""
        self.evaluations += evaluations
        if self.evaluations > self.numerics.max_evaluations:
            raise WorkExceededError(
                f"gave up after {self.evaluations} right-hand-side evaluations (max_evaluations)"
            )
        if self.started is not None and self.evaluations % 256 == 0:
            elapsed = _time.perf_counter() - self.started
            if elapsed > self.numerics.max_wall:
                raise WorkExceededError(
                    f"gave up after {elapsed:.3g} s of wall time (max_wall, a wall-clock limit: "
                    "this outcome depends on the machine)"
                )

    # -- the one clock

    def loaded(self):
        """The prepared layer is loaded from rest (force control, a time-clock rest, a drive
        accelerating from 0): the model describes it from now on, at x0 + displacement."""
        if self.origin is None:
            self.origin = ("rest", None, self.t, self.params.x0 - self.displacement)
        self.pristine = False

    def enter(self, duration):
        """A start-up of the prepared layer: the model takes over after ``duration`` [s] of
        shear, when the slip since the start of shear is x0.

        The record's time and displacement move on by ``duration`` and x0 (nothing is
        recorded in between: the model does not describe it); the layer is still in its
        prepared state (aging coordinate x0, friction F_init, age t0). A rigid drive moves
        it on at once; a machine spring, unloaded as the drive has moved x0 too, loads from
        here (the machine's own elastic ramp).
        """
        start = self.t
        self.t += duration
        self.displacement += self.params.x0
        if self.origin is None:
            self.origin = ("shear", start, self.t, 0.0)
        self.pristine = False

    # -- moves every stepper shares

    def reset(self):
        """Re-prepare the sample: back to the fresh layer, at rest, with no force."""
        self.x = self.params.x0
        self.tau = self.aging.t0
        self.F = self.aging.F_init
        self.applied = 0.0
        self.v = 0.0
        self.sliding = False
        self.pristine = True
        self.event("reset", self.t, self.x, self.applied, self.F, "sample re-prepared")
        self.record_now()

    def stop(self):
        """The sliding layer sticks at once (the force falls below its strength)."""
        self.event("stop", self.t, self.x, self.applied, self.F, "the layer sticks")
        self.sliding = False
        self.v = 0.0

    def stuck(self, t_from, t_to, sigma_from, sigma_to):
        """Record the layer at rest from t_from to t_to under a linearly changing force."""
        if t_to <= t_from:
            return
        times = np.linspace(0.0, t_to - t_from, 3)
        if self.time_clock:
            times = np.union1d(times, offsets(t_to - t_from, self.points // 4))
        tau = self.tau + times
        F = self.F + self.params.a * np.log(tau / self.tau) if self.time_clock else self.F
        sigma = sigma_from + (sigma_to - sigma_from) * times / (t_to - t_from)
        self.record(t_from + times, self.x, 0.0, sigma, F, tau, self.displacement)
        self.t, self.tau = t_to, float(tau[-1])
        self.F = float(np.broadcast_to(F, tau.shape)[-1])
        self.v = 0.0

    def runaway(self, t, sigma, message):
        """A quasi-static failure at once: no stable state ahead under the force sigma."""
        self.fail(t, self.x, sigma, self.F, message)
        self.record(t, self.x, np.inf, sigma, self.F, self.tau, self.displacement)

    def jump(self, x_new, F_new, sigma):
        """A quasi-static sudden slip at constant time under the force sigma."""
        self.displacement += x_new - self.x
        self.x, self.F, self.applied = x_new, F_new, sigma
        self.record(self.t, self.x, 0.0, sigma, self.F, self.tau, self.displacement)
