"""A friction curve at the door of a fit, and starting values read from its shape.

:func:`prepare` checks the data (a :class:`granflow.Run` or a pair of arrays), applies the fit
window and the weights; :func:`curve_features` finds the plateau, the overshoot and the early
rise, from which :func:`start_candidates` builds starting values of Eq. 3 (no initial guess
needed).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from granflow import _validate as check
from granflow.errors import FitError, InvalidDataError, InvalidParameterError
from granflow.model.run import Run
from granflow.model.special import scaled_ei_diff

if TYPE_CHECKING:
    from granflow._typing import FloatArray

__all__ = [
    "DROP_REASONS",
    "CurveData",
    "check_mapping",
    "curve_features",
    "noise_level",
    "prepare",
    "real_column",
    "require_overshoot",
    "start_candidates",
]

ABSCISSA = {"slip": ("x", "m"), "time": ("t", "s")}
MIN_POINTS = 10
#: The largest magnitude of a force [N] or an abscissa [m or s] a fit takes: least squares
#: sums squares, and 1e100 squared is still far from float64's 1.8e308 (a value beyond it
#: is a wrong unit, never a friction force).
LARGEST = 1e100
_START_PEAK_SLIPS = (0.9, 0.5, 1.6)  # trial alpha * x_peak for the starts


# --------------------------------------------------------------------------- data at the door


@dataclass(frozen=True)
class CurveData:
    """The points a fit uses: abscissa z [m or s], force y [N], weights w, and what came
    with them; ``dropped`` counts the points left out by reason (see :data:`DROP_REASONS`),
    non-zero counts only."""

    z: np.ndarray
    y: np.ndarray
    w: np.ndarray
    sigma_known: bool
    velocity: float | None
    window: tuple
    name: str | None
    dropped: dict


#: Why a fit leaves a point out: a NaN or infinite abscissa or force (a Run's rows only; arrays
#: with one are refused), an abscissa not positive (Eq. 3 needs x > 0), outside the window,
#: a weight of zero.
DROP_REASONS = ("non_finite", "not_positive", "outside_window", "zero_weight")


def _as_curve_arrays(data, domain):
    """(z, y, velocity, name, non-finite rows dropped) from a Run or a pair of arrays; Run
    rows with a NaN or an infinity are dropped (and counted)."""
    if isinstance(data, Run):
        z = data.slip if domain == "slip" else data.t
        keep = np.isfinite(z) & np.isfinite(data.force)
        if not keep.any():
            raise InvalidDataError(
                f"{data.name}: no point has both a finite {'slip' if domain == 'slip' else 't'} "
                "and a finite force"
            )
        dropped = int(keep.size - np.count_nonzero(keep))
        return (
            np.array(z[keep]),
            np.array(data.force[keep]),
            data.nominal_velocity,
            data.name,
            dropped,
        )
    if not isinstance(data, tuple | list) or len(data) != 2:
        raise InvalidDataError(
            "data must be a granflow.Run or a pair (abscissa, force) of arrays, "
            f"got {type(data).__name__}"
        )
    abscissa, unit = ABSCISSA[domain]
    arrays = [real_column(data[0], abscissa, unit), real_column(data[1], "force", "N")]
    if arrays[0].shape != arrays[1].shape:
        raise InvalidDataError(
            f"{abscissa} and force must have the same length, got {arrays[0].size} and "
            f"{arrays[1].size}"
        )
    return arrays[0], arrays[1], None, None, 0


def real_column(values: Any, name: str, unit: str = "") -> FloatArray:
    """``values`` as a new one-dimensional float array of finite numbers [``unit``].

    Raises
    ------
    InvalidDataError
        Not real numbers, not one-dimensional, or a NaN or infinity (its index named).
    """
    try:
        array = np.array(values, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise InvalidDataError(f"{name} must be an array of real numbers: {exc}") from None
    if array.ndim != 1:
        raise InvalidDataError(f"{name} must be one-dimensional, got shape {array.shape}")
    bad = ~np.isfinite(array)
    if bad.any():
        index = int(np.argmax(bad))
        unit = f" {unit}" if unit else ""
        raise InvalidDataError(f"{name} must be finite, got {array[index]}{unit} at index {index}")
    return array


def prepare(data, domain, velocity, window, weights, sigma):
    """The points of ``data`` inside the window, with their weights (see :func:`granflow.fit`)."""
    z, y, run_velocity, name, non_finite = _as_curve_arrays(data, domain)
    abscissa, unit = ABSCISSA[domain]
    for values, what, what_unit in ((z, abscissa, unit), (y, "force", "N")):
        if values.size and np.max(np.abs(values)) > LARGEST:
            index = int(np.argmax(np.abs(values)))
            raise InvalidDataError(
                f"{what}[{index}] = {values[index]:.6g} {what_unit} is beyond what a fit can "
                f"square (|{what}| <= {LARGEST:g} {what_unit}): is the unit right?"
            )
    steps = np.diff(z)
    if np.any(steps <= 0):
        index = int(np.argmax(steps <= 0))
        raise InvalidDataError(
            f"{abscissa} must increase strictly, but {abscissa}[{index + 1}] = "
            f"{z[index + 1]:.6g} {unit} follows {abscissa}[{index}] = {z[index]:.6g} {unit}"
        )
    if velocity is None:
        velocity = run_velocity
    elif velocity is not None:
        velocity = check.positive(velocity, "velocity", "m/s")
    n_all = z.size
    if weights is not None and sigma is not None:
        raise InvalidParameterError("give weights or sigma, not both")
    if sigma is not None:
        w = 1.0 / _per_point(sigma, n_all, "sigma", positive=True)
    elif weights is not None:
        w = _per_point(weights, n_all, "weights", positive=False)
    else:
        w = np.ones(n_all)
    positive = z > 0
    if window is None:
        inside = np.ones(z.shape, dtype=bool)
    else:
        if len(window) != 2:
            raise InvalidParameterError(f"window must be a pair (start, stop), got {window!r}")
        start = check.real_scalar(window[0], "window start", unit)
        stop = math.inf if window[1] is None else check.real_scalar(window[1], "window stop", unit)
        if stop <= start:
            raise InvalidParameterError(f"window must have start < stop, got {window!r}")
        inside = (z >= start) & (z <= stop)
    weighted = w > 0
    dropped = {
        "non_finite": non_finite,
        "not_positive": int(np.count_nonzero(~positive)),
        "outside_window": int(np.count_nonzero(positive & ~inside)),
        "zero_weight": int(np.count_nonzero(positive & inside & ~weighted)),
    }
    keep = positive & inside & weighted
    z, y, w = z[keep], y[keep], w[keep]
    if z.size < MIN_POINTS:
        raise InvalidDataError(
            f"a fit needs at least {MIN_POINTS} points with positive {abscissa} and positive "
            f"weight inside the window, got {z.size}"
        )
    used = (float(z[0]), float(z[-1]))
    dropped = {reason: count for reason, count in dropped.items() if count}
    return CurveData(z, y, w, sigma is not None, velocity, used, name, dropped)


def _per_point(values, n, name, positive):
    array = np.broadcast_to(np.asarray(values, dtype=np.float64), (n,)).copy()
    if not np.all(np.isfinite(array)):
        raise InvalidParameterError(f"{name} must be finite")
    if positive and np.any(array <= 0):
        raise InvalidParameterError(f"{name} must be positive")
    if np.any(array < 0):
        raise InvalidParameterError(f"{name} must be non-negative")
    return array


def check_mapping(mapping, names, what, domain):
    """``mapping`` as a dict whose keys are all parameter names of the domain."""
    mapping = dict(mapping or {})
    for key in mapping:
        if key not in names:
            raise InvalidParameterError(
                f"{what}: unknown parameter {key!r} for the {domain} domain; "
                f"the parameters are {', '.join(names)}"
            )
    return mapping


def require_overshoot(features, fixed, names):
    """Refuse data without a stress overshoot when a and x0 are to be fitted."""
    if names[0] in fixed:
        return
    overshoot = features["overshoot"]
    resolution = max(features["resolution"], 1e-6 * abs(features["peak_force"]))
    if overshoot <= resolution:
        raise FitError(
            "the data show no stress overshoot (the smoothed maximum exceeds the final "
            f"plateau by {overshoot:.3g} N, within the noise allowance {resolution:.3g} N), "
            "so the aging amplitude a and the initial state cannot be determined; fix them "
            "(fixed={'a': ...}; on the command line --fix a=VALUE) or compare simpler models "
            "with granflow.compare_models"
        )
    if features["peak_index"] >= 0.95 * features["smooth"].size:
        raise FitError(
            "the force still rises at the end of the window: the overshoot and the plateau Fd "
            "are not in the data; extend the window or fix Fd (fixed={'Fd': ...}; on the "
            "command line --fix Fd=VALUE)"
        )


# --------------------------------------------------------------------------- starting values


def _smooth(y, width):
    """Running mean over ``width`` points (edges padded with the end values)."""
    if width < 2:
        return y.copy()
    padded = np.concatenate([np.full(width // 2, y[0]), y, np.full(width - 1 - width // 2, y[-1])])
    total = np.concatenate([[0.0], np.cumsum(padded)])
    return (total[width:] - total[:-width]) / width


def noise_level(y):
    """Robust estimate of the point-to-point noise (median absolute second difference)."""
    if y.size < 4:
        return 0.0
    second = np.diff(y, 2)
    return float(1.4826 * np.median(np.abs(second - np.median(second))) / math.sqrt(6.0))


def curve_features(z, y):
    """Plateau, overshoot and early rise of a friction curve, for starting values.

    Returns a dict with ``plateau``, ``peak_z``, ``peak_force``, ``overshoot`` and ``noise``.
    """
    n = z.size
    # smooth over at most a quarter of the rise, so that a narrow overshoot survives
    rough_peak = int(np.argmax(_smooth(y, max(1, min(5, n // 50)))))
    width = max(1, min(n // 50, rough_peak // 4))
    smooth = _smooth(y, width)
    tail = y[int(0.9 * n) :]
    plateau = float(np.mean(tail))
    index = int(np.argmax(smooth))
    noise = noise_level(y)
    return {
        "plateau": plateau,
        "peak_index": index,
        "peak_z": float(z[index]),
        "peak_force": float(smooth[index]),
        "overshoot": float(smooth[index] - plateau),
        "noise": noise,
        # the largest of n / width smoothed noise values, minus the plateau, exceeds
        # this only by chance of order 1e-6
        "resolution": noise
        * (math.sqrt(2.0 * math.log(max(n / width, 2.0))) + 5.0)
        * math.sqrt(1.0 / width + 1.0 / max(tail.size, 1)),
        "smooth": smooth,
    }


def _rise_point(z, y, smooth, index):
    """(z, force) half-way up the rise: the first smoothed point above half the peak, with
    the raw data around it (a running mean is biased upwards on a steep rise)."""
    half = 0.5 * smooth[index]
    rising = np.nonzero(smooth[: index + 1] >= half)[0]
    point = int(rising[0]) if rising.size else index
    return float(z[point]), float(np.mean(y[max(point - 1, 0) : point + 2]))


_X0_TRIALS = np.exp(-np.linspace(26.0, 1e-6, 64))  # x0 from 5e-12 z_rise to z_rise


def _x0_from_rise(z_rise, f_rise, a, alpha, Fd):
    """x0 such that the model passes through the rise point ``(z_rise, f_rise)``.

    F at that point decreases monotonically with x0; it is evaluated for 64 trial values of
    x0 in one vectorised call and the crossing is interpolated in log x0.
    """
    trial = z_rise * _X0_TRIALS
    s, s0 = alpha * z_rise, alpha * trial
    force = a * scaled_ei_diff(s, s0) - Fd * math.expm1(-s)
    above = np.nonzero(force <= f_rise)[0]
    if not np.all(np.isfinite(force)) or above.size == 0 or above[0] == 0:
        return z_rise * 0.01
    k = int(above[0])
    log_x0 = np.log(trial[k - 1 : k + 1])
    weight = (force[k - 1] - f_rise) / (force[k - 1] - force[k])
    return float(math.exp(log_x0[0] + weight * (log_x0[1] - log_x0[0])))


def start_candidates(z, y, fixed, features):
    """Candidate (a, alpha, Fd, x0) starts from the curve features, honouring fixed values."""
    Fd = fixed.get("Fd", max(features["plateau"], 0.0))
    overshoot = max(features["peak_force"] - Fd, features["overshoot"], 1e-12)
    z_peak = max(features["peak_z"], z[0])
    z_rise, f_rise = _rise_point(z, y, features["smooth"], features["peak_index"])
    candidates = []
    for peak_slip in _START_PEAK_SLIPS:
        alpha = fixed.get("alpha", peak_slip / z_peak)
        a = fixed.get("a", overshoot * alpha * z_peak)
        rise = _x0_from_rise(z_rise, f_rise, a, alpha, Fd)
        # the initial state from the rise, or just before the first point
        for x0 in (rise, 0.5 * z[0]):
            candidates.append((a, alpha, Fd, fixed.get("x0", x0)))
    return candidates
