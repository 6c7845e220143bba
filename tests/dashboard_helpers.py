"""A realistic dashboard snapshot (the tanker's seven bags mid-ascent, one alarm) and the
headless Chromium the dashboard's browser tests drive."""

from __future__ import annotations

import math
import os
import tempfile
from contextlib import contextmanager

from flexlift.live.dashboard import Alarm, BagView, DashboardSnapshot, Limits

CHROMIUM = "/usr/bin/chromium"
CHROMIUM_ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                 "--disable-background-networking", "--disable-component-update", "--disable-sync"]


def tanker_mid_ascent(time_s: float = 2710.0, depth_shift_m: float = 0.0,
                      alarms: tuple = ()) -> DashboardSnapshot:
    """The tanker halfway up: hull near 180 m, bow up 0.4 deg, the bow bag fast, bag_3's
    inclinometer silent; ``depth_shift_m`` moves every bag down by that much [m]."""
    from flexlift import load_scenario

    limits = Limits.of_scenario(load_scenario("tanker"))
    pitch = math.radians(0.41)
    x = [-128.0, -95.0, -52.0, -8.0, 36.0, 85.0, 131.0]  # lift points from midships [m]
    speeds = [0.19, 0.20, 0.21, 0.20, 0.22, 0.31, 0.49]
    fills = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]
    purges = [0.06, 0.04, 0.08, 0.05, 0.11, 0.27, 0.52]
    bags = tuple(
        BagView(name=f"bag_{i + 1}", depth_m=181.4 - xi * math.sin(pitch) + depth_shift_m,
                speed_m_s=v, pitch_rad=None if i == 2 else pitch + 0.001 * (i - 3),
                fill=f, purge=p)
        for i, (xi, v, f, p) in enumerate(zip(x, speeds, fills, purges))
    )
    return DashboardSnapshot(time_s=time_s, state="ascending", bags=bags, limits=limits,
                             hull_pitch_rad=pitch, alarms=tuple(alarms), lift="tanker",
                             mode="master")


SILENT_BAG_3 = Alarm(time_s=2707.6, kind="silent", bag="bag_3",
                     message="bag_3/pitch silent for 2.4 s (period 1.0 s): its inclinometer")


@contextmanager
def chromium_page(width: int = 1366, height: int = 900):
    """A page of a fresh headless Debian Chromium (never playwright's own browsers)."""
    from playwright.sync_api import sync_playwright

    with tempfile.TemporaryDirectory(prefix="flexlift-chromium-") as profile, sync_playwright() as pw:
        ctx = pw.chromium.launch_persistent_context(
            profile, executable_path=CHROMIUM, args=CHROMIUM_ARGS, headless=True,
            viewport={"width": width, "height": height}, env={**os.environ, "HOME": profile})
        try:
            yield ctx.pages[0] if ctx.pages else ctx.new_page()
        finally:
            ctx.close()
