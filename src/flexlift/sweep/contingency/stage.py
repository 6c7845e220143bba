"""The single-failure study as a stage of ``flexlift run`` (``--stages ...,contingency``).

The study runs into ``contingency/`` of the run's folder on local worker processes (one per
core) and hands the report its verdict, the counts by outcome and the failures it does not
survive (ranked, with their margins); its own ``report.html`` and rerun files stay in that
folder.
"""

from __future__ import annotations

from flexlift.output.stage import StageOutput, Table
from flexlift.sweep.contingency.cases import KIND_TEXT

#: the most failures the run's report lists (the study's own report has them all)
LISTED = 20


def run_stage(scenario, out, control: str | None = None, progress=None, engine=None,
              **options) -> StageOutput:
    """Run the study of ``scenario`` into ``out / "contingency"``; its :class:`StageOutput`
    (criterion ``single_failure_tolerant``). ``options``: those of
    :func:`~flexlift.sweep.contingency.run.run_contingency` (``phases``, ``kinds``, ...)."""
    from flexlift.sweep.contingency.run import run_contingency

    def bar(done, total, failed):
        if progress is not None and total:
            progress(done / total)

    result = run_contingency(scenario, out / "contingency", mode=control, engine=engine,
                             progress=bar, **options)
    s = result.summary
    rows = {r["index"]: r for r in s["cases"]}
    table = Table("Single failures not survived (worst first)",
                  ["failure", "bag", "phase", "time [s]", "outcome", "reason", "margin"],
                  [[KIND_TEXT[rows[i]["kind"]], rows[i]["bag"], rows[i]["phase"],
                    rows[i]["time_s"], rows[i]["answer"]["outcome"].replace("_", " "),
                    rows[i]["answer"]["reason"],
                    (rows[i]["margin"] or {}).get("text", "–")]
                   for i in s["failures"][:LISTED]],
                  note=f"{s['n_cases']} cases; the whole study (the kind x phase matrix per "
                       "lift point, every case and its rerun file): contingency/report.html",
                  csv="contingency_failures.csv")
    if s["failures"]:
        from flexlift.plumbing.atomic import write_text

        (out / "tables").mkdir(exist_ok=True)
        write_text(out / "tables" / table.csv, table.to_csv())
    summary = {k: s[k] for k in ("verdict", "tolerant", "control", "n_cases", "counts",
                                 "phases", "failures")}
    return StageOutput("contingency", summary, tables=[table] if s["failures"] else [],
                       criteria={"single_failure_tolerant": bool(s["tolerant"])})
