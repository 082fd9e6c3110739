"""The views of the HTML report's tables of runs and joint analyses, read from the typed
:class:`~granflow.analysis.AnalysisResult`: the run table (start-up fits in the paper's
terms), creep, campaign, data quality, material constants, velocity collapse, Amontons' law,
preparations and model comparison. :mod:`granflow.analysis.report_stress` has the
stress-controlled runs and forecasts, :mod:`granflow.analysis.report_frame`
the figures, warnings and provenance.

Nothing here computes a statistic: every estimate, test and interval is a field of a result;
the views pick them, convert units for display (t0 = x0/v and αv = α·v from a run's
velocity, SI to mN, µm, s). Numbers stay in SI units where the template's filters convert
them (``si``, ``pm_si``); the text the views write themselves is in display units already.
"""

from __future__ import annotations

from typing import Any

from granflow.analysis.formatting import DASH, display_scale, real_number

__all__ = [
    "GRAIN_DIAMETER",
    "SECTIONS",
    "amontons_view",
    "campaign_view",
    "collapse_view",
    "comparison_view",
    "creep_view",
    "material_view",
    "model_comparison_view",
    "pair",
    "quality_view",
    "runs_view",
    "spread_view",
]

#: The grain diameter the rejuvenation length is compared with [m]: the paper's PMMA beads.
GRAIN_DIAMETER = 40e-6

#: The report's sections in page order: (anchor, title). The contents list is made from it.
SECTIONS = (
    ("summary", "Summary"),
    ("material", "Material constants"),
    ("runs", "Start-ups: per-run fits"),
    ("collapse", "Velocity collapse"),
    ("amontons", "Amontons' law"),
    ("preparation", "Preparations"),
    ("model-comparison", "Model comparison"),
    ("static-yield", "Static yield"),
    ("ramp", "Stress ramp"),
    ("creep", "Creep"),
    ("switch", "Switch to stress control"),
    ("stability-map", "Stability map"),
    ("forecasting", "Forecasting the failure"),
    # here the sections of the record families (granflow.families), in the families' order
    ("publication", "Publication figures"),
    ("campaign", "Campaign"),
    ("data-quality", "Data quality"),
    ("warnings", "Warnings"),
    ("provenance", "Provenance"),
)


# --------------------------------------------------------------------------- helpers


def pair(
    value: float | None, error: float | None, factor: float = 1.0
) -> tuple[float | None, float | None]:
    """(value, error) times ``factor``, None where missing."""
    value, error = real_number(value), real_number(error)
    return (
        None if value is None else value * factor,
        None if error is None else abs(error * factor),
    )


# --------------------------------------------------------------------------- runs


def _start_up_fit(fit, velocity, judged):
    """An Eq. 3 fit in the paper's terms: a, α, F_d, x0 (slip) and t0, αv (Fig. 2a's units,
    from the run's velocity)."""
    params, stderr = fit.params, fit.stderr
    if "alpha" in params:
        alpha, x0 = pair(params["alpha"], stderr["alpha"]), pair(params["x0"], stderr["x0"])
    elif velocity:
        alpha = pair(params["k"], stderr["k"], 1.0 / velocity)
        x0 = pair(params["t0"], stderr["t0"], velocity)
    else:
        alpha = x0 = (None, None)
    if velocity:
        k, t0 = pair(*alpha, velocity), pair(*x0, 1.0 / velocity)
    else:
        k = t0 = (None, None)
    at_bound = sorted(name for name, flag in fit.at_bound.items() if flag)
    return {
        "a": pair(params["a"], stderr["a"]),
        "alpha": alpha,
        "Fd": pair(params["Fd"], stderr["Fd"]),
        "x0": x0,
        "t0": t0,
        "k": k,
        "noise": None if judged is None else real_number(judged.noise),
        "chi2": None if judged is None else real_number(judged.chi2),
        "success": bool(fit.success),
        "message": str(fit.message or ""),
        "at_bound": at_bound,
    }


def runs_view(result: Any) -> list[dict[str, Any]]:
    """The run table: each run with its Eq. 3 fit in the paper's terms (start-ups and the
    rate-controlled part of switches), the force noise of its plateau and its normalised χ²
    (the one quantity of that column)."""
    goodness = result.analyses.goodness_of_fit
    judged = {} if goodness is None else goodness.runs
    rows = []
    for entry in result.runs:
        fit = getattr(entry.result, "fit", None) if entry.ok else None
        eq3 = fit is not None and entry.test in ("startup", "switch")
        rows.append(
            {
                "name": entry.name,
                "source": entry.source or "",
                "test": entry.test or DASH,
                "normal_load": entry.normal_load,
                "velocity": entry.velocity,
                "preparation": str(entry.preparation or DASH),
                "failed": not entry.ok,
                "reason": entry.reason or "",
                "problems": list(entry.problems),
                "geometry": entry.geometry,
                "fit": _start_up_fit(fit, entry.velocity, judged.get(entry.name)) if eq3 else None,
            }
        )
    return rows


def creep_view(result: Any) -> list[dict[str, Any]]:
    """The creep runs: the imposed force against F_d and F_peak, and the fit of
    δ = B ln(1 + t/τ_c) (τ_c flagged where it is below the record's sampling)."""
    compared = {row.run: row for row in result.analyses.creep}
    rows = []
    for entry in result.runs:
        if entry.test != "creep" or not entry.ok:
            continue
        creep, row = entry.result, compared.get(entry.name)
        fit = creep.fit
        sampling = creep.duration / (fit.ndata - 1) if fit.ndata > 1 else None
        tau = pair(fit.params["tau_c"], fit.stderr["tau_c"])
        rows.append(
            {
                "name": entry.name,
                "force": creep.stress,
                "over_Fd": None if row is None else row.stress_over_Fd,
                "over_peak": None if row is None else row.stress_over_peak,
                "B": pair(fit.params["B"], fit.stderr["B"]),
                "tau_c": tau,
                "sampling": sampling,
                "resolved": sampling is None or tau[0] is None or tau[0] >= sampling,
                "slip": creep.creep_slip,
                "duration": creep.duration,
                "residual": None if fit.sigma_known else real_number(fit.residual_std),
                "chi2": real_number(fit.redchi) if fit.sigma_known else None,
                "success": bool(fit.success),
                "message": str(fit.message or ""),
            }
        )
    return rows


def campaign_view(result: Any, runs: Any) -> dict[str, Any]:
    """The campaign section: counts per test, loads, velocities, the preparations (named
    when few, counted when many), geometry and problems."""
    tests: dict[str, int] = {}
    for run in runs:
        tests[run["test"]] = tests.get(run["test"], 0) + 1
    preparations = sorted({r["preparation"] for r in runs if r["preparation"] != DASH})
    campaign = result.campaign
    return {
        "runs": len(runs),
        "failed": sum(r["failed"] for r in runs),
        "tests": sorted(tests.items()),
        "loads": sorted({r["normal_load"] for r in runs if r["normal_load"] is not None}),
        "velocities": sorted({r["velocity"] for r in runs if r["velocity"] is not None}),
        "preparations": preparations if len(preparations) <= 8 else None,
        "preparation_count": len(preparations),
        "manifest": campaign.get("manifest"),
        "geometry": str(campaign.get("geometry") or "not recorded (runs given as data)"),
        "problems": [str(p) for p in campaign.get("problems", ())],
    }


def quality_view(runs: Any) -> dict[str, Any]:
    """Each run with problems, and each run's geometry where the runs' geometries differ."""
    flagged = [{"name": r["name"], "problems": r["problems"]} for r in runs if r["problems"]]
    geometries = {r["geometry"] for r in runs if r["geometry"] is not None}
    per_run = (
        [(r["name"], r["geometry"]) for r in runs if r["geometry"] is not None]
        if len(geometries) > 1
        else []
    )
    return {"flagged": flagged, "geometries": per_run}


# --------------------------------------------------------------------------- material


_MATERIAL = (
    ("mu_a", "μ_a", "aging amplitude over normal load a/F_N", None),
    ("mu_d", "μ_d", "dynamic friction coefficient F_d/F_N", None),
    ("alpha", "α", "shear-rejuvenation constant", None),
)


def material_view(result: Any) -> dict[str, Any] | None:
    """The material constants, α also as the rejuvenation length 1/α in µm and in grain
    diameters; None when the campaign determined none and says nothing why."""
    material = result.material
    if not material.determined and not material.reason:
        return None
    rows = []
    for key, symbol, meaning, _ in _MATERIAL:
        estimate = getattr(material, key)
        scale, unit = display_scale(key)
        rows.append(
            {
                "symbol": symbol,
                "meaning": meaning,
                "unit": unit,
                "scale": scale,
                "value": estimate.value,
                "stderr": estimate.stderr,
                "ci95": list(estimate.ci95),
                "reason": None if estimate.value is not None else material.reason,
            }
        )
    length = None
    alpha = material.alpha
    if alpha.value:
        low, high = (real_number(b) for b in alpha.ci95)
        length = {
            "value": 1.0 / alpha.value,
            "stderr": (alpha.stderr or 0.0) / alpha.value**2,
            "ci95": [1.0 / high if high else None, 1.0 / low if low else None],
            "grains": 1.0 / alpha.value / GRAIN_DIAMETER,
        }
    return {"rows": rows, "source": material.source or "", "length": length}


# --------------------------------------------------------------------------- joint analyses


def collapse_view(result: Any) -> dict[str, Any] | None:
    """The velocity collapse: per-velocity a and α, the shared fit and its test."""
    analysis = result.analyses.velocity_collapse
    if analysis is None:
        error = result.analyses.errors.get("velocity_collapse")
        return None if error is None else {"reason": error}
    collapse = analysis.result
    per, shared = collapse.per_velocity, collapse.shared
    rows = [
        {
            "velocity": v,
            "a": pair(per.params[f"a_v{i}"], per.stderr[f"a_v{i}"]),
            "alpha": pair(per.params[f"alpha_v{i}"], per.stderr[f"alpha_v{i}"]),
        }
        for i, v in enumerate(collapse.velocities)
    ]
    return {
        "reason": None,
        "rows": rows,
        "shared": {n: pair(shared.params[n], shared.stderr[n]) for n in ("a", "alpha", "Fd")},
        "statistic": collapse.statistic,
        "df": collapse.df,
        "p_value": collapse.p_value,
        "collapses": collapse.collapses,
        "normal_load": analysis.conditions.get("normal_load"),
    }


def amontons_view(result: Any) -> dict[str, Any] | None:
    """Amontons' law: per-load means, the lines through the origin, the joint fit and the
    test of the law (a field of :class:`granflow.AmontonsResult`)."""
    analysis = result.analyses.amontons
    if analysis is None:
        error = result.analyses.errors.get("amontons")
        return None if error is None else {"reason": error}
    amontons = analysis.result
    joint = amontons.joint
    rows = [
        {
            "normal_load": row["normal_load"],
            "repeats": row["repeats"],
            "a": tuple(row["a"]),
            "alpha": tuple(row["alpha"]),
            "alpha_v": tuple(row["alpha_v"]) if row.get("alpha_v") is not None else (None, None),
            "Fd": tuple(row["Fd"]),
        }
        for row in amontons.per_load
    ]
    return {
        "reason": None,
        "rows": rows,
        "has_alpha_v": any(r["alpha_v"][0] is not None for r in rows),
        "lines": [
            (key, tuple(amontons.lines[key]), tuple(amontons.lines_ci95.get(key, (None, None))))
            for key in ("a", "Fd")
            if key in amontons.lines
        ],
        "joint": {n: pair(joint.params[n], joint.stderr[n]) for n in ("mu_a", "mu_d", "alpha")},
        "success": bool(joint.success),
        "message": str(joint.message or ""),
        "test": amontons.test,
    }


def spread_view(result: Any) -> dict[str, Any] | None:
    """The preparation spread of each group of repeats (x0 with a, α and F_d held)."""
    spreads = result.analyses.preparation_spread
    if not spreads:
        error = result.analyses.errors.get("preparation_spread")
        return None if error is None else {"reason": error, "groups": []}
    groups = []
    for analysis in spreads:
        spread, conditions = analysis.result, analysis.conditions
        start_name = "x0" if spread.domain == "slip" else "t0"
        held = conditions.get("held")
        groups.append(
            {
                "label": str(conditions.get("preparation") or DASH),
                "repeats": spread.repeats,
                "start_name": start_name,
                "start_scale": display_scale(start_name)[0],
                "start": spread.start,
                "Fd": spread.Fd,
                "correlation": spread.correlation,
                "p_value": spread.p_value,
                "normal_load": conditions.get("normal_load"),
                "velocity": conditions.get("velocity"),
                "held": None
                if held is None
                else {
                    "a": tuple(held["a"]),
                    "alpha": tuple(held["alpha"]),
                    "Fd": tuple(held["Fd"]),
                    "x0_spread": held["x0_spread"],
                    "success": held.get("success") is not False,
                },
            }
        )
    return {"reason": None, "groups": groups}


def comparison_view(comparison: Any, label: Any = None) -> dict[str, Any]:
    """One model comparison (:class:`granflow.ModelComparison`): AIC and BIC per model."""
    rows = [
        {
            "model": str(row.get("model") or DASH),
            "formula": str(row.get("formula") or ""),
            "nfree": row.get("nfree"),
            "aic": real_number(row.get("aic")),
            "bic": real_number(row.get("bic")),
            "delta_aic": real_number(row.get("delta_aic")),
            "delta_bic": real_number(row.get("delta_bic")),
            "message": str(row.get("message") or ""),
            "fitted": real_number(row.get("aic")) is not None,
        }
        for row in comparison.rows
    ]
    return {
        "label": label,
        "rows": rows,
        "best_aic": comparison.best_aic,
        "best_bic": comparison.best_bic,
    }


def model_comparison_view(result: Any) -> dict[str, Any] | None:
    """Eq. 3 against simpler models on the representative start-up."""
    analysis = result.analyses.model_comparison
    if analysis is None:
        error = result.analyses.errors.get("model_comparison")
        return None if error is None else {"reason": error}
    return {"reason": None, **comparison_view(analysis.result, analysis.conditions.get("run"))}
