"""The live dashboard in headless Chromium: the page loads, a bag's depth changes after a new
snapshot, an alarm shows within 2 s of being published; and the docs' screenshot.

Set FLEXLIFT_DASHBOARD_PNG=docs/img/dashboard.png to write the screenshot the docs show."""

import os
import time
from pathlib import Path

import pytest
from dashboard_helpers import CHROMIUM, SILENT_BAG_3, chromium_page, tanker_mid_ascent

from flexlift.live.dashboard import Dashboard

pytestmark = pytest.mark.skipif(not os.path.exists(CHROMIUM),
                                reason=f"Debian's chromium is not installed at {CHROMIUM}")


@pytest.fixture(scope="module")
def served():
    board = Dashboard()
    url = board.start()
    board.publish(tanker_mid_ascent())
    try:
        with chromium_page() as page:
            page.goto(url, timeout=15_000)
            yield board, page
    finally:
        board.stop()


def _depth_text(page, bag):
    return page.locator(f"#bag-{bag} td[data-q=depth] .val").inner_text()


def test_page_loads_with_every_bag_and_state(served):
    _, page = served
    page.wait_for_selector("#bag-bag_7", timeout=5_000)
    assert page.locator("tr[data-testid=bag]").count() == 7
    assert page.locator("#state").inner_text().lower() == "ascending"
    page.wait_for_function("document.querySelector('#link').textContent === 'live'",
                           timeout=2_000)  # the link's state is redrawn every 0.5 s
    assert _depth_text(page, "bag_1") == "182.3"       # 181.4 + 128 sin(0.41 deg)
    assert page.locator("#bag-bag_3 td[data-q=pitch] .val").inner_text() == "—"   # silent
    assert page.locator("#bag-bag_7 td[data-q=speed]").get_attribute("class") == "warn"  # 0.49/0.6
    assert page.locator("#hull-pitch").inner_text() == "0.41°"


def test_depth_changes_after_a_new_snapshot(served):
    board, page = served
    page.wait_for_selector("#bag-bag_1", timeout=5_000)
    before = _depth_text(page, "bag_1")
    board.publish(tanker_mid_ascent(time_s=2711.0, depth_shift_m=-0.6))
    page.wait_for_function("document.querySelector('#bag-bag_1 td[data-q=depth] .val')"
                           f".textContent !== '{before}'", timeout=2_000)
    assert _depth_text(page, "bag_1") == "181.7"


def test_alarm_shows_within_two_seconds(served):
    board, page = served
    assert page.locator("li[data-testid=alarm]").count() == 0
    board.publish(tanker_mid_ascent(time_s=2712.0, alarms=(SILENT_BAG_3,)))
    published = time.monotonic()
    page.wait_for_selector("li[data-testid=alarm]", timeout=2_000)
    assert time.monotonic() - published < 2.0
    text = page.locator("#alarms").inner_text()
    assert "bag_3" in text and "silent" in text.lower()
    assert "alarms-on" in page.locator("#alarm-panel").get_attribute("class")
    assert "alarmed" in page.locator("#bag-bag_3").get_attribute("class")


def test_screenshot(served, tmp_path):
    board, page = served
    board.publish(tanker_mid_ascent(alarms=(SILENT_BAG_3,)))
    page.wait_for_function("document.querySelector('#time').textContent === '0:45:10'",
                           timeout=2_000)
    out = Path(os.environ.get("FLEXLIFT_DASHBOARD_PNG") or tmp_path / "dashboard.png")
    out.parent.mkdir(parents=True, exist_ok=True)
    page.screenshot(path=str(out), full_page=True)
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and out.stat().st_size > 20_000
