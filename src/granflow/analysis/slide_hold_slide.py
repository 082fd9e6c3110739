"""Slide-hold-slide records in a campaign: healing, both laws' fits, their comparison, a figure.

The campaign side of the slide-hold-slide family (:mod:`granflow.families.slide_hold_slide`
declares it): :func:`analyse` takes the manifest's ``test: slide_hold_slide`` entries and, for
each record (:func:`granflow.rsf.read_slide_hold_slide`), measures its healing
(:func:`granflow.rsf.healing`), fits the rate-and-state aging and slip laws over its holds
(:func:`granflow.rsf.fit`), tables the comparison (AIC, BIC, RMS) and draws Δμ_peak against the
hold time with each law's curve and the paper's prediction
(:func:`granflow.plotting.healing.plot_healing`). It returns plain JSON-safe data;
:func:`section` turns that into the report's HTML section. A record that cannot be read fails
alone; a law that cannot be fitted is named in the record's ``problems`` and the rest shown.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

from granflow._html import Html, table, text
from granflow._json import json_safe
from granflow._typing import PathLike
from granflow.errors import GranflowError
from granflow.fitting.results import FrozenMap

__all__ = [
    "LAWS",
    "TEST_KIND",
    "SlideHoldSlide",
    "analyse",
    "campaign_slide_hold_slide",
    "record_body",
    "report_section",
    "slide_hold_slide_entries",
]

#: The manifest's ``test`` of a slide-hold-slide record.
TEST_KIND = "slide_hold_slide"
#: The rate-and-state laws fitted to every record.
LAWS = ("aging", "slip")


def _parameters(fit: Any) -> list[dict[str, Any]]:
    return [
        {
            "name": name,
            "value": fit.params[name],
            "stderr": fit.stderr[name],
            "ci95": list(fit.ci95[name]),
            "unit": fit.units[name],
            "held": name in fit.fixed,
        }
        for name in fit.names
    ]


def _comparison(fits: Mapping[str, Any]) -> dict[str, Any]:
    """Rows (law, free parameters, AIC, ΔAIC, BIC, residual RMS) and the best law by AIC."""
    if not fits:
        return {"rows": [], "best_aic": None}
    best = min(fits, key=lambda law: fits[law].aic)
    rows = [
        {
            "model": f"rsf_{law}",
            "nfree": fit.nfree,
            "aic": fit.aic,
            "delta_aic": fit.aic - fits[best].aic,
            "bic": fit.bic,
            "residual_rms": fit.residual_rms,
            "success": fit.success,
        }
        for law, fit in fits.items()
    ]
    return {"rows": rows, "best_aic": f"rsf_{best}"}


def _record(
    path: Path, name: str, figures: Path, index: int, step_times: Any, laws: Sequence[str]
) -> dict[str, Any]:
    """Everything :func:`analyse` keeps of one record."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from granflow import rsf
    from granflow.fitting.healing import model_healing
    from granflow.plotting.healing import plot_healing

    record = rsf.read_slide_hold_slide(path, step_times=step_times)
    measured = rsf.healing(record)
    fits, problems = {}, []
    for law in laws:
        try:
            fits[law] = rsf.fit(record, law=law, windows=record.windows)
        except GranflowError as exc:
            problems.append(f"the {law} law could not be fitted: {exc}")
    velocity = float(sum(record.velocities) / len(record.velocities))
    span = [10 ** (k / 8) for k in range(-8, 33)]  # 0.1 s .. 1e4 s
    span = [t for t in span if min(measured.hold_times) / 2 <= t <= 2 * max(measured.hold_times)]
    curves = {law: (span, model_healing(fit, span, velocity=velocity)) for law, fit in fits.items()}
    ax = plot_healing(measured, curves=curves)
    figures.mkdir(parents=True, exist_ok=True)
    png = f"slide_hold_slide_{index}.png"
    figure: Any = ax.figure
    figure.savefig(figures / png, dpi=100)
    plt.close(figure)
    low, high = measured.beta_ci95
    return {
        "name": name,
        "healing": measured.to_dict(),
        "fits": {law: _parameters(fit) for law, fit in fits.items()},
        "comparison": _comparison(fits),
        "curves": {law: [list(c[0]), [float(v) for v in c[1]]] for law, c in curves.items()},
        "figure": f"{figures.name}/{png}",
        "caption": (
            f"{len(measured.hold_times)} holds of {min(measured.hold_times):.3g} to "
            f"{max(measured.hold_times):.3g} s; β = {measured.beta:.3g} per decade "
            f"(95 %: {low:.3g} .. {high:.3g})"
        ),
        "problems": problems,
    }


def analyse(
    entries: Iterable[Mapping[str, Any]],
    output: PathLike,
    *,
    folder: PathLike | None = None,
    figures_dir: str = "figures",
    laws: Sequence[str] = LAWS,
) -> dict[str, Any]:
    """Analyse a campaign's slide-hold-slide records.

    Parameters
    ----------
    entries : iterable of mapping
        The manifest's ``test: slide_hold_slide`` entries: ``file`` (relative to ``folder``)
        and optionally ``step_times`` (each hold's start and end [s]).
    output : path-like
        The analysis's output folder; the figures go to ``output/figures_dir``.
    folder : path-like, optional
        The manifest's folder (default: the current one).
    figures_dir : str
        The figures' folder, relative to ``output``.
    laws : sequence of str
        The rate-and-state laws fitted to each record (default aging and slip; none: the
        healing alone).

    Returns
    -------
    dict
        Empty without entries; otherwise ``records`` (per record: ``name``, ``healing`` (a
        :class:`~granflow.rsf.HealingResult` as a dict), ``fits`` (per law, its parameter
        table), ``comparison`` (``rows``, ``best_aic``), ``curves`` (per law, hold times [s]
        and Δμ_peak), ``figure`` (the PNG relative to ``output``), ``caption``, ``problems``)
        and ``failed`` (``name``, ``source``, ``stage``, ``reason``).
    """
    entries = list(entries)
    if not entries:
        return {}
    base = Path(folder) if folder is not None else Path()
    figures = Path(output) / figures_dir
    records, failed = [], []
    for index, entry in enumerate(entries, start=1):
        name = str(entry["file"])
        try:
            records.append(
                _record(base / name, name, figures, index, entry.get("step_times"), laws)
            )
        except Exception as exc:  # any error: the record fails alone, named
            failed.append(
                {
                    "name": name,
                    "source": name,
                    "interval": None,
                    "stage": TEST_KIND,
                    "reason": f"{type(exc).__name__}: {exc}",
                }
            )
    return json_safe({"records": records, "failed": failed})


def _number(value: Any, digits: int = 4) -> str:
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return "–"
    return f"{value:.{digits}g}"


def _parameter_row(p: Mapping[str, Any]) -> tuple[str, ...]:
    """A parameter's row: value, standard error, 95 % interval and unit, lengths in µm; a
    held parameter (the trend of each window, when not fitted) says so."""
    scale, unit = (1e6, "µm") if p["unit"] == "m" else (1.0, p["unit"] or "–")
    if p.get("held"):
        return (p["name"], f"{_number(p['value'] * scale, 5)} (held)", "–", "–", unit)
    low, high = (v * scale for v in p["ci95"])
    return (
        p["name"],
        _number(p["value"] * scale, 5),
        _number(p["stderr"] * scale, 2),
        f"{_number(low, 5)} .. {_number(high, 5)}",
        unit,
    )


def record_body(record: Mapping[str, Any]) -> Html:
    """The HTML of one record of :func:`analyse` below its figure: the holds (t_h,
    Δμ_peak), β with its interval and the paper's prediction, the comparison of the laws and
    each law's parameters, the record's problems."""
    h = record["healing"]
    low, high = h["beta_ci95"]
    parts = [
        table(
            [
                (_number(t, 4), _number(d, 4))
                for t, d in zip(h["hold_times"], h["delta_mu_peak"], strict=True)
            ],
            header=("hold time [s]", "Δμ_peak [–]"),
        ),
        Html(
            f"<p>β = {text(_number(h['beta']))} per decade of hold time "
            f"(95 %: {text(_number(low))} .. {text(_number(high))}; {text(h['method'])}). "
            f"The paper's time clock, Δμ_peak = μ_a ln(1 + t_h/t_s), fitted: μ_a = "
            f"{text(_number(h['paper_mu_a']))}, the sample's age at the record's start "
            f"{text(_number(h['paper_age']))} s.</p>"
        ),
    ]
    rows = record["comparison"]["rows"]
    if rows:
        parts.append(
            table(
                [
                    (
                        r["model"],
                        r["nfree"],
                        _number(r["aic"], 6),
                        _number(r["delta_aic"], 4),
                        _number(r["bic"], 6),
                        _number(r["residual_rms"], 3),
                    )
                    for r in rows
                ],
                header=("model", "free", "AIC", "ΔAIC", "BIC", "RMS [–]"),
            )
        )
    for law, parameters in record["fits"].items():
        parts.append(Html(f"<h4>{text(law)} law</h4>"))
        parts.append(
            table(
                [_parameter_row(p) for p in parameters],
                header=("parameter", "value", "stderr", "95 % interval", "unit"),
            )
        )
    parts += [Html(f"<p>{text(p)}</p>") for p in record["problems"]]
    return Html("\n".join(parts))


# --------------------------------------------------------------------------- the seam's shapes


def slide_hold_slide_entries(
    manifest: PathLike | None, allow_outside: bool = False
) -> list[dict[str, Any]]:
    """The manifest's slide-hold-slide records (``test: slide_hold_slide``), in manifest order:
    ``file`` (relative to the manifest's folder). None (a Campaign): none."""
    if manifest is None:
        return []
    from granflow.io.manifest import BadEntry, read_manifest

    return [
        {"file": str(entry["file"])}
        for entry in read_manifest(manifest, errors="collect", allow_outside=allow_outside)
        if not isinstance(entry, BadEntry) and entry.get("test") == TEST_KIND
    ]


def campaign_slide_hold_slide(
    manifest: PathLike | None,
    output: PathLike,
    figures_dir: str = "figures",
    allow_outside: bool = False,
) -> dict[str, Any]:
    """:func:`analyse` of the records a campaign's manifest names
    (:func:`slide_hold_slide_entries`), one after the other in this process."""
    entries = slide_hold_slide_entries(manifest, allow_outside)
    if not entries:
        return {}
    folder = Path(manifest).parent  # type: ignore[arg-type]
    return analyse(entries, output, folder=folder, figures_dir=figures_dir)


class SlideHoldSlide:
    """The slide-hold-slide records of a campaign, as :func:`analyse` returned them.

    Attributes
    ----------
    records : tuple of mapping
        Per record: ``name``, ``healing``, ``fits``, ``comparison``, ``curves``, ``figure``,
        ``caption``, ``problems`` (see :func:`analyse`).
    failed : tuple of mapping
        ``name``, ``source``, ``interval``, ``stage``, ``reason`` of each record that failed.
    """

    __slots__ = ("failed", "records")

    def __init__(self, records: Iterable[Any] = (), failed: Iterable[Any] = ()) -> None:
        self.records = tuple(FrozenMap(r) for r in records)
        self.failed = tuple(FrozenMap(f) for f in failed)

    def __bool__(self) -> bool:
        return bool(self.records or self.failed)

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, SlideHoldSlide):
            return NotImplemented
        return self.to_dict() == other.to_dict()

    __hash__ = None  # type: ignore[assignment]

    def summary_lines(self) -> list[str]:
        """One line per record for :meth:`granflow.AnalysisResult.summary`: the healing rate
        with its interval, the law best by AIC."""
        lines = []
        for record in self.records:
            healing = record["healing"]
            low, high = healing["beta_ci95"]
            best = record["comparison"].get("best_aic") or "none fitted"
            lines.append(
                f"slide-hold-slide {record['name']}: beta = {_number(healing['beta'])} per "
                f"decade of hold time (95 %: {_number(low)} .. {_number(high)}), best by AIC: "
                f"{best}"
            )
        return lines

    def __repr__(self) -> str:
        return f"SlideHoldSlide({len(self.records)} records, {len(self.failed)} failed)"

    def to_dict(self) -> dict[str, Any]:
        """Empty without records, else ``{"records", "failed"}`` (JSON-safe)."""
        if not self:
            return {}
        return json_safe(
            {
                "records": [_plain(r) for r in self.records],
                "failed": [_plain(f) for f in self.failed],
            }
        )

    @classmethod
    def from_dict(cls, saved: Mapping[str, Any] | None) -> SlideHoldSlide:
        """The records of :meth:`to_dict` (or of :func:`analyse`)."""
        saved = saved or {}
        return cls(saved.get("records", ()), saved.get("failed", ()))


def _plain(value: Any) -> Any:
    if isinstance(value, Mapping):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_plain(v) for v in value]
    return value


def report_section(
    result: SlideHoldSlide, figures: Callable[[list[dict[str, Any]]], list[dict[str, Any]]]
) -> dict[str, Any]:
    """The family's part of a campaign report (the seam's ``section``).

    Parameters
    ----------
    result : SlideHoldSlide
        The campaign's slide-hold-slide records.
    figures : callable
        ``figures(entries) -> views``: the report's embedding of figure entries (``name``,
        ``title``, ``caption``, ``png`` relative to the output folder).

    Returns
    -------
    dict
        ``id`` (the anchor), ``title``, ``template`` (``slide_hold_slide.html.j2``), ``view``
        (``records``: name, embedded figure, body; ``failed``: (name, reason) pairs) and
        ``summary`` (the verdict line, or None).
    """
    analysis = result.to_dict()
    entries = [
        {
            "name": f"slide-hold-slide-{index}",
            "title": f"{r['name']}: healing",
            "caption": r["caption"],
            "png": r["figure"],
        }
        for index, r in enumerate(analysis.get("records", ()), start=1)
    ]
    shown = {f["name"]: f for f in figures(entries)}
    records = [
        {
            "name": r["name"],
            "figure": shown.get(f"slide-hold-slide-{index}"),
            "body": record_body(r),
        }
        for index, r in enumerate(analysis.get("records", ()), start=1)
    ]
    failed = [(str(f.get("name")), str(f.get("reason"))) for f in analysis.get("failed", ())]
    betas = [
        f"{r['name']} β = {_number(r['healing']['beta'], 3)}/decade"
        for r in analysis.get("records", ())
    ]
    summary = None
    if records or failed:
        summary = (
            "warn" if failed else "ok",
            f"Slide-hold-slide ({len(records)} record{'s' if len(records) != 1 else ''}): "
            + ("; ".join(betas) if betas else "none analysed")
            + (f"; {len(failed)} failed" if failed else "")
            + ".",
            "#slide-hold-slide",
        )
    return {
        "id": "slide-hold-slide",
        "title": "Slide-hold-slide healing",
        "template": "slide_hold_slide.html.j2",
        "view": {"records": records, "failed": failed},
        "summary": summary,
    }
