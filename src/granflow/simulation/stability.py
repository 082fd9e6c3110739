"""Where does the layer fail? A map over switch points and imposed-to-current force ratios.

Each cell is the paper's Fig. 3c experiment: a start-up at a constant velocity, a switch to
force control at time ``t_switch`` with the force set to ``ratio`` times the force at that
moment, held for ``hold`` seconds. The cell records whether the layer fails or stops, the
slip from the switch to the stop and the time from the switch to the failure.

The switch points run on granflow's one executor (:class:`granflow._parallel.Executor`:
local processes, or a Dask cluster with ``scheduler=``); the work of one switch point is the
top-level function :func:`map_row`, so any executor that pickles functions can run it.
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import TYPE_CHECKING, Any

import numpy as np

from granflow import _validate as check
from granflow._html import HtmlReport
from granflow._parallel import Executor
from granflow._progress import progress_bar, wanted
from granflow.errors import InvalidParameterError
from granflow.model.params import Params
from granflow.simulation.driver import simulate
from granflow.simulation.protocol import Protocol, SwitchToForce, Velocity

if TYPE_CHECKING:
    import pandas as pd
    from numpy.typing import NDArray

    from granflow._typing import ArrayLike

__all__ = ["OUTCOMES", "StabilityMap", "map_row", "stability_map"]

#: Outcome of a cell: failed, stopped (at rest at the end), still creeping, or not computed.
OUTCOMES = ("failure", "stop", "creep", "error")


@dataclass(frozen=True, eq=False)
class StabilityMap(HtmlReport):
    """The result of :func:`stability_map`; 2-D arrays are (switch point, stress ratio).

    Attributes
    ----------
    switch_points : numpy.ndarray
        Times of the switch after the start of the start-up [s].
    stress_ratios : numpy.ndarray
        Imposed force over the force at the switch [-].
    switch_slip, switch_force : numpy.ndarray
        Aging coordinate [m] and force [N] at each switch point.
    outcome : numpy.ndarray of str
        One of :data:`OUTCOMES` per cell.
    stop_slip : numpy.ndarray
        Slip from the switch to the final rest [m]; NaN unless the layer stopped.
    failure_time : numpy.ndarray
        Time from the switch to the failure [s]; NaN unless the layer failed.
    failure_force : numpy.ndarray
        Force at the failure [N]; NaN unless the layer failed.
    messages : numpy.ndarray of str
        The simulation's message per cell.
    velocity : float
        Velocity of the start-up [m/s].
    method, clock : str
        How the map was made.
    params : Params
    options : mapping
        hold [s], ramp [s] and the options passed to :func:`simulate`.
    """

    switch_points: np.ndarray
    stress_ratios: np.ndarray
    switch_slip: np.ndarray
    switch_force: np.ndarray
    outcome: np.ndarray
    stop_slip: np.ndarray
    failure_time: np.ndarray
    failure_force: np.ndarray
    messages: np.ndarray
    velocity: float
    method: str
    clock: str
    params: Params
    options: Mapping[str, Any] = field(default_factory=dict)

    def __post_init__(self):
        object.__setattr__(self, "options", MappingProxyType(dict(self.options)))

    @property
    def shape(self) -> tuple[int, int]:
        return self.outcome.shape

    @property
    def failed(self) -> NDArray[np.bool_]:
        """Boolean array: where the layer failed."""
        return self.outcome == "failure"

    @property
    def stopped(self) -> NDArray[np.bool_]:
        """Boolean array: where the layer came to rest."""
        return self.outcome == "stop"

    def __repr__(self):
        n, m = self.shape
        return (
            f"StabilityMap({n} switch points x {m} ratios, method={self.method!r}, "
            f"clock={self.clock!r}, {int(self.failed.sum())} failures)"
        )

    def to_frame(self) -> pd.DataFrame:
        """One row per cell (SI units), with the map's settings in ``attrs``."""
        import pandas as pd

        n, m = self.shape
        frame = pd.DataFrame(
            {
                "switch_point": np.repeat(self.switch_points, m),
                "stress_ratio": np.tile(self.stress_ratios, n),
                "switch_slip": np.repeat(self.switch_slip, m),
                "switch_force": np.repeat(self.switch_force, m),
                "imposed_force": np.outer(self.switch_force, self.stress_ratios).ravel(),
                "outcome": self.outcome.ravel(),
                "stop_slip": self.stop_slip.ravel(),
                "failure_time": self.failure_time.ravel(),
                "failure_force": self.failure_force.ravel(),
            }
        )
        frame.attrs.update(self._settings())
        return frame

    def _settings(self):
        return {
            "velocity": self.velocity,
            "method": self.method,
            "clock": self.clock,
            "params": self.params.to_dict(),
            "options": {key: _plain(value) for key, value in self.options.items()},
        }

    def to_dict(self) -> dict[str, Any]:
        """JSON-safe mapping (NaN becomes None)."""

        def listed(array):
            return [
                [None if isinstance(v, float) and not math.isfinite(v) else v for v in row]
                for row in array.tolist()
            ]

        return {
            **self._settings(),
            "switch_points": self.switch_points.tolist(),
            "stress_ratios": self.stress_ratios.tolist(),
            "switch_slip": self.switch_slip.tolist(),
            "switch_force": self.switch_force.tolist(),
            "outcome": self.outcome.tolist(),
            "stop_slip": listed(self.stop_slip),
            "failure_time": listed(self.failure_time),
            "failure_force": listed(self.failure_force),
            "messages": self.messages.tolist(),
        }

    @classmethod
    def from_dict(cls, saved: Mapping[str, Any]) -> StabilityMap:
        """The map of :meth:`to_dict` (None read back as NaN); inverts ``to_dict``."""
        from granflow.simulation.options import DirectEffect

        def grid(key):
            return np.array(
                [[math.nan if v is None else v for v in row] for row in saved[key]], dtype=float
            )

        options = dict(saved.get("options", {}))
        if isinstance(options.get("direct_effect"), dict):
            options["direct_effect"] = DirectEffect.from_dict(options["direct_effect"])
        outcome = np.array(saved["outcome"], dtype=str)
        messages = saved.get("messages")
        return cls(
            switch_points=np.array(saved["switch_points"], dtype=float),
            stress_ratios=np.array(saved["stress_ratios"], dtype=float),
            switch_slip=np.array(saved["switch_slip"], dtype=float),
            switch_force=np.array(saved["switch_force"], dtype=float),
            outcome=outcome,
            stop_slip=grid("stop_slip"),
            failure_time=grid("failure_time"),
            failure_force=grid("failure_force"),
            messages=np.full(outcome.shape, "") if messages is None else np.array(messages),
            velocity=float(saved["velocity"]),
            method=saved["method"],
            clock=saved["clock"],
            params=Params(**saved["params"]),
            options=options,
        )

    def report(self) -> str:
        """A plain-text summary (display units)."""
        n, m = self.shape
        counts = {kind: int((self.outcome == kind).sum()) for kind in OUTCOMES}
        lines = [
            "[[Stability map]]",
            f"    method        = {self.method}",
            f"    clock         = {self.clock}",
            f"    start-up      = {self.velocity * 1e6:.6g} µm/s",
            f"    switch points = {n} from {self.switch_points.min():.6g} to "
            f"{self.switch_points.max():.6g} s",
            f"    stress ratios = {m} from {self.stress_ratios.min():.6g} to "
            f"{self.stress_ratios.max():.6g}",
            f"    hold          = {self.options.get('hold'):.6g} s, ramp "
            f"{self.options.get('ramp'):.6g} s",
            "    cells         = "
            + ", ".join(f"{counts[kind]} {kind}" for kind in OUTCOMES if counts[kind]),
        ]
        if counts["stop"]:
            slips = self.stop_slip[self.stopped]
            lines.append(
                f"    stop slip     = {np.min(slips) * 1e6:.6g} .. {np.max(slips) * 1e6:.6g} µm"
            )
        if counts["failure"]:
            times = self.failure_time[self.failed]
            lines.append(f"    time to fail  = {np.min(times):.6g} .. {np.max(times):.6g} s")
        lines.append("[[Lowest failing ratio per switch point]]")
        for i, point in enumerate(self.switch_points):
            failing = np.flatnonzero(self.failed[i])
            lowest = f"{self.stress_ratios[failing[0]]:.6g}" if failing.size else "none"
            lines.append(
                f"    t = {point:<10.6g} s  F = {self.switch_force[i] * 1e3:<10.6g} mN  "
                f"ratio {lowest}"
            )
        return "\n".join(lines)


def _plain(value):
    if hasattr(value, "to_dict"):
        return value.to_dict()
    return value


def map_row(task):
    """All the cells of one switch point (a top-level, picklable function).

    Parameters
    ----------
    task : tuple
        ``(params_dict, velocity, switch_point, ratios, hold, ramp, simulate_options)``.

    Returns
    -------
    tuple
        ``(switch_slip, switch_force, cells)`` with one
        ``(outcome, stop_slip, failure_time, failure_force, message)`` per ratio.
    """
    params_dict, velocity, switch_point, ratios, hold, ramp, options = task
    params = Params(**params_dict)
    startup = Velocity(velocity, switch_point)
    cells = []
    switch_slip = switch_force = math.nan
    for ratio in ratios:
        protocol = Protocol([startup, SwitchToForce(hold, factor=ratio, ramp=ramp)])
        result = simulate(params, protocol, **options)
        first = result.segments[0]
        switch_slip, switch_force = first.end_slip, first.end_force
        if not result.success:
            cells.append(("error", math.nan, math.nan, math.nan, result.message))
        elif result.failed:
            failure = result.failure
            cells.append(
                ("failure", math.nan, failure.time - switch_point, failure.force, result.message)
            )
        elif result.velocity[-1] == 0:
            cells.append(
                ("stop", float(result.slip[-1]) - switch_slip, math.nan, math.nan, result.message)
            )
        else:
            cells.append(("creep", math.nan, math.nan, math.nan, result.message))
    return switch_slip, switch_force, cells


def _rows(pool, tasks, progress):
    """The rows of ``tasks`` in order; a bar counts the switch points as they finish."""
    if not wanted(progress):
        return pool.map(map_row, tasks)
    rows = [None] * len(tasks)
    bar = progress_bar(len(tasks), progress=True, desc="stability map", unit="switch point")
    try:
        for position, row in pool.run(map_row, tasks):
            if isinstance(row, Exception):  # a worker that died, as map would raise
                raise row
            rows[position] = row
            bar.update()
    finally:
        bar.close()
    return rows


def stability_map(
    params: Params,
    switch_points: ArrayLike,
    stress_ratios: ArrayLike,
    *,
    velocity: float,
    hold: float = 60.0,
    ramp: float = 0.0,
    method: str = "quasistatic",
    clock: str = "slip",
    jobs: int | None = 1,
    executor: Any = None,
    scheduler: Any = None,
    progress: bool | None = None,
    **options: Any,
) -> StabilityMap:
    """Fail or stop, for each switch point of a start-up and each imposed-to-current ratio.

    Parameters
    ----------
    params : Params
        Model parameters.
    switch_points : array_like
        Times of the switch on the record's clock (0 when shearing starts) [s]; after the
        model takes over at t0 = x0 / velocity.
    stress_ratios : array_like
        Imposed force over the force at the switch [-]; positive.
    velocity : float
        Velocity of the start-up [m/s].
    hold : float
        Time under force control [s] (default 60 s).
    ramp : float
        Time over which the force goes from its value at the switch to the imposed one [s]
        (default 0, a step); use a ramp much slower than the inertial time to compare the
        dynamic method with the quasi-static one.
    method, clock : str
        Passed to :func:`granflow.simulate`.
    jobs : int or None
        Local processes; 1 (default) runs in this process, None uses every core.
    executor : object, optional
        Runs the switch points instead of ``jobs``: anything with a ``map(function,
        iterable)`` method that returns the results in order (a
        :class:`concurrent.futures.Executor` one already has, or an adapter of a Dask client).
    scheduler : str or distributed.Client, optional
        Runs the switch points on a Dask cluster (an address such as ``"tcp://host:8786"``, or
        a client) instead of ``jobs``; needs the ``dask`` extra.
    progress : bool or None
        A progress bar over the switch points on stderr (tqdm: a widget in Jupyter): True,
        False, or None (default) for one when a person watches (a terminal or Jupyter); none
        with ``executor``, whose ``map`` returns only at the end.
    **options
        Further keyword arguments of :func:`granflow.simulate` (mass, damping, ...).

    Returns
    -------
    StabilityMap

    Examples
    --------
    >>> import granflow as gf
    >>> p = gf.Params.from_time_domain(a=3.31e-3, k=0.036, t0=0.23, Fd=10e-3, velocity=0.86e-6)
    >>> m = gf.stability_map(p, [10.0, 80.0], [0.99, 1.01], velocity=0.86e-6)
    >>> m.outcome.tolist()
    [['stop', 'stop'], ['stop', 'failure']]
    """
    if not isinstance(params, Params):
        raise InvalidParameterError(
            f"params must be a granflow.Params, got {type(params).__name__}"
        )
    points = check.real_array(switch_points, "switch_points", "s").ravel()
    ratios = check.real_array(stress_ratios, "stress_ratios").ravel()
    if points.size == 0 or ratios.size == 0:
        raise InvalidParameterError("switch_points and stress_ratios must not be empty")
    if np.any(points <= 0):
        raise InvalidParameterError(f"switch_points must be positive, got {points.min():g} s")
    if np.any(ratios <= 0):
        raise InvalidParameterError(f"stress_ratios must be positive, got {ratios.min():g}")
    velocity = check.positive(velocity, "velocity", "m/s")
    start = params.x0 / velocity
    if np.any(points <= start):
        raise InvalidParameterError(
            f"switch_points must come after the model takes over at t0 = x0 / velocity = "
            f"{start:g} s, got {points.min():g} s"
        )
    hold = check.positive(hold, "hold", "s")
    ramp = check.non_negative(ramp, "ramp", "s")
    if ramp > hold:
        raise InvalidParameterError(f"ramp must not exceed hold = {hold:g} s, got {ramp:g} s")
    if jobs is None:
        jobs = os.cpu_count() or 1
    if isinstance(jobs, bool) or not isinstance(jobs, int) or jobs < 1:
        raise InvalidParameterError(f"jobs must be a positive integer or None, got {jobs!r}")
    if executor is not None and scheduler is not None:
        raise InvalidParameterError("give executor or scheduler, not both")
    sim_options = {"method": method, "clock": clock, **options}
    ratio_list = [float(r) for r in ratios]
    tasks = [
        (params.to_dict(), velocity, float(point), ratio_list, hold, ramp, sim_options)
        for point in points
    ]
    # Check the options once here, so that a bad one raises in this process.
    simulate(params, Protocol([Velocity(velocity, float(points[0]))]), **sim_options)
    if executor is not None:
        rows = list(executor.map(map_row, tasks))
    else:
        with Executor(min(jobs, len(tasks)), scheduler) as pool:
            rows = _rows(pool, tasks, progress)
    shape = (points.size, ratios.size)
    columns = {name: np.full(shape, np.nan) for name in ("stop", "time", "force")}
    outcome = np.empty(shape, dtype=object)
    messages = np.empty(shape, dtype=object)
    for i, (_, _, cells) in enumerate(rows):
        for j, (kind, slip, failure_time, failure_force, message) in enumerate(cells):
            outcome[i, j] = kind
            columns["stop"][i, j] = slip
            columns["time"][i, j] = failure_time
            columns["force"][i, j] = failure_force
            messages[i, j] = message
    return StabilityMap(
        switch_points=points,
        stress_ratios=ratios,
        switch_slip=np.array([row[0] for row in rows]),
        switch_force=np.array([row[1] for row in rows]),
        outcome=outcome.astype(str),
        stop_slip=columns["stop"],
        failure_time=columns["time"],
        failure_force=columns["force"],
        messages=messages.astype(str),
        velocity=velocity,
        method=method,
        clock=clock,
        params=params,
        options={"hold": hold, "ramp": ramp, **options},
    )
