"""The report in a real browser: headless Chromium (Debian's ``chromium`` and
``chromium-driver``, driven by selenium) opens it offline, logs no error, and shows every image.

Locally the tests skip when Chromium, its driver or selenium is missing; under CI (environment
variable ``CI`` set) they fail instead, so CI never skips them silently. Nothing is downloaded:
the driver is given by path, so selenium's driver manager never runs.
"""

from browser import browser, page_problems  # noqa: F401 (browser: a fixture)
from report_example import example_result

from granflow.analysis.report import render_report


def test_report_opens_with_no_errors_and_every_image_shown(browser, tmp_path):  # noqa: F811
    result = example_result(tmp_path)
    path = render_report(result)
    problems, images = page_problems(browser, path)
    assert problems == []
    assert len(images) == len(result.figures) >= 10
    assert {"fits", "fig2", "fig3"} <= {figure["name"] for figure in result.figures}
    assert {image["alt"] for image in images} == {f["title"] for f in result.figures}
    assert browser.title.startswith("[SYNTHETIC DATA]")


def test_checker_reports_broken_images_and_console_errors(browser, tmp_path):  # noqa: F811
    good = (
        "data:image/png;base64,iVBORw0KGgoAAAANSUhEUgAAAAEAAAABCAYAAAAfFcSJAAAADUlEQVR4nGNgYGD4"
        "DwABBAEAwS2OUAAAAABJRU5ErkJggg=="
    )
    page = tmp_path / "bad.html"
    page.write_text(
        "<!DOCTYPE html><html><head><title>bad</title></head><body>"
        f'<img alt="fine" src="{good}" width="20" height="20">'
        '<img alt="missing" src="missing.png">'
        f'<img alt="hidden" src="{good}" style="display:none">'
        "<script>console.error('deliberate error')</script>"
        "</body></html>",
        encoding="utf-8",
    )
    problems, images = page_problems(browser, page)
    assert len(images) == 3
    assert any("deliberate error" in p for p in problems)
    assert any("missing.png" in p for p in problems)  # the network error of the broken image
    assert "image 'missing' did not load" in problems
    assert "image 'hidden' has no rendered size" in problems
    assert not any("'fine'" in p for p in problems)


#: Each table's width against its container's, and the page's against the window's.
_TABLE_LAYOUT = """
return {
  page: document.documentElement.scrollWidth,
  window: document.documentElement.clientWidth,
  tables: Array.from(document.querySelectorAll('table')).map(function (table) {
    var section = table.closest('section');
    var cells = table.querySelectorAll('thead th');
    var last = cells.length ? cells[cells.length - 1].getBoundingClientRect().right : 0;
    return {name: table.id || (section ? section.id : '?'), width: table.scrollWidth,
            container: table.parentElement.clientWidth,
            right: table.getBoundingClientRect().right,
            limit: table.parentElement.getBoundingClientRect().right,
            lastHeader: last, columns: cells.length};
  })
};
"""


def _overflowing(layout):
    return [
        table
        for table in layout["tables"]
        if table["width"] > table["container"] + 1 or table["right"] > table["limit"] + 1
    ]


def _media(session, media):
    session.execute_cdp_cmd("Emulation.setEmulatedMedia", {"media": media})


def test_layout_at_1400_and_800_px_and_in_print(browser, tmp_path):  # noqa: F811
    import base64

    path = render_report(example_result(tmp_path))
    try:
        for width in (1400, 800):
            browser.set_window_size(width, 900)
            problems, _ = page_problems(browser, path)
            assert problems == []
            layout = browser.execute_script(_TABLE_LAYOUT)
            assert layout["tables"], "no table measured"
            assert _overflowing(layout) == [], width
            assert layout["page"] <= layout["window"], width  # no sideways scrolling
            shot = tmp_path / f"report-{width}.png"
            assert browser.save_screenshot(str(shot))
            assert shot.read_bytes().startswith(b"\x89PNG")
        # printed: the run table on landscape pages (277 mm wide inside the margins, 1047
        # CSS px), everything else on portrait ones (186 mm, 703 CSS px)
        _media(browser, "print")
        for width in (1047, 703):
            browser.set_window_size(width, 900)
            layout = browser.execute_script(_TABLE_LAYOUT)
            assert _overflowing(layout) == [], width
            (runs,) = [t for t in layout["tables"] if t["name"] == "run-table"]
            assert runs["columns"] == 12  # every column, status last, is on the page
            assert runs["lastHeader"] <= width
        pdf = browser.execute_cdp_cmd(
            "Page.printToPDF", {"printBackground": True, "preferCSSPageSize": True}
        )
        printed = base64.b64decode(pdf["data"])
        assert printed.startswith(b"%PDF")
        (tmp_path / "report.pdf").write_bytes(printed)
    finally:
        _media(browser, "")
        browser.set_window_size(1400, 900)
