"""Several runs advanced together in one compiled call per chunk (ascent/batch.py) give the
numbers of the same runs one by one, to the last bit."""

import numpy as np
import pytest

from flexlift import load_scenario
from flexlift.ascent import simulate
from flexlift.ascent.batch import run_batch
from flexlift.ascent.loop import prepare
from flexlift.scenario.schema import parse_scenario

TRAWLER = "tests/data/trawler.yaml"


def _variants():
    """Three runs of different bag counts, a fault and a control mode: the tanker
    coordinated, the tanker decentralized with a bag ruptured, the 21-bag trawler."""
    tanker = load_scenario("tanker")
    faulted = parse_scenario({**tanker.model_dump(mode="json", exclude_unset=True),
                              "faults": [{"kind": "bag_rupture", "bag": "bag_3",
                                          "time_s": 400.0}]})
    return [(tanker, "coordinated"), (faulted, "decentralized"),
            (load_scenario(TRAWLER), None)]


@pytest.fixture(scope="module")
def alone_and_together():
    runs = _variants()
    alone = [simulate(s, control=c, duration=1500.0, summary_only=True) for s, c in runs]
    together = run_batch([prepare(s, control=c, duration=1500.0) for s, c in runs])
    return alone, together


def test_a_batch_gives_each_runs_own_numbers_to_the_last_bit(alone_and_together):
    alone, together = alone_and_together
    for one, batch in zip(alone, together):
        assert one.headline == batch.headline
        assert one.criteria == batch.criteria
        assert one.events == batch.events
        names = one.dataset.variables
        assert set(names) == set(batch.dataset.variables) and "height" in names
        for name in names:
            a, b = one.dataset[name].values, batch.dataset[name].values
            same = np.array_equal(a, b, equal_nan=a.dtype.kind == "f")
            assert a.shape == b.shape and same, name


def test_the_faulted_run_of_a_batch_has_its_fault_and_the_others_not(alone_and_together):
    _, together = alone_and_together
    faults = [[e["bag"] for e in r.events if e["kind"] == "bag_rupture"] for r in together]
    assert faults == [[], ["bag_3"], []]
    assert together[0].headline != together[1].headline


def test_an_empty_batch_is_an_empty_answer():
    assert run_batch([]) == []


def test_runs_of_one_numba_type_share_each_compiled_call(monkeypatch):
    """Any bag count, fault or control mode: one call per chunk holds every run still going."""
    from flexlift.ascent import batch, kernel

    sizes = []

    def counted(loops, k_stops, codes):
        sizes.append(len(loops))
        kernel.advance_many(loops, k_stops, codes)

    monkeypatch.setattr(batch, "kernel", type("K", (), {
        "advance_many": staticmethod(counted), "loops_of": staticmethod(kernel.loops_of),
        "loops_append": staticmethod(kernel.loops_append)}))
    runs = [prepare(s, control=c, duration=300.0) for s, c in _variants()]
    run_batch(runs)
    assert sizes and sizes[0] == 3 and max(sizes) == 3


def test_a_runs_numba_type_is_found_once_and_again_when_a_record_is_replaced(monkeypatch):
    """batch.loop_type: numba.typeof walks the inputs only when one of the run's seven
    records is a new object; the type it gives is numba's own."""
    import numba

    from flexlift.ascent import batch

    calls = []

    def counted(value):
        calls.append(1)
        return numba.typeof(value)

    monkeypatch.setattr(batch, "numba", type("N", (), {"typeof": staticmethod(counted)}))
    run = prepare(load_scenario("tanker"), duration=60.0)
    first = batch.loop_type(run)[1]
    assert first == numba.typeof(run.inputs()) and len(calls) == 1
    assert batch.loop_type(run)[1] is first and len(calls) == 1  # nothing replaced
    # a record replaced by one whose arrays are of another type: found again, not the stale
    run.state = type(run.state)(*[a.astype(np.float32) if isinstance(a, np.ndarray)
                                  and a.dtype == np.float64 else a for a in run.state])
    again = batch.loop_type(run)[1]
    assert len(calls) == 2 and again != first and again == numba.typeof(run.inputs())


def test_a_batchs_list_is_made_by_the_cached_loop_not_numbas_own_methods():
    """The typed List of a batch is made and filled in compiled code cached with the loop
    (kernel.loops_of, kernel.loops_append): made from Python, numba compiled its List's
    methods for the loop inputs' type afresh in every process, about 6 s at the first batch
    of every replay, live estimate or design. In a fresh process, after a batch, numba's own
    append has compiled nothing."""
    import json
    import subprocess
    import sys

    code = """
import json
from numba.typed import typedlist
from flexlift import load_scenario
from flexlift.ascent.batch import advance_batch
from flexlift.ascent.loop import prepare
tanker = load_scenario("tanker")
runs = [prepare(tanker, "decentralized", 60.0, share=False) for _ in range(2)]
for run in runs:
    run.start()
advance_batch(runs, 101)
print(json.dumps({"append": len(typedlist._append.overloads),
                  "steps": [int(run.state.counters[0]) for run in runs]}))
"""
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         timeout=600, check=True)
    seen = json.loads(out.stdout.strip().splitlines()[-1])
    assert seen == {"append": 0, "steps": [101, 101]}, seen
