"""The slide-hold-slide family in a campaign: its FAMILY declaration, analysis, report section
and figure (records from the independent solver of ``tests/rsf/shs_radau.py``)."""

import importlib
import json
import sys
from pathlib import Path

import numpy as np
import pytest

from granflow import families
from granflow.analysis import slide_hold_slide as family_analysis
from granflow.families.slide_hold_slide import FAMILY

sys.path.insert(0, str(Path(__file__).parents[1] / "rsf"))
import shs_radau


def _write(folder, name="shs.txt"):
    t, x, mu, _ = shs_radau.record("aging")
    (folder / name).write_text(shs_radau.table(t, x, mu), encoding="utf-8")
    return name


def test_the_family_declares_its_test_kind_and_callables_that_resolve():
    assert FAMILY.test_kind == family_analysis.TEST_KIND == "slide_hold_slide"
    references = [FAMILY.entries, FAMILY.analyse, FAMILY.results, FAMILY.section]
    for reference in [*references, *FAMILY.result_types]:
        module, _, name = reference.partition(":")
        assert callable(getattr(importlib.import_module(module), name)), reference
    assert FAMILY in families.record_families()  # found without a generic module naming it


def test_the_manifest_names_the_familys_records(tmp_path):
    name = _write(tmp_path)
    manifest = tmp_path / "manifest.yaml"
    manifest.write_text(f"runs:\n  - file: {name}\n    test: slide_hold_slide\n")
    entries = family_analysis.slide_hold_slide_entries(manifest)
    assert entries == [{"file": name}]  # (analysing it fits both laws: the study's job)


def test_the_results_class_and_the_report_section_of_an_analysis(tmp_path):
    name = _write(tmp_path)
    analysis = family_analysis.analyse([{"file": name}], tmp_path / "out", folder=tmp_path, laws=())
    result = family_analysis.SlideHoldSlide.from_dict(json.loads(json.dumps(analysis)))
    assert result and result == family_analysis.SlideHoldSlide.from_dict(result.to_dict())
    assert not family_analysis.SlideHoldSlide.from_dict({})
    asked = []

    def embedded(entries):
        asked.extend(entries)
        return [{**entry, "src": "data:image/png;base64,"} for entry in entries]

    part = family_analysis.report_section(result, embedded)
    assert part["id"] == "slide-hold-slide" and part["template"] == "slide_hold_slide.html.j2"
    assert asked[0]["png"] == analysis["records"][0]["figure"]
    (record,) = part["view"]["records"]
    assert record["figure"]["name"] == "slide-hold-slide-1"
    assert "β = " in record["body"] and "hold time [s]" in record["body"]
    status, line, link = part["summary"]
    assert status == "ok" and line.startswith("Slide-hold-slide (1 record): ") and "β" in line
    assert link == "#slide-hold-slide"


def test_analyse_measures_healing_draws_it_and_fails_a_bad_record_alone(tmp_path):
    name = _write(tmp_path)
    (tmp_path / "broken.txt").write_text("Time(s)\tDispl(microns)\tFriction\n1\t2\t3\n")
    entries = [{"file": name, "test": "slide_hold_slide"}, {"file": "broken.txt"}]
    result = family_analysis.analyse(entries, tmp_path / "out", folder=tmp_path, laws=())
    (record,) = result["records"]
    assert record["name"] == name
    assert len(record["healing"]["hold_times"]) == len(shs_radau.HOLDS)
    assert (tmp_path / "out" / record["figure"]).stat().st_size > 10_000
    (failed,) = result["failed"]
    assert failed["name"] == "broken.txt" and "at least 10 rows" in failed["reason"]
    html = family_analysis.record_body(record)
    assert html.count("<tr>") >= len(shs_radau.HOLDS) + 1
    part = family_analysis.report_section(
        family_analysis.SlideHoldSlide.from_dict(result), lambda entries: entries
    )
    assert part["view"]["failed"] == [("broken.txt", failed["reason"])]
    assert part["summary"][0] == "warn" and "1 failed" in part["summary"][1]
    assert family_analysis.analyse([], tmp_path) == {}


def test_the_section_tables_the_comparison_of_the_laws():
    healing = {
        "hold_times": [1.0, 10.0],
        "delta_mu_peak": [0.01, 0.03],
        "beta_ci95": [0.01, 0.03],
        "beta": 0.02,
        "paper_mu_a": 0.05,
        "paper_age": 100.0,
        "method": "least squares",
    }
    rows = [
        {
            "model": "rsf_aging",
            "nfree": 12,
            "aic": -100.0,
            "delta_aic": 0.0,
            "bic": -50.0,
            "residual_rms": 3e-4,
        },
        {
            "model": "rsf_slip",
            "nfree": 12,
            "aic": 900.0,
            "delta_aic": 1000.0,
            "bic": 950.0,
            "residual_rms": 4e-3,
        },
    ]
    parameter = {"name": "a", "value": 0.01, "stderr": 1e-4, "ci95": [0.0098, 0.0102], "unit": ""}
    length = {"name": "Dc", "value": 5e-6, "stderr": 1e-8, "ci95": [4.98e-6, 5.02e-6], "unit": "m"}
    trend = {"name": "slope_1", "value": 0.0, "stderr": 0.0, "ci95": [0, 0], "unit": "1/m"}
    trend["held"] = True
    analysis = {
        "records": [
            {
                "name": "r.txt",
                "healing": healing,
                "figure": "figures/x.png",
                "caption": "c",
                "comparison": {"rows": rows, "best_aic": "rsf_aging"},
                "fits": {"aging": [parameter, length, trend]},
                "problems": ["the slip law could not be fitted"],
            }
        ]
    }
    html = family_analysis.record_body(analysis["records"][0])
    assert "rsf_slip" in html and "1000" in html and "0.0098 .. 0.0102" in html
    assert "4.98 .. 5.02" in html and "µm" in html  # lengths in µm
    assert "<td>slope_1</td><td>0 (held)</td><td>–</td><td>–</td>" in html
    assert "the slip law could not be fitted" in html


def test_the_healing_figure_has_a_log_time_axis_units_and_each_curve():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from granflow import rsf
    from granflow.plotting.healing import plot_healing

    t, x, mu, _ = shs_radau.record("aging")
    result = rsf.healing(rsf.parse_slide_hold_slide(shs_radau.table(t, x, mu)))
    span = np.geomspace(1.0, 100.0, 5)
    ax = plot_healing(
        result, curves={"aging": (span, 0.02 * np.log10(span)), "slip": (span, 0 * span)}
    )
    try:
        assert ax.get_xscale() == "log"
        assert "[s]" in ax.get_xlabel() and "$" in ax.get_ylabel()
        labels = [line.get_label() for line in ax.get_lines()]
        assert "rate-and-state, aging law" in labels and "rate-and-state, slip law" in labels
        assert any(label.startswith("paper") for label in labels)
        measured = ax.get_lines()[0]
        assert np.allclose(measured.get_ydata(), result.delta_mu_peak)
    finally:
        plt.close(ax.figure)
    with pytest.raises(Exception, match="Axes"):
        plot_healing(result, ax="not axes")
