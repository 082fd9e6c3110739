"""A headless Chromium for the report's tests (Debian's ``chromium`` and ``chromium-driver``,
driven by selenium): the ``browser`` fixture and :func:`page_problems`.

Locally the tests that use it skip when Chromium, its driver or selenium is missing; under CI
(environment variable ``CI`` set) they fail instead. Nothing is downloaded: the driver is given
by path, so selenium's driver manager never runs.
"""

import os
import shutil
from pathlib import Path

import pytest

CHROMIUM_FLAGS = (
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--disable-dev-shm-usage",
)

#: Every <img>: loaded, with an intrinsic size and a rendered size.
_IMAGES = """
return Array.from(document.images).map(function (img) {
  var box = img.getBoundingClientRect();
  return {alt: img.alt, complete: img.complete, naturalWidth: img.naturalWidth,
          naturalHeight: img.naturalHeight, width: box.width, height: box.height};
});
"""


def _find(names, paths):
    for name in names:
        found = shutil.which(name)
        if found:
            return found
    return next((path for path in paths if Path(path).is_file()), None)


def _unavailable(reason):
    if os.environ.get("CI"):
        pytest.fail(f"{reason}; CI must run the browser test (.ci/run installs chromium)")
    pytest.skip(reason)


@pytest.fixture(scope="module")
def browser(tmp_path_factory):
    """A headless Chromium with a fresh profile, logging the page's console."""
    chromium = _find(("chromium", "chromium-browser"), ("/usr/bin/chromium",))
    driver = _find(("chromedriver",), ("/usr/bin/chromedriver", "/usr/lib/chromium/chromedriver"))
    if chromium is None or driver is None:
        _unavailable("Chromium or chromedriver is not installed (Debian: chromium chromium-driver)")
    try:
        from selenium import webdriver
        from selenium.webdriver.chrome.service import Service
    except ImportError:
        _unavailable("selenium is not installed (pip install -e '.[test]')")
    options = webdriver.ChromeOptions()
    options.binary_location = chromium
    for flag in CHROMIUM_FLAGS:
        options.add_argument(flag)
    options.add_argument(f"--user-data-dir={tmp_path_factory.mktemp('chromium-profile')}")
    options.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    session = webdriver.Chrome(service=Service(executable_path=driver), options=options)
    session.set_page_load_timeout(60)
    yield session
    session.quit()


def page_problems(browser, path):
    """Open ``path`` and list what is wrong: console or network errors, and images that did
    not load or are not shown. Returns (problems, images)."""
    browser.get_log("browser")  # drop what an earlier page left
    browser.get(Path(path).resolve().as_uri())
    problems = [
        f"console {entry['level']} ({entry.get('source', '?')}): {entry['message']}"
        for entry in browser.get_log("browser")
        if entry["level"] == "SEVERE"
    ]
    images = browser.execute_script(_IMAGES)
    for image in images:
        if not image["complete"] or image["naturalWidth"] <= 0 or image["naturalHeight"] <= 0:
            problems.append(f"image {image['alt']!r} did not load")
        elif image["width"] <= 0 or image["height"] <= 0:
            problems.append(f"image {image['alt']!r} has no rendered size")
    return problems, images
