"""HTML representations (Jupyter) and the one value ± error formatter."""

import math
import re
from html.parser import HTMLParser

import numpy as np
import pytest

import granflow as gf
from granflow import _html
from granflow._format import format_value_error

P = gf.Params(a=3e-3, alpha=4e4, Fd=10e-3, x0=2e-7)
_VOID = {"br", "img", "hr", "meta", "input"}


class _Tags(HTMLParser):
    """Checks that every tag closes in order; collects the text of each table cell."""

    def __init__(self):
        super().__init__()
        self.open, self.cells, self.tags = [], [], []
        self._cell = None

    def handle_starttag(self, tag, attrs):
        self.tags.append(tag)
        if tag not in _VOID:
            self.open.append(tag)
        if tag in ("td", "th"):
            self._cell = []

    def handle_endtag(self, tag):
        assert self.open and self.open[-1] == tag, f"</{tag}> closes {self.open[-1:]}"
        self.open.pop()
        if tag in ("td", "th"):
            self.cells.append("".join(self._cell))
            self._cell = None

    def handle_data(self, data):
        if self._cell is not None:
            self._cell.append(data)


def parsed(markup):
    parser = _Tags()
    parser.feed(markup)
    parser.close()
    assert parser.open == [], f"unclosed tags {parser.open}"
    return parser


def _noisy_curve(seed=0):
    x = np.linspace(1e-6, 5e-4, 300)
    return x, gf.friction_slip(x, P) + np.random.default_rng(seed).normal(0, 3e-5, x.size)


_SUPERSCRIPT = str.maketrans("⁻⁰¹²³⁴⁵⁶⁷⁸⁹", "-0123456789")


def _read_value_error(cell):
    """(value, error, place) of a 'v ± e' or '(v ± e)×10ⁿ' cell: place is the size of the
    last digit shown."""
    match = re.fullmatch(r"\(?(-?[\d.]+) ± ([\d.]+)\)?(?:×10([⁻⁰¹²³⁴⁵⁶⁷⁸⁹]+))?", cell)
    assert match, cell
    value, error, exponent = match.groups()
    power = 10.0 ** int(exponent.translate(_SUPERSCRIPT)) if exponent else 1.0
    # an integer error keeps two significant digits: "170" ends at the tens
    decimals = len(error.split(".")[1]) if "." in error else -max(len(error) - 2, 0)
    place = 10.0**-decimals
    return float(value) * power, float(error) * power, place * power


@pytest.mark.parametrize(
    ("value", "error", "expected"),
    [
        (11.1, 0.069, "11.100 ± 0.069"),  # the value keeps the digits the error has
        (49251.89, 433.72, "49250 ± 430"),
        (-0.5, 0.0123, "-0.500 ± 0.012"),
        (2.1e-9, 3.0e-11, "(2.100 ± 0.030)×10⁻⁹"),
        (1.0, math.nan, "1.000"),  # no error: the value alone, four digits
    ],
)
def test_value_error_by_hand(value, error, expected):
    assert format_value_error(value, error) == expected


def test_text_is_escaped_once():
    cells = parsed(_html.table([["<b>&\"'"]], header=["a<b"])).cells
    assert cells == ["a<b", "<b>&\"'"]
    markup = _html.table([["<script>alert(1)</script>"]])
    assert "<script>" not in markup and "&lt;script&gt;" in markup
    assert _html.text(_html.Html("<i>x</i>")) == "<i>x</i>"
    report = "[[A <b>]] note & more\n    key<1> = value & <x>\n    free text <y>"
    page = parsed(_html.report_html("T<", report))
    assert page.cells == ["key<1>", "value & <x>", "free text <y>", ""]
    assert "b" not in page.tags and "x" not in page.tags and "y" not in page.tags


def test_fit_result_html_is_the_report_as_tables():
    x, y = _noisy_curve()
    run = gf.Run(t=x / 1e-6, slip=x, velocity=np.full(x.size, 1e-6), force=y)
    run = gf.Run(run.t, run.slip, run.velocity, run.force, meta={"name": "<img src=x>"})
    result = gf.fit(run)
    markup = result._repr_html_()
    page = parsed(markup)
    assert "img" not in page.tags and "<img" not in markup
    assert "FitResult: Eq. 3 in slip of <img src=x>" in markup.replace("&lt;", "<").replace(
        "&gt;", ">"
    )
    cells = page.cells
    shown = {"N": (1e3, "mN"), "m": (1e6, "µm"), "1/m": (1.0, "1/m")}  # display units
    for name in result.names:
        row = cells[cells.index(name) : cells.index(name) + 6]
        value, error, place = _read_value_error(row[1])
        scale, unit = shown[result.units[name]]
        # the value is rounded at the error's last digit, the error to two digits
        assert abs(value - scale * result.params[name]) <= 0.5 * place * (1 + 1e-9)
        assert abs(error - scale * result.stderr[name]) <= 0.5 * place * (1 + 1e-9)
        assert error >= 10 * place * (1 - 1e-9)  # two significant digits
        assert row[4] == unit
        assert row[5] == result.ci_method[name]
    assert "C(a, x0)" in cells  # the correlation the report lists first
    assert cells[cells.index("data points") + 1] == str(result.ndata)


def test_every_result_renders_as_balanced_html():
    x, y = _noisy_curve(1)
    fits = [gf.fit(_noisy_curve(seed)) for seed in range(3)]
    comparison = gf.compare_models((x, y))
    spread = gf.preparation_spread(fits)
    creep = gf.fit_creep(np.linspace(1.0, 100.0, 50), 1e-6 * np.log1p(np.linspace(1, 100, 50)))
    simulation = gf.simulate(P, [gf.Velocity(1e-6, 100.0), gf.SwitchToForce(60.0, factor=1.01)])
    campaign = gf.Campaign([simulation.to_run()])
    results = [fits[0], comparison, spread, creep, simulation, campaign]
    for result in results:
        markup = result._repr_html_()
        assert markup.startswith('<div class="granflow-result">')
        parsed(markup)
    # the simulation's events, one row each
    cells = parsed(simulation._repr_html_()).cells
    assert cells.count("failure") == len(simulation.events_of("failure")) == 1
    assert [c for c in cells if c in ("peak", "slide", "failure")] == [
        event.kind for event in simulation.events
    ]
    # the comparison names every model and its verdict
    cells = parsed(comparison._repr_html_()).cells
    assert [row["model"] for row in comparison.rows] == [
        c for c in cells if c in dict.fromkeys(("eq3", "log_aging", "exponential"))
    ]


def test_reprs_do_not_dump_mappings():
    fits = [gf.fit(_noisy_curve(seed)) for seed in range(3)]
    spread = gf.preparation_spread(fits)
    comparison = gf.compare_models(_noisy_curve(4))
    for result in (spread, comparison):
        text = repr(result)
        assert "FrozenMap" not in text and "{" not in text and len(text) < 200, text
    assert repr(spread).startswith("PreparationSpread(3 repeats")
    assert f"best_aic={comparison.best_aic!r}" in repr(comparison)


def test_material_constants_typed_and_as_results_json():
    from granflow.analysis.joint_results import Estimate, Material

    saved = {
        "mu_a": {"value": 0.0612, "stderr": 0.0011, "ci95": [0.059, 0.0634]},
        "mu_d": {"value": 0.2003, "stderr": 0.00041, "ci95": [0.1995, 0.2011]},
        "alpha": {"value": 50123.0, "stderr": 870.0, "ci95": [48400.0, 51800.0]},
        "source": "Amontons joint fit",
        "reason": None,
        "runs": 9,
        "normal_loads": [0.03, 0.06, 0.09],
        "velocity": 8.6e-7,
    }
    material = Material.from_dict(saved)
    assert material.to_dict() == saved  # results.json's layout, unchanged
    assert material["alpha"]["value"] == 50123.0 and material.alpha.ci95 == (48400.0, 51800.0)
    assert isinstance(material.mu_a, Estimate) and str(material.mu_a) == "0.0612 ± 0.0011"
    constants = material.constants
    assert constants == gf.MaterialConstants(mu_a=0.0612, mu_d=0.2003, alpha=50123.0)
    params = constants.params_at(0.05, x0=2e-7)
    assert (params.a, params.Fd) == pytest.approx((0.0612 * 0.05, 0.2003 * 0.05))
    cells = parsed(material._repr_html_()).cells
    assert cells[cells.index("alpha") + 1 : cells.index("alpha") + 4] == [
        "50120 ± 870",
        "[48400, 51800]",
        "1/m",
    ]
    missing = Material(reason="no start-ups")
    assert missing.constants is None and "no start-ups" in missing._repr_html_()
