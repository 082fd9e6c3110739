"""The HTML report of a campaign analysis: one self-contained file that opens offline.

:func:`render_report` turns the content of ``results.json`` (see :mod:`granflow.analysis`)
into ``report.html``: campaign summary, material constants, per-run fits, joint analyses,
predictions, figures (PNG embedded as base64 data URIs), warnings and provenance. The page has
no external resources (no fonts, style sheets or scripts) and no JavaScript.

Every quantity in ``results`` is in SI units; the report shows display units (mN, µm, µm/s,
s, 1/m and 1/µm). Sections whose entry is missing or None are left out; an analysis given as
``{"reason": "..."}`` (or whose material value is None) shows that reason instead.

Accepted shapes beyond the plain ``to_dict()`` of granflow's results:

* ``analyses["preparation_spread"]`` and ``analyses["model_comparison"]``: one result, a list
  of results (each with an optional ``"name"``, ``"run"`` or ``"preparation"``), or a mapping
  from a label to a result;
* ``analyses["stress_ramp"]`` and ``analyses["switch"]``: a mapping or a list of mappings with
  an optional ``"run"`` (or ``"name"``) and ``"observed"`` / ``"predicted"`` mappings of
  quantities, shown side by side with their relative difference; other scalar entries are
  listed under the table;
* ``analyses["creep"]``: a list of mappings with ``"name"`` (or ``"run"``), an optional
  imposed ``"force"`` (or ``"stress"``, ``"imposed_force"``) [N] and a ``"fit"`` (the
  ``to_dict()`` of :class:`granflow.CurveFitResult`); runs whose own fit is a creep fit are
  listed too;
* ``predictions["stability_map"]``: the ``to_dict()`` of :class:`granflow.StabilityMap` (or a
  summary with ``"counts"``), or a list of them.

Quantities are put into display units by their names (``*_force``, ``F_*`` and ``a`` in mN,
``*_slip`` and ``x0`` in µm, ``*_time`` in s, ...), see :func:`display_unit`.
"""

import base64
import math
import numbers
import os
import re
from collections.abc import Mapping
from pathlib import Path

from granflow._files import write_text_atomic
from granflow.errors import InvalidParameterError

__all__ = [
    "display_unit",
    "format_interval",
    "format_number",
    "format_p_value",
    "format_value_error",
    "render_html",
    "render_report",
]

TEMPLATE = "report.html.j2"
_PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
_SUPERSCRIPT = str.maketrans("-0123456789", "⁻⁰¹²³⁴⁵⁶⁷⁸⁹")
_DASH = "—"

# --------------------------------------------------------------------------- numbers


def _real(value):
    """``value`` as a finite float, or None (bools, text and non-finite numbers give None)."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        return None
    value = float(value)
    return value if math.isfinite(value) else None


def _exponent(value, significant):
    """Decimal exponent of ``value`` once rounded to ``significant`` digits."""
    return int(f"{abs(value):.{significant - 1}e}".split("e")[1])


def _times_ten(exponent):
    return "×10" + str(exponent).translate(_SUPERSCRIPT)


def _fixed(value, place):
    """``value`` rounded at the decimal ``place`` (10**place is the last digit kept)."""
    if place >= 0:
        text = f"{round(value / 10**place) * 10**place:.0f}"
    else:
        text = f"{value:.{-place}f}"
    return text[1:] if text.startswith("-") and float(text) == 0 else text


def format_number(value, scale=1.0, significant=4):
    """A number for display: ``significant`` digits, plain between 1e-3 and 1e5, else with a
    power of ten (``1.968×10⁻⁷``).

    Parameters
    ----------
    value : float or None
        The number [SI]; None, NaN, infinities and non-numbers give "—".
    scale : float
        Factor to display units (1e3 for N -> mN).
    significant : int
        Significant digits.

    Returns
    -------
    str

    Examples
    --------
    >>> format_number(0.0123456, 1e3)
    '12.35'
    >>> format_number(1.9675e-07)
    '1.968×10⁻⁷'
    """
    value = _real(value)
    if value is None:
        return _DASH
    value *= scale
    if value == 0:
        return "0"
    exponent = _exponent(value, significant)
    if -3 <= exponent < 5:
        return _fixed(value, min(exponent - significant + 1, 0))
    mantissa = value / 10**exponent
    return f"{mantissa:.{significant - 1}f}{_times_ten(exponent)}"


def format_value_error(value, error, scale=1.0, digits=2):
    """``value ± error`` with the value rounded at the last digit of the error.

    Parameters
    ----------
    value, error : float or None
        The value and its standard error [SI]. Without a finite positive error the value is
        shown alone (4 significant digits); without a value, "—".
    scale : float
        Factor to display units.
    digits : int
        Significant digits kept in the error.

    Returns
    -------
    str

    Examples
    --------
    >>> format_value_error(49251.89, 433.72)
    '49250 ± 430'
    >>> format_value_error(0.0017915, 7.58e-06, 1e3)
    '1.7915 ± 0.0076'
    >>> format_value_error(1.9612e-07, 3.3e-09, 1e6)
    '0.1961 ± 0.0033'
    >>> format_value_error(2.1e-9, 3.0e-11)
    '(2.100 ± 0.030)×10⁻⁹'
    """
    value, error = _real(value), _real(error)
    if value is None:
        return _DASH
    if error is None or error <= 0:
        return format_number(value, scale)
    value, error = value * scale, abs(error * scale)
    place = _exponent(error, digits) - digits + 1
    exponent = _exponent(value, digits) if value != 0 else place
    exponent = max(exponent, _exponent(error, digits))
    if -3 <= exponent < 5:
        return f"{_fixed(value, place)} ± {_fixed(error, place)}"
    shift = 10**exponent
    local = place - exponent
    return (
        f"({_fixed(value / shift, local)} ± {_fixed(error / shift, local)}){_times_ten(exponent)}"
    )


def format_interval(bounds, scale=1.0, significant=4):
    """A 95 % interval ``[low, high]`` for display ("—" when it is missing)."""
    if not isinstance(bounds, list | tuple) or len(bounds) != 2:
        return _DASH
    low, high = (_real(b) for b in bounds)
    if low is None and high is None:
        return _DASH
    return f"[{format_number(low, scale, significant)}, {format_number(high, scale, significant)}]"


def format_p_value(p):
    """A p-value: two significant digits, with a power of ten below 1e-4."""
    p = _real(p)
    if p is None:
        return _DASH
    if p == 0:
        return "< 10⁻³⁰⁰"
    if p < 1e-4:
        return format_number(p, significant=2)
    return f"{p:.2g}"


def _format_percent(value):
    value = _real(value)
    return _DASH if value is None else f"{100 * value:.3g} %"


#: Display units by quantity name: (scale from SI, unit).
_UNITS_BY_NAME = {
    "a": (1e3, "mN"),
    "Fd": (1e3, "mN"),
    "F_d": (1e3, "mN"),
    "force": (1e3, "mN"),
    "stress": (1e3, "mN"),
    "normal_load": (1e3, "mN"),
    "alpha": (1.0, "1/m"),
    "x0": (1e6, "µm"),
    "slip": (1e6, "µm"),
    "B": (1e6, "µm"),
    "velocity": (1e6, "µm/s"),
    "k": (1.0, "1/s"),
    "alpha_v": (1.0, "1/s"),
    "t0": (1.0, "s"),
    "time": (1.0, "s"),
    "tau_c": (1.0, "s"),
    "rest_time": (1.0, "s"),
    "elapsed_s": (1.0, "s"),
}


def display_unit(name):
    """The display scale and unit of a quantity named ``name`` (SI -> display).

    Names ending in ``_force``/``_load``/``_stress`` or starting with ``F_`` are forces
    (mN), ``_slip``/``x_`` slips (µm), ``_time``/``t_`` times (s), ``_velocity`` velocities
    (µm/s); ``mu_*`` are dimensionless.

    Returns
    -------
    (float, str)
        Factor from SI and the unit ("" when dimensionless or unknown).

    Examples
    --------
    >>> display_unit("failure_force")
    (1000.0, 'mN')
    >>> display_unit("x_peak")
    (1000000.0, 'µm')
    """
    name = str(name)
    if name in _UNITS_BY_NAME:
        return _UNITS_BY_NAME[name]
    if name.startswith("mu"):
        return (1.0, "")
    if re.search(r"(_force|_load|_stress)$", name) or name.startswith("F_"):
        return (1e3, "mN")
    if name.endswith("_slip") or name.startswith("x_"):
        return (1e6, "µm")
    if name.endswith("_velocity"):
        return (1e6, "µm/s")
    if name.endswith("_time") or name.startswith("t_"):
        return (1.0, "s")
    return (1.0, "")


def _quantity(name, value, *, unit=True):
    """A display string for a named value of unknown kind (number, text, list, bool); the
    unit follows the number unless ``unit`` is false (when a header carries it)."""
    if isinstance(value, bool):
        return "yes" if value else "no"
    scale, symbol = display_unit(name)
    if isinstance(value, numbers.Integral) and scale == 1.0:
        text = str(int(value))
    elif _real(value) is not None:
        text = format_number(value, scale)
    elif value is None:
        return _DASH
    elif isinstance(value, list | tuple):
        return ", ".join(_quantity(name, item, unit=unit) for item in value) or _DASH
    elif isinstance(value, Mapping):
        return "; ".join(f"{key}: {_quantity(key, item)}" for key, item in value.items())
    else:
        return str(value)
    return f"{text} {symbol}" if unit and symbol else text


def _label(name):
    """``name [unit]`` for a column or row header."""
    unit = display_unit(name)[1]
    return f"{name} [{unit}]" if unit else str(name)


# --------------------------------------------------------------------------- the view


def _mapping(value):
    return value if isinstance(value, Mapping) else {}


def _sequence(value):
    return list(value) if isinstance(value, list | tuple) else []


def _reason(value):
    """The reason an analysis is missing: a mapping holding only reason-like entries."""
    if isinstance(value, Mapping):
        for key in ("reason", "error", "skipped"):
            if isinstance(value.get(key), str):
                return value[key]
    return None


def _scalars(mapping, skip=()):
    """(name, display text) of the scalar (or list-of-scalar) entries of a mapping."""
    rows = []
    for key, value in _mapping(mapping).items():
        if key in skip or isinstance(value, Mapping):
            continue
        if isinstance(value, list | tuple) and any(
            isinstance(item, Mapping | list | tuple) for item in value
        ):
            continue
        rows.append((_label(key), _quantity(key, value, unit=False)))
    return rows


def _estimate(params, stderr, name, factor=1.0):
    value, error = _real(params.get(name)), _real(stderr.get(name))
    return (
        None if value is None else value * factor,
        None if error is None else abs(error * factor),
    )


def _fit_view(fit, velocity):
    """Eq. 3 fit of one run in slip-domain terms (a time-domain fit is converted with v)."""
    params, stderr = _mapping(fit.get("params")), _mapping(fit.get("stderr"))
    at_bound = sorted(str(n) for n, flag in _mapping(fit.get("at_bound")).items() if flag)
    if "alpha" in params or "x0" in params:
        alpha, x0 = _estimate(params, stderr, "alpha"), _estimate(params, stderr, "x0")
    elif velocity:
        alpha = _estimate(params, stderr, "k", 1.0 / velocity)
        x0 = _estimate(params, stderr, "t0", velocity)
    else:
        alpha = x0 = (None, None)
    return {
        "a": _estimate(params, stderr, "a"),
        "alpha": alpha,
        "Fd": _estimate(params, stderr, "Fd"),
        "x0": x0,
        "redchi": _real(fit.get("redchi")),
        "sigma_known": bool(fit.get("sigma_known")),
        "success": fit.get("success") is not False,
        "message": str(fit.get("message") or ""),
        "at_bound": at_bound,
    }


def _is_creep_fit(fit):
    params = _mapping(fit.get("params"))
    return fit.get("model") == "creep" or ("B" in params and "tau_c" in params)


def _creep_view(name, fit, force):
    params, stderr = _mapping(fit.get("params")), _mapping(fit.get("stderr"))
    return {
        "name": name,
        "force": _real(force),
        "B": _estimate(params, stderr, "B"),
        "tau_c": _estimate(params, stderr, "tau_c"),
        "redchi": _real(fit.get("redchi")),
        "sigma_known": bool(fit.get("sigma_known")),
        "success": fit.get("success") is not False,
        "message": str(fit.get("message") or ""),
    }


def _imposed_force(entry):
    for key in ("force", "imposed_force", "stress", "creep_force"):
        if _real(entry.get(key)) is not None:
            return entry[key]
    return None


def _runs_view(results):
    runs, creep, names = [], [], set()
    for index, run in enumerate(_sequence(results.get("runs"))):
        run = _mapping(run)
        name = str(run.get("name") or run.get("source") or f"run {index + 1}")
        velocity = _real(run.get("velocity"))
        fit = _mapping(run.get("fit"))
        failed = run.get("status") == "failed"
        row = {
            "name": name,
            "source": str(run.get("source") or ""),
            "interval": run.get("interval"),
            "test": str(run.get("test") or _DASH),
            "normal_load": _real(run.get("normal_load")),
            "velocity": velocity,
            "preparation": str(run.get("preparation") or _DASH),
            "failed": failed,
            "reason": str(run.get("reason") or run.get("error") or ""),
            "fit": None,
        }
        if fit and _is_creep_fit(fit):
            creep.append(_creep_view(name, fit, _imposed_force(run)))
            names.add(name)
        elif fit and not failed:
            row["fit"] = _fit_view(fit, velocity)
        runs.append(row)
    analysis = _mapping(results.get("analyses")).get("creep")
    for index, entry in enumerate(_sequence(analysis)):
        entry = _mapping(entry)
        name = str(entry.get("name") or entry.get("run") or f"creep {index + 1}")
        fit = _mapping(entry.get("fit"))
        if name not in names and fit:
            creep.append(_creep_view(name, fit, _imposed_force(entry)))
    return runs, creep


def _campaign_view(results, runs):
    def distinct(key):
        values = sorted({r[key] for r in runs if r[key] is not None})
        return values

    tests = {}
    for run in runs:
        test = run["test"] if run["test"] != _DASH else "unspecified"
        tests[test] = tests.get(test, 0) + 1
    campaign = _mapping(results.get("campaign"))
    return {
        "runs": len(runs),
        "failed": sum(r["failed"] for r in runs),
        "tests": sorted(tests.items()),
        "loads": distinct("normal_load"),
        "velocities": distinct("velocity"),
        "preparations": sorted({r["preparation"] for r in runs if r["preparation"] != _DASH}),
        "details": _scalars(campaign, skip=("problems",)),
        "problems": [str(p) for p in _sequence(campaign.get("problems"))],
    }


_MATERIAL = (
    ("mu_a", "μ_a", "aging amplitude over normal load a/F_N", 1.0, ""),
    ("mu_d", "μ_d", "dynamic friction coefficient F_d/F_N", 1.0, ""),
    ("alpha", "α", "shear-rejuvenation constant", 1.0, "1/m"),
    ("alpha", "α", "shear-rejuvenation constant", 1e-6, "1/µm"),
)


def _material_view(results):
    material = results.get("material")
    if material is None:
        return None
    material = _mapping(material)
    rows = []
    for key, symbol, meaning, scale, unit in _MATERIAL:
        entry = material.get(key)
        entry = entry if isinstance(entry, Mapping) else {"value": entry}
        value = _real(entry.get("value"))
        rows.append(
            {
                "symbol": symbol,
                "meaning": meaning,
                "unit": unit,
                "scale": scale,
                "value": value,
                "stderr": _real(entry.get("stderr")),
                "ci95": entry.get("ci95"),
                "reason": None
                if value is not None
                else str(entry.get("reason") or material.get("reason") or "not determined"),
            }
        )
    return {"rows": rows, "source": str(material.get("source") or "")}


def _joint_status(joint):
    joint = _mapping(joint)
    return {
        "success": joint.get("success") is not False,
        "message": str(joint.get("message") or ""),
        "redchi": _real(joint.get("redchi")),
    }


def _collapse_view(collapse):
    if collapse is None:
        return None
    if _reason(collapse) is not None:
        return {"reason": _reason(collapse)}
    collapse = _mapping(collapse)
    per = _mapping(collapse.get("per_velocity"))
    shared = _mapping(collapse.get("shared"))
    p, e = _mapping(per.get("params")), _mapping(per.get("stderr"))
    rows = [
        {
            "velocity": _real(v),
            "a": _estimate(p, e, f"a_v{i}"),
            "alpha": _estimate(p, e, f"alpha_v{i}"),
        }
        for i, v in enumerate(_sequence(collapse.get("velocities")))
    ]
    sp, se = _mapping(shared.get("params")), _mapping(shared.get("stderr"))
    collapses = collapse.get("collapses")
    return {
        "reason": None,
        "rows": rows,
        "shared": {n: _estimate(sp, se, n) for n in ("a", "alpha", "Fd")},
        "statistic": _real(collapse.get("statistic")),
        "df": collapse.get("df"),
        "p_value": collapse.get("p_value"),
        "verdict": None
        if collapses is None
        else (
            "consistent with one curve in slip: the collapse is not rejected at the 5 % level"
            if collapses
            else "a and α depend on the velocity: the collapse is rejected at the 5 % level"
        ),
        "collapses": collapses,
    }


def _amontons_view(amontons):
    if amontons is None:
        return None
    if _reason(amontons) is not None:
        return {"reason": _reason(amontons)}
    amontons = _mapping(amontons)
    joint = _mapping(amontons.get("joint"))
    jp, je = _mapping(joint.get("params")), _mapping(joint.get("stderr"))

    def pair(value):
        value = _sequence(value)
        return (_real(value[0]), _real(value[1])) if len(value) == 2 else (None, None)

    rows = [
        {
            "normal_load": _real(row.get("normal_load")),
            "repeats": row.get("repeats"),
            "a": pair(row.get("a")),
            "alpha": pair(row.get("alpha")),
            "alpha_v": pair(row.get("alpha_v")),
            "Fd": pair(row.get("Fd")),
        }
        for row in map(_mapping, _sequence(amontons.get("per_load")))
    ]
    lines = _mapping(amontons.get("lines"))
    return {
        "reason": None,
        "rows": rows,
        "has_alpha_v": any(r["alpha_v"][0] is not None for r in rows),
        "lines": [(key, pair(lines.get(key))) for key in ("a", "Fd") if key in lines],
        "joint": {n: _estimate(jp, je, n) for n in ("mu_a", "mu_d", "alpha")},
        "status": _joint_status(joint),
    }


def _labelled(value, keys=("name", "run", "preparation", "label")):
    """(label, entry) pairs from one result, a list of results or a mapping label -> result."""
    if isinstance(value, list | tuple):
        pairs = []
        for index, entry in enumerate(value):
            entry = _mapping(entry)
            label = next((str(entry[k]) for k in keys if entry.get(k) is not None), None)
            pairs.append((label or f"#{index + 1}", entry))
        return pairs
    value = _mapping(value)
    keyed = value and all(isinstance(v, Mapping) for v in value.values())
    if keyed and not any(k in value for k in ("rows", "start", "Fd")):
        return [(str(k), v) for k, v in value.items()]
    return [(None, value)]


def _spread_view(spread):
    if spread is None:
        return None
    if _reason(spread) is not None:
        return {"reason": _reason(spread), "groups": []}
    groups = []
    for label, entry in _labelled(spread):
        domain = entry.get("domain", "slip")
        start_name = "x0" if domain == "slip" else "t0"
        scale, unit = display_unit(start_name)
        start, Fd = _mapping(entry.get("start")), _mapping(entry.get("Fd"))
        peaks = [p for p in map(_real, _sequence(entry.get("peak_force"))) if p is not None]
        groups.append(
            {
                "label": label,
                "reason": _reason(entry),
                "repeats": entry.get("repeats"),
                "start_name": start_name,
                "start_scale": scale,
                "start_unit": unit,
                "start": start,
                "Fd": Fd,
                "peak_range": (min(peaks), max(peaks)) if peaks else None,
                "correlation": _real(entry.get("correlation")),
                "p_value": entry.get("p_value"),
            }
        )
    return {"reason": None, "groups": groups}


def _comparison_view(comparison):
    if comparison is None:
        return None
    if _reason(comparison) is not None:
        return {"reason": _reason(comparison), "groups": []}
    groups = []
    for label, entry in _labelled(comparison):
        rows = [_mapping(row) for row in _sequence(entry.get("rows"))]
        groups.append(
            {
                "label": label,
                "reason": _reason(entry),
                "rows": [
                    {
                        "model": str(row.get("model") or _DASH),
                        "formula": str(row.get("formula") or ""),
                        "nfree": row.get("nfree"),
                        "aic": _real(row.get("aic")),
                        "bic": _real(row.get("bic")),
                        "delta_aic": _real(row.get("delta_aic")),
                        "delta_bic": _real(row.get("delta_bic")),
                        "message": str(row.get("message") or ""),
                        "fitted": _real(row.get("aic")) is not None,
                    }
                    for row in rows
                ],
                "best_aic": str(entry.get("best_aic") or _DASH),
                "best_bic": str(entry.get("best_bic") or _DASH),
            }
        )
    return {"reason": None, "groups": groups}


def _comparison_rows(observed, predicted):
    """Observed against predicted, one row per quantity, with the relative difference."""
    rows = []
    for key in list(dict.fromkeys([*observed, *predicted])):
        seen, model = observed.get(key), predicted.get(key)
        difference = None
        if _real(seen) is not None and _real(model) is not None and _real(seen) != 0:
            difference = (_real(model) - _real(seen)) / abs(_real(seen))
        rows.append(
            {
                "quantity": _label(key),
                "observed": _quantity(key, seen, unit=False),
                "predicted": _quantity(key, model, unit=False),
                "difference": _format_percent(difference) if difference is not None else _DASH,
            }
        )
    return rows


def _experiment_view(experiment):
    """Stress ramp or switch: observed against predicted, per run."""
    if experiment is None:
        return None
    if _reason(experiment) is not None:
        return {"reason": _reason(experiment), "entries": []}
    entries = []
    for label, entry in _labelled(experiment, keys=("run", "name")):
        observed, predicted = _mapping(entry.get("observed")), _mapping(entry.get("predicted"))
        entries.append(
            {
                "label": label,
                "reason": _reason(entry),
                "rows": _comparison_rows(observed, predicted),
                "details": _scalars(entry, skip=("run", "name", "reason", "error")),
            }
        )
    return {"reason": None, "entries": entries}


def _stability_view(stability):
    if stability is None:
        return None
    if _reason(stability) is not None:
        return {"reason": _reason(stability), "maps": []}
    maps = []
    for label, entry in _labelled(stability, keys=("name", "label")):
        if _real(entry.get("normal_load")) is not None:
            label = f"F_N = {_quantity('normal_load', entry['normal_load'])}"
        counts = dict(_mapping(entry.get("counts")))
        if not counts:
            for row in _sequence(entry.get("outcome")):
                for cell in _sequence(row) if isinstance(row, list | tuple) else [row]:
                    counts[str(cell)] = counts.get(str(cell), 0) + 1
        points = [p for p in map(_real, _sequence(entry.get("switch_points"))) if p is not None]
        ratios = [r for r in map(_real, _sequence(entry.get("stress_ratios"))) if r is not None]
        params = _mapping(entry.get("params"))
        maps.append(
            {
                "label": label,
                "reason": _reason(entry),
                "counts": sorted(counts.items()),
                "points": (len(points), min(points), max(points)) if points else None,
                "ratios": (len(ratios), min(ratios), max(ratios)) if ratios else None,
                "details": _scalars(
                    {k: entry.get(k) for k in ("velocity", "method", "clock") if k in entry}
                ),
                "params": [(str(k), _quantity(k, v)) for k, v in params.items()],
            }
        )
    return {"reason": None, "maps": maps}


def _static_yield_view(rows):
    if rows is None:
        return None
    if _reason(rows) is not None:
        return {"reason": _reason(rows), "rows": [], "extra": [], "has_ci95": False}
    rows = [_mapping(row) for row in _sequence(rows)]
    known = {"normal_load", "F_peak", "stderr", "ci95"}
    extra = list(
        dict.fromkeys(
            key
            for row in rows
            for key, value in row.items()
            if key not in known and _real(value) is not None
        )
    )
    return {
        "reason": None,
        "has_ci95": any(isinstance(row.get("ci95"), list | tuple) for row in rows),
        "extra": [_label(key) for key in extra],
        "rows": [
            {
                "normal_load": _real(row.get("normal_load")),
                "F_peak": (_real(row.get("F_peak")), _real(row.get("stderr"))),
                "ci95": row.get("ci95"),
                "extra": [_quantity(key, row.get(key), unit=False) for key in extra],
            }
            for row in rows
        ],
    }


def _png_size(data):
    """(width, height) from a PNG header."""
    return int.from_bytes(data[16:20], "big"), int.from_bytes(data[20:24], "big")


def _figures_view(results, output_dir, report_dir, problems):
    figures = []
    for index, figure in enumerate(_sequence(results.get("figures"))):
        figure = _mapping(figure)
        name = str(figure.get("name") or f"figure {index + 1}")
        entry = {
            "name": name,
            "anchor": "fig-" + re.sub(r"[^A-Za-z0-9_-]", "-", name),
            "title": str(figure.get("title") or name),
            "caption": str(figure.get("caption") or ""),
            "src": None,
            "width": None,
            "height": None,
            "svg": None,
        }
        png = figure.get("png")
        if png:
            file = Path(output_dir, png)
            try:
                data = file.read_bytes()
            except OSError as exc:
                problems.append(f"figure {name!r}: cannot read {png}: {exc.strerror or exc}")
            else:
                if data.startswith(_PNG_SIGNATURE) and len(data) > 24:
                    encoded = base64.b64encode(data).decode("ascii")
                    entry["src"] = f"data:image/png;base64,{encoded}"
                    entry["width"], entry["height"] = _png_size(data)
                else:
                    problems.append(f"figure {name!r}: {png} is not a PNG file")
        else:
            problems.append(f"figure {name!r}: no PNG file given")
        svg = figure.get("svg")
        if svg and Path(output_dir, svg).is_file():
            entry["svg"] = Path(os.path.relpath(Path(output_dir, svg), report_dir)).as_posix()
        figures.append(entry)
    return figures


def _warnings_view(results, runs, analyses, problems):
    failed = []
    for entry in _sequence(results.get("failed_runs")):
        entry = _mapping(entry)
        failed.append(
            {
                "name": str(entry.get("name") or entry.get("source") or _DASH),
                "source": str(entry.get("source") or ""),
                "reason": str(entry.get("reason") or "no reason given"),
            }
        )
    listed = {f["name"] for f in failed}
    for run in runs:
        if run["failed"] and run["name"] not in listed:
            failed.append(
                {
                    "name": run["name"],
                    "source": run["source"],
                    "reason": run["reason"] or "no reason given",
                }
            )
    at_bound = [
        (run["name"], ", ".join(run["fit"]["at_bound"]))
        for run in runs
        if run["fit"] and run["fit"]["at_bound"]
    ]
    convergence = [
        (run["name"], run["fit"]["message"] or "the fit did not converge")
        for run in runs
        if run["fit"] and not run["fit"]["success"]
    ]
    for name, joint in (
        (
            "velocity collapse (shared fit)",
            _mapping(analyses.get("velocity_collapse")).get("shared"),
        ),
        (
            "velocity collapse (per-velocity fit)",
            _mapping(analyses.get("velocity_collapse")).get("per_velocity"),
        ),
        ("Amontons joint fit", _mapping(analyses.get("amontons")).get("joint")),
    ):
        if isinstance(joint, Mapping) and joint.get("success") is False:
            convergence.append((name, str(joint.get("message") or "did not converge")))
    return {
        "failed": failed,
        "at_bound": at_bound,
        "convergence": convergence,
        "messages": [str(w) for w in _sequence(results.get("warnings"))],
        "report": problems,
    }


def _provenance_view(results):
    provenance = _mapping(results.get("provenance"))
    inputs = [
        {
            "file": str(_mapping(i).get("file") or _DASH),
            "sha256": str(_mapping(i).get("sha256") or ""),
        }
        for i in _sequence(provenance.get("inputs"))
    ]
    options = []
    for key, value in _mapping(provenance.get("options")).items():
        options.append((str(key), _quantity("", value)))
    timing = [
        (_label(k), _quantity(k, v, unit=False)) for k, v in _mapping(results.get("timing")).items()
    ]
    tables = []
    for name, files in _mapping(results.get("tables")).items():
        files = _mapping(files)
        tables.append((str(name), ", ".join(str(v) for v in files.values() if v)))
    from granflow import __version__

    return {
        "version": str(results.get("granflow_version") or _DASH),
        "renderer": __version__,
        "inputs": inputs,
        "options": options,
        "timing": timing,
        "tables": tables,
        "extra": _scalars(provenance, skip=("inputs", "options")),
    }


def _context(results, output_dir, report_dir):
    if not isinstance(results, Mapping):
        raise InvalidParameterError(
            f"results must be a mapping (the content of results.json), got {type(results).__name__}"
        )
    problems = []
    runs, creep = _runs_view(results)
    analyses = _mapping(results.get("analyses"))
    predictions = _mapping(results.get("predictions"))
    campaign = _mapping(results.get("campaign"))
    timing = _mapping(results.get("timing"))
    joint = {
        "collapse": _collapse_view(analyses.get("velocity_collapse")),
        "amontons": _amontons_view(analyses.get("amontons")),
        "spread": _spread_view(analyses.get("preparation_spread")),
        "comparison": _comparison_view(analyses.get("model_comparison")),
    }
    known = {
        "velocity_collapse",
        "amontons",
        "preparation_spread",
        "model_comparison",
        "creep",
        "stress_ramp",
        "switch",
    }
    other = [
        (str(k), _reason(v) or "", _scalars(v))
        for k, v in analyses.items()
        if k not in known and v is not None
    ]
    prediction = {
        "static_yield": _static_yield_view(predictions.get("static_yield")),
        "stability": _stability_view(predictions.get("stability_map")),
        "ramp": _experiment_view(analyses.get("stress_ramp")),
        "switch": _experiment_view(analyses.get("switch")),
    }
    figures = _figures_view(results, output_dir, report_dir, problems)
    return {
        "synthetic": bool(results.get("synthetic")),
        "title": str(campaign.get("name") or campaign.get("title") or "campaign"),
        "date": str(timing.get("finished") or timing.get("started") or ""),
        "campaign": _campaign_view(results, runs),
        "material": _material_view(results),
        "runs": runs,
        "any_fit": any(r["fit"] for r in runs),
        "chi_scaled": any(r["fit"] and not r["fit"]["sigma_known"] for r in runs),
        "creep": creep,
        "joint": joint,
        "any_joint": any(v is not None for v in joint.values()) or bool(other),
        "other": other,
        "prediction": prediction,
        "any_prediction": any(v is not None for v in prediction.values()),
        "figures": figures,
        "warnings": _warnings_view(results, runs, analyses, problems),
        "provenance": _provenance_view(results),
    }


# --------------------------------------------------------------------------- rendering


def _environment():
    import jinja2

    environment = jinja2.Environment(
        loader=jinja2.PackageLoader("granflow.analysis", "templates"),
        autoescape=True,
        undefined=jinja2.StrictUndefined,
        trim_blocks=True,
        lstrip_blocks=True,
        keep_trailing_newline=True,
    )
    environment.filters.update(
        num=format_number,
        pm=lambda estimate, scale=1.0: format_value_error(*estimate, scale=scale),
        value_error=format_value_error,
        interval=format_interval,
        pvalue=format_p_value,
        percent=_format_percent,
    )
    return environment


def render_html(results, output_dir=".", *, report_dir=None):
    """The report as an HTML string (see :func:`render_report`).

    Parameters
    ----------
    results : mapping
        The content of ``results.json``.
    output_dir : str or path-like
        Folder the figure paths in ``results["figures"]`` are relative to.
    report_dir : str or path-like, optional
        Folder the report will be written to, for the relative links to SVG files
        (default ``output_dir``).

    Returns
    -------
    str
    """
    output_dir = Path(output_dir)
    context = _context(results, output_dir, Path(report_dir or output_dir))
    return _environment().get_template(TEMPLATE).render(**context)


def render_report(results, output_dir, *, path=None):
    """Write the HTML report of an analysis: one self-contained file that opens offline.

    Parameters
    ----------
    results : mapping
        The content of ``results.json`` (SI units), as written by :func:`granflow.analysis.analyze`.
    output_dir : str or path-like
        The analysis' output folder; the PNG files of ``results["figures"]`` are read from it
        and embedded in the page as base64 data URIs.
    path : str or path-like, optional
        Where to write the report (default ``output_dir/report.html``). Written atomically:
        a reader never sees a half-written file.

    Returns
    -------
    pathlib.Path
        The report's path.

    Raises
    ------
    InvalidParameterError
        When ``results`` is not a mapping.

    Examples
    --------
    >>> import json, tempfile
    >>> from granflow.report import render_report
    >>> folder = tempfile.mkdtemp()
    >>> path = render_report({"synthetic": True, "runs": []}, folder)
    >>> "SYNTHETIC DATA" in path.read_text(encoding="utf-8")
    True
    """
    output_dir = Path(output_dir)
    path = Path(path) if path is not None else output_dir / "report.html"
    html = render_html(results, output_dir, report_dir=path.parent)
    path.parent.mkdir(parents=True, exist_ok=True)
    write_text_atomic(path, html)
    return path
