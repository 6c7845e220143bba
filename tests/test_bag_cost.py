"""The cost of many bags: the recorded rows' static correction of the eliminated modes kept
factored (no bags x bags product), checked against the dense matrices built from the modes."""

from __future__ import annotations

import numba
import numpy as np
import pytest

from flexlift import load_scenario
from flexlift.ascent import kernel
from flexlift.ascent.loop import Ascent
from flexlift.ascent.plant import coupled_plant, layout


@pytest.fixture(scope="module")
def many_bags():
    """The tanker on 50 t catalogue bags (73 bags), and its plant."""
    sc = load_scenario("tanker").with_changes(**{
        "lift.layout": "balanced", "lift.internal_bags": 0, "lift.catalogue_bag": {"lift_t": 50}})
    return sc, coupled_plant(sc)


def test_plant_keeps_no_bags_by_bags_matrix(many_bags):
    _, P = many_bags
    nb, ne = P.bags.nb, P.modes.n_modes - P.modal.nr
    assert nb > 50 and 0 < ne < nb
    for name, arr in P.bags._asdict().items():
        if isinstance(arr, np.ndarray) and arr.ndim == 2:
            assert arr.shape != (nb, nb), name


def test_recorded_row_matches_dense_correction(many_bags):
    """store_row's heights and slopes with the factored correction equal those of the dense
    (nb, ns) and (nb, nb) correction matrices built from all the modes, to 1e-12."""
    sc, P = many_bags
    nr = P.modal.nr
    lay = layout(sc, P.hull, P.plan, P.modes)
    om2_e = P.modes.omega[nr:] ** 2
    scaled_z, scaled_s = lay.psi_p[:, nr:] / om2_e, lay.dpsi_p[:, nr:] / om2_e
    strip_e, bag_e = lay.strip_gen[nr:], lay.psi_b[:, nr:].T
    dense = {"z_strip": scaled_z @ strip_e, "z_bag": scaled_z @ bag_e,
             "s_strip": scaled_s @ strip_e, "s_bag": scaled_s @ bag_e}
    assert dense["z_bag"].shape == (P.bags.nb, P.bags.nb)
    run = Ascent(sc, P, "decentralized", 60.0, "table", share=False)  # a loop bag per bag
    st = run.state
    rng = np.random.default_rng(7)
    st.q[:] = 0.0  # at rest: the row's heights are the correction alone, read to 1e-12
    st.z[:] = 0.0
    st.line[:] = rng.normal(0.0, 2e4, st.line.size)
    st.contact[:] = rng.normal(0.0, 1e4, st.contact.size)
    st.point[:] = rng.normal(4e5, 1e5, st.point.size)
    r = int(run.recorder.counts[0])
    kernel.final_row(12.5, run.inputs())
    row = run.recorder.bag[r]
    line = st.line + st.contact
    z = st.z + P.bags.corr_weight + dense["z_strip"] @ line + dense["z_bag"] @ st.point
    slope = (P.bags.slope @ st.q + P.bags.slope_weight + dense["s_strip"] @ line
             + dense["s_bag"] @ st.point)
    assert np.abs(z - P.bags.corr_weight).max() > 1e-6  # the loads' part is there to check
    np.testing.assert_allclose(row[0], z, rtol=0, atol=1e-12 * np.abs(z).max())
    np.testing.assert_allclose(row[2], slope, rtol=0, atol=1e-12 * np.abs(slope).max())


def test_one_blas_thread_inside_and_restored_after():
    import scipy.optimize  # noqa: F401  (its OpenBLAS loaded too)
    from threadpoolctl import threadpool_limits

    from flexlift._threads import blas_threads, one_blas_thread

    if not blas_threads():
        pytest.skip("no BLAS loaded in this process")
    with threadpool_limits(limits=2, user_api="blas"):
        n = len(blas_threads())
        with one_blas_thread():
            assert blas_threads() == [1] * n
        assert blas_threads() == [2] * n


def test_sweep_workers_run_one_blas_thread_and_leave_this_process_alone():
    import os

    from flexlift._threads import blas_threads
    from flexlift.sweep.executors import Processes

    env_before = dict(os.environ)
    pool = Processes(1)
    try:
        assert pool.submit(os.getenv, "OPENBLAS_NUM_THREADS").result(timeout=300) == "1"
        counts = pool.submit(blas_threads).result(timeout=120)
    finally:
        pool.close()
    assert counts and set(counts) == {1}
    assert dict(os.environ) == env_before


def test_benchmark_scenario_gives_the_documented_bag_counts():
    """benchmarks/bags_tanker.yaml with the catalogue bags of benchmarks/bench_bags.py."""
    from pathlib import Path

    from flexlift.loads.liftplan import plan_lift
    from flexlift.structure.hull import hull_from_scenario

    path = Path(__file__).resolve().parents[1] / "benchmarks" / "bags_tanker.yaml"
    base = load_scenario(path)
    hull = hull_from_scenario(base)
    counts = {}
    for lift_t in (565.0, 150.0, 50.0, 20.0, 10.0):
        plan = plan_lift(base.with_changes(**{"lift.catalogue_bag.lift_t": lift_t}), hull)
        assert all(b.kind == "external" for b in plan.bags)
        counts[lift_t] = len(plan.bags)
    assert counts == {565.0: 7, 150.0: 25, 50.0: 73, 20.0: 181, 10.0: 362}


@pytest.mark.skipif(numba.config.DISABLE_JIT, reason="NUMBA_DISABLE_JIT: nothing is allocated")
def test_a_step_and_its_recorded_row_allocate_nothing(many_bags):
    """The compiled loop allocates per call (its structs), never per step: 40 steps with a
    row recorded at each allocate what 20 do (numba's allocation counts). A row's static
    correction works in the state's row scratch (``row_line``, ``row_force``) and the row."""
    from numba.core.runtime import _nrt_python, rtsys

    sc, P = many_bags
    sc = sc.with_changes(**{"simulation.output_interval_s": sc.simulation.time_step_s})
    run = Ascent(sc, P, "decentralized", 60.0, "table", share=False)

    def allocations(n):
        k = int(run.state.counters[0])
        before = rtsys.get_allocation_stats().mi_alloc
        kernel.advance(run.inputs(), k + n)
        assert run.state.counters[0] == k + n
        return rtsys.get_allocation_stats().mi_alloc - before

    was_on = _nrt_python.memsys_stats_enabled()
    _nrt_python.memsys_enable_stats()  # as NUMBA_NRT_STATS=1 would
    try:
        allocations(5)
        rows = int(run.recorder.counts[0])
        twenty, forty = allocations(20), allocations(40)
    finally:
        if not was_on:
            _nrt_python.memsys_disable_stats()
    assert int(run.recorder.counts[0]) - rows == 60  # a row every step
    assert forty == twenty


def test_a_row_reuses_the_last_rows_line_forces_only_for_the_same_line_to_the_bit(many_bags):
    """store_row keeps the eliminated modes' generalised forces of the last row's line
    (``F_ROW_LINE``): a row of the same line to the bit reuses them (spoilt here to NaN to
    see it); a line one bit apart in one strip, or a zero of the other sign, is computed
    again (the dense correction's row)."""
    from flexlift.ascent.state import F_ROW_LINE

    sc, P = many_bags
    run = Ascent(sc, P, "decentralized", 60.0, "table", share=False)
    st, rec = run.state, run.recorder
    rng = np.random.default_rng(3)
    st.q[:] = 0.0
    st.z[:] = 0.0
    st.point[:] = rng.normal(4e5, 1e5, st.point.size)

    def row():
        r = int(rec.counts[0])
        kernel.final_row(12.5, run.inputs())
        return rec.bag[r, 0].copy()

    # the first row computes its forces, whatever the scratch holds (a line of zeros, as the
    # scratch's line starts)
    assert not st.counters[1] & F_ROW_LINE
    st.row_force[0][:] = np.nan
    assert np.isfinite(row()).all()
    st.line[:] = rng.normal(0.0, 2e4, st.line.size)
    st.contact[:] = rng.normal(0.0, 1e4, st.contact.size)
    st.line[0], st.contact[0] = -0.0, -0.0  # the first strip's line load: -0.0
    first = row()
    assert st.counters[1] & F_ROW_LINE and np.isfinite(first).all()
    np.testing.assert_array_equal(row(), first)  # the same line: the same row
    st.row_force[0][:] = np.nan
    assert np.isnan(row()).all()  # ... from the kept forces
    s = int(np.argmax(np.abs(P.bags.gen_strip).sum(0)))
    st.line[s] = np.nextafter(st.line[s], np.inf)  # one bit
    again = row()
    assert np.isfinite(again).all()
    st.row_force[0][:] = np.nan
    st.contact[0] = 0.0  # -0.0 + 0.0 = +0.0: the same value, the other sign
    np.testing.assert_array_equal(row(), again)
