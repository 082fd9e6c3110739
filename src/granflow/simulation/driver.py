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

The method picks a stepper from :data:`METHODS` (the pattern of ``solve_ivp``'s ``METHODS``):

``"quasistatic"`` (default; inertia neglected as in the paper)
    :class:`~granflow.simulation.quasistatic.QuasiStaticStepper`: closed form and root
    finding on either clock; the creep velocity is integrated with the direct effect.
``"dynamic"``
    :class:`~granflow.simulation.dynamic.DynamicStepper`: the drive's inertia, damping and an
    optional machine spring integrated with stick, slide and failure events. A sudden force
    step overshoots the quasi-static slip (up to about twice it when undamped, the "creep
    ringing" of stress-controlled rheometers) and failures take a finite time; for forces
    applied slowly compared with the inertial time ``sqrt(m / (dF/dx))`` the two methods agree.

Both implement one interface (:class:`~granflow.simulation.stepper.Stepper`): a piece of
imposed velocity (start-ups, tables, holds) or of imposed force (creeps, ramps, switches).
The keywords of :func:`simulate` are checked and bundled into frozen option objects
(:mod:`granflow.simulation.options`); the result types live in
:mod:`granflow.simulation.results`.

Results are on the record's clock (the one-clock rule of :mod:`granflow.simulation`): t is 0
when the protocol starts; a start-up of the prepared layer enters the model at t0 = x0 / v
with displacement x0 (:meth:`~granflow.simulation.state.RunState.enter`); a layer loaded from
rest is described from the start, at the aging coordinate x0 + displacement. The slip is the
aging coordinate x of the model (back to x0 after a re-preparation), the displacement the
total slip since the start of the protocol. ``SimulationResult.origin`` says which applies.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import TYPE_CHECKING

from granflow.errors import InvalidParameterError, InvalidProtocolError
from granflow.model.friction import initial_force
from granflow.model.params import Params
from granflow.simulation.dynamic import DynamicStepper
from granflow.simulation.options import (
    CLOCKS,
    DEFAULT_DAMPING,
    DEFAULT_MASS,
    DEFAULT_REFERENCE_VELOCITY,
    MOTOR_INERTIA,
    Aging,
    DirectEffect,
    Drive,
    Numerics,
    check_choice,
)
from granflow.simulation.protocol import Protocol
from granflow.simulation.quasistatic import QuasiStaticStepper
from granflow.simulation.results import Event, Origin, SegmentRecord, SimulationResult
from granflow.simulation.segments import RatePiece
from granflow.simulation.state import IntegrationError, RunState, WorkExceededError

if TYPE_CHECKING:
    from granflow.simulation.options import DirectEffect
    from granflow.simulation.results import SimulationResult
    from granflow.simulation.segments import Segment

__all__ = [
    "DEFAULT_DAMPING",
    "DEFAULT_MASS",
    "DEFAULT_REFERENCE_VELOCITY",
    "METHODS",
    "MOTOR_INERTIA",
    "DirectEffect",
    "Event",
    "SegmentRecord",
    "SimulationResult",
    "simulate",
]

#: The steppers by the name ``simulate(method=...)`` takes.
METHODS = {"quasistatic": QuasiStaticStepper, "dynamic": DynamicStepper}
_FAIL_FACTOR = 1000.0
_STOP_FRACTION = 1e-9  # v_stop = this times the velocity scale


def simulate(
    params: Params,
    protocol: Protocol | Iterable[Segment],
    *,
    clock: str = "slip",
    method: str = "quasistatic",
    F_init: float | None = None,
    t0: float | None = None,
    mass: float | None = None,
    damping: float | None = None,
    stiffness: float | None = None,
    v_fail: float | None = None,
    direct_effect: float | DirectEffect | None = None,
    points: int = 200,
    rtol: float = 1e-09,
    solver: str | None = None,
    max_evaluations: int = 2000000,
    max_transitions: int = 10000,
    max_wall: float | None = None,
) -> SimulationResult:
    """Run a protocol through the model and report sticking, sliding, stops and failure.

    Parameters
    ----------
    params : Params
        Model parameters (a [N], alpha [1/m], Fd [N], x0 [m]).
    protocol : Protocol or sequence of segments
        The imposed history (see :mod:`granflow.simulation.protocol`).
    clock : {"slip", "time"}
        Aging along the slip (default; nothing evolves at rest) or in time since preparation
        (the layer also ages at rest).
    method : {"quasistatic", "dynamic"}
        Neglect inertia (default, as the paper does) or integrate it: a key of
        :data:`METHODS`.
    F_init : float, optional
        Friction state on a fresh layer [N]; default the paper's ``Fd (1 - exp(-alpha x0))``.
    t0 : float, optional
        Age of a fresh layer where the model takes over [s] (the time clock's start):
        default ``x0 / v`` with v the protocol's first imposed velocity, else
        ``DEFAULT_REFERENCE_VELOCITY`` (1 um/s). (The time at which a start-up enters the
        model is always the time it takes to slip x0, ``x0 / v``.)
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
        Kept so that earlier calls still run, and recorded in the result's options; it no
        longer changes anything: the dynamic method runs on granflow's compiled integrator
        (:mod:`granflow.simulation.ode`), and the two quasi-static paths that integrate (the
        time clock under a changing velocity, the direct effect) use LSODA.
    max_evaluations, max_transitions : int
        Bounds on the work, counted: right-hand-side evaluations and stick-slip transitions.
        A run that reaches one returns ``success=False`` with a message; the work done is
        in ``SimulationResult.work``.
    max_wall : float, optional
        A wall-clock limit [s], off by default (None): with it, whether a long run completes
        depends on the machine, and a run it stops says so in its message.

    Every physical number may also be a string with a unit ("0.05 kg", "1 mm/s") or a pint
    quantity; a bare number is in SI units.

    Returns
    -------
    SimulationResult
        On the record's clock: a start-up of a fresh layer at v begins at t = x0 / v with
        displacement x0 (see :mod:`granflow.simulation`).

    Raises
    ------
    InvalidParameterError
        For a bad argument (mass or stiffness with the quasi-static method, a negative
        damping, ...).
    InvalidProtocolError
        For a protocol that cannot be run (a ramp whose force would become negative, a
        start-up that ends before the layer has slipped x0).

    Examples
    --------
    >>> import granflow as gf
    >>> p = gf.Params.from_time_domain(a=3.31e-3, k=0.036, t0=0.23, Fd=10e-3, velocity=0.86e-6)
    >>> ramp = gf.Protocol([gf.ForceRamp(rate=0.05e-3, duration=400.0)])
    >>> result = gf.simulate(p, ramp)
    >>> result.failed, round(result.failure.force * 1e3, 6)  # fails at the peak, in mN
    (True, 13.782947)
    >>> startup = gf.simulate(p, [gf.Velocity("0.86 um/s", "100 s")])
    >>> float(startup.t[0]), round(startup.events_of("peak")[0].time, 6)  # as gf.peak(...)
    (0.23, 24.304978)
    """
    if not isinstance(params, Params):
        raise InvalidParameterError(
            f"params must be a granflow.Params, got {type(params).__name__}"
        )
    if not isinstance(protocol, Protocol):
        protocol = Protocol(protocol)
    check_choice(clock, "clock", CLOCKS)
    check_choice(method, "method", tuple(METHODS))
    stepper = METHODS[method]
    if not stepper.inertial:
        for value, name in ((mass, "mass"), (damping, "damping"), (stiffness, "stiffness")):
            if value is not None:
                raise InvalidParameterError(
                    f"{name} applies to method='dynamic' only (the quasi-static limit has no "
                    "inertia and a rigid drive)"
                )
    scale = protocol.max_velocity or DEFAULT_REFERENCE_VELOCITY
    first = protocol.first_velocity or DEFAULT_REFERENCE_VELOCITY
    aging = Aging(
        clock,
        t0=params.x0 / first if t0 is None else t0,
        F_init=initial_force(params) if F_init is None else F_init,
    )
    v_fail = _FAIL_FACTOR * scale if v_fail is None else v_fail
    if stepper.inertial:
        drive = Drive(
            v_fail,
            _STOP_FRACTION * scale,
            mass=DEFAULT_MASS if mass is None else mass,
            damping=DEFAULT_DAMPING if damping is None else damping,
            stiffness=stiffness,
        )
    else:
        drive = Drive(v_fail, _STOP_FRACTION * scale)
    if direct_effect is not None:
        if not isinstance(direct_effect, DirectEffect):
            direct_effect = DirectEffect(amplitude=direct_effect)
        if direct_effect.velocity is None:
            direct_effect = DirectEffect(direct_effect.amplitude, scale)
    numerics = Numerics(
        points=points,
        rtol=rtol,
        solver=solver or "LSODA",
        max_evaluations=max_evaluations,
        max_transitions=max_transitions,
        max_wall=max_wall,
    )
    return _run(params, protocol, method, aging, drive, direct_effect, numerics)


def _options(method, aging, drive, effect, numerics):
    """The result's ``options`` mapping (keys and order as they have always been)."""
    return {
        "clock": aging.clock,
        "method": method,
        "t0": aging.t0,
        "mass": drive.mass,
        "damping": drive.damping,
        "stiffness": drive.stiffness,
        "v_fail": drive.v_fail,
        "v_stop": drive.v_stop,
        "direct_effect": effect,
        "rtol": numerics.rtol,
        "solver": numerics.solver,
        "max_evaluations": numerics.max_evaluations,
        "max_transitions": numerics.max_transitions,
        "max_wall": numerics.max_wall,
    }


class _Pieces:
    """Some pieces of a rate-controlled segment, as :meth:`Stepper.segment` takes them."""

    control = "rate"

    def __init__(self, pieces):
        self._pieces = pieces

    def pieces(self):
        return self._pieces


def _entry(pieces, x0):
    """Where a start-up of the prepared layer slips x0: (time into ``pieces`` [s], the pieces
    left), or None when they never slip that far."""
    elapsed = 0.0
    for index, piece in enumerate(pieces):
        accel = (piece.end - piece.start) / piece.duration
        slip = 0.5 * (piece.start + piece.end) * piece.duration
        if slip < x0:
            x0 -= slip
            elapsed += piece.duration
            continue
        if accel == 0:
            into = x0 / piece.start
        else:  # start u + accel u^2 / 2 = x0, the root in the piece (stable form)
            into = 2.0 * x0 / (piece.start + (piece.start**2 + 2.0 * accel * x0) ** 0.5)
        into = min(into, piece.duration)
        velocity = piece.start + accel * into
        rest = list(pieces[index + 1 :])
        if piece.duration - into > 1e-12 * piece.duration:
            rest.insert(0, RatePiece(velocity, piece.end, piece.duration - into))
        return elapsed + into, rest
    return None


def _rate_segment(stepper, state, segment, where):
    """A rate-controlled segment: a start-up of the prepared layer enters the model at t0."""
    if not state.pristine:
        stepper.segment(segment)
        return
    pieces = segment.pieces()
    moving = next((i for i, piece in enumerate(pieces) if piece.end > 0 or piece.start > 0), None)
    if moving is None and not state.time_clock:  # a rest changes nothing on the slip clock
        stepper.segment(segment)
        return
    if moving is None or pieces[moving].start == 0 or (state.time_clock and moving > 0):
        state.loaded()  # from rest: an accelerating drive, or a rest that ages the layer
        stepper.segment(segment)
        return
    if moving > 0:  # rests before the start-up (slip clock: the layer does not change)
        stepper.segment(_Pieces(pieces[:moving]))
    p = state.params
    entry = _entry(pieces[moving:], p.x0)
    if entry is None:
        raise InvalidProtocolError(
            f"{where} ends before the layer has slipped x0 = {p.x0:.6g} m since the start of "
            "shear, where the model takes over (the one-clock rule): lengthen it"
        )
    duration, rest = entry
    state.enter(duration)
    if rest:
        stepper.segment(_Pieces(rest))
    else:  # the segment ends where the model takes over
        state.record_now()


def _run(params, protocol, method, aging, drive, effect, numerics):
    """Run every segment through the method's stepper until the end or a failure."""
    state = RunState(params, aging, numerics)
    stepper = METHODS[method](state, drive, effect)
    records = []
    message = "completed"
    success = True
    for index, segment in enumerate(protocol):
        state.segment_index = index
        start = (state.t, state.x, state.applied)
        outcome = "completed"
        where = f"segment {index + 1} ({segment.type_name})"
        try:
            if segment.control == "rate":
                _rate_segment(stepper, state, segment, where)
            else:
                state.loaded()
                stepper.segment(segment)
        except WorkExceededError as exc:
            success, outcome, message = False, "aborted", f"{where}: {exc}"
        except IntegrationError as exc:
            success, outcome = False, "aborted"
            message = f"{where}: integration failed: {exc}"
        if state.failure:
            outcome = "failed"
            f = state.failure
            message = (
                f"failure in {where} at t = {f.time:.7g} s, "
                f"slip = {f.slip:.7g} m, force = {f.force:.7g} N: {f.message}"
            )
        records.append(
            SegmentRecord(
                index=index,
                kind=segment.type_name,
                control=segment.control,
                start_time=start[0],
                end_time=state.t,
                start_slip=start[1],
                end_slip=state.x,
                start_force=start[2],
                end_force=state.applied,
                outcome=outcome,
            )
        )
        if outcome != "completed":
            break
    if state.origin is None:  # nothing loaded the layer: rests only
        state.loaded()
    if not state.chunks["t"]:  # aborted before its first sample: where it stood
        state.record_now()
    return SimulationResult(
        **state.arrays(),
        events=tuple(state.events),
        segments=tuple(records),
        failed=state.failure is not None,
        failure=state.failure,
        success=success,
        message=message,
        params=params,
        protocol=protocol,
        options=_options(method, aging, drive, effect, numerics),
        origin=Origin(*state.origin),
        work={"evaluations": state.evaluations, "transitions": state.phases},
    )
