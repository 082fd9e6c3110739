"""The documentation site, checked like code.

* The site builds with warnings as errors (``python -m sphinx -W --keep-going``), from a fresh
  copy of ``docs/`` (so every gallery example is executed, none reused from an earlier build),
  every example produces its figure, and every public name of ``granflow.__all__`` has its
  reference page.
* A headless Chromium opens the index, a user-guide page and a gallery page: no console
  error, every image loaded and shown; no link inside the site points to a missing page or
  anchor, and nothing is loaded from the network.
* The ``>>>`` examples of the getting-started page and of the user guide run as doctests, and
  the shell commands of the getting-started page run as written.

Locally these tests skip when Sphinx and its extensions (``pip install -e ".[docs]"``) or
Chromium are missing; under CI (environment variable ``CI`` set) they fail instead.
"""

import doctest
import html.parser
import os
import re
import shlex
import shutil
import subprocess
import sys
from pathlib import Path
from urllib.parse import unquote, urlsplit

import pytest
from browser import browser, page_problems  # noqa: F401 (browser: a fixture)

import granflow

DOCS = Path(__file__).resolve().parents[2] / "docs"
EXTENSIONS = ("sphinx", "numpydoc", "pydata_sphinx_theme", "sphinx_gallery")
#: What a build leaves in the source folder, never copied into the test's fresh copy.
GENERATED = ("_build", "auto_examples", "api/generated", "sg_execution_times.rst")
#: Pages with ``>>>`` examples (the getting-started page also has shell commands).
DOCTESTED = (
    "getting_started.rst",
    *(
        f"user_guide/{page.name}"
        for page in sorted((DOCS / "user_guide").glob("*.rst"))
        if page.name != "index.rst"
    ),
)
#: The gallery the issue asks for: every figure of the paper and four more.
PAPER_GALLERY = (
    "plot_fig2a_preparations",
    "plot_fig2b_collapse",
    "plot_fig2c_amontons",
    "plot_fig3a_stress_ramp",
    "plot_fig3b_creep",
    "plot_fig3c_switch",
    "plot_stability_map",
    "plot_posterior_corner",
    "plot_rsf_velocity_step",
    "plot_forecast_running",
    "plot_rsf_sepiolite",
    "plot_rsf_basalt",
)
#: The real velocity-step records the gallery reads, beside the repository (never copied in).
RECORDS = DOCS.parents[1] / "shared" / "data" / "rate-state-velocity-steps"
#: The pages the browser opens: the index, a user-guide page, a gallery page.
OPENED = (
    "index.html",
    "getting_started.html",
    "user_guide/physics.html",
    "auto_examples/plot_fig3c_switch.html",
    "auto_examples/plot_rsf_sepiolite.html",
)
#: Where each figure of the user guide and the index must be: every page teaches with one.
FIGURED = (
    "index.html",
    "getting_started.html",
    *(
        f"user_guide/{p.stem}.html"
        for p in (DOCS / "user_guide").glob("*.rst")
        if p.name != "index.rst"
    ),
)


def _require(modules):
    missing = []
    for name in modules:
        try:
            __import__(name)
        except ImportError:
            missing.append(name)
    if missing:
        reason = f"{', '.join(missing)} not installed (pip install -e '.[docs]')"
        if os.environ.get("CI"):
            pytest.fail(f"{reason}; CI must build the documentation")
        pytest.skip(reason)


def _build(target):
    """Build a fresh copy of docs/ into ``target``/html; returns (html folder, output)."""
    source = target / "docs"
    shutil.copytree(DOCS, source, ignore=shutil.ignore_patterns(*GENERATED, "__pycache__"))
    for generated in GENERATED:  # nested paths (api/generated) are not matched by name
        shutil.rmtree(source / generated, ignore_errors=True)
    html_dir = target / "html"
    command = [
        sys.executable, "-m", "sphinx", "-W", "--keep-going", "-q", "-b", "html",
        "-d", str(target / "doctrees"), str(source), str(html_dir),
    ]  # fmt: skip
    env = {**os.environ, "MPLBACKEND": "Agg"}
    done = subprocess.run(command, capture_output=True, text=True, env=env, cwd=target)
    output = done.stdout + done.stderr
    assert done.returncode == 0, f"the documentation build failed:\n{output[-6000:]}"
    return html_dir, output


class _Links(html.parser.HTMLParser):
    """Every href/src of a page, and every id it defines."""

    def __init__(self):
        super().__init__()
        self.links, self.ids = [], set()

    def handle_starttag(self, tag, attrs):
        attrs = dict(attrs)
        if "id" in attrs:
            self.ids.add(attrs["id"])
        if tag == "a" and attrs.get("name"):
            self.ids.add(attrs["name"])
        for key in ("href", "src"):
            if attrs.get(key):
                self.links.append((tag, attrs[key]))


def _parse(path, cache):
    if path not in cache:
        parser = _Links()
        parser.feed(path.read_text(encoding="utf-8"))
        cache[path] = parser
    return cache[path]


def _broken_links(html_dir):
    """Links inside the site to a missing file or anchor, and anything fetched from outside."""
    broken, pages = [], {}
    for page in sorted(html_dir.rglob("*.html")):
        if "_static" in page.relative_to(html_dir).parts:
            continue  # the theme's templates, not pages
        for tag, link in _parse(page, pages).links:
            parts = urlsplit(link)
            if parts.scheme in ("http", "https") or link.startswith("//"):
                if tag != "a":  # a script, style sheet, image or font from the network
                    broken.append(f"{page.relative_to(html_dir)}: loads {link}")
                continue
            if parts.scheme in ("mailto", "data", "javascript"):
                continue
            target = (page.parent / unquote(parts.path)).resolve() if parts.path else page
            if target.is_dir():
                target = target / "index.html"
            if not target.exists():
                broken.append(f"{page.relative_to(html_dir)}: {link} (no such file)")
            elif (
                parts.fragment
                and target.suffix == ".html"
                and unquote(parts.fragment) not in _parse(target, pages).ids
            ):
                broken.append(f"{page.relative_to(html_dir)}: {link} (no such anchor)")
    return broken


def _require_records():
    if not RECORDS.is_dir():
        reason = f"the real velocity-step records are not beside the repository ({RECORDS})"
        if os.environ.get("CI"):
            pytest.fail(f"{reason}; CI must build the gallery on them")
        pytest.skip(reason)


#: Every pre block's width against its box: long lines wrap, none is cut or scrolls.
#: The page's width and how far its content reaches to the side [CSS px].
_PAGE_WIDTH = """
return {scroll: document.documentElement.scrollWidth,
        client: document.documentElement.clientWidth};
"""
#: The boxes around each image that would clip it (overflow not visible), by tag and class.
_CLIPPING_BOXES = """
var found = [];
Array.from(document.images).forEach(function (img) {
  for (var box = img.parentElement; box; box = box.parentElement) {
    var style = getComputedStyle(box);
    if (style.overflowY !== 'visible' || style.overflowX === 'hidden') {
      var name = box.tagName + '.' + box.className;
      if (found.indexOf(name) < 0) { found.push(name); }
    }
  }
});
return found;
"""
_PRE_LAYOUT = """
return Array.from(document.querySelectorAll('pre')).map(function (pre) {
  return {scroll: pre.scrollWidth, box: pre.clientWidth, text: pre.textContent.slice(0, 60)};
});
"""


def test_site_builds_runs_every_example_and_opens_cleanly(tmp_path, browser):  # noqa: F811
    _require(EXTENSIONS)
    _require_records()
    html_dir, output = _build(tmp_path)
    assert "WARNING" not in output and "ERROR" not in output, output[-6000:]

    # every gallery example ran and drew its figure
    examples = sorted(path.stem for path in (DOCS / "examples").glob("plot_*.py"))
    assert set(PAPER_GALLERY) <= set(examples), set(PAPER_GALLERY) - set(examples)
    for name in examples:
        page = html_dir / "auto_examples" / f"{name}.html"
        assert page.is_file(), f"no gallery page for {name}"
        assert list((html_dir / "_images").glob(f"sphx_glr_{name}_*.png")), f"{name} drew nothing"

    # every public name has its reference page
    reference = html_dir / "api" / "generated"
    missing = [
        name
        for name in granflow.__all__
        if name != "__version__" and not (reference / f"granflow.{name}.html").is_file()
    ]
    assert missing == [], f"public names without a reference page: {missing}"
    assert (reference / "granflow.rsf.simulate.html").is_file()

    assert _broken_links(html_dir) == []

    # every page of the user guide, and the index, teaches with a figure drawn at build time
    for relative in FIGURED:
        text = (html_dir / relative).read_text(encoding="utf-8")
        assert re.search(r'<img[^>]+src="[^"]*\.png"', text), f"{relative} has no figure"
    # formulas are drawn (SVG in the page), none left as plain text, no MathJax
    physics = (html_dir / "user_guide" / "physics.html").read_text(encoding="utf-8")
    assert physics.count('class="math"') >= 6 and "data:image/svg+xml;base64," in physics
    assert "mathjax" not in physics.lower()

    for relative in OPENED:
        problems, images = page_problems(browser, html_dir / relative)
        assert problems == [], (relative, problems)
        if relative.startswith("auto_examples"):
            assert any(image["alt"] for image in images), "the gallery page shows no figure"
    browser.set_window_size(800, 900)
    try:
        for relative in ("getting_started.html", "user_guide/forecasting.html"):
            page_problems(browser, html_dir / relative)
            cut = [p for p in browser.execute_script(_PRE_LAYOUT) if p["scroll"] > p["box"] + 1]
            assert cut == [], (relative, cut)
        # at 800 px no page runs off to the side (a long heading's "#" link once did)
        for relative in FIGURED:
            page_problems(browser, html_dir / relative)
            width = browser.execute_script(_PAGE_WIDTH)
            assert width["scroll"] <= width["client"], (relative, width)
    finally:
        browser.set_window_size(1400, 900)
    # in print no figure sits in a box that clips it: the theme's scrolling containers once
    # printed as one page-high box, cutting a gallery figure off at the sheet's end
    browser.execute_cdp_cmd("Emulation.setEmulatedMedia", {"media": "print"})
    try:
        for relative in ("auto_examples/plot_fig2c_amontons.html", "user_guide/physics.html"):
            page_problems(browser, html_dir / relative)
            clipping = browser.execute_script(_CLIPPING_BOXES)
            assert clipping == [], (relative, clipping)
    finally:
        browser.execute_cdp_cmd("Emulation.setEmulatedMedia", {"media": ""})


def test_link_checker_sees_a_missing_page_a_missing_anchor_and_a_cdn(tmp_path):
    (tmp_path / "a.html").write_text(
        '<html><body><p id="here">x</p><a href="b.html">b</a><a href="a.html#there">t</a>'
        '<a href="#here">fine</a><a href="https://example.org">an outside link is fine</a>'
        '<script src="https://cdn.example.org/x.js"></script></body></html>',
        encoding="utf-8",
    )
    broken = _broken_links(tmp_path)
    assert broken == [
        "a.html: b.html (no such file)",
        "a.html: a.html#there (no such anchor)",
        "a.html: loads https://cdn.example.org/x.js",
    ]


def _shell_commands(page):
    """The ``granflow ...`` lines of the page's bash blocks."""
    commands, in_bash = [], False
    for line in page.read_text(encoding="utf-8").splitlines():
        if line.startswith(".. code-block::"):
            in_bash = line.split("::")[1].strip() == "bash"
        elif in_bash and line.strip().startswith("granflow "):
            commands.append(shlex.split(line.strip())[1:])
        elif line and not line.startswith(" "):
            in_bash = False
    return commands


@pytest.mark.parametrize("page", DOCTESTED)
def test_examples_of_the_page_run_as_written(page, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # the examples write their files into the current folder
    monkeypatch.setenv("MPLBACKEND", "Agg")
    flags = doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE
    result = doctest.testfile(str(DOCS / page), module_relative=False, optionflags=flags)
    assert result.attempted > 0, f"{page} has no >>> example"
    assert result.failed == 0, f"{result.failed} of {result.attempted} examples of {page} failed"
    if page == "getting_started.rst":
        from granflow.cli import main

        commands = _shell_commands(DOCS / page)
        assert [command[0] for command in commands] == ["demo", "fit"]
        for command in commands:
            assert main(command) == 0, command
        assert (tmp_path / "granflow-demo" / "report.html").is_file()


def test_autodoc_can_ask_granflow_rsf_for_a_submodule():
    """autodoc imports ``granflow.rsf.simulate`` as a module before it looks for the
    attribute; granflow.rsf is a plain module with lazy names, and asking it for a submodule
    once recursed without end (importlib asks the parent for ``__path__``)."""
    import importlib

    with pytest.raises(ModuleNotFoundError, match="not a package"):
        importlib.import_module("granflow.rsf.simulate")
    from granflow import rsf

    assert callable(rsf.simulate)


#: A symbol written with an underscore outside mathtext ("F_d", "F_N").
_LITERAL_SUBSCRIPT = re.compile(r"(?<![A-Za-z])[A-Za-zμτα]_[A-Za-z0-9]")


def _label_strings(path):
    """The string constants a gallery script gives to axis labels and titles."""
    import ast

    tree = ast.parse(path.read_text(encoding="utf-8"))
    for node in ast.walk(tree):
        if not isinstance(node, ast.Call) or not isinstance(node.func, ast.Attribute):
            continue
        if node.func.attr in ("set_xlabel", "set_ylabel", "set_title", "suptitle"):
            for argument in node.args[:1]:
                if isinstance(argument, ast.Constant) and isinstance(argument.value, str):
                    yield node.lineno, argument.value


def test_gallery_axis_labels_write_symbols_in_mathtext():
    """An axis label in the gallery once read "F_d [mN]" with a literal underscore."""
    found = []
    for path in sorted((DOCS / "examples").glob("plot_*.py")):
        for line, text in _label_strings(path):
            if _LITERAL_SUBSCRIPT.search(re.sub(r"\$[^$]*\$", "", text)):
                found.append(f"{path.name}:{line}: {text!r}")
    assert found == []
