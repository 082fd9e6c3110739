"""The HTML report, rendered from the typed AnalysisResult: number filters, every section in
the contents' order with its figure, units, escaping, missing sections, self-containment."""

import base64
import dataclasses
import importlib.resources
import json
import re
from html.parser import HTMLParser

import numpy as np
import pytest
from report_example import CORRUPT, example_result

import granflow as gf
from granflow.analysis.formatting import (
    display_scale,
    format_interval,
    format_number,
    format_p_value,
    format_value_error,
)
from granflow.analysis.report import render_html, render_report
from granflow.analysis.report_views import SECTIONS
from granflow.errors import InvalidParameterError


@pytest.fixture(scope="module")
def example(tmp_path_factory):
    directory = tmp_path_factory.mktemp("analysis")
    return directory, example_result(directory)


@pytest.fixture(scope="module")
def page(example):
    directory, result = example
    return render_html(result, directory)


@pytest.fixture(scope="module")
def single(tmp_path_factory):
    """A campaign of one start-up, analysed (no joint analysis, no prediction)."""
    directory = tmp_path_factory.mktemp("single")
    params = gf.Params(3.0e-3, 4.2e4, 1.0e-2, 2.0e-7)
    run = gf.simulate(params, [gf.Velocity(0.86e-6, 300.0)]).to_run()
    rng = np.random.default_rng(0)
    run = dataclasses.replace(run, force=run.force + rng.normal(0, 2e-5, run.force.size))
    meta = {**run.meta, "name": "only-run", "normal_load": 0.05, "preparation": "p1"}
    run = dataclasses.replace(run, meta=meta)
    return directory, gf.analyze(gf.Campaign([run]), directory, quiet=True)


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
        if tag not in ("img", "meta", "link", "br", "input", "wbr"):
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


def _text(html):
    """The page's text without the break opportunities of run names."""
    return html.replace("<wbr>", "")


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
    # a noise-free fit: the ends differ in the 16th digit; shown with 8, equal, not 18
    assert format_interval([235.953800872746029, 235.953800872746086]) == "[235.95380, 235.95380]"
    assert format_interval([1.0, 1.0 + 1e-6]) == "[1.0000000, 1.0000010]"
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
def test_display_scale_by_name(name, expected):
    assert display_scale(name) == expected


# --------------------------------------------------------------------------- sections


def test_every_section_is_rendered_in_the_contents_order(example, page):
    _, result = example
    parsed = _Page(_text(page))
    for section in (
        "synthetic-banner",
        "failed-summary",
        "headline",
        "verdicts",
        "material",
        "runs",
        "collapse",
        "amontons",
        "preparation",
        "model-comparison",
        "static-yield",
        "ramp",
        "creep",
        "switch",
        "stability-map",
        "forecasting",
        "publication",
        "campaign",
        "warnings",
        "failed-runs",
        "provenance",
    ):
        assert section in parsed.by_id, section
    # the contents list and the page agree on the order
    listed = re.findall(r'<li><a href="#([\w-]+)">', page.split("</nav>")[0])
    on_page = [m for m in re.findall(r'<section id="([\w-]+)"', page) if m in listed]
    assert listed == on_page
    assert listed == [anchor for anchor, _ in SECTIONS if anchor in listed]
    campaign = parsed.section("campaign")
    assert "creep: 1; ramp: 1; startup: 11; switch: 1" in campaign
    assert "30.00, 60.00, 90.00" in campaign  # loads [mN]
    assert "0.8600, 2.000, 4.000" in campaign  # velocities [µm/s]
    runs = parsed.section("runs")
    for entry in result.runs:
        assert entry.name in runs
    collapse = result.analyses.velocity_collapse.result
    assert format_p_value(collapse.p_value) in parsed.section("collapse")
    amontons = parsed.section("amontons")
    for load in ("30.00", "60.00", "90.00"):
        assert load in amontons
    comparison = parsed.section("model-comparison")
    assert "log_aging" in comparison and "Best by AIC: eq3" in comparison
    outcomes = list(result.predictions.stability_map.map.outcome.ravel())
    counts = {o: outcomes.count(o) for o in ("failure", "stop")}
    assert f"{counts['failure']} failure, {counts['stop']} stop" in parsed.section("stability-map")
    ramp = parsed.section("ramp")
    [row] = result.analyses.stress_ramp
    observed, predicted = row.observed["failure_force"], row.predicted_force
    assert 0.01 < observed < 0.1 and 0.01 < predicted < 0.1  # so 4 digits are 2 decimals in mN
    assert f"{observed * 1e3:.2f}" in ramp and f"{predicted * 1e3:.2f}" in ramp
    relative = f"({100 * (observed - predicted) / predicted:+.2g} %)".replace("-", "−")
    assert relative in ramp
    provenance = parsed.section("provenance")
    for entry in result.provenance["inputs"]:
        assert entry["file"] in provenance and entry["sha256"] in provenance
    assert result.timing["finished"] in provenance


def test_each_figure_sits_in_its_section(example, page):
    _, result = example
    parsed = _Page(_text(page))
    homes = {
        "startup": "runs",
        "fits": "runs",
        "collapse": "collapse",
        "amontons": "amontons",
        "stress_ramp": "ramp",
        "creep": "creep",
        "switch": "switch",
        "stability_map": "stability-map",
        "forecast_1": "forecasting",
        "fig2": "publication",
        "fig3": "publication",
    }
    for figure in result.figures:
        home = parsed.section(homes[figure["name"]])
        assert figure["title"] in home and figure["caption"] in home, figure["name"]


def test_the_headline_tells_the_papers_story(example, page):
    _, result = example
    headline = _Page(_text(page)).section("headline")
    mu_d = result.material.mu_d.value
    assert f"μ_d = {format_number(mu_d)}" in headline  # static against dynamic friction
    peaks = [row.mu_peak for row in result.predictions.static_yield]
    assert format_number(min(peaks), significant=3) in headline
    length = 1e6 / result.material.alpha.value  # 1/α [µm]
    assert f"1/α = {format_number(length, significant=3)} µm" in headline
    assert f"{format_number(length / 40, significant=2)} diameters" in headline
    assert "creeps logarithmically and holds" in headline
    assert "fails at" in headline and "F_peak" in headline


def test_material_constants_in_display_units(single, example):
    _, result = example
    text = _Page(_text(render_html(result))).section("material")
    alpha = result.material.alpha
    assert format_value_error(alpha.value, alpha.stderr) in text and "1/m" in text
    assert "1/α" in text and "µm" in text  # the rejuvenation length
    mu_a = result.material.mu_a
    assert format_value_error(mu_a.value, mu_a.stderr) in text


def test_material_without_value_shows_its_reason(single):
    from granflow.analysis.joint_results import Material

    directory, result = single
    material = Material(reason="the runs have no normal load")
    text = _Page(render_html(dataclasses.replace(result, material=material), directory))
    assert text.section("material").count("not determined: the runs have no normal load") == 3


def test_run_table_in_display_units_with_t0_and_alpha_v(single):
    directory, result = single
    runs = _Page(_text(render_html(result, directory))).section("run-table")
    fit = result.runs[0].result.fit
    v = result.runs[0].velocity
    assert format_value_error(fit.params["a"], fit.stderr["a"], 1e3) in runs  # a [mN]
    assert format_value_error(fit.params["x0"], fit.stderr["x0"], 1e6) in runs  # x0 [µm]
    assert format_value_error(fit.params["x0"] / v, fit.stderr["x0"] / v) in runs  # t0 [s]
    assert format_value_error(fit.params["alpha"] * v, fit.stderr["alpha"] * v) in runs  # αv
    assert "50.00" in runs and "0.8600" in runs  # load [mN], velocity [µm/s]
    judged = result.analyses.goodness_of_fit.runs["only-run"]
    assert format_number(judged.chi2, significant=3) in runs  # the normalised χ²


def test_a_fit_at_a_bound_and_one_not_converged_are_warned_about(single):
    directory, result = single
    entry = result.runs[0]
    fit = dataclasses.replace(
        entry.result.fit,
        at_bound=gf.fitting.results.FrozenMap({**entry.result.fit.at_bound, "x0": True}),
        success=False,
        message="maximum number of evaluations reached",
    )
    startup = dataclasses.replace(entry.result, fit=fit)
    changed = dataclasses.replace(result, runs=(dataclasses.replace(entry, result=startup),))
    parsed = _Page(_text(render_html(changed, directory)))
    assert "x0" in parsed.section("at-bound") and "only-run" in parsed.section("at-bound")
    assert "maximum number of evaluations reached" in parsed.section("convergence")


def test_failed_runs_are_named_with_their_reason(example, page):
    _, result = example
    [failure] = result.failed_runs
    assert failure["source"] == CORRUPT
    parsed = _Page(_text(page))
    assert failure["name"] in parsed.section("failed-summary")
    failed = parsed.section("failed-runs")
    assert failure["name"] in failed and failure["source"] in failed
    assert failure["reason"] in failed
    assert failure["reason"] in parsed.section("run-table")


def test_no_warnings_says_so(single):
    directory, result = single
    assert "No warnings" in _Page(render_html(result, directory)).section("warnings")


def test_synthetic_banner_present_only_for_synthetic_data(single):
    directory, result = single
    synthetic = render_html(dataclasses.replace(result, synthetic=True), directory)
    measured = render_html(result, directory)
    assert "SYNTHETIC DATA" in _Page(synthetic).section("synthetic-banner")
    assert "<title>[SYNTHETIC DATA]" in synthetic
    assert "SYNTHETIC" not in measured.upper()


def test_user_data_is_escaped(example):
    directory, result = example
    evil = '<script>alert("run")</script>'
    runs = (dataclasses.replace(result.runs[0], name=evil), *result.runs[1:])
    figures = ({**result.figures[0], "title": '"><script>alert("figure")</script>'},)
    changed = dataclasses.replace(
        result,
        runs=runs,
        warnings=(*result.warnings, "</li><b>bold</b>"),
        figures=figures + tuple(result.figures[1:]),
    )
    html = render_html(changed, directory)
    assert "<script" not in html
    assert "<b>bold</b>" not in html
    assert "&lt;script&gt;alert(&#34;run&#34;)&lt;/script&gt;" in _text(html)
    assert evil in _Page(_text(html)).section("run-table")  # shown as text, not run


def test_missing_sections_are_left_out_of_the_page_and_the_contents(single):
    directory, result = single
    html = render_html(result, directory)
    parsed = _Page(html)
    for absent in ("collapse", "amontons", "ramp", "creep", "switch", "forecasting"):
        assert absent not in parsed.by_id, absent
        assert f'href="#{absent}"' not in html
    assert "only-run" in _text(parsed.section("run-table"))


def test_options_and_timing_are_shown_with_their_units(example, page):
    _, result = example
    options = _Page(page).section("options")
    assert "forecast intervals 90 %" in options  # the level, not "900.0 mN"
    reference = result.provenance["options"]["reference_velocity"]
    assert f"reference velocity {format_number(reference, 1e6)} µm/s" in options
    provenance = _Page(page).section("provenance")
    assert "elapsed_s" not in provenance and "[s] " not in provenance
    assert re.search(r"elapsed \d+(\.\d+)? s", provenance)


def test_figures_are_embedded_as_data_uris(example, page):
    directory, result = example
    images = [attrs for tag, attrs in _Page(page).tags if tag == "img"]
    assert len(images) == len(result.figures)
    assert {"fits", "fig2", "fig3"} <= {figure["name"] for figure in result.figures}
    by_name = {f["title"]: f for f in result.figures}
    prefix = "data:image/png;base64,"
    for attrs in images:
        figure = by_name[attrs["alt"]]
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
    directory, result = example
    (directory / "figures" / "fake.png").write_text("not a png", encoding="utf-8")
    figures = (
        *result.figures,
        {"name": "ghost", "title": "Ghost", "png": "figures/ghost.png"},
        {"name": "fake", "title": "Fake", "png": "figures/fake.png"},
    )
    parsed = _Page(render_html(dataclasses.replace(result, figures=figures), directory))
    assert sum(tag == "img" for tag, _ in parsed.tags) == len(figures) - 2
    warnings = parsed.section("report-warnings")
    assert "figures/ghost.png" in warnings and "figures/fake.png is not a PNG file" in warnings


def test_render_report_writes_the_file(example, tmp_path):
    directory, result = example
    path = render_report(result)
    assert path == directory / "report.html"
    assert path.read_text(encoding="utf-8") == render_html(result, directory)
    elsewhere = render_report(result, directory, path=tmp_path / "sub" / "r.html")
    assert elsewhere == tmp_path / "sub" / "r.html" and elsewhere.is_file()
    assert not list(tmp_path.glob("sub/.*.tmp"))
    assert 'href="../../' in elsewhere.read_text(encoding="utf-8")  # the SVG, relative


def test_results_json_read_back_renders_the_same_page(example):
    directory, result = example
    saved = json.loads((directory / "results.json").read_text(encoding="utf-8"))
    assert render_html(saved, directory) == render_html(result, directory)


def test_the_report_takes_a_result_or_its_json(tmp_path):
    with pytest.raises(InvalidParameterError, match="must be an AnalysisResult"):
        render_report([1, 2], tmp_path)
    with pytest.raises(InvalidParameterError, match=r"not the content of a results\.json"):
        render_report({"runs": []}, tmp_path)


def test_template_is_package_data():
    template = importlib.resources.files("granflow.analysis") / "templates" / "report.html.j2"
    assert template.is_file()
    text = template.read_text(encoding="utf-8")
    assert "|safe" not in text.replace(" ", "") and "autoescape" not in text  # escaping stays on


def test_the_stability_map_is_fine_enough_to_follow_its_boundary(example):
    from granflow.analysis.predictions import MAP_POINTS, MAP_RATIOS

    _, result = example
    grid = result.predictions.stability_map.map.outcome.shape
    assert grid == (MAP_POINTS, MAP_RATIOS) and MAP_POINTS >= 40 and MAP_RATIOS >= 25


def test_figure_captions_give_the_load_in_mN(example):
    _, result = example
    captions = " ".join(figure["caption"] for figure in result.figures)
    loads = re.findall(r"F_N = ([\d.]+) (\w+)", captions)
    assert loads and all(unit == "mN" and 1 <= float(v) <= 1000 for v, unit in loads), loads


def _visible_text(html):
    """The page's text: no tags, no style sheet, no data URIs, entities decoded."""
    import html as entities

    html = re.sub(r"<style>.*?</style>", " ", _text(html), flags=re.S)
    return entities.unescape(re.sub(r"<[^>]+>", " ", html))


#: The display units the report may write after a number (SI inside, these outside).
DISPLAY_UNITS = {"mN", "µm", "µm/s", "s", "1/m", "1/µm", "1/s", "%", "d.o.f.", "mN/s"}


def test_every_displayed_quantity_is_in_a_display_unit(page):
    text = _visible_text(page)
    number = r"[−-]?\d+(?:\.\d+)?(?:×10[⁻⁰¹²³⁴⁵⁶⁷⁸⁹]+)?"
    pairs = re.findall(
        rf"(?<![\w.]){number}\s(N|m|m/s|mN|µm|µm/s|s|1/m|1/µm|1/s|kg|%)(?![\w/])", text
    )
    assert pairs, "no quantity found"
    assert set(pairs) <= DISPLAY_UNITS, set(pairs) - DISPLAY_UNITS  # never a bare N, m or m/s
    # a load in mN is tens of mN (the campaign's 30-90 mN), never 0.06 (N) nor 60000 (µN)
    loads = [float(v) for v in re.findall(r"F_N = ([\d.]+) mN", text)]
    assert loads and all(10 <= load <= 200 for load in loads)
    # every column of every table that holds numbers names its unit or is a pure number
    pure = (
        "repeats",
        "χ²",
        "p",
        "relation",
        "constant",
        "run",
        "/ F",
        "free parameters",
        "AIC",
        "BIC",
        "ΔAIC",
        "ΔBIC",
        "corr",
        "F peak /F N",
        "holds",
        "note",
        "quantity",
        "observed",
        "predicted",
        "parameter",
        "value",
        "interval",
        "degrees of freedom",
        "unit",
        "meaning",
        "status",
        "model",
        "formula",
        "test",
        "problems",
        "file",
        "SHA-256",
        "geometry",
        "preparation",
        "reason",
        "held in common",
        "std, separate fits",
    )
    heads = " ".join(re.findall(r"<thead>(.*?)</thead>", page, flags=re.S))
    for header in re.findall(r"<th>(.*?)</th>", heads):
        label = re.sub(r"<[^>]+>", " ", header).strip()
        assert "[" in label or any(word in label for word in pure), label


def test_the_options_show_no_fraction_as_a_force(page):
    options = _Page(page).section("options")
    assert "mN" not in options  # the forecast level was "900.0 mN"
    assert "90 %" in options


def test_many_preparation_labels_are_counted_not_listed():
    from types import SimpleNamespace

    from granflow.analysis.report_views import campaign_view

    runs = [
        {
            "test": "startup",
            "normal_load": 0.02,
            "velocity": 8.6e-7,
            "preparation": f"load-{i}",
            "failed": False,
        }
        for i in range(48)
    ]
    view = campaign_view(SimpleNamespace(campaign={}), runs)
    assert view["preparations"] is None and view["preparation_count"] == 48
    few = campaign_view(SimpleNamespace(campaign={}), runs[:3])
    assert few["preparations"] == ["load-0", "load-1", "load-2"]


def test_run_names_break_only_between_their_tokens(page):
    assert "overflow-wrap: anywhere" not in page  # no break inside a token
    assert "loads_<wbr>" in page or "startup_<wbr>" in page or "_<wbr>" in page
    names = re.findall(r"<code>([^<]*(?:<wbr>[^<]*)+)</code>", page)
    assert names and all(
        piece[-1] in "_#/." for name in names for piece in name.split("<wbr>")[:-1]
    )
