"""The output folder of a live run: written in place as the lift goes (the log must survive
a kill), under flexlift's folder rules (:func:`flexlift.output.folders.incremental_folder`):
``live.sqlite`` (with SQLite's ``-wal`` and ``-shm`` while it is open), and at the end
``report.md`` and ``report.json``. One live run per folder."""

from __future__ import annotations

import contextlib
import time

from flexlift.errors import InputError
from flexlift.live.log import LiveLog
from flexlift.live.report import estimate_text, lift_summary, plan_summary, report_text
from flexlift.output.folders import incremental_folder
from flexlift.plumbing.atomic import write_json, write_text

LOG_NAME = "live.sqlite"
FILES = (LOG_NAME, LOG_NAME + "-wal", LOG_NAME + "-shm", "report.md", "report.json")


@contextlib.contextmanager
def live_folder(out, lift: str):
    """(folder, log) of a new live run of ``lift`` in ``out``; refused (InputError) when the
    folder already holds a live log."""
    with incremental_folder(out, "live", identity=f"live:{lift}") as inc:
        if (inc.path / LOG_NAME).exists():
            raise InputError("--out", str(out), "already holds a live log; choose a new folder")
        inc.claim(*FILES)
        log = LiveLog(inc.path / LOG_NAME, {"lift": lift, "started": time.time()})
        try:
            yield inc.path, log
        finally:
            log.close()
        inc.finish()


def finish_report(folder, scenario, outcome, lift: str, control: str, plan: bool,
                  rig=None, estimate: dict | None = None) -> dict:
    """Write report.json and report.md of a finished run; the summary (``estimate``: the
    estimator's, :meth:`flexlift.live.estimate.LiveEstimate.summary`)."""
    summary = {"lift": lift_summary(outcome, lift, control)}
    if rig is not None and rig.result is not None:
        summary["rig"] = {"outcome": rig.result.outcome.get("kind"),
                          "max_ascent_velocity_ms": rig.result.headline["max_ascent_velocity_ms"],
                          "max_pitch_deg": rig.result.headline["max_pitch_deg"]}
    summary["plan"] = plan_summary(scenario) if plan else None
    summary["estimate"] = estimate
    write_json(folder / "report.json", summary)
    write_text(folder / "report.md", report_text(summary["lift"], summary["plan"])
               + estimate_text(estimate))
    return summary
