"""A plan of a hundred real bags: its report and output folder read by lift point, not by bag
(legends of a dozen entries at most, every bag's numbers in the CSV, no file written twice,
the grouped figures holding the same numbers as the per-bag data)."""

import csv
import hashlib
import signal
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pytest
from matplotlib.collections import PolyCollection

from flexlift.output.liftpoints import lift_points
from flexlift.output.plots import _style, ascent
from flexlift.output.plots.groups import MAX_LEGEND
from flexlift.output.results import load_netcdf, netcdf_modes

MODES = ("decentralized", "coordinated")


def _legend_entries(fig) -> int:
    """The most entries of any legend of the figure (axes, inset axes and figure legends)."""
    axes = list(fig.axes) + [c for ax in fig.axes for c in ax.child_axes]
    legends = [ax.get_legend() for ax in axes] + list(fig.legends)
    return max((len(lg.get_texts()) for lg in legends if lg is not None), default=0)


@pytest.fixture(scope="module")
def hundred(tmp_path_factory, tanker):
    """``flexlift run``'s stages on the tanker planned with 36.5 t catalogue bags (100 bags at
    10 lift points; bag_2's supply fails), 400 s of the run, every figure drawn here and its
    legends counted."""
    from flexlift.output.report import render_report
    from flexlift.stages.run import run_all

    sc = tanker.with_changes(**{"lift.layout": "balanced", "lift.internal_bags": 0,
                                "lift.catalogue_bag.lift_t": 36.5,
                                "simulation.duration_s": 400.0,
                                # one bag of the aft cluster gets no gas: its cluster spreads
                                "faults": [{"kind": "supply_failure", "bag": "bag_2",
                                            "time_s": 1.0}]})
    out = tmp_path_factory.mktemp("hundred")
    legends: dict[str, int] = {}
    real_save = _style.save

    def counting_save(fig, path):
        legends[Path(path).name] = _legend_entries(fig)
        return real_save(fig, path)

    mp = pytest.MonkeyPatch()
    mp.setenv(_style.PROCESSES_ENV, "0")  # every figure in this process, through save()
    mp.setattr(_style, "save", counting_save)
    signal.alarm(900)  # a hang fails instead of blocking the suite
    try:
        outputs = run_all(sc, out)
        (out / "report.html").write_text(render_report(sc, outputs))
    finally:
        signal.alarm(0)
        mp.undo()
    return sc, out, outputs, legends


def test_the_plan_has_a_hundred_bags(hundred):
    _, out, _, _ = hundred
    ds = load_netcdf(out / "results.nc").dataset
    assert ds.bag.size == 100 and len(lift_points(ds)) == 10
    assert netcdf_modes(out / "results.nc") == list(MODES)


def test_every_legend_within_the_limit(hundred):
    _, out, _, legends = hundred
    assert set(legends) == {p.name for p in (out / "figures").glob("*.png")}
    too_long = {k: v for k, v in legends.items() if v > MAX_LEGEND}
    assert not too_long, too_long


def test_a_legend_of_many_lift_points_lists_the_styles_only(hundred):
    """30 lift points (built from the run's dataset): the legend names styles, not points,
    and the colour bar is in metres."""
    _, out, _, _ = hundred
    r = load_netcdf(out / "results.nc")
    ds = r.dataset.isel(bag=np.arange(30) % r.dataset.bag.size)
    ds = ds.assign_coords(bag=[f"bag_{k}" for k in range(1, 31)])
    ds["bag_x"] = ("bag", np.linspace(0.0, 78.0, 30))
    fig = ascent.bag_histories(type(r)(ds))
    assert 0 < _legend_entries(fig) <= 3
    bar = fig.axes[0].child_axes[0]
    assert "[m]" in bar.get_ylabel()
    plt.close(fig)


def _rows(path: Path) -> list[dict]:
    with path.open() as f:
        return list(csv.DictReader(f))


def test_every_bag_in_the_csv(hundred):
    _, out, _, _ = hundred
    ds = load_netcdf(out / "results.nc").dataset
    bags = [str(b) for b in ds.bag.values]
    points = {b: p.label for p in lift_points(ds) for b in p.bags}
    assert [r["bag"] for r in _rows(out / "tables" / "reduce_comparison.csv")] == [
        b for b in bags for _ in range(4)]
    gains = next(csv.reader((out / "tables" / "reduce_gains.csv").open()))
    assert gains[3:] == [f"{b} [m/N]" for b in bags]
    for mode in MODES:
        rows = _rows(out / "tables" / f"simulate_{mode}_bags.csv")
        assert [r["bag"] for r in rows] == bags
        assert all(r["lift point"] == points[r["bag"]] for r in rows)
        head = next(csv.reader((out / "tables" / f"simulate_{mode}_time_histories.csv").open()))
        for label in set(points.values()):
            assert f"height_{label}_mean [m]" in head and f"gas_volume_{label}_mean [m3]" in head


def test_no_file_written_twice(hundred):
    _, out, _, _ = hundred
    seen: dict[str, Path] = {}
    for p in sorted(out.rglob("*")):
        if p.is_file():
            digest = hashlib.sha256(p.read_bytes()).hexdigest()
            assert digest not in seen, (p, seen.get(digest))
            seen[digest] = p
    assert not (out / "data").exists()


def test_grouped_figure_and_csv_hold_the_per_bag_numbers(hundred):
    """The bag figure's line and band of each lift point (heights over the whole run, net
    flow in the zoom window), and the CSV's columns, against the per-bag data in results.nc."""
    _, out, _, _ = hundred
    for mode in MODES:
        r = load_netcdf(out / "results.nc", mode)
        ds = r.dataset
        points = lift_points(ds)
        fig = ascent.bag_histories(r)
        t = ds.time.values
        for ax, name in ((fig.axes[0], "height"), (fig.axes[5], "net_flow")):
            x0 = ax.get_lines()[0].get_xdata()
            rows = np.flatnonzero((t >= x0[0]) & (t <= x0[-1]))
            lines = {ln.get_label(): ln for ln in ax.get_lines()}
            bands = iter(c for c in ax.collections if isinstance(c, PolyCollection))
            for p in points:
                per_bag = ds[name].values[rows][:, p.index]
                np.testing.assert_allclose(lines[p.label].get_ydata(), per_bag.mean(axis=1),
                                           rtol=1e-12, atol=1e-15, err_msg=f"{name} {p.label}")
                if p.count > 1:
                    y = next(bands).get_paths()[0].vertices[:, 1]
                    assert y.min() == pytest.approx(per_bag.min(), abs=1e-12)
                    assert y.max() == pytest.approx(per_bag.max(), abs=1e-12)
            assert next(bands, None) is None  # a band for each cluster, no other
        aft = points[0]
        assert "bag_2" in aft.bags and np.ptp(ds.gas_volume.values[:, aft.index], axis=1).max() > 0.1
        plt.close(fig)
        rows = _rows(out / "tables" / f"simulate_{mode}_time_histories.csv")
        table = {k: np.array([float(r[k] or "nan") for r in rows]) for k in rows[0]}
        for p in points:
            for name in ("height", "gas_volume"):
                unit = ds[name].attrs["units"]
                col = f"{name}_{p.label}_mean [{unit}]" if p.count > 1 else f"{name}_{p.label} [{unit}]"
                np.testing.assert_allclose(table[col], ds[name].values[:, p.index].mean(axis=1),
                                           rtol=5.01e-6, atol=1e-12)  # %.6g
            if p.count > 1:
                np.testing.assert_allclose(table[f"height_{p.label}_max [m]"],
                                           ds.height.values[:, p.index].max(axis=1),
                                           rtol=5.01e-6)


def test_report_by_lift_point(hundred):
    """The page holds lift-point rows and the worst reduction per method, not a row per bag."""
    _, out, outputs, _ = hundred
    text = (out / "report.html").read_text()
    assert "Lift points (decentralized): 10 point(s), 100 bag(s)" in text
    reduce = next(o for o in outputs if o.name == "reduce")
    worst = reduce.tables[0]
    assert worst.in_report and len(worst.rows) == 4
    assert reduce.summary["distinct_models"] == 10
    assert all(not t.in_report for t in reduce.tables[1:])
    for o in outputs:
        if o.name.startswith("simulate:"):
            events = o.tables[0]
            assert len(events.rows) <= 4 * 10 + 10  # merged by lift point
            points = next(t for t in o.tables if t.title.startswith("Lift points"))
            assert len(points.rows) == 10 and sum(r[3] for r in points.rows) == 100


def test_results_nc_round_trip_modes_of_different_lengths(tanker, tmp_path):
    """Each mode read back as simulated: shorter runs padded with NaN in the file only; the
    state variables exact, the float32 ones to float32."""
    from flexlift.ascent import simulate
    from flexlift.output.modesfile import FLOAT32_VARS
    from flexlift.output.results import add_to_netcdf

    runs = [simulate(tanker, control=m, duration=d) for m, d in zip(MODES, (90.0, 60.0))]
    for r in runs:
        add_to_netcdf(r, tmp_path / "r.nc")
    add_to_netcdf(runs[1], tmp_path / "r.nc")  # a mode written again replaces itself
    assert netcdf_modes(tmp_path / "r.nc") == list(MODES)
    for r in runs:
        back = load_netcdf(tmp_path / "r.nc", r.control).dataset
        assert back.sizes == r.dataset.sizes and back.attrs == r.dataset.attrs
        for name, v in r.dataset.variables.items():
            want = v.values.astype(np.float32) if name in FLOAT32_VARS else v.values
            np.testing.assert_array_equal(back[name].values, want, err_msg=name)
            assert back[name].dtype == v.dtype, name
    n0, n1 = runs[0].dataset.time.size, runs[1].dataset.time.size
    assert n0 > n1
    import xarray as xr

    with xr.open_dataset(tmp_path / "r.nc", engine="scipy") as f:
        assert f.sizes["row"] == n0 and list(f["rows"].values) == [n0, n1]
        assert np.isnan(f["height"].values[1, n1:]).all()  # the shorter run padded with NaN
        assert np.isfinite(f["height"].values[1, :n1]).all()
        assert f["height"].dtype == np.float64 and f["pitch_rate"].dtype == np.float32


def test_results_nc_stores_a_cluster_once_and_reads_every_bag_back(tanker, tmp_path):
    """Bags of one lift point with equal histories are stored once per point; one that
    differs (a bag's gas, here) keeps its column per bag; every bag reads back exactly."""
    import xarray as xr

    from flexlift.ascent import simulate
    from flexlift.ascent.result import Result
    from flexlift.output.modesfile import FLOAT32_VARS
    from flexlift.output.results import save_netcdf

    r = simulate(tanker, duration=60.0)
    take = [0, 0, 0, 1, 1, 2, 3, 4, 5, 6]  # clusters of 3 and 2 at the first two points
    ds = r.dataset.isel(bag=take).assign_coords(bag=[f"bag_{k}" for k in range(1, 11)])
    gas = ds.gas_volume.values.copy()
    gas[-1, 1] += 1e-9  # one bit of one bag of the first cluster
    ds["gas_volume"] = (ds.gas_volume.dims, gas, ds.gas_volume.attrs)
    clustered = Result(ds)
    save_netcdf([clustered], tmp_path / "r.nc")
    with xr.open_dataset(tmp_path / "r.nc", engine="scipy") as f:
        assert f.sizes["point"] == 7 and f["height"].dims == ("mode", "row", "point")
        assert f["gas_volume"].dims == ("mode", "row", "bag")
        assert list(f["bag_point"].values) == [0, 0, 0, 1, 1, 2, 3, 4, 5, 6]
    back = load_netcdf(tmp_path / "r.nc").dataset
    for name, v in ds.variables.items():
        want = v.values.astype(np.float32) if name in FLOAT32_VARS else v.values
        np.testing.assert_array_equal(back[name].values, want, err_msg=name)
        assert back[name].dims == v.dims and back[name].attrs == v.attrs, name


def test_seven_bags_events_and_columns_as_before(tanker):
    """The tanker's lift points are its seven bags: its event rows and CSV columns are those
    of one bag each, as they were before lift points."""
    from flexlift.ascent import simulate
    from flexlift.ascent.result import BAG_VARS
    from flexlift.output.liftpoints import point_columns
    from flexlift.output.pointtables import event_rows

    r = simulate(tanker, duration=60.0)
    assert [p.count for p in lift_points(r.dataset)] == [1] * 7
    assert event_rows(r) == [[e["time_s"], e["kind"], e["bag"] or "", e.get("detail", "")]
                             for e in r.events]
    cols = [c for c, _ in point_columns(r.dataset, list(BAG_VARS))]
    assert cols == [f"{n}_{b} [{r.dataset[n].attrs['units']}]" for n in BAG_VARS
                    for b in r.dataset.bag.values]


def test_events_of_a_cluster_merge_into_one_row(hundred):
    """An arrival of each of the 100 bags (written into the run's dataset) makes one row per
    lift point, at its first bag's time, saying how many and the last time."""
    import json

    from flexlift.ascent.result import Result
    from flexlift.output.pointtables import event_rows

    _, out, _, _ = hundred
    ds = load_netcdf(out / "results.nc").dataset.copy()
    bags = [str(b) for b in ds.bag.values]
    events = [{"time_s": 1000.0 + k, "kind": "arrival", "bag": b} for k, b in enumerate(bags)]
    ds.attrs["events"] = json.dumps([{"time_s": 10.0, "kind": "separation", "bag": None}] + events)
    rows = event_rows(Result(ds))
    points = lift_points(ds)
    assert len(rows) == 1 + len(points)
    assert rows[0][:3] == [10.0, "separation", ""]
    for p in points:
        row = next(r for r in rows if r[2] == p.label)
        first, last = 1000.0 + p.index.min(), 1000.0 + p.index.max()
        assert row[0] == first and row[1] == "arrival"
        if p.count > 1:
            assert row[3] == f"{p.count} bags, the last at {last:.1f} s"
    # a fault on one bag of a lift point names that bag, not the point's range of bags; two
    # events of one bag: that bag, with the count
    big = next(p for p in points if p.count > 1)
    one, other = bags[big.index[1]], bags[big.index[2]]
    ds.attrs["events"] = json.dumps([
        {"time_s": 900.0, "kind": "bag_rupture", "bag": one, "detail": "leak_time_s 5"},
        {"time_s": 950.0, "kind": "sensor_freeze", "bag": other, "detail": ""},
        {"time_s": 990.0, "kind": "sensor_freeze", "bag": other, "detail": ""}])
    assert event_rows(Result(ds)) == [
        [900.0, "bag_rupture", one, "leak_time_s 5"],
        [950.0, "sensor_freeze", other, "1 bag, 2 events, the last at 990.0 s"]]
    # every bag arriving in the same step, the bow's first in the log: one row per lift
    # point, after the structure's event at that time, aft to bow
    ds.attrs["events"] = json.dumps(
        [{"time_s": 2000.0, "kind": "arrival", "bag": b} for b in reversed(bags)]
        + [{"time_s": 2000.0, "kind": "liftoff", "bag": None}])
    rows = event_rows(Result(ds))
    assert rows[0][:3] == [2000.0, "liftoff", ""]
    assert [r[2] for r in rows[1:]] == [p.label for p in sorted(points, key=lambda p: p.x)]


def test_results_nc_modes_with_other_bags_and_no_strength_grid(tanker, tmp_path):
    """The paper's plant has the four external bags only and no strength grid: in one file
    with a seven-bag mode, each reads back with its own bags and variables."""
    from flexlift.ascent import simulate
    from flexlift.output.modesfile import FLOAT32_VARS
    from flexlift.output.results import save_netcdf

    runs = [simulate(tanker, control=m, duration=d) for m, d in (("paper", 50.0),
                                                                 ("decentralized", 70.0))]
    assert runs[0].dataset.bag.size == 4 and "x" not in runs[0].dataset.coords
    save_netcdf(runs, tmp_path / "r.nc")
    for r in runs:
        back = load_netcdf(tmp_path / "r.nc", r.control).dataset
        assert back.sizes == r.dataset.sizes and set(back.variables) == set(r.dataset.variables)
        for name, v in r.dataset.variables.items():
            want = v.values.astype(np.float32) if name in FLOAT32_VARS else v.values
            np.testing.assert_array_equal(back[name].values, want, err_msg=name)
            assert back[name].dtype == v.dtype and back[name].dims == v.dims, name


def test_many_bags_are_listed_by_lift_point_on_the_page_and_every_bag_in_the_csv():
    """The loads page lists lift points once there are more than a dozen bags (the trawler:
    21 bags at 9 points); the CSV keeps a row per bag; the totals agree."""
    from pathlib import Path

    from flexlift import load_scenario
    from flexlift.stages.loads import MAX_BAG_ROWS, bag_table, run_stage

    trawler = load_scenario(Path(__file__).parent / "data" / "trawler.yaml")
    out = run_stage(trawler)
    page, every = out.tables[0], bag_table(out.summary)
    assert len(every.rows) > MAX_BAG_ROWS and page.title.startswith("Lift points")
    assert sum(r[2] for r in page.rows) == len(every.rows)
    assert sum(r[7] for r in page.rows) == pytest.approx(sum(r[6] for r in every.rows), abs=0.1)
    assert len(page.rows) < len(every.rows)
