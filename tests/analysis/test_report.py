"""The HTML report: number filters, every section, escaping, missing sections, self-containment."""

import base64
import copy
import importlib.resources
import re
from html.parser import HTMLParser

import pytest
from report_example import CORRUPT, example_results

from granflow.analysis.report import (
    display_unit,
    format_interval,
    format_number,
    format_p_value,
    format_value_error,
    render_html,
    render_report,
)
from granflow.errors import InvalidParameterError


@pytest.fixture(scope="module")
def example(tmp_path_factory):
    directory = tmp_path_factory.mktemp("analysis")
    return directory, example_results(directory)


@pytest.fixture(scope="module")
def page(example):
    directory, results = example
    return render_html(results, directory)


class _Page(HTMLParser):
    """Tags, attributes and text of a page, and the text inside each element with an id."""

    def __init__(self, html):
        super().__init__()
        self.tags, self.text, self.stack = [], [], []
        self.by_id = {}
        self.feed(html)

    def handle_starttag(self, tag, attrs):
        attrs = dict(attrs)
        self.tags.append((tag, attrs))
        if tag not in ("img", "meta", "link", "br", "input"):
            self.stack.append((tag, attrs.get("id"), len(self.text)))

    def handle_endtag(self, tag):
        while self.stack:
            open_tag, element_id, start = self.stack.pop()
            if element_id:
                self.by_id[element_id] = " ".join(self.text[start:])
            if open_tag == tag:
                break

    def handle_data(self, data):
        if data.strip():
            self.text.append(data.strip())

    def section(self, element_id):
        return self.by_id[element_id]


def _minimal(**extra):
    """A results dict of a one-run campaign, with ``extra`` entries."""
    run = {
        "name": "only-run",
        "source": "a.csv",
        "test": "startup",
        "normal_load": 0.05,
        "velocity": 0.86e-6,
        "preparation": "p1",
        "status": "ok",
        "fit": {
            "params": {"a": 3.0e-3, "alpha": 4.2e4, "Fd": 1.0e-2, "x0": 2.0e-7},
            "stderr": {"a": 2.0e-5, "alpha": 300.0, "Fd": 1.0e-5, "x0": 4.0e-9},
            "at_bound": {"a": False, "alpha": False, "Fd": False, "x0": False},
            "success": True,
            "message": "converged",
            "redchi": 1.1,
            "sigma_known": True,
        },
    }
    return {"granflow_version": "0.1.0", "synthetic": False, "runs": [run], **extra}


# --------------------------------------------------------------------------- filters


@pytest.mark.parametrize(
    ("value", "error", "scale", "expected"),
    [
        (49251.89, 433.72, 1.0, "49250 ± 430"),
        (0.0017915, 7.58e-06, 1e3, "1.7915 ± 0.0076"),
        (0.059988, 4.4e-05, 1.0, "0.059988 ± 0.000044"),
        (3.3e-9, 1.26e-10, 1.0, "(3.30 ± 0.13)×10⁻⁹"),
        (6.02e23, 3.1e21, 1.0, "(6.020 ± 0.031)×10²³"),
        (12.0, 1.5, 1.0, "12.0 ± 1.5"),
        (-0.5, 0.0123, 1.0, "-0.500 ± 0.012"),
        (1e-6, 0.0123, 1.0, "0.000 ± 0.012"),
        (3.21, None, 1.0, "3.210"),
        (3.21, 0.0, 1.0, "3.210"),
        (3.21, float("nan"), 1.0, "3.210"),
        (None, 0.1, 1.0, "—"),
        (float("inf"), 0.1, 1.0, "—"),
    ],
)
def test_value_error_rounds_the_value_at_the_errors_last_digit(value, error, scale, expected):
    assert format_value_error(value, error, scale) == expected


@pytest.mark.parametrize(
    ("value", "scale", "significant", "expected"),
    [
        (0.0123456, 1e3, 4, "12.35"),
        (1.96752e-07, 1.0, 4, "1.968×10⁻⁷"),
        (123456.0, 1.0, 4, "1.235×10⁵"),
        (99999.0, 1.0, 4, "1.000×10⁵"),
        (9.99951, 1.0, 4, "10.00"),
        (0.001, 1.0, 3, "0.00100"),
        (0.0, 1.0, 4, "0"),
        (-2.5e-3, 1e3, 3, "-2.50"),
        (None, 1.0, 4, "—"),
        (float("nan"), 1.0, 4, "—"),
        ("12", 1.0, 4, "—"),
        (True, 1.0, 4, "—"),
    ],
)
def test_format_number(value, scale, significant, expected):
    assert format_number(value, scale, significant) == expected


@pytest.mark.parametrize(
    ("p", "expected"),
    [(0.2617, "0.26"), (0.04, "0.04"), (1.0, "1"), (6.2e-34, "6.2×10⁻³⁴"), (None, "—")],
)
def test_format_p_value(p, expected):
    assert format_p_value(p) == expected


def test_format_interval():
    assert format_interval([0.05990, 0.06007]) == "[0.05990, 0.06007]"
    assert format_interval([4.9733e4, 5.0057e4], 1e-6) == "[0.04973, 0.05006]"
    assert format_interval([None, 2.0]) == "[—, 2.000]"
    assert format_interval(None) == "—"


@pytest.mark.parametrize(
    ("name", "expected"),
    [
        ("a", (1e3, "mN")),
        ("failure_force", (1e3, "mN")),
        ("F_peak", (1e3, "mN")),
        ("x_peak", (1e6, "µm")),
        ("stop_slip", (1e6, "µm")),
        ("switch_time", (1.0, "s")),
        ("velocity", (1e6, "µm/s")),
        ("mu_a", (1.0, "")),
        ("outcome", (1.0, "")),
    ],
)
def test_display_units_by_name(name, expected):
    assert display_unit(name) == expected


# --------------------------------------------------------------------------- sections


def test_every_section_is_rendered(example, page):
    _, results = example
    parsed = _Page(page)
    for section in (
        "synthetic-banner",
        "failed-summary",
        "campaign",
        "material",
        "runs",
        "creep",
        "joint",
        "collapse",
        "amontons",
        "preparation",
        "model-comparison",
        "predictions",
        "static-yield",
        "stability-map",
        "ramp",
        "switch",
        "figures",
        "warnings",
        "failed-runs",
        "analysis-warnings",
        "provenance",
    ):
        assert section in parsed.by_id, section
    campaign = parsed.section("campaign")
    # 11 start-ups, one each of creep, ramp and switch; the corrupt file has no test
    assert "creep: 1; ramp: 1; startup: 11; switch: 1; unspecified: 1" in campaign
    assert "30.00, 60.00, 90.00" in campaign  # loads [mN]
    assert "0.8600, 2.000, 4.000" in campaign  # velocities [µm/s]
    runs = parsed.section("runs")
    for run in results["runs"]:
        assert run["name"] in runs
    collapse = parsed.section("collapse")
    verdict = (
        "not rejected" if results["analyses"]["velocity_collapse"]["collapses"] else "rejected"
    )
    assert verdict in collapse
    assert format_p_value(results["analyses"]["velocity_collapse"]["p_value"]) in collapse
    amontons = parsed.section("amontons")
    for load in ("30.00", "60.00", "90.00"):
        assert load in amontons
    assert "·F N" in amontons  # F<sub>N</sub>
    comparison = parsed.section("model-comparison")
    assert "log_aging" in comparison and "Best by AIC: eq3" in comparison
    outcomes = results["predictions"]["stability_map"]["outcome"]
    counts = {o: sum(row.count(o) for row in outcomes) for o in ("failure", "stop")}
    assert f"{counts['failure']} failure, {counts['stop']} stop" in parsed.section("stability-map")
    ramp = parsed.section("ramp")
    [row] = results["analyses"]["stress_ramp"]
    observed = row["observed"]["failure_force"]
    predicted = row["predicted"]["failure_force"]
    assert 0.01 < observed < 0.1 and 0.01 < predicted < 0.1  # so 4 digits are 2 decimals in mN
    assert f"{observed * 1e3:.2f}" in ramp and f"{predicted * 1e3:.2f}" in ramp
    # signed, observed − predicted, relative to the prediction (U+2212 for the minus)
    relative = f"({100 * (observed - predicted) / predicted:+.2g} %)".replace("-", "−")
    assert relative in ramp
    provenance = parsed.section("provenance")
    for entry in results["provenance"]["inputs"]:
        assert entry["file"] in provenance and entry["sha256"] in provenance
    assert results["timing"]["finished"] in provenance
    for figure in results["figures"]:
        assert figure["title"] in parsed.section("figures")
        assert figure["caption"] in parsed.section("figures")


def test_material_constants_in_display_units(tmp_path):
    material = {
        "mu_a": {"value": 0.06012, "stderr": 3.1e-4, "ci95": [0.0595, 0.0607]},
        "mu_d": {"value": 0.2003, "stderr": 2.2e-4, "ci95": [0.1999, 0.2007]},
        "alpha": {"value": 4.9895e4, "stderr": 83.0, "ci95": [4.9733e4, 5.0057e4]},
        "source": "amontons joint fit",
    }
    text = _Page(render_html(_minimal(material=material), tmp_path)).section("material")
    assert "0.06012 ± 0.00031" in text
    assert "0.20030 ± 0.00022" in text
    assert "49895 ± 83" in text and "1/m" in text
    assert "0.049895 ± 0.000083" in text and "1/µm" in text  # alpha in 1/µm
    assert "[0.04973, 0.05006]" in text
    assert "amontons joint fit" in text


def test_material_without_value_shows_its_reason(tmp_path):
    material = {
        "mu_a": {"value": None, "stderr": None, "ci95": None},
        "mu_d": {"value": None, "stderr": None, "ci95": None},
        "alpha": {"value": 4.2e4, "stderr": 300.0, "ci95": [4.14e4, 4.26e4]},
        "reason": "the campaign has a single normal load",
    }
    text = _Page(render_html(_minimal(material=material), tmp_path)).section("material")
    assert text.count("not determined: the campaign has a single normal load") == 2
    assert "42000 ± 300" in text


def test_run_table_converts_units_and_flags_bounds(tmp_path):
    results = _minimal()
    results["runs"][0]["fit"]["at_bound"]["x0"] = True
    parsed = _Page(render_html(results, tmp_path))
    runs = parsed.section("run-table")
    assert "3.000 ± 0.020" in runs  # a [mN]
    assert "42000 ± 300" in runs  # alpha [1/m]
    assert "10.000 ± 0.010" in runs  # Fd [mN]
    assert "0.2000 ± 0.0040" in runs  # x0 [µm]
    assert "50.00" in runs and "0.8600" in runs  # load [mN], velocity [µm/s]
    assert "1.10" in runs  # reduced chi-square with a known noise
    assert "x0" in parsed.section("at-bound") and "only-run" in parsed.section("at-bound")


def test_time_domain_fit_is_shown_in_slip(tmp_path):
    results = _minimal()
    results["runs"][0]["fit"]["params"] = {"a": 3.0e-3, "k": 0.036, "Fd": 1.0e-2, "t0": 0.25}
    results["runs"][0]["fit"]["stderr"] = {"a": 2e-5, "k": 0.0004, "Fd": 1e-5, "t0": 0.01}
    results["runs"][0]["velocity"] = 1.0e-6
    runs = _Page(render_html(results, tmp_path)).section("run-table")
    assert "36000 ± 400" in runs  # alpha = k / v
    assert "0.250 ± 0.010" in runs  # x0 = t0 v [µm]


def test_failed_runs_are_named_with_their_reason(example, page):
    _, results = example
    [failure] = results["failed_runs"]
    assert failure["source"] == CORRUPT
    parsed = _Page(page)
    assert failure["name"] in parsed.section("failed-summary")
    failed = parsed.section("failed-runs")
    assert failure["name"] in failed and failure["source"] in failed
    assert failure["reason"] in failed
    assert failure["reason"] in parsed.section("run-table")


def test_failed_run_only_in_the_runs_list_is_still_warned_about(tmp_path):
    results = _minimal()
    results["runs"].append(
        {"name": "broken", "source": "b.csv", "status": "failed", "reason": "no torque column"}
    )
    parsed = _Page(render_html(results, tmp_path))
    assert "startup: 1; unspecified: 1" in parsed.section("campaign")
    assert "no torque column" in parsed.section("failed-runs")
    assert "broken" in parsed.section("failed-summary")


def test_poor_convergence_is_warned_about(tmp_path):
    results = _minimal()
    results["runs"][0]["fit"]["success"] = False
    results["runs"][0]["fit"]["message"] = "maximum number of evaluations reached"
    text = _Page(render_html(results, tmp_path)).section("convergence")
    assert "only-run" in text and "maximum number of evaluations reached" in text


def test_no_warnings_says_so(tmp_path):
    text = _Page(render_html(_minimal(), tmp_path)).section("warnings")
    assert "No warnings" in text


def test_synthetic_banner_present_only_for_synthetic_data(tmp_path):
    synthetic = render_html({**_minimal(), "synthetic": True}, tmp_path)
    measured = render_html(_minimal(), tmp_path)
    assert "SYNTHETIC DATA" in _Page(synthetic).section("synthetic-banner")
    assert "<title>[SYNTHETIC DATA]" in synthetic
    assert "SYNTHETIC" not in measured.upper()
    assert "synthetic-banner" not in measured


def test_user_data_is_escaped(example):
    directory, results = example
    results = copy.deepcopy(results)
    evil = '<script>alert("run")</script>'
    results["runs"][0]["name"] = evil
    results["failed_runs"][0]["reason"] = "<img src=x onerror=alert(1)> & more"
    results["warnings"].append("</li><b>bold</b>")
    results["figures"][0]["title"] = '"><script>alert("figure")</script>'
    results["campaign"]["name"] = "<i>campaign</i>"
    html = render_html(results, directory)
    assert "<script" not in html
    assert "<img src=x" not in html and "<b>bold</b>" not in html and "<i>campaign" not in html
    assert "&lt;script&gt;alert(&#34;run&#34;)&lt;/script&gt;" in html
    assert "&lt;img src=x onerror=alert(1)&gt; &amp; more" in html
    parsed = _Page(html)
    assert evil in parsed.section("run-table")  # shown as text, not run


def test_missing_sections_render_gracefully(tmp_path):
    html = render_html(_minimal(), tmp_path)
    parsed = _Page(html)
    for absent in ("material", "joint", "amontons", "predictions", "figures", "creep"):
        assert absent not in parsed.by_id, absent
    assert "only-run" in parsed.section("run-table")
    assert render_html({}, tmp_path).count("No runs.") == 1


def test_single_load_campaign_has_no_amontons_section(tmp_path):
    analyses = {
        "velocity_collapse": None,
        "amontons": None,
        "preparation_spread": {"reason": "no repeats"},
        "model_comparison": None,
    }
    parsed = _Page(render_html(_minimal(analyses=analyses), tmp_path))
    assert "amontons" not in parsed.by_id and "collapse" not in parsed.by_id
    assert "Not available: no repeats" in parsed.section("preparation")


def test_labelled_results_are_listed_per_label(tmp_path):
    spread = {
        "domain": "slip",
        "repeats": 3,
        "start": {"mean": 3e-7, "std": 1e-7, "min": 2e-7, "max": 4e-7, "relative": 1 / 3},
        "Fd": {"mean": 0.012, "std": 1e-5, "min": 0.01199, "max": 0.01201, "relative": 8e-4},
        "peak_force": [0.0150, 0.0149],
        "correlation": -0.9,
        "p_value": 0.28,
    }
    analyses = {"preparation_spread": {"sieved": spread, "poured": {"reason": "one repeat"}}}
    text = _Page(render_html(_minimal(analyses=analyses), tmp_path)).section("preparation")
    assert "sieved" in text and "poured" in text and "one repeat" in text
    assert "0.300" in text and "33.3 %" in text  # x0 mean [µm], relative spread


def test_figures_are_embedded_as_data_uris(example, page):
    directory, results = example
    images = [attrs for tag, attrs in _Page(page).tags if tag == "img"]
    assert len(images) == len(results["figures"]) == 10
    assert {"fits", "fig2", "fig3"} <= {figure["name"] for figure in results["figures"]}
    for attrs, figure in zip(images, results["figures"], strict=True):
        prefix = "data:image/png;base64,"
        assert attrs["src"].startswith(prefix)
        assert (
            base64.b64decode(attrs["src"][len(prefix) :])
            == (directory / figure["png"]).read_bytes()
        )
        assert int(attrs["width"]) > 0 and int(attrs["height"]) > 0


def test_page_is_self_contained(page):
    parsed = _Page(page)
    assert not [attrs for tag, attrs in parsed.tags if tag == "script"]
    for tag, attrs in parsed.tags:
        for name in ("src", "href"):
            link = attrs.get(name)
            if link is None:
                continue
            if tag == "a":  # navigation inside the page, or the SVG beside it
                assert link.startswith("#") or re.fullmatch(r"figures/\w+\.svg", link), link
            else:
                assert link.startswith("data:"), (tag, link)
    assert "url(" not in page and "@import" not in page
    assert "http://" not in page and "https://" not in page


def test_missing_figure_file_is_reported_without_a_broken_image(example):
    directory, results = example
    results = copy.deepcopy(results)
    results["figures"].append({"name": "ghost", "title": "Ghost", "png": "figures/ghost.png"})
    (directory / "figures" / "fake.png").write_text("not a png", encoding="utf-8")
    results["figures"].append({"name": "fake", "title": "Fake", "png": "figures/fake.png"})
    parsed = _Page(render_html(results, directory))
    assert sum(tag == "img" for tag, _ in parsed.tags) == len(results["figures"]) - 2
    warnings = parsed.section("report-warnings")
    assert "figures/ghost.png" in warnings and "figures/fake.png is not a PNG file" in warnings


def test_render_report_writes_the_file(example, tmp_path):
    directory, results = example
    path = render_report(results, directory)
    assert path == directory / "report.html"
    assert path.read_text(encoding="utf-8") == render_html(results, directory)
    elsewhere = render_report(results, directory, path=tmp_path / "sub" / "r.html")
    assert elsewhere == tmp_path / "sub" / "r.html" and elsewhere.is_file()
    assert not list(tmp_path.glob("sub/.*.tmp"))
    # the SVG link is relative to where the report is
    assert 'href="../../' in elsewhere.read_text(encoding="utf-8")


def test_results_must_be_a_mapping(tmp_path):
    with pytest.raises(InvalidParameterError, match="results must be a mapping"):
        render_report([1, 2], tmp_path)


def test_template_is_package_data():
    template = importlib.resources.files("granflow.analysis") / "templates" / "report.html.j2"
    assert template.is_file()
    text = template.read_text(encoding="utf-8")
    assert "|safe" not in text.replace(" ", "") and "autoescape" not in text  # escaping stays on
