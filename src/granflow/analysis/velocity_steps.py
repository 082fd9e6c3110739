"""Velocity-step records in a campaign: their rate-and-state fits and model comparison.

A self-contained piece of the campaign analysis: :class:`VelocitySteps` (its records, each a
:class:`VelocityStepRecord`) is the campaign's ``velocity_steps``. It holds, for each
velocity-step record (:func:`is_velocity_step_file` tells them from rheometer exports), the
rate-and-state fit of :func:`granflow.rsf.fit`, the comparison of
:func:`granflow.compare_models` (rate-and-state aging and slip laws, the paper's Eq. 2 with
and without the direct effect) and a figure of the fit and its residuals.
:func:`velocity_step_section` returns plain JSON-safe data in the shapes the report already
reads: ``model_comparison`` (one entry per record, with ``label``, ``rows``, ``best_aic``,
``best_bic``, as ``analyses["model_comparison"]``), ``figures`` (``name``, ``title``,
``caption``, ``png`` relative to the output folder, as ``results["figures"]``) and ``fits``
(the parameter table of each record: value, standard error, 95 % interval, unit).
"""

import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from granflow._format import format_value_error
from granflow._json import json_safe
from granflow._typing import PathLike
from granflow.analysis.values import Value
from granflow.errors import GranflowError
from granflow.fitting.compare import ModelComparison
from granflow.fitting.results import FrozenMap
from granflow.io.velocity_steps import is_velocity_step_file

__all__ = [
    "VELOCITY_STEP_TEST",
    "StepFit",
    "StepParameter",
    "VelocityStepRecord",
    "VelocitySteps",
    "campaign_velocity_steps",
    "is_velocity_step_file",
    "velocity_step_entries",
    "velocity_step_section",
]

#: The manifest's ``test`` of a velocity-step record.
VELOCITY_STEP_TEST = "velocity_steps"


def _parameter_table(fit):
    rows = []
    for name in fit.names:
        low, high = fit.ci95[name]
        rows.append(
            {
                "name": name,
                "value": fit.params[name],
                "stderr": fit.stderr[name],
                "ci95": [low, high],
                "method": fit.ci_method[name],
                "unit": fit.units[name],
            }
        )
    return {
        "law": "+".join(fit.laws),
        "success": fit.success,
        "message": fit.message,
        "a_minus_b": fit.a_minus_b,
        "a_minus_b_stderr": fit.a_minus_b_stderr,
        "residual_rms": fit.residual_rms,
        "scatter": fit.noise,
        "harmonics": fit.harmonics,
        "periodicity": dict(fit.periodicity),
        "parameters": rows,
    }


def _ripple_caption(fit):
    """The caption's words on a ripple periodic in load-point displacement: the fitted one,
    or one the residuals hold (with the advice to fit it)."""
    if fit.harmonics:
        return (
            f"; a ripple of wavelength {fit.params['wavelength'] * 1e6:.4g} µm in load-point "
            "displacement fitted with it"
        )
    check = fit.periodicity
    if check and check["significant"]:
        return (
            f"; the residuals hold a ripple of wavelength {check['wavelength'] * 1e6:.4g} µm "
            f"in load-point displacement (amplitude {check['amplitude']:.2g}): consider "
            "periodic: true"
        )
    return ""


def velocity_step_section(
    paths: Any,
    output_dir: PathLike,
    *,
    law: str = "aging",
    correlated_noise: bool = True,
    first_index: int = 1,
    periodic: bool | float | None = None,
) -> dict[str, Any]:
    """Fit, compare and draw every velocity-step record of ``paths``.

    Parameters
    ----------
    paths : sequence of path-like
        Velocity-step records (:func:`granflow.io.read_velocity_steps`).
    output_dir : path-like
        Where the figures are written (``velocity_step_<k>.png``).
    law : str
        The rate-and-state law of the fit shown and tabled.
    correlated_noise : bool
        Uncertainties scaled by the residuals' correlation time (real records).
    first_index : int
        The number of the first record's figure.
    periodic : bool or float, optional
        Fit the shown (and tabled) fit with an apparatus ripple periodic in load-point
        displacement (:func:`granflow.rsf.fit`'s ``periodic``: True, or a wavelength [m]);
        the model comparison's fits stay without it, all alike.

    Returns
    -------
    dict
        ``model_comparison``, ``figures``, ``fits`` (see the module) and ``problems`` (one
        sentence per record that could not be read or fitted).
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from granflow import rsf
    from granflow.fitting.compare import compare_models

    output_dir = Path(output_dir)
    output_dir.mkdir(parents=True, exist_ok=True)
    section: dict[str, Any] = {"model_comparison": [], "figures": [], "fits": {}, "problems": []}
    for index, path in enumerate(paths, start=first_index):
        label = Path(path).name
        try:
            record = rsf.read_velocity_steps(path)
            comparison = compare_models(record, correlated_noise=correlated_noise)
        except GranflowError as exc:
            section["problems"].append(f"{label}: {exc}")
            continue
        entry = comparison.to_dict(include_arrays=False)
        entry.pop("fits", None)
        section["model_comparison"].append({"label": label, **entry})
        fit: Any = comparison.fits.get(f"rsf_{law}")
        if fit is None:
            section["problems"].append(f"{label}: the {law} law could not be fitted")
            continue
        if periodic:
            try:
                fit = rsf.fit(record, law=law, correlated_noise=correlated_noise, periodic=periodic)
            except GranflowError as exc:
                section["problems"].append(f"{label}: with the ripple: {exc}")
                continue
        section["fits"][label] = _parameter_table(fit)
        top, _ = fit.plot()
        name = f"velocity_step_{index}"
        top.figure.savefig(output_dir / f"{name}.png", dpi=100)
        plt.close(top.figure)
        ratio = fit.residual_rms / fit.noise if fit.noise > 0 else math.nan
        section["figures"].append(
            {
                "name": name,
                "title": f"{label}: rate-and-state fit ({law} law)",
                "caption": (
                    f"load point {' → '.join(f'{v * 1e6:.3g}' for v in record.velocities)} µm/s; "
                    f"a − b = {fit.a_minus_b:.4g} ± {1.96 * fit.a_minus_b_stderr:.2g}; residual "
                    f"RMS {ratio:.2f} × the scatter; best by AIC: {comparison.best_aic}"
                    f"{_ripple_caption(fit)}"
                ),
                "png": f"{name}.png",
            }
        )
    return section


def velocity_step_entries(
    manifest: PathLike | None, allow_outside: bool = False
) -> list[dict[str, Any]]:
    """The manifest's velocity-step records (``test: velocity_steps``), in manifest order.

    Parameters
    ----------
    manifest : path-like or None
        The campaign's manifest (None: a Campaign, which holds none).

    Returns
    -------
    list of dict
        ``file`` (as the manifest writes it, relative to its folder), ``law`` (default
        ``"aging"``) and ``periodic`` (True, False or a wavelength [m]; default False).
        Entries the manifest cannot use are failed runs of the campaign already.
    """
    if manifest is None:
        return []
    from granflow.io.manifest import BadEntry, read_manifest

    return [
        {
            "file": str(entry["file"]),
            "law": str(entry.get("law") or "aging"),
            "periodic": entry.get("periodic", False),
        }
        for entry in read_manifest(manifest, errors="collect", allow_outside=allow_outside)
        if not isinstance(entry, BadEntry) and entry.get("test") == VELOCITY_STEP_TEST
    ]


def campaign_velocity_steps(
    manifest: PathLike | None,
    output: PathLike,
    figures_dir: str = "figures",
    allow_outside: bool = False,
) -> dict[str, Any]:
    """Fit, compare and draw the velocity-step records a campaign's manifest names.

    One record after the other, in manifest order and in this process, so the result does not
    depend on the number of workers; a record that cannot be read or fitted fails alone.

    Parameters
    ----------
    manifest : path-like or None
        The campaign's manifest (:func:`velocity_step_entries`).
    output : path-like
        The analysis's output folder; the figures go to ``output/figures_dir``.
    figures_dir : str
        The figures' folder, relative to ``output``.
    allow_outside : bool
        Read records outside the manifest's folder too (see
        :func:`granflow.io.read_manifest`).

    Returns
    -------
    dict
        Empty without velocity-step records; otherwise ``records`` (one per record analysed:
        ``name``, ``law``, ``fit`` (the parameter table), ``comparison`` (rows, best by AIC and
        BIC) and ``figure`` (the PNG relative to ``output``)) and ``failed`` (``name``,
        ``source``, ``interval``, ``stage``, ``reason``, as the failed runs).
    """
    entries = velocity_step_entries(manifest, allow_outside)
    if not entries:
        return {}
    folder = Path(manifest).parent  # type: ignore[arg-type]
    records, failed = [], []
    for index, entry in enumerate(entries, start=1):
        name, path = entry["file"], folder / entry["file"]
        try:
            section = velocity_step_section(
                [path],
                Path(output) / figures_dir,
                law=entry["law"],
                first_index=index,
                periodic=entry["periodic"],
            )
        except Exception as exc:  # any error: the record fails alone, named
            section = {"problems": [f"{path.name}: {type(exc).__name__}: {exc}"]}
        if section["problems"] or not section.get("fits"):
            reasons = [p.removeprefix(f"{path.name}: ") for p in section["problems"]]
            failed.append(
                {
                    "name": name,
                    "source": name,
                    "interval": None,
                    "stage": VELOCITY_STEP_TEST,
                    "reason": "; ".join(reasons) or "no fit",
                }
            )
            continue
        (comparison,) = section["model_comparison"]
        comparison = {k: v for k, v in comparison.items() if k != "label"}
        figure = section["figures"][0]
        records.append(
            {
                "name": name,
                "law": entry["law"],
                "fit": section["fits"][path.name],
                "comparison": comparison,
                "figure": f"{figures_dir}/{figure['png']}",
                "caption": figure["caption"],
            }
        )
    return {"records": records, "failed": failed}


# --------------------------------------------------------------------------- typed results


def _value(value):
    return math.nan if value is None else float(value)


@dataclass(frozen=True, eq=False)
class StepParameter(Value):
    """One parameter of a velocity-step record's rate-and-state fit.

    Attributes
    ----------
    name : str
    value, stderr : float
        [unit]
    ci95 : (float, float)
        Its 95 % interval [unit].
    method : str
        ``"profile"``, ``"wald"`` or ``"fixed"``.
    unit : str
        Its SI unit ("" for the friction coefficients, "m" for Dc).
    """

    name: str
    value: float
    stderr: float
    ci95: tuple
    method: str
    unit: str

    def to_dict(self) -> dict[str, Any]:
        """JSON-safe mapping."""
        return json_safe(
            {
                "name": self.name,
                "value": self.value,
                "stderr": self.stderr,
                "ci95": list(self.ci95),
                "method": self.method,
                "unit": self.unit,
            }
        )

    @classmethod
    def from_dict(cls, saved: Mapping[str, Any]) -> "StepParameter":
        """The parameter of :meth:`to_dict`."""
        low, high = saved.get("ci95") or (None, None)
        return cls(
            name=str(saved["name"]),
            value=_value(saved["value"]),
            stderr=_value(saved["stderr"]),
            ci95=(_value(low), _value(high)),
            method=str(saved.get("method") or ""),
            unit=str(saved.get("unit") or ""),
        )


@dataclass(frozen=True, eq=False)
class StepFit(Value):
    """The rate-and-state fit of a velocity-step record, as the campaign keeps it.

    Attributes
    ----------
    law : str
    success : bool
    message : str
    a_minus_b, a_minus_b_stderr : float
        [-]
    residual_rms, scatter : float
        The residuals' RMS and the record's high-frequency scatter [-].
    harmonics : int
        Harmonics of the fitted apparatus ripple (0 without one).
    periodicity : mapping
        The residuals' check for a ripple.
    parameters : tuple of StepParameter
    """

    law: str
    success: bool
    message: str
    a_minus_b: float
    a_minus_b_stderr: float
    residual_rms: float
    scatter: float
    harmonics: int
    periodicity: FrozenMap
    parameters: tuple

    @property
    def rms_ratio(self) -> float:
        """The residuals' RMS over the record's scatter [-] (NaN without a scatter)."""
        return self.residual_rms / self.scatter if self.scatter > 0 else math.nan

    def to_dict(self) -> dict[str, Any]:
        """JSON-safe mapping (the shape of :func:`velocity_step_section`'s ``fits``)."""
        return json_safe(
            {
                "law": self.law,
                "success": self.success,
                "message": self.message,
                "a_minus_b": self.a_minus_b,
                "a_minus_b_stderr": self.a_minus_b_stderr,
                "residual_rms": self.residual_rms,
                "scatter": self.scatter,
                "harmonics": self.harmonics,
                "periodicity": dict(self.periodicity),
                "parameters": [p.to_dict() for p in self.parameters],
            }
        )

    @classmethod
    def from_dict(cls, saved: Mapping[str, Any]) -> "StepFit":
        """The fit of :meth:`to_dict`."""
        return cls(
            law=str(saved["law"]),
            success=bool(saved["success"]),
            message=str(saved.get("message") or ""),
            a_minus_b=_value(saved["a_minus_b"]),
            a_minus_b_stderr=_value(saved["a_minus_b_stderr"]),
            residual_rms=_value(saved["residual_rms"]),
            scatter=_value(saved["scatter"]),
            harmonics=int(saved.get("harmonics") or 0),
            periodicity=FrozenMap(saved.get("periodicity") or {}),
            parameters=tuple(StepParameter.from_dict(p) for p in saved["parameters"]),
        )


@dataclass(frozen=True, eq=False)
class VelocityStepRecord(Value):
    """One velocity-step record of a campaign: its fit, its model comparison, its figure.

    Attributes
    ----------
    name : str
        The file, as the manifest names it.
    law : str
        The rate-and-state law of the fit shown.
    fit : StepFit
    comparison : granflow.ModelComparison
        Rate-and-state aging and slip laws, Eq. 2 with and without the direct effect (its
        fits left out).
    figure : str
        The figure's PNG, relative to the output folder.
    caption : str
    """

    name: str
    law: str
    fit: StepFit
    comparison: ModelComparison
    figure: str
    caption: str

    def to_dict(self) -> dict[str, Any]:
        """JSON-safe mapping."""
        comparison = self.comparison.to_dict(include_arrays=False)
        comparison.pop("fits", None)
        return json_safe(
            {
                "name": self.name,
                "law": self.law,
                "fit": self.fit.to_dict(),
                "comparison": comparison,
                "figure": self.figure,
                "caption": self.caption,
            }
        )

    @classmethod
    def from_dict(cls, saved: Mapping[str, Any]) -> "VelocityStepRecord":
        """The record of :meth:`to_dict`."""
        return cls(
            name=str(saved["name"]),
            law=str(saved["law"]),
            fit=StepFit.from_dict(saved["fit"]),
            comparison=ModelComparison.from_dict(saved["comparison"]),
            figure=str(saved["figure"]),
            caption=str(saved.get("caption") or ""),
        )


@dataclass(frozen=True, eq=False)
class VelocitySteps(Value):
    """The velocity-step records of a campaign (``results.json``'s ``velocity_steps``).

    Attributes
    ----------
    records : tuple of VelocityStepRecord
    failed : tuple of mapping
        ``name``, ``source``, ``interval``, ``stage``, ``reason`` of each record that could
        not be read or fitted (as the campaign's failed runs).
    """

    records: tuple = ()
    failed: tuple = ()

    def __bool__(self) -> bool:
        return bool(self.records or self.failed)

    def summary_lines(self) -> list[str]:
        """One line per record for :meth:`granflow.AnalysisResult.summary`: a - b with its
        standard error, the law, the model best by AIC."""
        return [
            f"velocity steps {record.name}: a - b = "
            f"{format_value_error(record.fit.a_minus_b, record.fit.a_minus_b_stderr)} "
            f"({record.law} law), best by AIC: {record.comparison.best_aic}"
            for record in self.records
        ]

    def to_dict(self) -> dict[str, Any]:
        """Empty without records, else ``{"records", "failed"}``."""
        if not self:
            return {}
        return json_safe(
            {
                "records": [record.to_dict() for record in self.records],
                "failed": [dict(f) for f in self.failed],
            }
        )

    @classmethod
    def from_dict(cls, saved: Mapping[str, Any] | None) -> "VelocitySteps":
        """The records of :meth:`to_dict` (or of :func:`campaign_velocity_steps`)."""
        saved = saved or {}
        return cls(
            records=tuple(VelocityStepRecord.from_dict(r) for r in saved.get("records", ())),
            failed=tuple(FrozenMap(f) for f in saved.get("failed", ())),
        )
