"""Run a protocol through the model: sticking, sliding, stopping and failing (SPEC §2).

The state of the layer is the friction state F of Eq. 2 (its strength) and an aging
coordinate. Two readings of aging are offered (``clock=``):

* ``"slip"`` (default): ``dF/dx = a/x - alpha (F - Fd)`` along the slip x; nothing evolves at
  rest. F is then a function of the slip alone since the last re-preparation, so every
  quasi-static answer follows from the closed form (Eq. 3 with the general initial condition)
  and root finding, without integrating anything.
* ``"time"``: ``dF/dt = a/tau - alpha v (F - Fd)`` with tau the time since preparation (t0 at
  the start); the layer keeps aging at rest, ``F = F_s + a ln(tau / tau_s)``.

Under an imposed velocity the two agree when the velocity is constant (both give Eq. 3).
Under an imposed force sigma(t) the layer sticks while ``sigma <= F`` and slides otherwise.

Quasi-static limit (``method="quasistatic"``, the default; inertia neglected as in the paper)
    *Slip clock.* From a state (x_s, F_s) the layer, when it slides, follows
    ``F(x) = friction_slip(x, params.replace(x0=x_s), F_init=F_s)``. Under a force sigma > F_s
    it slides to the first x where F(x) = sigma on the rising branch (a stop), or fails if
    sigma exceeds the largest F ahead (F_peak if the peak lies ahead, F_s itself on the
    falling branch). Under a ramp it creeps up the branch, ``x(t) = F^-1(sigma(t))`` with the
    velocity ``(dsigma/dt) / (dF/dx)``, and fails when sigma reaches F_peak, exactly.

    *Time clock.* Sliding at a fixed age only rejuvenates: ``dF/dx = -alpha (F - Fd)`` at fixed
    tau, so F relaxes towards Fd and the largest F ahead in slip is max(F, Fd). While stuck the
    strength ages, ``F = F_s + a ln(tau / tau_s)``. When sigma exceeds the strength the layer
    fails if sigma >= Fd; below Fd it slides (a step: ``alpha dx = ln((Fd - F)/(Fd - sigma))``)
    and then creeps with F = sigma, which gives ``v = (dsigma/dt - a/tau) / (alpha (Fd - sigma))``
    (the layer sticks again when the force grows more slowly than the strength ages, and fails
    when sigma reaches Fd; for a linear ramp x(tau) is integrated in closed form).

    With the optional direct effect the layer never sticks: the force balance
    ``sigma = A asinh(v / (2 v_ref) exp(F/A))`` gives the creep velocity, which is integrated.

Dynamic (``method="dynamic"``)
    The drive's inertia is integrated while sliding under an imposed force:
    ``m dv/dt = sigma - F_friction - c v``, ``dx/dt = v`` and Eq. 2 for F, with
    ``scipy.integrate.solve_ivp`` and events: *failure* when v rises through ``v_fail``
    (terminal), *stop* when v falls through ``v_stop`` (a billionth of the velocity scale), after
    which the layer sticks while ``sigma <= F + c v_stop``, and *slide* when the force exceeds
    that again. With ``stiffness=K`` a spring sits between a rate-controlled drive and the
    layer (spring-block slider): ``m dv/dt = K s - F_friction - c v``, ``ds/dt = v_drive - v``.
    A sudden force step then overshoots the quasi-static slip (up to about twice it when
    undamped, the "creep ringing" of stress-controlled rheometers) and failures take a finite
    time; for forces applied slowly compared with the inertial time ``sqrt(m / (dF/dx))`` the
    two methods agree. Under an imposed velocity without a spring the drive is rigid and
    both methods are the same.

Results use the experiment's time t (0 at the start of the protocol); the slip is the aging
coordinate x of the model (x0 on a fresh layer, back to x0 after a re-preparation), the
displacement the total slip since the start.
"""

import math
import time as _time
from dataclasses import dataclass, field
from types import MappingProxyType

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from granflow import _validate as check
from granflow.errors import InvalidParameterError
from granflow.model.friction import friction_slip, has_peak, initial_force, peak
from granflow.model.geometry import Annulus
from granflow.model.params import Params
from granflow.model.special import _jit, _scaled_ei_diff_scalar, _scaled_ei_scalar
from granflow.simulation.protocol import Protocol

__all__ = [
    "DEFAULT_DAMPING",
    "DEFAULT_MASS",
    "DEFAULT_REFERENCE_VELOCITY",
    "MOTOR_INERTIA",
    "DirectEffect",
    "Event",
    "SegmentRecord",
    "SimulationResult",
    "simulate",
]

#: Moment of inertia of an MCR 302-like rheometer motor and tool [kg m^2].
MOTOR_INERTIA = 1e-5
#: Default effective mass at the contact: MOTOR_INERTIA / r_m**2 of Annulus.paper(), 0.0533 kg.
DEFAULT_MASS = MOTOR_INERTIA / Annulus.paper().mean_radius ** 2
#: Default viscous damping of the drive [N s/m]: light, about 6 % of critical damping for the
#: default mass on the rising branch of the paper's layer (dF/dx ~ 300 N/m).
DEFAULT_DAMPING = 0.5
#: Velocity scale [m/s] used when a protocol imposes no velocity: for t0 = x0 / v and for the
#: default failure threshold (1000 times it, 1 mm/s).
DEFAULT_REFERENCE_VELOCITY = 1e-6
_FAIL_FACTOR = 1000.0
_STOP_FRACTION = 1e-9  # v_stop = this times the velocity scale
_CLOCKS = ("slip", "time")
_METHODS = ("quasistatic", "dynamic")
_TIME_TOLERANCE = 1e-12  # relative, for "the piece has ended"
_RTOL = 4 * np.finfo(float).eps  # the finest relative tolerance brentq accepts
_REJUVENATION_ONLY = "sliding only lowers the strength towards Fd = {:.7g} N (time clock)"


class _WorkExceededError(Exception):
    """The bounded work of a run (evaluations, wall time, transitions) was used up."""


@dataclass(frozen=True, slots=True)
class DirectEffect:
    """The direct (rate) effect of rate-and-state friction, regularised at v -> 0.

    While sliding, the friction force is ``A asinh(v / (2 v_ref) exp(F / A))``, which is
    ``F + A ln(v / v_ref)`` for ``v >> v_ref exp(-F/A)`` and vanishes smoothly at v = 0, so
    the layer creeps under any force (logarithmically below the peak: Fig. 3b).

    Parameters
    ----------
    amplitude : float
        A [N]; positive, typically a few percent of a.
    velocity : float, optional
        Reference velocity v_ref [m/s] at which the friction equals F; default the
        protocol's velocity scale.
    """

    amplitude: float
    velocity: float | None = None

    def __post_init__(self):
        object.__setattr__(self, "amplitude", check.positive(self.amplitude, "amplitude", "N"))
        if self.velocity is not None:
            object.__setattr__(self, "velocity", check.positive(self.velocity, "velocity", "m/s"))

    def to_dict(self):
        return {"amplitude": self.amplitude, "velocity": self.velocity}


@dataclass(frozen=True, slots=True)
class Event:
    """Something that happened during a run.

    Attributes
    ----------
    kind : str
        ``"failure"`` (runaway: no stable state ahead, or v above v_fail; ends the run),
        ``"stop"`` (the layer sticks again under an imposed force), ``"slide"`` (it starts to
        slide), ``"peak"`` (a maximum of the friction under an imposed velocity: the
        overshoot) or ``"reset"`` (the sample is re-prepared).
    time : float
        Time [s] since the start of the protocol.
    slip : float
        Aging coordinate x [m] at the event.
    force : float
        Force [N] the drive exerts at the event: the imposed force under force control.
    state : float
        Friction state F [N] of Eq. 2 (the strength) at the event.
    segment : int
        Index of the protocol segment (from 0).
    message : str
        A short explanation.
    """

    kind: str
    time: float
    slip: float
    force: float
    state: float
    segment: int
    message: str = ""

    def to_dict(self):
        return {
            "kind": self.kind,
            "time": self.time,
            "slip": self.slip,
            "force": self.force,
            "state": self.state,
            "segment": self.segment,
            "message": self.message,
        }


@dataclass(frozen=True, slots=True)
class SegmentRecord:
    """Bookkeeping of one protocol segment in a run (times [s], slips [m], forces [N])."""

    index: int
    kind: str
    control: str
    start_time: float
    end_time: float
    start_slip: float
    end_slip: float
    start_force: float
    end_force: float
    outcome: str

    def to_dict(self):
        return {name: getattr(self, name) for name in self.__dataclass_fields__}


_ARRAYS = ("t", "slip", "velocity", "force", "state", "age", "displacement", "segment")


def _json_number(value):
    return float(value) if math.isfinite(value) else None


@dataclass(frozen=True, eq=False)
class SimulationResult:
    """The outcome of :func:`simulate`.

    Attributes
    ----------
    t : numpy.ndarray
        Time since the start of the protocol [s] (repeated at a jump: a sudden slip, a reset).
    slip : numpy.ndarray
        Aging coordinate x [m] (x0 on a fresh layer; back to x0 after ``Hold(reset=True)``).
    velocity : numpy.ndarray
        Sliding velocity [m/s] (inf at a quasi-static failure).
    force : numpy.ndarray
        Force the drive exerts on the layer [N]: the imposed force under force control, the
        friction (plus the direct effect) under a rigid imposed velocity, K s with a spring.
    state : numpy.ndarray
        Friction state F of Eq. 2 [N]: the strength of the layer.
    age : numpy.ndarray
        Time since preparation [s] (t0 + t on a fresh layer): the time clock's coordinate.
    displacement : numpy.ndarray
        Total slip since the start of the protocol [m], never reset.
    segment : numpy.ndarray
        Index of the protocol segment of each point (int).
    events : tuple of Event
        In time order.
    segments : tuple of SegmentRecord
        One per segment that was run.
    failed : bool
        Whether the layer failed.
    failure : Event or None
        The failure event.
    success : bool
        False if the run could not be completed (integration failure, work bound reached).
    message : str
        What happened, in words.
    params : Params
    protocol : Protocol
    options : mapping
        clock, method, t0, mass, damping, stiffness, v_fail, v_stop, direct_effect.
    """

    t: np.ndarray
    slip: np.ndarray
    velocity: np.ndarray
    force: np.ndarray
    state: np.ndarray
    age: np.ndarray
    displacement: np.ndarray
    segment: np.ndarray
    events: tuple
    segments: tuple
    failed: bool
    failure: Event | None
    success: bool
    message: str
    params: Params
    protocol: Protocol
    options: MappingProxyType = field(default_factory=dict)

    def __post_init__(self):
        for name in _ARRAYS:
            getattr(self, name).flags.writeable = False
        object.__setattr__(self, "options", MappingProxyType(dict(self.options)))

    def __repr__(self):
        outcome = "failed" if self.failed else ("ok" if self.success else "aborted")
        return (
            f"SimulationResult({self.options['method']}, clock={self.options['clock']!r}, "
            f"{len(self.t)} points, {len(self.events)} events, {outcome})"
        )

    def events_of(self, kind):
        """The events of one kind, in time order."""
        return tuple(event for event in self.events if event.kind == kind)

    def to_frame(self):
        """A pandas DataFrame of the arrays; ``attrs`` holds events, segments and options."""
        import pandas as pd

        frame = pd.DataFrame({name: getattr(self, name) for name in _ARRAYS})
        frame.attrs["events"] = [event.to_dict() for event in self.events]
        frame.attrs["segments"] = [record.to_dict() for record in self.segments]
        frame.attrs["options"] = self.to_dict()["options"]
        frame.attrs["units"] = {
            "t": "s",
            "slip": "m",
            "velocity": "m/s",
            "force": "N",
            "state": "N",
            "age": "s",
            "displacement": "m",
        }
        return frame

    def to_run(self):
        """The simulated data as a :class:`granflow.Run` (slip measured from the start).

        Time and slip start at zero at the initial state, as a rheometer would record them.
        :func:`granflow.fit` reads a run the paper's way instead (its abscissa is the model's
        own coordinate, which starts at x0 = v t0): to fit a simulated start-up, shift it
        first, e.g. ``Run(t + x0 / v, slip + x0, ...)``, or fit the fitted x0 as an offset.
        """
        from granflow.model.run import Run

        control = "stress" if any(s.control == "force" for s in self.protocol) else "rate"
        return Run(
            t=self.t,
            slip=self.displacement,
            velocity=self.velocity,
            force=self.force,
            control=control,
            meta={
                "source": "simulation",
                "method": self.options["method"],
                "clock": self.options["clock"],
            },
        )

    def to_dict(self):
        """JSON-safe mapping (non-finite numbers become None)."""
        options = {}
        for key, value in self.options.items():
            options[key] = value.to_dict() if isinstance(value, DirectEffect) else value
        arrays = {
            name: [_json_number(v) for v in getattr(self, name).tolist()]
            for name in _ARRAYS
            if name != "segment"
        }
        arrays["segment"] = self.segment.tolist()
        return {
            "params": self.params.to_dict(),
            "protocol": self.protocol.to_dict(),
            "options": options,
            "success": self.success,
            "failed": self.failed,
            "message": self.message,
            "failure": None if self.failure is None else self.failure.to_dict(),
            "events": [
                {
                    k: (_json_number(v) if isinstance(v, float) else v)
                    for k, v in e.to_dict().items()
                }
                for e in self.events
            ],
            "segments": [record.to_dict() for record in self.segments],
            **arrays,
        }

    def report(self):
        """A plain-text summary in the manner of lmfit's fit report (display units)."""
        opts = self.options
        lines = [
            "[[Simulation]]",
            f"    method     = {opts['method']}",
            f"    clock      = {opts['clock']}",
            f"    segments   = {len(self.segments)} of {len(self.protocol)}",
            f"    time       = {self.t[-1]:.6g} s of {self.protocol.duration:.6g} s",
            f"    success    = {self.success}",
            f"    message    = {self.message}",
        ]
        if opts["method"] == "dynamic":
            lines.append(
                f"    mass       = {opts['mass']:.6g} kg, damping = {opts['damping']:.6g} N s/m"
            )
            if opts["stiffness"] is not None:
                lines.append(f"    stiffness  = {opts['stiffness']:.6g} N/m")
        lines.append(f"    v_fail     = {opts['v_fail'] * 1e6:.6g} um/s")
        if opts["direct_effect"] is not None:
            effect = opts["direct_effect"]
            lines.append(
                f"    direct     = A {effect.amplitude * 1e3:.6g} mN, v_ref "
                f"{effect.velocity * 1e6:.6g} um/s"
            )
        lines.append("[[Events]]")
        if not self.events:
            lines.append("    (none)")
        for event in self.events:
            lines.append(
                f"    {event.kind:<8} t = {event.time:<12.7g} s  slip = "
                f"{event.slip * 1e6:<12.7g} um  force = {event.force * 1e3:.7g} mN"
            )
        lines.append("[[Segments]]")
        for record in self.segments:
            lines.append(
                f"    {record.index + 1:>3} {record.kind:<14} {record.control:<5} "
                f"t = {record.start_time:.6g}..{record.end_time:.6g} s  "
                f"force {record.start_force * 1e3:.6g} -> {record.end_force * 1e3:.6g} mN  "
                f"{record.outcome}"
            )
        return "\n".join(lines)


# ---------------------------------------------------------------- closed form from any state


@_jit
def _curve_scalar(z, alpha, a, Fd, s0, scaled_ei_s0, offset):
    """F(z) from the state (z0 = s0/alpha, Fd + offset): Eq. 3 with the general condition."""
    s = alpha * z
    decay = math.exp(s0 - s)
    return Fd + offset * decay + a * _scaled_ei_diff_scalar(s, s0, scaled_ei_s0, decay)


class _Curve:
    """The slip-clock solution through (z_s, F_s): F(z) along the coordinate z >= z_s."""

    def __init__(self, params, start, force):
        self.params = params.replace(x0=start)
        self.start = start
        self.force = force
        self._s0 = params.alpha * start
        self._scaled_ei_s0 = float(_scaled_ei_scalar(self._s0))
        self._peak = None
        self._peak_known = False

    def __call__(self, z):
        p = self.params
        return _curve_scalar(z, p.alpha, p.a, p.Fd, self._s0, self._scaled_ei_s0, self.force - p.Fd)

    def values(self, z):
        return friction_slip(np.maximum(z, self.start), self.params, F_init=self.force)

    def slope(self, z, F):
        p = self.params
        return p.a / z - p.alpha * (F - p.Fd)

    @property
    def peak(self):
        """(z, F) of the maximum ahead, or None when F does not rise from here."""
        if not self._peak_known:
            self._peak_known = True
            if has_peak(self.params, F_init=self.force):
                top = peak(self.params, F_init=self.force)
                self._peak = (top.slip, top.force)
        return self._peak

    def top(self):
        """(sup of F ahead, whether it is attained)."""
        if self.peak is not None:
            return self.peak[1], True
        p = self.params
        if p.a == 0 and self.force < p.Fd:
            return p.Fd, False
        return self.force, True

    def root(self, target, upper=None):
        """The first z >= z_s with F(z) = target on the rising branch (F(z_s) <= target)."""
        if upper is None:
            upper = self.peak[0] if self.peak is not None else 2.0 * self.start
            while self(upper) < target:
                upper = self.start + 2.0 * (upper - self.start)
        if self(upper) <= target:
            return upper
        return brentq(
            lambda z: self(z) - target,
            self.start,
            upper,
            xtol=self.start * 1e-16,
            rtol=_RTOL,
            maxiter=200,
        )


def _offset_of(z_peak, z_of, duration):
    """The offset in [0, duration] where the increasing z_of(offset) equals z_peak."""
    if z_peak <= z_of(0.0):
        return 0.0
    return brentq(lambda u: z_of(u) - z_peak, 0.0, duration, xtol=1e-15 * duration, rtol=_RTOL)


def _offsets(duration, points):
    """Sample offsets in [0, duration]: even spacing plus geometric refinement near 0."""
    even = np.linspace(0.0, duration, max(points, 2))
    fine = np.geomspace(duration * 1e-5, duration, max(points // 4, 2))
    return np.union1d(even, fine)


# ---------------------------------------------------------------- direct effect


def _direct_friction(effect, v, F):
    """A asinh(v / (2 v_ref) exp(F/A)) for arrays or scalars, without overflow."""
    amplitude = effect.amplitude
    v = np.asarray(v, dtype=float)
    F = np.asarray(F, dtype=float)
    with np.errstate(divide="ignore"):
        log_q = np.log(v / (2.0 * effect.velocity)) + F / amplitude
    big = log_q > 0
    safe = np.where(big, -log_q, log_q)
    out = np.where(
        big,
        log_q + np.log1p(np.sqrt(1.0 + np.exp(2.0 * safe))),
        np.arcsinh(np.exp(safe)),
    )
    out = amplitude * np.where(v > 0, out, 0.0)
    return float(out) if out.ndim == 0 else out


def _direct_scalar(amplitude, v_ref, v, F):
    """The scalar form of _direct_friction, for right-hand sides."""
    if v <= 0:
        return 0.0
    log_q = math.log(v / (2.0 * v_ref)) + F / amplitude
    if log_q > 0:
        return amplitude * (log_q + math.log1p(math.sqrt(1.0 + math.exp(-2.0 * log_q))))
    return amplitude * math.asinh(math.exp(log_q))


def _direct_derivatives(amplitude, v_ref, v, F):
    """d/dv and d/dF of A asinh(v / (2 v_ref) exp(F/A)), finite at v = 0."""
    log_scale = F / amplitude - math.log(2.0 * v_ref)  # log of q / v
    if v <= 0:
        return amplitude * math.exp(min(log_scale, 700.0)), 0.0
    log_q = math.log(v) + log_scale
    share = 1.0 / math.sqrt(1.0 + math.exp(min(-2.0 * log_q, 1400.0)))  # q / sqrt(1 + q^2)
    if log_q < 0:
        share = math.exp(log_q) / math.sqrt(1.0 + math.exp(2.0 * log_q))
    return amplitude * share / v, share


def _creep_velocity(effect, sigma, F):
    """The v with A asinh(v / (2 v_ref) exp(F/A)) = sigma (0 for sigma <= 0)."""
    if sigma <= 0:
        return 0.0
    amplitude = effect.amplitude
    z = sigma / amplitude
    log_v = math.log(effect.velocity) + (sigma - F) / amplitude + math.log1p(-math.exp(-2 * z))
    return math.exp(min(log_v, 700.0))


# ---------------------------------------------------------------- the engine


class _Run:
    """Runs one protocol; holds the state and the recorded output."""

    def __init__(self, params, protocol, options):
        self.params = params
        self.protocol = protocol
        self.opt = options
        self.clock = options["clock"]
        self.dynamic = options["method"] == "dynamic"
        self.effect = options["direct_effect"]
        self.points = options["points"]
        self.t = 0.0
        self.x = params.x0
        self.tau = options["t0"]
        self.F = options["F_init"]
        self.v = 0.0
        self.applied = 0.0
        self.displacement = 0.0
        self.sliding = False
        self.segment_index = 0
        self.chunks = {name: [] for name in _ARRAYS}
        self.events = []
        self.failure = None
        self.evaluations = 0
        self.started = _time.perf_counter()
        self.phases = 0

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
        """Bound the work: evaluations and wall time."""
        self.evaluations += evaluations
        if self.evaluations > self.opt["max_evaluations"]:
            raise _WorkExceededError(
                f"gave up after {self.evaluations} right-hand-side evaluations (max_evaluations)"
            )
        if self.evaluations % 256 == 0:
            elapsed = _time.perf_counter() - self.started
            if elapsed > self.opt["max_wall"]:
                raise _WorkExceededError(f"gave up after {elapsed:.3g} s of wall time (max_wall)")

    # -- driver

    def run(self):
        records = []
        message = "completed"
        success = True
        for index, segment in enumerate(self.protocol):
            self.segment_index = index
            start = (self.t, self.x, self.applied)
            outcome = "completed"
            try:
                if segment.control == "rate":
                    for piece in segment.pieces():
                        self.rate_piece(piece)
                        if self.failure:
                            break
                else:
                    for piece in segment.pieces(self.applied):
                        self.force_piece(piece)
                        if self.failure:
                            break
            except _WorkExceededError as exc:
                success, outcome = False, "aborted"
                message = f"segment {index + 1} ({segment.type_name}): {exc}"
            except _IntegrationError as exc:
                success, outcome = False, "aborted"
                message = f"segment {index + 1} ({segment.type_name}): integration failed: {exc}"
            if self.failure:
                outcome = "failed"
                f = self.failure
                message = (
                    f"failure in segment {index + 1} ({segment.type_name}) at t = {f.time:.7g} s, "
                    f"slip = {f.slip:.7g} m, force = {f.force:.7g} N: {f.message}"
                )
            records.append(
                SegmentRecord(
                    index=index,
                    kind=segment.type_name,
                    control=segment.control,
                    start_time=start[0],
                    end_time=self.t,
                    start_slip=start[1],
                    end_slip=self.x,
                    start_force=start[2],
                    end_force=self.applied,
                    outcome=outcome,
                )
            )
            if outcome != "completed":
                break
        arrays = {name: np.concatenate(self.chunks[name]) for name in _ARRAYS}
        return SimulationResult(
            **arrays,
            events=tuple(self.events),
            segments=tuple(records),
            failed=self.failure is not None,
            failure=self.failure,
            success=success,
            message=message,
            params=self.params,
            protocol=self.protocol,
            options={k: v for k, v in self.opt.items() if k not in ("points", "F_init")},
        )

    # -- rate control

    def rate_piece(self, piece):
        if self.opt["stiffness"] is not None:
            self.dynamic_piece(piece, rate=True)
        else:
            self.rigid_rate(piece)
        if piece.reset:
            self.reset()

    def reset(self):
        self.x = self.params.x0
        self.tau = self.opt["t0"]
        self.F = self.opt["F_init"]
        self.applied = 0.0
        self.v = 0.0
        self.sliding = False
        self.event("reset", self.t, self.x, self.applied, self.F, "sample re-prepared")
        self.record_now()

    def rigid_rate(self, piece):
        p = self.params
        d = piece.duration
        v_a, v_b = piece.start, piece.end
        u = _offsets(d, self.points)
        x_s, F_s, tau_s, t_s = self.x, self.F, self.tau, self.t
        accel = (v_b - v_a) / d

        def slip_at(offset):
            return x_s + v_a * offset + 0.5 * accel * offset**2

        peak_offset = None
        if v_a == 0 and v_b == 0:
            F = None
        elif self.clock == "slip" or v_a == v_b:
            # slip clock: F(x); time clock at constant v: the same curve in z = v tau
            if self.clock == "slip":
                curve = _Curve(p, x_s, F_s)
                z_of = slip_at
            else:
                curve = _Curve(p, v_a * tau_s, F_s)

                def z_of(offset):
                    return v_a * (tau_s + offset)

            z_end = z_of(d)
            if curve.peak is not None and curve.peak[0] <= z_end:
                peak_offset = _offset_of(curve.peak[0], z_of, d)
                u = np.union1d(u, [peak_offset])
            F = curve.values(z_of(u))
        else:
            F, peak_offset, u = self._time_clock_ode(piece, u)
        if F is None:  # rest
            F = (
                F_s + p.a * np.log((tau_s + u) / tau_s)
                if self.clock == "time"
                else np.full(u.shape, F_s)
            )
        velocity = v_a + accel * u
        x = slip_at(u)
        force = F if self.effect is None else _direct_friction(self.effect, velocity, F)
        if v_a == 0 and v_b == 0:  # the drive stands still: its force stays
            force = np.full(u.shape, self.applied)
        self.record(t_s + u, x, velocity, force, F, tau_s + u, self.displacement + (x - x_s))
        if peak_offset is not None:
            i = int(np.searchsorted(u, peak_offset))
            self.event("peak", t_s + u[i], x[i], force[i], F[i], "maximum of the friction")
        self.t, self.x, self.F, self.tau = t_s + d, float(x[-1]), float(F[-1]), tau_s + d
        self.v = v_b
        self.displacement += float(x[-1]) - x_s
        self.applied = float(force[-1])
        self.sliding = v_b > 0

    def _time_clock_ode(self, piece, u):
        """Time clock under a velocity that changes linearly: integrate Eq. 2 in time."""
        p = self.params
        d = piece.duration
        v_a, accel = piece.start, (piece.end - piece.start) / piece.duration
        tau_s = self.tau

        def rhs(offset, y):
            self.count()
            return [p.a / (tau_s + offset) - p.alpha * (v_a + accel * offset) * (y[0] - p.Fd)]

        def turning(offset, y):
            return rhs(offset, y)[0]

        turning.direction = -1
        sol = solve_ivp(
            rhs,
            (0.0, d),
            [self.F],
            method="LSODA",
            rtol=1e-11,
            atol=1e-14 * max(p.a, p.Fd, 1e-300),
            dense_output=True,
            events=turning,
        )
        if sol.status == -1:
            raise _IntegrationError(sol.message)
        peak_offset = float(sol.t_events[0][0]) if sol.t_events[0].size else None
        if peak_offset is not None:
            u = np.union1d(u, [peak_offset])
        return sol.sol(u)[0], peak_offset, u

    # -- force control

    def force_piece(self, piece):
        if self.sliding and not self.dynamic and piece.start <= self.F and piece.rate <= 0:
            self.event("stop", self.t, self.x, self.applied, self.F, "the layer sticks")
            self.sliding = False
            self.v = 0.0
        if self.dynamic:
            self.dynamic_piece(piece, rate=False)
        elif self.effect is not None:
            self.creep_piece(piece)
        elif self.clock == "slip":
            self.quasistatic_slip(piece)
        else:
            self.quasistatic_time(piece)
        if not self.failure:
            self.applied = piece.end

    def stuck(self, t_from, t_to, sigma_from, sigma_to):
        """Record the layer at rest from t_from to t_to under a linearly changing force."""
        if t_to <= t_from:
            return
        offsets = np.linspace(0.0, t_to - t_from, 3)
        if self.clock == "time":
            offsets = np.union1d(offsets, _offsets(t_to - t_from, self.points // 4))
        tau = self.tau + offsets
        F = self.F + self.params.a * np.log(tau / self.tau) if self.clock == "time" else self.F
        sigma = sigma_from + (sigma_to - sigma_from) * offsets / (t_to - t_from)
        self.record(t_from + offsets, self.x, 0.0, sigma, F, tau, self.displacement)
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

    def quasistatic_slip(self, piece):
        """Slip clock, no inertia: closed form and root finding only."""
        sigma_a, rate, d = piece.start, piece.rate, piece.duration
        t_a, t_b = self.t, self.t + d
        curve = _Curve(self.params, self.x, self.F)
        top, attained = curve.top()
        self.record(t_a, self.x, 0.0, sigma_a, self.F, self.tau, self.displacement)
        if sigma_a > self.F:
            self.event("slide", t_a, self.x, sigma_a, self.F, "the force exceeds the strength")
            if sigma_a > top or (sigma_a == top and not attained):
                self.runaway(
                    t_a, sigma_a, f"the force exceeds the largest friction ahead ({top:.7g} N)"
                )
                return
            x_new = curve.root(sigma_a)
            self.jump(x_new, curve(x_new), sigma_a)
            if rate <= 0:
                self.event("stop", t_a, self.x, sigma_a, self.F, "the layer sticks")
        if rate <= 0 or t_a + (self.F - sigma_a) / rate >= t_b:
            self.stuck(t_a, t_b, sigma_a, piece.end)
            self.sliding = False
            return
        t_u = t_a + max(self.F - sigma_a, 0.0) / rate
        if t_u > t_a:
            self.stuck(t_a, t_u, sigma_a, sigma_a + rate * (t_u - t_a))
            self.event("slide", t_u, self.x, self.F, self.F, "the force reaches the strength")
        t_f = t_a + (top - sigma_a) / rate
        if t_f <= t_u and curve.peak is None:  # on the falling branch: no creep, a runaway
            self.runaway(t_u, self.F, "the force exceeds the friction on the falling branch")
            return
        failing = t_f <= t_b
        t_end = t_f if failing else t_b
        sigma_end = top if failing else piece.end
        if failing and not attained:
            sigma_end = top * (1.0 - 1e-9)
        x_end = curve.peak[0] if (failing and curve.peak is not None and attained) else None
        if x_end is None:
            x_end = curve.root(sigma_end) if sigma_end > self.F else self.x
        x = self.x + (x_end - self.x) * np.union1d(
            np.linspace(0.0, 1.0, self.points), np.geomspace(1e-6, 1.0, self.points // 4)
        )
        F = curve.values(x)
        F[-1] = sigma_end if not failing else F[-1]
        times = np.clip(t_a + (F - sigma_a) / rate, t_u, t_end)
        times[-1] = t_end
        with np.errstate(divide="ignore"):
            velocity = rate / curve.slope(x, F)
        if failing:
            velocity[-1] = np.inf
        self.record(
            times, x, velocity, F, F, self.tau + (times - t_a), self.displacement + (x - self.x)
        )
        self.displacement += x_end - self.x
        self.t, self.x, self.F, self.tau = t_end, x_end, float(F[-1]), self.tau + (t_end - t_a)
        self.v = float(velocity[-1])
        self.sliding = True
        if failing:
            self.applied = sigma_end
            self.fail(
                t_end,
                x_end,
                sigma_end,
                self.F,
                "the force reached the largest friction ahead (the peak)",
            )

    def quasistatic_time(self, piece):
        """Time clock, no inertia: aging while stuck, rejuvenation while sliding."""
        p = self.params
        sigma_a, rate, d = piece.start, piece.rate, piece.duration
        t_a, t_b = self.t, self.t + d
        self.record(t_a, self.x, 0.0, sigma_a, self.F, self.tau, self.displacement)
        if sigma_a > self.F:
            self.event("slide", t_a, self.x, sigma_a, self.F, "the force exceeds the strength")
            if sigma_a >= p.Fd:
                self.runaway(t_a, sigma_a, _REJUVENATION_ONLY.format(p.Fd))
                return
            x_new = self.x + math.log((p.Fd - self.F) / (p.Fd - sigma_a)) / p.alpha
            self.jump(x_new, sigma_a, sigma_a)
            if rate <= p.a / self.tau:
                self.event("stop", t_a, self.x, sigma_a, self.F, "the layer sticks")
        # the gap between force and strength while stuck: convex in time
        F_s, tau_s = self.F, self.tau

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
            self.stuck(t_a, t_b, sigma_a, piece.end)
            self.sliding = False
            return
        self.stuck(t_a, t_u, sigma_a, sigma_a + rate * (t_u - t_a))
        sigma_u = sigma_a + rate * (t_u - t_a)
        if t_u > t_a:
            self.event("slide", t_u, self.x, sigma_u, self.F, "the force reaches the strength")
        if sigma_u >= p.Fd:
            self.runaway(t_u, sigma_u, _REJUVENATION_ONLY.format(p.Fd))
            return
        # sliding with F = sigma: alpha dx/dtau = (rate - a/tau) / (Fd - sigma), closed form
        tau_u, gap_u = self.tau, p.Fd - sigma_u
        t_f = t_u + gap_u / rate
        failing = t_f <= t_b
        remaining = np.geomspace(1.0, 1e-9, self.points) if failing else None
        if failing:
            times = t_f - gap_u * remaining / rate
        else:
            times = t_u + _offsets(t_b - t_u, self.points)
        tau = tau_u + (times - t_u)
        gap_now = p.Fd - (sigma_u + rate * (times - t_u))
        if failing:
            gap_now = gap_u * remaining
        total = gap_now + rate * tau  # C = Fd - sigma(tau) + rate tau, constant and positive
        C = total[0]
        x = (
            self.x
            + (-(1 - p.a / C) * np.log(gap_now / gap_u) - (p.a / C) * np.log(tau / tau_u)) / p.alpha
        )
        sigma = p.Fd - gap_now
        velocity = (rate - p.a / tau) / (p.alpha * gap_now)
        if failing:
            velocity[-1] = np.inf
        self.record(times, x, velocity, sigma, sigma, tau, self.displacement + (x - self.x))
        self.displacement += float(x[-1]) - self.x
        self.t, self.x, self.F, self.tau = (
            float(times[-1]),
            float(x[-1]),
            float(sigma[-1]),
            float(tau[-1]),
        )
        self.v = float(velocity[-1])
        self.sliding = True
        if failing:
            self.applied = float(sigma[-1])
            self.fail(
                self.t,
                self.x,
                self.applied,
                self.F,
                f"the force reached Fd = {p.Fd:.7g} N while creeping (time clock)",
            )

    def creep_piece(self, piece):
        """Quasi-static with the direct effect: the layer creeps at the force-balance velocity."""
        p = self.params
        effect, v_fail = self.effect, self.opt["v_fail"]
        sigma_a, rate, d = piece.start, piece.rate, piece.duration
        t_a, tau_a, D_a = self.t, self.tau, self.displacement
        time_clock = self.clock == "time"

        def velocity(offset, F):
            return _creep_velocity(effect, sigma_a + rate * offset, F)

        def rhs(offset, y):
            self.count()
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
            [self.x, self.F],
            method="LSODA",
            rtol=self.opt["rtol"],
            atol=[p.x0 * 1e-10, 1e-13 * max(p.a, p.Fd)],
            dense_output=True,
            events=failure,
        )
        if sol.status == -1:
            raise _IntegrationError(sol.message)
        end = float(sol.t[-1])
        u = np.union1d(_offsets(end, self.points), [end]) if end > 0 else np.array([0.0])
        x, F = sol.sol(u)
        v = np.array([velocity(o, f) for o, f in zip(u, F, strict=True)])
        self.record(t_a + u, x, v, sigma_a + rate * u, F, tau_a + u, D_a + (x - self.x))
        self.displacement = D_a + float(x[-1]) - self.x
        self.t, self.tau, self.x, self.F, self.v = (
            t_a + end,
            tau_a + end,
            float(x[-1]),
            float(F[-1]),
            float(v[-1]),
        )
        self.sliding = True
        if sol.status == 1:
            self.applied = sigma_a + rate * end
            self.fail(
                self.t,
                self.x,
                self.applied,
                self.F,
                f"the creep velocity exceeded v_fail = {v_fail:.4g} m/s",
            )

    # -- dynamic: inertia, damping, spring

    def dynamic_piece(self, piece, *, rate):
        """Integrate m dv/dt = drive - friction - c v with stick, slide and failure events."""
        p = self.params
        opt = self.opt
        m, c, K = opt["mass"], opt["damping"], opt["stiffness"]
        v_fail, v_stop = opt["v_fail"], opt["v_stop"]
        effect = self.effect
        time_clock = self.clock == "time"
        t_a, d = self.t, piece.duration
        t_b = t_a + d
        slope = (piece.end - piece.start) / d
        start = piece.start
        tau_shift = self.tau - t_a
        x_shift = self.displacement - self.x  # displacement = x + x_shift within the piece

        a, alpha, Fd = p.a, p.alpha, p.Fd
        amplitude = None if effect is None else effect.amplitude
        v_ref = None if effect is None else effect.velocity
        count = self.count

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
            friction = F if amplitude is None else _direct_scalar(amplitude, v_ref, v, F)
            drive = K * s if rate else start + slope * (t - t_a)
            return [v, (drive - friction - c * v) / m, dF, (drive_velocity(t) - v) if rate else 0.0]

        def slide_jacobian(t, y):
            x, v, F, _ = y
            if amplitude is None:
                d_friction_dv, d_friction_dF = 0.0, 1.0
            else:
                d_friction_dv, d_friction_dF = _direct_derivatives(amplitude, v_ref, v, F)
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

        y = np.array([self.x, self.v, self.F, self.applied / K if K else 0.0])
        scale = np.array(
            [
                p.x0 * 1e-9,
                opt["v_stop"] * 1e-3,
                1e-13 * max(p.a, p.Fd),
                (1e-13 * max(p.a, p.Fd) / K) if K else 1.0,
            ]
        )
        t = t_a
        sliding = effect is not None or y[1] > v_stop or unstick(t, y) > 0
        if sliding and effect is None and y[1] <= v_stop:
            self.event("slide", t, y[0], drive_force(t, y), y[2], "the force exceeds the strength")
        if not rate:
            self.record(t, self.x, self.v, start, self.F, self.tau, self.displacement)
        while t < t_b - _TIME_TOLERANCE * max(abs(t_b), 1.0):
            self.phases += 1
            if self.phases > opt["max_transitions"]:
                raise _WorkExceededError(
                    f"gave up after {opt['max_transitions']} stick-slip transitions "
                    "(max_transitions)"
                )
            if sliding:
                events = [failure] if effect is not None else [failure, stop]
                implicit = opt["solver"] in ("LSODA", "Radau", "BDF")
                sol = solve_ivp(
                    slide_rhs,
                    (t, t_b),
                    y,
                    method=opt["solver"],
                    rtol=opt["rtol"],
                    atol=scale,
                    dense_output=True,
                    events=events,
                    **({"jac": slide_jacobian} if implicit else {}),
                )
            else:
                sol = solve_ivp(
                    stuck_rhs,
                    (t, t_b),
                    y,
                    method="LSODA",
                    rtol=opt["rtol"],
                    atol=scale,
                    dense_output=True,
                    events=[unstick],
                )
            if sol.status == -1:
                raise _IntegrationError(sol.message)
            t_end = float(sol.t[-1])
            if t_end > t:
                n = max(3, int(self.points * (t_end - t) / d) + 2)
                times = np.linspace(t, t_end, n)
                # the solver's own steps crowd where the motion is fast: keep (some of) them
                stride = max(1, sol.t.size // (4 * self.points))
                times = np.union1d(times, sol.t[::stride])
                ys = sol.sol(times)
                ys[:, -1] = sol.y[:, -1]
                force = K * ys[3] if rate else start + slope * (times - t_a)
                self.record(times, ys[0], ys[1], force, ys[2], times + tau_shift, ys[0] + x_shift)
            y = np.array(sol.y[:, -1])
            t = t_end
            force_now = K * y[3] if rate else start + slope * (t - t_a)
            if sol.status == 1:
                fired = [i for i, times in enumerate(sol.t_events) if times.size]
                kind = (events if sliding else [unstick])[fired[0]]
                if kind is failure:
                    self._finish_dynamic(t, y, tau_shift, x_shift, force_now)
                    self.fail(
                        t, y[0], force_now, y[2], f"the velocity exceeded v_fail = {v_fail:.4g} m/s"
                    )
                    return
                if kind is stop:
                    y[1] = 0.0
                    sliding = False
                    self.event("stop", t, y[0], force_now, y[2], "the layer sticks")
                else:
                    sliding = True
                    self.event("slide", t, y[0], force_now, y[2], "the force exceeds the strength")
        self._finish_dynamic(
            t_b if t >= t_b - _TIME_TOLERANCE * max(abs(t_b), 1.0) else t,
            y,
            tau_shift,
            x_shift,
            (K * y[3]) if rate else piece.end,
        )
        self.sliding = sliding and y[1] > 0

    def _finish_dynamic(self, t, y, tau_shift, x_shift, force):
        self.t = t
        self.tau = t + tau_shift
        self.x, self.v, self.F = float(y[0]), float(y[1]), float(y[2])
        self.displacement = self.x + x_shift
        self.applied = float(force)


class _IntegrationError(Exception):
    """solve_ivp reported a failure."""


def _choice(value, name, allowed):
    if value not in allowed:
        raise InvalidParameterError(
            f"{name} must be one of {', '.join(repr(a) for a in allowed)}, got {value!r}"
        )
    return value


def simulate(
    params,
    protocol,
    *,
    clock="slip",
    method="quasistatic",
    F_init=None,
    t0=None,
    mass=None,
    damping=None,
    stiffness=None,
    v_fail=None,
    direct_effect=None,
    points=200,
    rtol=1e-9,
    solver=None,
    max_evaluations=2_000_000,
    max_transitions=10_000,
    max_wall=60.0,
):
    """Run a protocol through the model and report sticking, sliding, stops and failure.

    Parameters
    ----------
    params : Params
        Model parameters (a [N], alpha [1/m], Fd [N], x0 [m]).
    protocol : Protocol or sequence of segments
        The imposed history (see :mod:`granflow.protocol`).
    clock : {"slip", "time"}
        Aging along the slip (default; nothing evolves at rest) or in time since preparation
        (the layer also ages at rest).
    method : {"quasistatic", "dynamic"}
        Neglect inertia (default, as the paper does) or integrate it.
    F_init : float, optional
        Friction state on a fresh layer [N]; default the paper's ``Fd (1 - exp(-alpha x0))``.
    t0 : float, optional
        Age of a fresh layer [s] (the time clock's start): default ``x0 / v`` with v the
        protocol's first imposed velocity, else ``DEFAULT_REFERENCE_VELOCITY`` (1 um/s).
    mass : float, optional
        Effective mass of drive and tool at the contact [kg] (dynamic only); default
        ``DEFAULT_MASS`` = 1e-5 kg m^2 / r_m^2 = 0.0533 kg (an MCR 302 at the paper's tube).
    damping : float, optional
        Viscous damping of the drive [N s/m] (dynamic only); default ``DEFAULT_DAMPING``
        (0.5 N s/m, light); 0 for none, large values make the motion overdamped.
    stiffness : float, optional
        Machine stiffness K [N/m] between a rate-controlled drive and the layer (dynamic only;
        under force control the force is applied through it unchanged). Default: rigid.
    v_fail : float, optional
        Failure threshold on the sliding velocity [m/s]; default 1000 times the protocol's
        largest imposed velocity, or 1 mm/s (1000 x 1 um/s) when it imposes none.
    direct_effect : float or DirectEffect, optional
        The direct effect ``A ln(v / v_ref)``, regularised as ``A asinh(v / (2 v_ref) e^{F/A})``;
        a float is the amplitude A [N] with v_ref the velocity scale. The layer then creeps.
    points : int
        Output points per segment (about; events and jumps are added).
    rtol : float
        Relative tolerance of the integrations.
    solver : str, optional
        solve_ivp method of the dynamic integration (default "LSODA", with an analytic
        Jacobian; it handles the stiffness of slow creep and of the direct effect).
    max_evaluations, max_transitions, max_wall : int, int, float
        Bounds on the work: right-hand-side evaluations, stick-slip transitions and wall time
        [s]. A run that reaches one returns ``success=False`` with a message.

    Returns
    -------
    SimulationResult

    Raises
    ------
    InvalidParameterError
        For a bad argument (mass or stiffness with the quasi-static method, a negative
        damping, ...).
    InvalidProtocolError
        For a protocol that cannot be run (a ramp whose force would become negative).

    Examples
    --------
    >>> import granflow as gf
    >>> p = gf.Params.from_time_domain(a=3.31e-3, k=0.036, t0=0.23, Fd=10e-3, velocity=0.86e-6)
    >>> ramp = gf.Protocol([gf.ForceRamp(rate=0.05e-3, duration=400.0)])
    >>> result = gf.simulate(p, ramp)
    >>> result.failed, round(result.failure.force * 1e3, 6)  # fails at the peak, in mN
    (True, 13.782947)
    """
    if not isinstance(params, Params):
        raise InvalidParameterError(
            f"params must be a granflow.Params, got {type(params).__name__}"
        )
    if not isinstance(protocol, Protocol):
        protocol = Protocol(protocol)
    _choice(clock, "clock", _CLOCKS)
    _choice(method, "method", _METHODS)
    dynamic = method == "dynamic"
    for value, name in ((mass, "mass"), (damping, "damping"), (stiffness, "stiffness")):
        if value is not None and not dynamic:
            raise InvalidParameterError(
                f"{name} applies to method='dynamic' only (the quasi-static limit has no "
                "inertia and a rigid drive)"
            )
    scale = protocol.max_velocity or DEFAULT_REFERENCE_VELOCITY
    first = protocol.first_velocity or DEFAULT_REFERENCE_VELOCITY
    t0 = params.x0 / first if t0 is None else check.positive(t0, "t0", "s")
    F_init = initial_force(params) if F_init is None else check.non_negative(F_init, "F_init", "N")
    v_fail = _FAIL_FACTOR * scale if v_fail is None else check.positive(v_fail, "v_fail", "m/s")
    if direct_effect is not None:
        if not isinstance(direct_effect, DirectEffect):
            direct_effect = DirectEffect(amplitude=direct_effect)
        if direct_effect.velocity is None:
            direct_effect = DirectEffect(direct_effect.amplitude, scale)
    if isinstance(points, bool) or not isinstance(points, int | np.integer) or points < 2:
        raise InvalidParameterError(f"points must be an integer of at least 2, got {points!r}")
    options = {
        "clock": clock,
        "method": method,
        "t0": t0,
        "F_init": F_init,
        "mass": (DEFAULT_MASS if mass is None else check.positive(mass, "mass", "kg"))
        if dynamic
        else None,
        "damping": (
            DEFAULT_DAMPING if damping is None else check.non_negative(damping, "damping", "N s/m")
        )
        if dynamic
        else None,
        "stiffness": None if stiffness is None else check.positive(stiffness, "stiffness", "N/m"),
        "v_fail": v_fail,
        "v_stop": _STOP_FRACTION * scale,
        "direct_effect": direct_effect,
        "points": int(points),
        "rtol": check.positive(rtol, "rtol"),
        "solver": solver or "LSODA",
        "max_evaluations": int(check.positive(max_evaluations, "max_evaluations")),
        "max_transitions": int(check.positive(max_transitions, "max_transitions")),
        "max_wall": check.positive(max_wall, "max_wall", "s"),
    }
    return _Run(params, protocol, options).run()
