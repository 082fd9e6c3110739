"""Rate-and-state beside the paper's law on one record: the rows of :func:`compare_models`.

On velocity steps (a load-point velocity history is known) four models are fitted to the same
points:

``rsf_aging``, ``rsf_slip``
    Rate-and-state with one state variable (Dieterich's aging law, Ruina's slip law) on a
    spring: a, b, Dc, k, mu0 (:func:`granflow.rsf.fit`).
``eq2_direct``
    The paper's Eq. 2 with the direct effect, ``mu = mu_d + A ln(v / v_ref)`` on the same
    spring. In the slip clock Eq. 2 has no rate dependence, and long after preparation its
    aging transient ``a / (alpha x)`` is a constant folded into mu_d, so on a velocity step
    the law is the direct effect alone: rate-and-state with b = 0 (A, k, mu0).
``eq2``
    Eq. 2 without the direct effect: the friction does not see the step (mu_d).

They nest (eq2 in eq2_direct in each rate-and-state law), so beside AIC and BIC each row
gets the likelihood-ratio test against the model it extends (Gaussian errors: ``n ln(chi2_0 /
chi2_1)`` against chi-square with the difference of free parameters; with
``correlated_noise`` n is divided by the residuals' correlation time) and the pattern of its
residuals (lag-1 autocorrelation, the z-score of the runs of their signs).

On start-up overshoots (:func:`startup_rows`) the rate-and-state laws join Eq. 3 as a step
of the load point from a slow steady sliding (velocity ``r v``, r = 1e-1 .. 1e-4, the best
kept and counted as one more parameter) to the imposed velocity v: the rest before the
start-up is the slow sliding's old state, theta = Dc / (r v).
"""

import math

import numpy as np
from scipy.stats import chi2

from granflow.errors import GranflowError
from granflow.fitting.compare import failed_row
from granflow.fitting.creep import fit_curve
from granflow.fitting.engine import Model
from granflow.fitting.rsf_fit import fit as fit_rsf
from granflow.simulation.protocol import Protocol
from granflow.simulation.segments import Velocity

__all__ = ["STEP_MODELS", "residual_pattern", "startup_rows", "velocity_step_rows"]

STEP_MODELS = ("rsf_aging", "rsf_slip", "eq2_direct", "eq2")
FORMULAS = {
    "rsf_aging": "rate-and-state, aging law: mu0 + a ln(v/v0) + b ln(v0 theta/Dc), spring k",
    "rsf_slip": "rate-and-state, slip law: mu0 + a ln(v/v0) + b ln(v0 theta/Dc), spring k",
    "eq2_direct": "Eq. 2 with the direct effect: mu_d + A ln(v/v0), spring k",
    "eq2": "Eq. 2 without the direct effect: mu_d (no rate dependence)",
}
#: Which model each extends (for the likelihood-ratio test).
NESTS_IN = {"eq2_direct": "eq2", "rsf_aging": "eq2_direct", "rsf_slip": "eq2_direct"}
_HOLD_RATIOS = (1e-1, 1e-2, 1e-3, 1e-4)


def residual_pattern(residuals):
    """Lag-1 autocorrelation of the residuals and the z-score of the runs of their signs
    (Wald-Wolfowitz: about -N(0, 1) for white noise, strongly negative for a systematic
    misfit)."""
    r = np.asarray(residuals, dtype=float)
    centred = r - r.mean()
    denominator = float(centred @ centred)
    lag1 = float(centred[:-1] @ centred[1:] / denominator) if denominator > 0 else 0.0
    signs = r > 0
    plus, minus = int(signs.sum()), int((~signs).sum())
    n = plus + minus
    runs = 1 + int(np.count_nonzero(signs[1:] != signs[:-1]))
    if plus == 0 or minus == 0:
        return {"lag1": lag1, "runs_z": -math.inf}
    mean = 2.0 * plus * minus / n + 1.0
    variance = (mean - 1.0) * (mean - 2.0) / (n - 1.0)
    return {"lag1": lag1, "runs_z": float((runs - mean) / math.sqrt(max(variance, 1e-300)))}


def _row(model, result, extra_free=0):
    nfree = result.nfree + extra_free
    n = result.ndata
    log_term = n * math.log(result.chisqr / n) if result.chisqr > 0 else -math.inf
    return {
        "model": model,
        "formula": FORMULAS.get(model, model),
        "nfree": nfree,
        "chisqr": result.chisqr,
        "aic": log_term + 2 * nfree,
        "bic": log_term + math.log(n) * nfree,
        "success": result.success,
        "message": result.message,
        "pattern": residual_pattern(result.residuals),
    }


def _failed(model, nfree, exc):
    return failed_row(model, FORMULAS.get(model, model), nfree, exc)


def _constant(x, mu_d):
    return np.full(x.shape, mu_d)


def _constant_jacobian(x, mu_d):
    return np.full(x.shape, mu_d), np.ones((x.size, 1))


#: Eq. 2 without the direct effect on a velocity step: a constant friction.
CONSTANT = Model(("mu_d",), _constant, _constant_jacobian, log=(False,))


def likelihood_ratios(rows, correlation_time=1.0):
    """Add ``lr_test`` (against the model each row extends) to the fitted rows, in place."""
    by_name = {row["model"]: row for row in rows if row.get("chisqr")}
    for row in rows:
        base = by_name.get(NESTS_IN.get(row["model"]))
        if base is None or row.get("chisqr") is None:
            continue
        n = row.get("ndata", 0) / max(correlation_time, 1.0)
        statistic = max(n * math.log(base["chisqr"] / row["chisqr"]), 0.0)
        df = max(row["nfree"] - base["nfree"], 1)
        row["lr_test"] = {
            "against": base["model"],
            "statistic": statistic,
            "df": df,
            "p_value": float(chi2.sf(statistic, df)),
        }


def velocity_step_rows(t, friction, protocol, *, windows=None, detrend=False, correlated=False):
    """(rows, fits, correlation time) of the four velocity-step models on one record."""
    rows, fits = [], {}
    tau = 1.0
    for model in ("rsf_aging", "rsf_slip", "eq2_direct"):
        options = {"windows": windows, "detrend": detrend, "correlated_noise": correlated}
        if model == "eq2_direct":
            options["fixed"] = {"b": 0.0, "Dc": 1e-3}
        law = "slip" if model == "rsf_slip" else "aging"
        try:
            result = fit_rsf(t, friction, protocol, law=law, profile=False, **options)
        except GranflowError as exc:
            fits[model] = None
            rows.append(_failed(model, 5 if model != "eq2_direct" else 3, exc))
            continue
        fits[model] = result
        if model == "rsf_aging":
            tau = result.correlation_time
        row = _row(model, result)
        row["ndata"] = result.ndata
        rows.append(row)
    reference = next((f for f in fits.values() if f is not None), None)
    if reference is None:
        rows.append(_failed("eq2", 1, "no model could be fitted"))
        fits["eq2"] = None
    else:
        held = {} if detrend else {"slope": 0.0}
        slots, start = ("mu_d",), (float(np.mean(reference.data)),)
        model_fn, function = CONSTANT, f"{__name__}:CONSTANT"
        if detrend:
            slots, model_fn, function = ("mu_d", "slope"), TREND, f"{__name__}:TREND"
            start = (start[0], 0.0)
        result = fit_curve(
            model_fn,
            name="eq2",
            formula=FORMULAS["eq2"],
            units=dict.fromkeys(slots, ""),
            start=start,
            x=_displacement(reference),
            y=np.asarray(reference.data),
            held={k: v for k, v in held.items() if k in slots},
            function=function,
        )
        fits["eq2"] = result
        row = _row("eq2", result)
        row["ndata"] = result.ndata
        rows.append(row)
    likelihood_ratios(rows, tau if correlated else 1.0)
    return rows, fits, tau


def _displacement(result):
    """Load-point displacement at the fitted points [m] (per window, from its start)."""
    t, v = np.asarray(result.t), np.asarray(result.load_point_velocity)
    steps = np.concatenate([[0.0], 0.5 * (v[1:] + v[:-1]) * np.diff(t)])
    return np.cumsum(steps)


def _trend(x, mu_d, slope):
    return mu_d + slope * x


def _trend_jacobian(x, mu_d, slope):
    return mu_d + slope * x, np.column_stack([np.ones_like(x), x])


TREND = Model(("mu_d", "slope"), _trend, _trend_jacobian, log=(False, False))


def startup_rows(z, y, *, domain, velocity):
    """(rows, fits) of the two rate-and-state laws on a start-up curve (abscissa z: slip [m]
    or time [s]; force y), each a step of the load point from ``r * velocity`` to
    ``velocity`` with the best r of 1e-1 .. 1e-4 (counted as a parameter)."""
    v = 1.0 if velocity is None else float(velocity)
    duration = np.asarray(z, dtype=float) / v if domain == "slip" else np.asarray(z, dtype=float)
    rows, fits = [], {}
    lead = 1.0  # s of slow steady sliding before the start-up
    for model, law in (("rsf_aging", "aging"), ("rsf_slip", "slip")):
        best = None
        for ratio in _HOLD_RATIOS:
            protocol = Protocol([Velocity(ratio * v, lead), Velocity(v, float(duration[-1]))])
            try:
                result = fit_rsf(
                    lead + duration,
                    y,
                    protocol,
                    law=law,
                    windows=[(0.0, lead + duration[-1])],
                    profile=False,
                )
            except GranflowError:
                continue
            if result.success and (best is None or result.chisqr < best.chisqr):
                best = result
        if best is None:
            fits[model] = None
            rows.append(_failed(model, 6, "no start-up fit converged"))
            continue
        fits[model] = best
        rows.append(_row(model, best, extra_free=1))
    return rows, fits
