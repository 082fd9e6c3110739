"""The result of a campaign analysis: :class:`AnalysisResult` and its :class:`RunEntry` rows.

``AnalysisResult.to_dict()`` is ``results.json`` without its ``timing`` entry, and
``AnalysisResult.from_dict`` inverts it; every part is a frozen value of
:mod:`granflow.analysis.run_results` or :mod:`granflow.analysis.joint_results`.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from granflow._format import (
    DASH,
    format_interval,
    format_number,
    format_value_error,
    real_number,
)
from granflow._json import json_safe
from granflow.analysis.forecasts import RunForecast
from granflow.analysis.joint_results import MATERIAL_CONSTANTS, Analyses, Material
from granflow.analysis.prediction_results import Predictions
from granflow.analysis.run_results import FailedRun, run_result_from_dict
from granflow.analysis.values import Value, frozen_json
from granflow.families import record_families, resolve
from granflow.fitting.results import FrozenMap
from granflow.model.units import display_unit, to_display

if TYPE_CHECKING:
    from granflow._typing import PathLike

__all__ = ["AnalysisResult", "RunEntry"]

_DESCRIPTION = (
    "index",
    "name",
    "source",
    "interval",
    "test",
    "control",
    "normal_load",
    "velocity",
    "preparation",
    "points",
)


@dataclass(frozen=True, eq=False)
class RunEntry(Value):
    """One run of the campaign (or one file that could not be read), in manifest order.

    Attributes
    ----------
    index : int
        Position in the manifest's order.
    name, source : str or None
        The run's name and its file (relative to the manifest's folder).
    interval : int or None
        The interval of the file.
    test : {"startup", "creep", "ramp", "switch"} or None
        None for a file that could not be read.
    control : {"rate", "stress"} or None
    normal_load : float or None
        [N]
    velocity : float or None
        The imposed velocity [m/s].
    preparation : str or None
    points : int
    result : StartupResult, CreepResult, RampResult, SwitchResult or FailedRun
    key : str or None
        The name of its saved result in ``runs/`` (None when it was not saved).
    stage : {"read", "analysis", "quality"} or None
        Where a failed run failed ("quality": a data-quality problem, under ``strict``).
    problems : tuple of str
        Its data-quality problems, one sentence each, empty when clean: the reader's (a
        truncated block, non-finite cells, ...), the points its fit left out and why, the
        manifest entry's own error.
    geometry : str or None
        The tube its torque and angle were converted with (``"paper (default)"`` when the
        manifest declares none; None for a run given as data).
    run : granflow.Run or None
        The data (not in ``to_dict``; None when rebuilt from JSON).
    """

    index: int
    name: str
    source: str | None
    interval: int | None
    test: str | None
    control: str | None
    normal_load: float | None
    velocity: float | None
    preparation: object
    points: int
    result: Any
    key: str | None = None
    stage: str | None = None
    problems: tuple = ()
    geometry: str | None = None
    run: object = field(default=None, repr=False)

    @property
    def ok(self) -> bool:
        """Whether the run was analysed."""
        return not isinstance(self.result, FailedRun)

    @property
    def reason(self) -> str | None:
        """Why the run failed (None when it did not)."""
        return None if self.ok else self.result.reason

    def to_dict(self) -> dict[str, Any]:
        """The run's entry in ``results["runs"]``."""
        out = {name: getattr(self, name) for name in _DESCRIPTION}
        if self.key is not None:
            out["key"] = self.key
        out.update({k: v for k, v in self.result.to_dict().items() if k != "warnings"})
        if self.stage is not None:
            out["stage"] = self.stage
        out["problems"] = list(self.problems)
        out["geometry"] = self.geometry
        return json_safe(out)

    def failure(self) -> dict[str, Any] | None:
        """The run's entry in ``results["failed_runs"]`` (None when it did not fail)."""
        if self.ok:
            return None
        return {
            "name": self.name,
            "source": self.source,
            "interval": self.interval,
            "stage": self.stage,
            "reason": self.reason,
        }

    @property
    def flagged(self) -> bool:
        """Whether the run has data-quality problems."""
        return bool(self.problems)

    @classmethod
    def from_dict(cls, saved: Mapping[str, Any]) -> RunEntry:
        """The entry of :meth:`to_dict`."""
        own = (*_DESCRIPTION, "key", "stage", "problems", "geometry")
        rest = {k: v for k, v in saved.items() if k not in own}
        return cls(
            **{name: saved[name] for name in _DESCRIPTION},
            result=run_result_from_dict(saved["test"], rest),
            key=saved.get("key"),
            stage=saved.get("stage"),
            problems=tuple(saved.get("problems", ())),
            geometry=saved.get("geometry"),
        )


@dataclass(frozen=True, eq=False)
class AnalysisResult(Value):
    """What :func:`granflow.analyze` found and wrote (SI units).

    ``to_dict()`` is the content of ``results.json`` apart from ``timing``;
    ``AnalysisResult.from_dict(result.to_dict())`` rebuilds an equal result (equality
    compares ``to_dict()``). It holds every fitting result in its compact form
    (``to_dict(include_arrays=False)``: no per-point arrays, no posterior chain); each run's
    complete result is in ``runs/<key>.json``.

    Attributes
    ----------
    granflow_version : str
    synthetic : bool
        Whether the campaign is synthetic (a banner in the report).
    campaign : mapping
        Manifest, counts (runs, tests, loads, velocities, preparations), problems reading
        it, and the synthetic truth where there is one.
    runs : tuple of RunEntry
        In manifest order.
    material : Material
        The material constants (reads as ``results.json``'s mapping too).
    analyses : Analyses
    predictions : Predictions
    forecasts : tuple of RunForecast
        The retrospective running forecast of each stress ramp (or staircase): the failure
        time forecast at a few cut times before the observed failure.
    warnings : tuple of str
    figures : tuple of mapping
        ``name``, ``title``, ``caption``, ``png``, ``svg`` (paths relative to ``output``).
    tables : mapping
        Table name to its files (relative to ``output``).
    provenance : mapping
        Version, Python, input files with their SHA-256, options.
    record_analyses : mapping of str to object
        The analyses of the record families (:mod:`granflow.families`) by their manifest
        ``test`` kind, each an object of the family's ``results`` class (``records`` and
        ``failed``); ``results.json`` holds each under that key (``velocity_steps``: the
        rate-and-state fits and model comparisons of the velocity-step records), empty
        without records. Their failures are among :attr:`failed_runs`. Each is also an
        attribute of its key: ``result.velocity_steps``.
    timing : mapping
        Dates, durations, jobs, scheduler, runs fitted now or reused (not in ``to_dict``).
    output : pathlib.Path or None
        The output folder.
    fitted_now, reused : int
        Runs analysed in this call, and saved results reused.
    report : pathlib.Path or None
        The HTML report.
    """

    granflow_version: str
    synthetic: bool
    campaign: FrozenMap
    runs: tuple
    material: Material
    analyses: Analyses
    predictions: Predictions
    forecasts: tuple = ()
    warnings: tuple = ()
    figures: tuple = ()
    tables: FrozenMap = field(default_factory=FrozenMap)
    provenance: FrozenMap = field(default_factory=FrozenMap)
    record_analyses: FrozenMap = field(default_factory=FrozenMap)
    timing: FrozenMap = field(default_factory=FrozenMap, repr=False)
    output: Path | None = None
    fitted_now: int = 0
    reused: int = 0
    report: Path | None = None

    def __getattr__(self, name: str) -> Any:
        """A record family's analysis by its ``test`` kind (``result.velocity_steps``): the
        stored one, or the family's empty one."""
        if not name.startswith("_"):
            stored = self.__dict__.get("record_analyses", {})
            if name in stored:
                return stored[name]
            for family in record_families():
                if family.test_kind == name and family.results is not None:
                    return resolve(family.results).from_dict(None)
        raise AttributeError(f"{type(self).__name__!r} object has no attribute {name!r}")

    def __repr__(self):
        output = None if self.output is None else str(self.output)
        return (
            f"AnalysisResult({len(self.runs)} runs, {len(self.failed_runs)} failed, "
            f"output={output!r})"
        )

    def to_dict(self) -> dict[str, Any]:
        """The content of ``results.json`` apart from ``timing`` (JSON-safe)."""
        return json_safe(
            {
                "granflow_version": self.granflow_version,
                "synthetic": self.synthetic,
                "campaign": self.campaign,
                "runs": [entry.to_dict() for entry in self.runs],
                "failed_runs": self.failed_runs,
                "material": self.material.to_dict(),
                "analyses": self.analyses.to_dict(),
                "predictions": self.predictions.to_dict(),
                "forecasts": [forecast.to_dict() for forecast in self.forecasts],
                "warnings": list(self.warnings),
                "figures": list(self.figures),
                "tables": self.tables,
                "provenance": self.provenance,
                **{kind: part.to_dict() for kind, part in _record_parts(self.record_analyses)},
            }
        )

    @classmethod
    def from_dict(
        cls, saved: Mapping[str, Any], *, output: PathLike | None = None
    ) -> AnalysisResult:
        """The result of :meth:`to_dict` (or of ``results.json``, its ``timing`` kept).

        Parameters
        ----------
        saved : mapping
        output : str or pathlib.Path, optional
            The folder it was written to.
        """
        return cls(
            granflow_version=saved["granflow_version"],
            synthetic=bool(saved["synthetic"]),
            campaign=frozen_json(saved["campaign"], tuple),
            runs=tuple(RunEntry.from_dict(entry) for entry in saved["runs"]),
            material=Material.from_dict(saved["material"]),
            analyses=Analyses.from_dict(saved["analyses"]),
            predictions=Predictions.from_dict(saved["predictions"]),
            forecasts=tuple(RunForecast.from_dict(f) for f in saved.get("forecasts", ())),
            warnings=tuple(saved["warnings"]),
            figures=frozen_json(saved["figures"], tuple),
            tables=frozen_json(saved["tables"], tuple),
            provenance=frozen_json(saved["provenance"], tuple),
            record_analyses=record_analyses(saved),
            timing=frozen_json(saved.get("timing", {}), tuple),
            output=None if output is None else Path(output),
        )

    @functools.cached_property
    def results(self) -> dict[str, Any]:
        """The content of ``results.json``: :meth:`to_dict` plus ``timing``."""
        return {**self.to_dict(), "timing": json_safe(self.timing)}

    @property
    def failed_runs(self) -> list[dict[str, Any]]:
        """The runs that could not be analysed: ``name``, ``source``, ``interval``, ``stage``,
        ``reason``."""
        failed = [entry.failure() for entry in self.runs if not entry.ok]
        for _, part in _record_parts(self.record_analyses):
            failed += [dict(f) for f in part.failed]
        return failed

    @property
    def exit_code(self) -> int:
        """0 when every run and every joint analysis succeeded, 1 when some failed (the
        command's exit code)."""
        return 1 if self.failed_runs or self.analyses.errors else 0

    def summary(self) -> str:
        """A one-screen summary: counts, material constants with intervals, predictions,
        failed runs, and where the output and the report are (display units)."""
        counts = self.campaign["counts"]
        lines = [
            f"campaign: {counts['runs']} runs"
            + (" (synthetic data)" if self.synthetic else "")
            + f", {counts['analysed']} analysed, {counts['failed']} failed "
            f"({self.fitted_now} analysed now, {self.reused} reused)"
        ]
        lines += _material_lines(self.material)
        truth = self.campaign.get("truth")
        if truth:
            inside = ", ".join(
                f"{name} {'inside' if ok else 'OUTSIDE'}" for name, ok in truth["contained"].items()
            )
            lines.append(f"  synthetic truth: {inside} the 95 % intervals")
        lines += _prediction_lines(self.predictions, self.analyses)
        lines += [forecast.summary() for forecast in self.forecasts]
        for _, part in _record_parts(self.record_analyses):
            lines += part.summary_lines()
        for name, reason in self.analyses.errors.items():
            lines.append(f"joint analysis failed: {name.replace('_', ' ')}: {reason}")
        lines += _quality_lines(self.runs, self.campaign)
        if self.warnings:
            lines.append(f"warnings: {len(self.warnings)} (see results.json or the report)")
        failed = self.failed_runs
        if failed:
            lines.append(f"failed runs ({len(failed)}):")
            lines += [f"  {entry['name']}: {entry['reason']}" for entry in failed[:10]]
            if len(failed) > 10:
                lines.append(f"  ... and {len(failed) - 10} more in results.json")
        if self.output is not None:
            lines.append(f"output: {self.output.resolve()}")
        if self.report is not None:
            lines.append(f"report: {self.report.resolve()}")
        return "\n".join(lines)

    def _repr_html_(self) -> str:
        """The summary as HTML (Jupyter): the material constants, what the campaign shows,
        and every run in a table that opens on a click."""
        from granflow._html import Html, heading, result_html, table, text

        counts = self.campaign["counts"]
        title = (
            f"AnalysisResult: {counts['runs']} runs"
            + (" (synthetic data)" if self.synthetic else "")
            + f", {counts['analysed']} analysed, {counts['failed']} failed"
        )
        parts = [Html(self.material._repr_html_())]
        findings = _prediction_lines(self.predictions, self.analyses)
        findings += [forecast.summary() for forecast in self.forecasts]
        findings += [
            f"joint analysis failed: {name.replace('_', ' ')}: {reason}"
            for name, reason in self.analyses.errors.items()
        ]
        findings += _quality_lines(self.runs, self.campaign)
        if self.warnings:
            findings.append(f"warnings: {len(self.warnings)} (see results.json or the report)")
        if findings:
            items = "".join(f"<li>{text(line.strip())}</li>" for line in findings)
            parts += [heading("Findings"), Html(f"<ul>{items}</ul>")]
        rows = [
            (
                entry.name,
                entry.test or "—",
                _number(_millinewton(entry.normal_load)),
                _number(None if entry.velocity is None else entry.velocity * 1e6),
                "ok" if entry.ok else f"failed ({entry.stage}): {entry.reason}",
                "; ".join(entry.problems),
            )
            for entry in self.runs
        ]
        header = ("run", "test", "F_N [mN]", "V [µm/s]", "status", "data quality")
        runs = table(rows, header=header, numeric=(2, 3))
        parts.append(Html(f"<details><summary>Runs ({len(rows)})</summary>{runs}</details>"))
        if self.output is not None:
            where = self.report if self.report is not None else self.output
            parts.append(Html(f"<p>output: <code>{text(where)}</code></p>"))
        return result_html(title, parts)


def record_analyses(saved: Mapping[str, Any]) -> FrozenMap:
    """The analyses of the record families in ``saved`` (a ``results.json``, or what the
    families' ``analyse`` returned, by ``test`` kind): each read by its family's ``results``
    class, those that hold anything."""
    parts = {}
    for family in record_families():
        if family.results is None or family.test_kind is None:
            continue
        part = resolve(family.results).from_dict(saved.get(family.test_kind))
        if part:
            parts[family.test_kind] = part
    return FrozenMap(parts)


def _record_parts(stored):
    """(kind, analysis) of every record family, in the families' order: the stored one or
    the family's empty one (so ``results.json`` always has its key)."""
    for family in record_families():
        if family.results is None or family.test_kind is None:
            continue
        part = stored.get(family.test_kind)
        if part is None:
            part = resolve(family.results).from_dict(None)
        yield family.test_kind, part


def _number(value, significant=4):
    """``value`` with ``significant`` digits, "n/a" for None or NaN (never a crash)."""
    text = format_number(value, significant=significant)
    return "n/a" if text == DASH else text


def _value_error(value, error, scale=1.0):
    """``value ± error`` with the digits the error justifies (:mod:`granflow._format`);
    "n/a" for a missing value, "± n/a" after a value without an error."""
    if real_number(value) is None:
        return "n/a"
    if real_number(error) is None:
        return f"{format_number(value, scale)} ± n/a"
    return format_value_error(value, error, scale)


def _quality_lines(runs, campaign):
    """The runs with data-quality problems (at most ten named) and the geometry."""
    lines = [f"geometry: {campaign.get('geometry') or 'as given by the caller'}"]
    flagged = [entry for entry in runs if entry.problems]
    if flagged:
        plural = "s" if len(flagged) != 1 else ""
        lines.append(f"data quality: {len(flagged)} run{plural} with problems:")
        for entry in flagged[:10]:
            lines.append(f"  {entry.name}: {'; '.join(entry.problems)}")
        if len(flagged) > 10:
            lines.append(f"  ... and {len(flagged) - 10} more in results.json")
    return lines


def _material_lines(material):
    if not material.determined:
        return [f"material constants: not determined ({material.reason})"]
    lines = [f"material constants ({material.source}):"]
    for name in MATERIAL_CONSTANTS:
        estimate = getattr(material, name)
        unit = f" {display_unit(name)}" if display_unit(name) else ""
        interval = format_interval(list(estimate.ci95))  # digits enough for its two ends
        interval = "[n/a, n/a]" if interval == DASH else interval.replace(DASH, "n/a")
        lines.append(
            f"  {name:<5} = {_value_error(estimate.value, estimate.stderr)}{unit}   95%: {interval}"
        )
    return lines


_MILLI = to_display("force", 1.0)  # N -> mN


def _millinewton(value):
    return None if value is None else value * _MILLI


def _prediction_lines(predictions, analyses):
    lines = []
    rows = predictions.static_yield
    if rows:
        text = "; ".join(
            f"{_number(_millinewton(row.normal_load))} mN -> "
            f"{_value_error(row.F_peak, row.stderr, _MILLI)} mN"
            for row in rows[:6]
        )
        lines.append(f"static yield F_peak: {text}" + (" ..." if len(rows) > 6 else ""))
    for row in analyses.stress_ramp:
        if row.observed is not None and row.predicted_force is not None:
            errors = (row.F_peak_stderr, row.F_peak_spread)
            width = None if None in errors else math.hypot(*errors)
            lines.append(
                f"stress ramp {row.run}: failed at "
                f"{_number(_millinewton(row.observed.get('failure_force')))} mN, "
                f"predicted F_peak {_value_error(row.predicted_force, width, _MILLI)} mN"
                + (" (consistent)" if row.consistent else " (NOT consistent)")
            )
    for row in analyses.switch:
        if row.predicted is not None:
            lines.append(
                f"switch {row.run}: observed {row.observed['outcome']}, predicted "
                f"{row.predicted}" + (" (agree)" if row.agree else " (DISAGREE)")
            )
    return lines
