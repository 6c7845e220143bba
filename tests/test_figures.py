"""The report's figures: what they draw (phase, loads, windows, labels), not only that a PNG
appears. Each figure is built by the function the stages call and inspected through
matplotlib's own objects (lines, texts and their drawn extents)."""

import itertools

import matplotlib.pyplot as plt
import numpy as np
import pytest

from flexlift.output.plots import ascent
from flexlift.output.plots._style import prepare
from flexlift.output.plots.loads import load_diagram, shear_moment_figure
from flexlift.output.plots.reduce import bode_phase, plot_bode, plot_gains, plot_time


def _drawn(fig):
    """Lay out (as the saver does) and draw ``fig``; return its renderer."""
    prepare(fig)
    fig.canvas.draw()
    return fig.canvas.get_renderer()


def _texts_inside(fig, renderer):
    """Every visible, non-empty text of the figure lies inside the figure (no label cut off
    by the fixed margins)."""
    W, H = fig.bbox.width, fig.bbox.height
    unseen = set()  # tick labels beyond an axis's view are not drawn
    for ax in fig.axes:
        for axis in (ax.xaxis, ax.yaxis):
            lo, hi = sorted(axis.get_view_interval())
            tol = 1e-9 * max(abs(lo), abs(hi), 1.0)
            for tick in axis.get_major_ticks() + axis.get_minor_ticks():
                if not lo - tol <= tick.get_loc() <= hi + tol:
                    unseen |= {id(tick.label1), id(tick.label2)}
    bad = []
    for t in fig.findobj(plt.Text):
        if not t.get_visible() or not t.get_text().strip() or id(t) in unseen:
            continue
        bb = t.get_window_extent(renderer)
        if bb.x0 < -1 or bb.y0 < -1 or bb.x1 > W + 1 or bb.y1 > H + 1:
            bad.append((t.get_text()[:40], bb.bounds))
    assert not bad, bad
    _titles_clear(fig, renderer)


def _titles_clear(fig, renderer):
    """No axes title overlaps a drawn tick label, axis label or offset text of the figure."""
    titles = [t for ax in fig.axes for t in (ax.title, ax._left_title, ax._right_title)
              if t.get_text()]
    others = []
    for ax in [c for a in fig.axes for c in (a, *a.child_axes)]:  # secondary axes too
        for axis in (ax.xaxis, ax.yaxis):
            lo, hi = sorted(axis.get_view_interval())
            others += [tk.label1 for tk in axis.get_major_ticks()
                       if lo <= tk.get_loc() <= hi and tk.label1.get_visible()]
            others += [tk.label2 for tk in axis.get_major_ticks()
                       if lo <= tk.get_loc() <= hi and tk.label2.get_visible()]
            others += [axis.label, axis.offsetText]
    for t in titles:
        tb = t.get_window_extent(renderer)
        for o in others:
            if o.get_visible() and o.get_text().strip():
                assert not tb.overlaps(o.get_window_extent(renderer)), (t.get_text(), o.get_text())


# ----------------------------------------------------------------------------- Bode phase
def test_phase_of_one_damped_mode_falls_monotonically_to_minus_180():
    w = np.geomspace(0.01, 100.0, 2000)
    G = 1.0 / (1.0 - w**2 + 2j * 0.02 * w)
    ph = bode_phase(G)
    assert ph[0] == pytest.approx(0.0, abs=0.1) and ph[-1] == pytest.approx(-180.0, abs=0.1)
    assert np.all(np.diff(ph) <= 1e-9)


def test_phase_of_three_modes_goes_on_below_minus_180_without_jumps():
    w = np.geomspace(0.01, 100.0, 4000)
    G = 1.0 / ((1.0 - w**2 + 0.04j * w) * (4.0 - w**2 + 0.08j * w) * (9.0 - w**2 + 0.12j * w))
    ph = bode_phase(G)
    assert ph[-1] == pytest.approx(-540.0, abs=0.5)  # np.angle alone would wrap twice
    assert np.all(np.diff(ph) <= 1e-9) and np.abs(np.diff(ph)).max() < 30


def test_undamped_sign_change_rises_through_a_zero_and_falls_through_a_pole():
    w = np.geomspace(0.1, 10.0, 1001)
    # a reduced model's rigid part plus its mdc feedthrough: real, through zero at w = 1
    ph = bode_phase(-1.0 / w**2 + 1.0 + 0j)
    assert ph[0] == pytest.approx(-180.0) and ph[-1] == pytest.approx(0.0)
    assert np.all(np.diff(ph) >= 0)
    # an undamped mode: real, through a pole at w = 2 (not on a grid point)
    ph = bode_phase(1.0 / (4.0 - w**2) + 0j)
    assert ph[0] == pytest.approx(0.0) and ph[-1] == pytest.approx(-180.0)
    assert np.all(np.diff(ph) <= 0)


@pytest.fixture(scope="module")
def bag_models(tanker, tanker_modes, tanker_plan):
    from flexlift.dynamics.reduce import band_grid, reduce_all
    from flexlift.dynamics.statespace import bag_siso, default_omega_lo

    full = bag_siso(tanker_modes, tanker_plan.bag("bag_1"), 0.02, None, tanker_plan.bags)
    w_lo = default_omega_lo(full)
    return reduce_all(full, 2, w_lo), band_grid(full, w_lo / 2, 3000), w_lo


def test_bode_figure_of_the_tanker(bag_models):
    """Force to displacement at the same point (collocated): the full model's phase stays
    within [-180, 0] deg, poles and zeros alternating; the 2-mode del model is the rigid body
    alone (-180 throughout) and the mdc model rises once, through its zero, to 0."""
    models, w, _ = bag_models
    fig = plot_bode(models, w)
    phase = {line.get_label(): line.get_ydata() for line in fig.axes[1].lines}
    plt.close(fig)
    assert set(phase) >= {"full", "unsorted del", "unsorted mdc", "sorted mdc"}
    full = phase["full"]
    assert full.min() > -180.5 and full.max() < 0.5
    np.testing.assert_allclose(phase["unsorted del"], -180.0, atol=1e-6)
    mdc = phase["unsorted mdc"]
    assert mdc[0] == pytest.approx(-180.0) and mdc[-1] == pytest.approx(0.0, abs=1e-6)
    assert np.all(np.diff(mdc) >= -1e-9)


def test_gain_figure_names_modes_as_everywhere(bag_models):
    from flexlift.dynamics.statespace import mode_gains

    models, _, w_lo = bag_models
    full = models["full"]
    fig = plot_gains(full, mode_gains(full, w_lo), w_lo, "bag_1")
    labels = [t.get_text() for t in fig.axes[0].get_xticklabels()]
    assert labels[:5] == ["h", "p", "1", "2", "3"] and labels[-1] == "22"
    assert "heave, pitch" in fig.axes[0].get_xlabel()
    _texts_inside(fig, _drawn(fig))
    decades = [t.get_text() for t in fig.axes[0].get_yticklabels() if t.get_text()]
    assert "10⁻⁹" in decades and not any("$" in t for t in decades)  # plain text, no mathtext
    plt.close(fig)


def test_time_response_figure_fits(bag_models):
    models, _, _ = bag_models
    fig = plot_time(models, np.linspace(0.0, 2.0, 401))
    _texts_inside(fig, _drawn(fig))
    plt.close(fig)


# ----------------------------------------------------------------------------- load diagram
def _plan(scenario):
    from flexlift.loads.liftplan import plan_lift
    from flexlift.loads.strength import lift_load_case
    from flexlift.structure.hull import hull_from_scenario

    hull = hull_from_scenario(scenario)
    plan = plan_lift(scenario, hull)
    return hull, plan, lift_load_case(plan, hull)


def _bag_labels(fig):
    return [t for t in fig.findobj(plt.Text) if t.get_gid() == "bag-label"]


def _assert_no_overlap(texts, renderer):
    boxes = [(t.get_text(), t.get_window_extent(renderer)) for t in texts]
    for (a, ba), (b, bb) in itertools.combinations(boxes, 2):
        assert not ba.overlaps(bb), (a, b)


CROWDED = {"lift.bags": [
    {"name": "a", "kind": "external", "x_m": 10.0, "lift_t": 400.0, "count": 3},
    {"name": "b", "kind": "external", "x_m": 12.0, "lift_t": 400.0},
    {"name": "c", "kind": "external", "x_m": 14.5, "lift_t": 400.0},
    {"name": "d", "kind": "external", "x_m": 70.0, "lift_t": 400.0, "count": 2},
    {"name": "e", "kind": "internal", "span_m": [20.0, 23.0], "lift_t": 300.0},
    {"name": "f", "kind": "internal", "span_m": [23.0, 26.0], "lift_t": 300.0},
    {"name": "g", "kind": "internal", "span_m": [26.0, 60.0], "lift_t": 300.0},
]}


@pytest.mark.parametrize("changes", [{}, CROWDED], ids=["tanker", "crowded"])
def test_bag_labels_never_overlap(tanker, changes):
    hull, plan, case = _plan(tanker.with_changes(**changes))
    fig = load_diagram(hull, plan, case)
    renderer = _drawn(fig)
    labels = _bag_labels(fig)
    text = " ".join(t.get_text() for t in labels)
    for name in ("a_1..a_3", "3 × 400 t", "d_1..d_2", "b\n400 t", "e\n300 t", "g  300 t") \
            if changes else [f"bag_{k}" for k in range(1, 8)]:
        assert name in text
    _assert_no_overlap(labels, renderer)
    _texts_inside(fig, renderer)
    plt.close(fig)


def test_load_diagram_draws_the_real_weight(tanker):
    """A hull heavier in its middle elements with two point masses: the drawn load curve
    follows the load case's line load, each point mass is an arrow with its tonnes, and the
    totals add up to the required lift's weight."""
    mass = [30e3] * 3 + [60e3] * 5 + [30e3] * 3
    sc = tanker.with_changes(**{"lift.layout": "balanced",
                                "hull.displacement_t": None, "hull.mass_per_length_kg_m": mass,
                                "hull.point_masses": [{"node": 2, "mass_t": 300.0},
                                                      {"node": 10, "mass_t": 150.0}]})
    hull, plan, case = _plan(sc)
    g = plan.gravity
    fig = load_diagram(hull, plan, case)
    texts = [t.get_text() for t in fig.findobj(plt.Text)]
    point = sorted(t.get_text() for t in fig.findobj(plt.Text) if t.get_gid() == "point-mass-label")
    k = plan.breakout_factor * plan.wet_weight / plan.dry_weight
    assert point == sorted(f"{k * m:.0f} t" for m in (300.0, 150.0))
    total = -sum(d.resultant for d in case.line_loads if d.resultant < 0) - sum(
        p.force for p in case.point_loads if p.force < 0)
    summary = next(t for t in texts if t.startswith("downward"))
    assert f"= {total / (1e3 * g):.0f} t" in summary and "point masses" in summary
    distributed = -sum(d.resultant for d in case.line_loads if d.resultant < 0)
    assert f"distributed {distributed / (1e3 * g):.0f} t" in summary
    # the load curve: depth under the keel proportional to the line load
    curve = max(fig.axes[0].lines, key=lambda ln: len(ln.get_xdata()))
    x, y = curve.get_xdata(), curve.get_ydata()
    element = np.clip((x / hull.element_length).astype(int), 0, hull.n_elements - 1)
    depth = y.max() - y
    inner = np.abs(x[:, None] - hull.x_nodes[None, :]).min(axis=1) > 1e-6
    expected = np.array(mass)[element] / max(mass)
    np.testing.assert_allclose(depth[inner] / depth.max(), expected[inner], atol=1e-9)
    plt.close(fig)


def test_shear_moment_figure_fits(tanker):
    from flexlift.loads.strength import strength

    hull, plan, case = _plan(tanker)
    fig = shear_moment_figure(strength(case, hull, 20), hull, plan)
    _texts_inside(fig, _drawn(fig))
    plt.close(fig)


# ----------------------------------------------------------------------------- time histories
@pytest.fixture(scope="module")
def short(tanker):
    from flexlift.ascent import simulate

    sc = tanker.with_changes(**{"control.target_height_m": 20.0, "seabed.breakout_time_s": 60.0,
                                "simulation.hold_time_s": 30.0})
    return simulate(sc, duration=900.0)


def test_zoom_window_starts_a_minute_before_separation(short):
    sep = short.event_time("separation")
    t0, t1 = ascent.zoom_window(short)
    assert sep is not None and t0 == pytest.approx(sep - 60.0)
    assert t1 == pytest.approx(float(short.dataset.time.values[-1]))
    assert f"{t0:.0f} to {t1:.0f} s" in ascent.window_text(short)


def test_bag_histories_overview_then_zoom_in_seconds(short):
    fig = ascent.bag_histories(short)
    over, *zoomed = fig.axes
    t0, t1 = ascent.zoom_window(short)
    assert over.get_xlim() == pytest.approx((0.0, t1))
    assert len(zoomed) == 5
    for ax in zoomed:
        assert ax.get_xlim() == pytest.approx((t0, t1))
        t = ax.lines[0].get_xdata()
        assert t[0] <= t0 + 1.0 and t[-1] >= t1 - 1.0 and t[1] > t0 - 1.5
    assert over.get_xlabel() == zoomed[-1].get_xlabel() == "time [s]"
    labels = [t.get_text() for t in over.get_legend().get_texts()]
    assert labels == [f"bag_{k}" for k in range(1, 8)]
    _texts_inside(fig, _drawn(fig))
    plt.close(fig)


@pytest.mark.parametrize("name", ["hull_motion", "moment_map"])
def test_other_histories_use_seconds_and_the_window(short, name):
    fig = getattr(ascent, name)(short)
    t0, t1 = ascent.zoom_window(short)
    timed = [ax for ax in fig.axes if "time" in ax.get_xlabel() + ax.get_ylabel()]
    assert timed
    for ax in timed:
        assert "[s]" in ax.get_xlabel() + ax.get_ylabel()
        lim = ax.get_xlim() if "time" in ax.get_xlabel() else ax.get_ylim()
        assert lim[0] >= t0 - 15.0 and lim[1] <= t1 + 15.0
    _texts_inside(fig, _drawn(fig))
    plt.close(fig)


def test_never_separated_shows_the_whole_run(tanker):
    from flexlift.ascent import simulate

    r = simulate(tanker, duration=120.0)
    assert r.event_time("separation") is None
    assert ascent.zoom_window(r) == (0.0, pytest.approx(float(r.dataset.time.values[-1])))
    assert "never separated" in ascent.window_text(r)


# ----------------------------------------------------------------------------- modal figures
def test_mode_figures_say_flexible_mode(tanker_modes):
    from flexlift.output.plots.modes import plot_frequencies, plot_mode_shapes

    fig = plot_mode_shapes(tanker_modes, 5, highlight=3)
    ylabels = [ax.get_ylabel().splitlines()[0] for ax in fig.axes]
    assert ylabels == [f"flexible mode {k}" for k in range(1, 6)]
    assert fig.axes[2].get_ylabel().endswith("27.1 Hz")
    assert "the external bags sit here" in fig.axes[2].get_title(loc="right")
    _texts_inside(fig, _drawn(fig))
    plt.close(fig)
    fig = plot_frequencies(tanker_modes, None, 5)
    ax = fig.axes[0]
    assert ax.get_xlabel() == "flexible mode"
    assert list(ax.lines[0].get_xdata()) == [1, 2, 3, 4, 5]
    np.testing.assert_allclose(ax.lines[0].get_ydata(), tanker_modes.frequencies_hz[2:7])
    plt.close(fig)


def _fuzzy_figures():
    from flexlift.fuzzy.rulebase import fill_fis, supervisor_fis
    from flexlift.output.plots import fuzzy
    from flexlift.stages.fuzzy import grid_values

    fis = supervisor_fis()
    g = grid_values(fis, 21)
    u = np.array(g["u"])
    d = np.linspace(-1.0, 1.0, 101)
    return [fuzzy.plot_memberships(fis),
            fuzzy.plot_surface_contour(g["ze"], g["w"], u, title="Control surface of x"),
            fuzzy.plot_map(d, fill_fis()(d))]


def test_remaining_figures_fit(tanker_hull, tanker_modes, short):
    """The fixed margins leave every text of every other report figure on the figure and no
    title over a label."""
    from flexlift.output.plots.modes import plot_convergence, plot_frequencies
    from flexlift.structure.convergence import convergence_study

    figs = [plot_convergence(convergence_study(tanker_hull)),
            plot_frequencies(tanker_modes, tanker_modes, 5), ascent.compare([short, short]),
            *_fuzzy_figures()]
    for fig in figs:
        _texts_inside(fig, _drawn(fig))
        plt.close(fig)


# ----------------------------------------------------------------------------- figure processes
def _plain_plot():
    return plt.subplots()[0]


def _failing_plot():
    fig, ax = plt.subplots()
    ax.set_title("$\\notacommand$")  # mathtext fails when drawn, not when set
    return fig


def test_figures_in_background_are_the_same_files(tanker, tmp_path):
    """Drawn by child processes or in this one, the modes stage's PNG files are identical,
    and all complete when the block ends."""
    from flexlift.output.plots._style import figures_in_background
    from flexlift.stages.modes import run_stage

    with figures_in_background(0):
        here = run_stage(tanker, tmp_path / "here")
    with figures_in_background(2):
        there = run_stage(tanker, tmp_path / "there")
    assert [f.path.name for f in here.figures] == [f.path.name for f in there.figures]
    for a, b in zip(here.figures, there.figures):
        assert a.path.read_bytes() == b.path.read_bytes()


def test_a_failed_figure_process_is_an_error_at_the_end(tmp_path):
    from flexlift.output.plots import _style

    ok = _style.draw(tmp_path / "plain.png", _plain_plot)  # no block: drawn here
    assert ok.read_bytes()[:4] == b"\x89PNG"
    with pytest.raises(_style.FigureError, match="bad.png"):
        with _style.figures_in_background(2):
            _style.draw(tmp_path / "bad.png", _failing_plot)
            _style.draw(tmp_path / "good.png", _plain_plot)
    assert (tmp_path / "good.png").is_file() and not (tmp_path / "bad.png").exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["good.png", "plain.png"]


def _slow_plot():
    import time

    time.sleep(60)
    return _plain_plot()


def test_an_interrupt_kills_the_figure_processes(tmp_path):
    """Ctrl-C while both figure processes draw (a minute each): they are killed at once,
    not waited for, and their figures are not written."""
    import time

    from flexlift.output.plots import _style

    workers = []
    with pytest.raises(KeyboardInterrupt):
        with _style.figures_in_background(2) as pool:
            for k in range(2):
                _style.draw(tmp_path / f"{k}.png", _slow_plot)
            time.sleep(0.5)
            workers = list(pool.workers)
            t0 = time.monotonic()
            raise KeyboardInterrupt
    assert time.monotonic() - t0 < 30.0
    assert len(workers) == 2 and _style._BACKGROUND.get() is None
    assert list(tmp_path.iterdir()) == []
    for p in workers:  # stopped and reaped: no such process any more, not even a zombie
        assert _gone(p.pid)


def test_the_figure_processes_serve_the_block_that_opened_them_only():
    """The pool is the opening thread's (a context variable): another thread's figures are
    drawn where it runs, and outside the block nothing is handed on."""
    import threading

    from flexlift.output.plots import _style

    assert _style._BACKGROUND.get() is None
    with _style.figures_in_background(1) as pool:
        assert pool is not None and _style._BACKGROUND.get() is pool
        with _style.figures_in_background(2) as inner:  # nested: the outer block's pool
            assert inner is pool
        other = []
        t = threading.Thread(target=lambda: other.append(_style._BACKGROUND.get()))
        t.start()
        t.join(30)
        assert other == [None]
    assert _style._BACKGROUND.get() is None


def _gone(pid: int) -> bool:
    """Whether no process ``pid`` exists (reaped, not a zombie)."""
    import os

    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return True
    return False


def _dying_plot(parent):
    """Kills the figure process drawing it (as the out-of-memory killer would); drawn in
    the main process, a plain figure."""
    import os

    if os.getpid() != parent:
        os._exit(3)
    return _plain_plot()


def test_the_figures_a_dead_figure_process_leaves_are_drawn_here(tmp_path):
    import os
    import time

    from flexlift.output.plots import _style

    with _style.figures_in_background(2):
        _style.draw(tmp_path / "dead.png", _dying_plot, os.getpid())
        time.sleep(1.0)  # the pool sees its broken process: the next ones are drawn here
        for k in range(3):
            _style.draw(tmp_path / f"after{k}.png", _plain_plot)
    plain = (tmp_path / "after0.png").read_bytes()
    for name in ("dead.png", "after1.png", "after2.png"):
        assert (tmp_path / name).read_bytes() == plain
    assert _style._BACKGROUND.get() is None


_ORPHAN = r"""
import os, signal, sys, time
from flexlift.output.plots import _style

def slow():
    time.sleep(60)
    return _style.plt.subplots()[0]

with _style.figures_in_background(2) as pool:
    _style.draw(sys.argv[1] + "/slow.png", slow)
    time.sleep(0.5)
    print(" ".join(str(p.pid) for p in pool.workers), flush=True)
    os.kill(os.getpid(), signal.SIGKILL)
"""


def _running(pid: int) -> bool:
    """Whether ``pid`` is a live process (neither gone nor a zombie)."""
    import os
    from pathlib import Path

    stat = Path(f"/proc/{pid}/stat")
    try:
        return stat.read_text().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        pass
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    return True


def test_figure_processes_end_when_their_parent_is_killed(tmp_path):
    """A parent killed outright (SIGKILL, out of memory) leaves no figure process behind:
    nothing waits for ever on their output, nothing writes into its folder afterwards."""
    import subprocess
    import sys
    import time

    proc = subprocess.run([sys.executable, "-c", _ORPHAN, str(tmp_path)],
                          capture_output=True, text=True, timeout=60)
    assert proc.returncode == -9, proc.stderr
    pids = [int(p) for p in proc.stdout.split()]
    assert len(pids) == 2
    deadline = time.monotonic() + 10.0
    alive = pids
    while alive and time.monotonic() < deadline:
        time.sleep(0.1)
        alive = [p for p in alive if _running(p)]
    assert not alive
    assert not (tmp_path / "slow.png").exists()


def test_a_figure_whose_data_do_not_pickle_is_drawn_here_at_once(tmp_path, monkeypatch):
    """A figure process gets the plot function and its data by pickle, when the figure is
    handed over; what does not pickle (a local function here) is drawn by the main process
    there and then, the same file."""
    import threading

    from flexlift.output.plots import _style

    def local_plot(lock):  # neither the function nor a lock pickles
        return _plain_plot()

    here = []
    draw_here = _style._draw_here

    def recording(plot, args, kwargs, path, why):
        here.append(path.name)
        draw_here(plot, args, kwargs, path, why)

    monkeypatch.setattr(_style, "_draw_here", recording)
    with _style.figures_in_background(2):
        _style.draw(tmp_path / "here.png", local_plot, threading.Lock())
        assert here == ["here.png"] and (tmp_path / "here.png").is_file()
        _style.draw(tmp_path / "there.png", _plain_plot)
    assert here == ["here.png"]
    assert (tmp_path / "here.png").read_bytes() == (tmp_path / "there.png").read_bytes()


def test_every_figure_of_a_run_is_drawn_by_the_figure_processes(tmp_path, monkeypatch,
                                                                tanker_run_folder):
    """`flexlift run` on the tanker: with two figure processes (conftest's run, shared with
    test_run) every figure's data pickle (none is drawn in the main process) and the 19 PNG
    files are the bytes one process draws."""
    from flexlift.cli import main
    from flexlift.output.plots import _style

    two, rc, fallbacks = tanker_run_folder
    assert rc == 0 and fallbacks == [], fallbacks  # none drawn in the main process

    def no_fallback(plot, args, kwargs, path, why):
        raise AssertionError(f"{path.name} drawn in the main process: {why}")

    monkeypatch.setattr(_style, "_draw_here", no_fallback)
    monkeypatch.setenv(_style.PROCESSES_ENV, "0")
    assert main(["run", "--quiet", "--out", str(tmp_path / "0")]) == 0
    folders = {"0": tmp_path / "0" / "figures", "2": two / "figures"}
    names = sorted(p.name for p in folders["0"].glob("*.png"))
    assert len(names) == 19
    assert names == sorted(p.name for p in folders["2"].glob("*.png"))
    for name in names:
        assert (folders["0"] / name).read_bytes() == (folders["2"] / name).read_bytes(), name


def _plot_recording_niceness(record):
    import os

    record.write_text(str(os.nice(0)))
    return _plain_plot()


def test_the_figure_processes_have_a_lower_priority(tmp_path):
    import os

    from flexlift.output.plots import _style

    with _style.figures_in_background(1):
        _style.draw(tmp_path / "nice.png", _plot_recording_niceness, tmp_path / "nice.txt")
    expected = min(os.nice(0) + _style.WORKER_NICENESS, 19)
    assert int((tmp_path / "nice.txt").read_text()) == expected


@pytest.mark.parametrize("text, n", [("", 2), ("0", 0), ("3", 3), ("-2", 0), ("many", 2)])
def test_figure_processes_from_the_environment(monkeypatch, text, n):
    """Set, or by default two where two cores are free, none on one core or a busy machine."""
    import os

    from flexlift.output.plots._style import PROCESSES_ENV, figure_processes

    monkeypatch.setenv(PROCESSES_ENV, text)
    default = text in ("", "many")
    for cores, load, expected in (({0, 1}, 0.5, n), ({0}, 0.0, 0), ({0, 1, 2, 3}, 3.5, 0),
                                  ({0, 1, 2, 3}, 2.5, 2)):
        monkeypatch.setattr(os, "sched_getaffinity", lambda pid, c=cores: c)
        monkeypatch.setattr(os, "getloadavg", lambda ld=load: (ld, ld, ld))
        assert figure_processes() == (expected if default else n)


def test_png_files_are_the_pixels_savefig_draws(tmp_path):
    """The saver writes what matplotlib's savefig draws, pixel for pixel: RGB for an opaque
    figure, RGBA for one with transparent parts, at the house dpi."""
    import io

    from PIL import Image

    from flexlift.output.plots._style import STYLE, new_figure, save

    for alpha in (1.0, 0.0):
        fig, ax = new_figure()
        ax.semilogy(np.linspace(1, 10, 50), np.exp(np.linspace(0, 8, 50)), label="exp")
        ax.set_title("Title", fontweight="bold")
        ax.legend()
        fig.patch.set_alpha(alpha)
        prepare(fig)
        ref = io.BytesIO()
        with plt.rc_context(STYLE):
            fig.savefig(ref, format="png")
        expected = np.asarray(Image.open(ref).convert("RGBA"))
        path = save(fig, tmp_path / f"a{alpha:g}.png")
        got = Image.open(path)
        assert got.mode == ("RGB" if alpha == 1.0 else "RGBA")
        assert got.info["dpi"] == pytest.approx((STYLE["savefig.dpi"],) * 2, abs=0.01)
        np.testing.assert_array_equal(np.asarray(got.convert("RGBA")), expected)


def test_ticks_are_made_only_in_the_view_with_the_same_labels():
    """The saver's locators leave out the ticks beyond the ends of each axis (never drawn,
    each costs three lines and two texts) and the labels in the view stay as matplotlib
    writes them, on linear, log and shared axes."""
    from flexlift.output.plots._style import InView, apply_margins, lean_log_axes, new_figure

    def figure():
        fig, (a1, a2, a3) = new_figure(3, 1, sharex=True, figsize=(8.0, 8.0))
        t = np.linspace(3.3, 97.2, 400)
        a1.plot(t, 1e3 + np.sin(t / 9) * 0.37)  # an offset on the y axis
        a2.semilogy(t, np.exp(t / 20))
        a3.plot(t, np.cos(t / 7))
        return fig

    def drawn_ticks(fig):
        out = []
        for ax in fig.axes:
            for axis in (ax.xaxis, ax.yaxis):
                lo, hi = sorted(axis.get_view_interval())
                tol = 1e-9 * max(abs(lo), abs(hi), 1.0)
                out.append([(round(t.get_loc(), 9), t.label1.get_text())
                            for t in axis.get_major_ticks() + axis.get_minor_ticks()
                            if lo - tol <= t.get_loc() <= hi + tol])
                out.append(axis.offsetText.get_text())
        return out

    plain = figure()  # all that prepare does but the locators
    apply_margins(plain)
    for ax in plain.axes:
        lean_log_axes(ax)
    plain.canvas.draw()
    lean = figure()
    _drawn(lean)
    assert drawn_ticks(lean) == drawn_ticks(plain)
    made = [len(axis.get_majorticklocs()) for ax in plain.axes for axis in (ax.xaxis, ax.yaxis)]
    assert sum(len(axis.get_majorticklocs()) for ax in lean.axes
               for axis in (ax.xaxis, ax.yaxis)) < sum(made)
    for ax in lean.axes:
        for axis in (ax.xaxis, ax.yaxis):
            assert isinstance(axis.get_major_locator(), InView)
            lo, hi = sorted(axis.get_view_interval())
            locs = axis.get_majorticklocs()
            assert ((locs >= lo - 1e-9 * abs(hi)) & (locs <= hi + 1e-9 * abs(hi))).all()
    plt.close(plain)
    plt.close(lean)
