"""What makes the single-failure study quicker without changing an answer: the report draws
the worst cases' traces as their workers ran them (no rerun, unless resumed), the costly
kinds are submitted first (the results keep the cases' order), and the workers build the
plant while the fault-free run runs."""

import json
import threading

import numpy as np

from flexlift import load_scenario
from flexlift.sweep.contingency import run as R
from flexlift.sweep.contingency.answer import TRACES, warm_plant
from flexlift.sweep.executors import Serial

TANKER = load_scenario("tanker")
#: at breakout: 7 lost bags and 4 broken slings (the resettling ones among them), 4 stuck
#: sensors: 15 cases
KW = {"kinds": ["sensor_stuck", "bag_rupture", "sling_break"], "phases": ["breakout"],
      "margins": False}


def answers(summary):
    return [(c["index"], c["bag"], c["kind"], c["answer"]) for c in summary["cases"]]


def test_the_report_draws_the_worst_cases_as_their_workers_ran_them(tmp_path, monkeypatch):
    """The three worst cases' traces come back with their records (not written with them)
    and equal a rerun of each, array by array; resumed, they are run again, the same."""
    seen = []
    histories = R._histories

    def spy(summary, base, kept=None):
        out = histories(summary, base, kept)
        seen.append((dict(kept or {}), out, histories(summary, base, {})))
        return out

    monkeypatch.setattr(R, "_histories", spy)
    out = tmp_path / "study"
    s = R.run_contingency(TANKER, out, engine=Serial(), **KW).summary
    kept, drawn, rerun = seen[-1]
    worst = R.worst_cases(s)
    assert len(worst) == 3 and sorted(kept) == sorted(worst)  # none run again
    assert sorted(drawn) == sorted(rerun) == sorted(worst)
    for i in worst:
        assert set(drawn[i]) == {"time", "height", "speed", "pitch"}
        for name, values in rerun[i].items():
            assert np.array_equal(drawn[i][name], values), (i, name)
    for f in (out / "cases").iterdir():
        assert TRACES not in json.loads(f.read_text())
    again = R.run_contingency(TANKER, out, engine=Serial(), **KW).summary
    kept, drawn, rerun = seen[-1]
    assert kept == {} and answers(again) == answers(s)
    for i in worst:
        for name, values in rerun[i].items():
            assert np.array_equal(drawn[i][name], values), (i, name)


class Recording(Serial):
    """Every case in this process, each submission's function and case (``workers`` as a
    pool of that many would say)."""

    def __init__(self, workers=1):
        self.workers = workers
        self.calls = []
        self.lock = threading.Lock()

    def submit(self, fn, *args):
        with self.lock:
            self.calls.append((fn.__name__, getattr(args[0], "index", None)))
        return super().submit(fn, *args)


def test_costly_kinds_go_first_and_the_results_keep_the_cases_order(tmp_path, monkeypatch):
    """The lost bags and broken slings are submitted first; the summary lists the cases in
    their own order, with the answers of a study submitted in that order."""
    eng = Recording()
    s = R.run_contingency(TANKER, tmp_path / "costly", engine=eng, **KW).summary
    kinds = {c["index"]: c["kind"] for c in s["cases"]}
    sent = [i for fn, i in eng.calls if fn == "run_fault_case"]
    assert sorted(sent) == sorted(kinds) and len(sent) == s["n_cases"] == 15
    costly = sorted(i for i in kinds if kinds[i] in R.COSTLY)
    assert len(costly) == 11 and sent[:11] == costly  # each part in the cases' order
    assert sent[11:] == sorted(i for i in kinds if kinds[i] not in R.COSTLY)
    assert sent != sorted(sent)
    assert [c["index"] for c in s["cases"]] == sorted(kinds)
    monkeypatch.setattr(R, "submission_order", lambda cases: list(cases))
    plain = Recording()
    p = R.run_contingency(TANKER, tmp_path / "plain", engine=plain, **KW).summary
    assert [i for fn, i in plain.calls if fn == "run_fault_case"] == sorted(kinds)
    assert answers(p) == answers(s)


def test_the_workers_build_the_plant_while_the_fault_free_run_runs(tmp_path):
    """A pool of two: one warm-up per worker (the plant of the cases' scenario, built), and
    the answers of a study without it."""
    eng = Recording(workers=2)
    s = R.run_contingency(TANKER, tmp_path / "warm", engine=eng, kinds=["sling_break"],
                          phases=["breakout"], margins=False).summary
    assert [fn for fn, _ in eng.calls].count("warm_plant") == 2
    assert warm_plant(TANKER.with_changes(faults=[]), "coordinated") is True
    one = R.run_contingency(TANKER, tmp_path / "one", engine=Recording(), kinds=["sling_break"],
                            phases=["breakout"], margins=False).summary
    assert answers(one) == answers(s)


def test_the_worst_kept_as_cases_return_are_the_reports_worst_ties_in_case_order():
    """Offered in any order, with ties of severity and of upward speed, the cases whose
    traces are kept are the report's worst three (failures by severity, then the largest
    upward speed, the earlier case first among equals)."""
    import random

    limits = {"max_ascent_velocity_ms": 0.6}

    def answer(outcome, up):
        return {"outcome": outcome, "up_ms": up, "status": "completed", "criteria": {},
                "headline": {"max_ascent_velocity_ms": up}, "validity_end_s": None}

    sets = [[answer("safe", 0.2), answer("unsafe", 0.5), answer("safe", 0.3),
             answer("unsafe", 0.5), answer("not_achieved", 0.1), answer("unsafe", 0.5)],
            [answer("safe", 0.3), answer("safe", 0.2), answer("safe", 0.3),
             answer("incomplete", 0.3), answer("safe", 0.1)],
            [answer("unsafe", 0.4), answer("safe", 0.7), answer("unsafe", 0.4)]]
    rng = random.Random(7)
    for given in sets:
        rows = [{"index": i, "answer": a} for i, a in enumerate(given)]
        fails = [r for r in rows if r["answer"]["outcome"] not in R.SURVIVED]
        fails.sort(key=lambda r: R.severity(r["answer"], [], limits), reverse=True)
        summary = {"cases": rows, "failures": [r["index"] for r in fails]}
        for _ in range(5):
            worst = R.Worst(3, "m", [], limits)
            for i in rng.sample(range(len(given)), len(given)):
                worst.offer(i, given[i], {"m": {"time": np.zeros(1)}})
            assert [i for _, i, _ in worst.kept] == R.worst_cases(summary), given


def test_the_command_starts_its_workers_fork_server_first(monkeypatch):
    """``flexlift contingency`` starts the fork server before its own imports, as ``flexlift
    sweep`` does (the workers' warm-up runs meanwhile); other commands do not."""
    from flexlift import cli
    from flexlift.sweep import executors

    seen = []
    monkeypatch.setattr(executors, "start_early", lambda words: seen.append(list(words)))
    assert cli.main(["contingency", "--help"]) == 0
    assert cli.main(["simulate", "--help"]) == 0
    assert seen == [["contingency", "--help"]]
