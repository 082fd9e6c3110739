"""The report in a real browser: headless Chromium (Debian's ``chromium`` and
``chromium-driver``, driven by selenium) opens it offline, logs no error, and shows every image.

Locally the tests skip when Chromium, its driver or selenium is missing; under CI (environment
variable ``CI`` set) they fail instead, so CI never skips them silently. Nothing is downloaded:
the driver is given by path, so selenium's driver manager never runs.
"""

from browser import browser, page_problems  # noqa: F401 (browser: a fixture)
from report_example import example_results

from granflow.analysis.report import render_report


def test_report_opens_with_no_errors_and_every_image_shown(browser, tmp_path):  # noqa: F811
    results = example_results(tmp_path)
    path = render_report(results, tmp_path)
    problems, images = page_problems(browser, path)
    assert problems == []
    assert len(images) == len(results["figures"]) == 10
    assert {"fits", "fig2", "fig3"} <= {figure["name"] for figure in results["figures"]}
    assert {image["alt"] for image in images} == {f["title"] for f in results["figures"]}
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
