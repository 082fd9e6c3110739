"""The live page of ``granflow watch --serve`` in headless Chromium: it loads with nothing
from the network, updates as the export grows, shows the alarm, and logs no console error."""

import json
import time
from pathlib import Path

import pytest
from browser import browser  # noqa: F401 (a fixture)
from live_writer import export_steps, write_plan
from test_watch_cli import finish, record, watch, writer


def _serving(log):
    """The page's address, from the log's "serving" record (the watch has started)."""
    deadline = time.monotonic() + 300
    while time.monotonic() < deadline:
        if log.exists():
            for line in log.read_text().splitlines():
                entry = json.loads(line)
                if entry["event"] == "serving":
                    return entry["message"].rsplit(" ", 1)[-1]
        time.sleep(0.1)
    pytest.fail("the watch never said where it serves")


def _shown(driver, element):
    """The text of the element with this id, read in one step in the page (the page rebuilds
    its elements as it updates, so a handle found first may be stale when read)."""
    text = driver.execute_script(
        "const e = document.getElementById(arguments[0]); return e ? e.innerText : '';", element
    )
    return text or ""


def test_the_page_updates_as_the_file_grows(tmp_path, browser):  # noqa: F811
    from selenium.webdriver.support.ui import WebDriverWait

    export, live, log = tmp_path / "ramp.txt", tmp_path / "live.txt", tmp_path / "watch.jsonl"
    record(export)
    steps, _, _ = export_steps(export, live, speed=8.0)
    write_plan(tmp_path / "plan.json", steps, log)
    follower = watch(
        live,
        "--log",
        log,
        "--serve",
        "127.0.0.1:0",
        "--horizon",
        "30s",
        "--until-end",
        "--stall",
        "30s",
    )
    source = writer(tmp_path / "plan.json")
    try:
        url = _serving(log)
        browser.get_log("browser")
        browser.get(url)
        wait = WebDriverWait(browser, 240, poll_frequency=0.2)
        wait.until(lambda b: _shown(b, "rows").isdigit())
        first = int(_shown(browser, "rows"))
        wait.until(lambda b: _shown(b, "rows").isdigit() and int(_shown(b, "rows")) > first + 20)
        later = int(_shown(browser, "rows"))
        updates = int(browser.find_element("tag name", "body").get_attribute("data-updates"))
        assert later > first and updates >= 2
        wait.until(lambda b: "ALARM" in _shown(b, "status") or "FAILED" in _shown(b, "status"))
        assert _shown(browser, "probability") not in ("", "-")
        canvas_drawn = browser.execute_script(
            "var c = document.getElementById('record');"
            "var d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data;"
            "for (var i = 3; i < d.length; i += 4) { if (d[i] > 0) { return true; } }"
            "return false;"
        )
        assert canvas_drawn
        problems = [
            entry["message"]
            for entry in browser.get_log("browser")
            if entry["level"] in ("SEVERE", "ERROR")
        ]
        assert problems == []
        resources = browser.execute_script(
            "return performance.getEntriesByType('resource').map(function (r) { return r.name; });"
        )
        assert all(name.startswith(url.rstrip("/")) for name in resources), resources
    finally:
        source.kill()
        follower.terminate()
        finish(source, follower)
    assert Path(log).read_text().splitlines()[-1].startswith('{"event":"stopped"')
