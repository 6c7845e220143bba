"""House style for figures a naval architect would put in a report, and an atomic saver.

Figures are laid out by fixed margins in inches (:func:`new_figure`), not by a layout engine:
matplotlib's constrained layout draws every figure twice (once to measure, once to render),
which was half of the time of ``flexlift run``. Each save is one draw at ``savefig.dpi``.

Inside a :func:`figures_in_background` block (``flexlift run`` opens one around its stages)
:func:`draw` hands the building, drawing and writing of each PNG to one of
:func:`figure_processes` figure processes (forked once, at the first figure, at a lower
priority) and returns at once, so the figures are drawn while the next stage computes;
leaving the block waits for them all (an error in one is raised there; an exception or
Ctrl-C in the block stops them first) and ends the processes. The block is the caller's: the
library never opens one, so outside it (a single-stage command, a notebook) every figure is
drawn in the calling process and nothing is forked; the block's processes are seen by the
thread (or task) that opened it only (a context variable, not a module-wide setting).
``FLEXLIFT_FIGURE_PROCESSES=0`` (or a platform without ``fork``) makes the block draw in the
calling process too.
"""

from __future__ import annotations

import contextlib
import contextvars
import gc
import os
import signal
import sys
import traceback
import warnings
from pathlib import Path

import matplotlib
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.ticker import (
    FuncFormatter,
    Locator,
    LogFormatterSciNotation,
    LogLocator,
    NullLocator,
)

from flexlift.plumbing.marker import active_roots

STYLE = {
    "figure.figsize": (8.0, 4.5),
    "figure.dpi": 100,
    "savefig.dpi": 100,
    "axes.grid": True,
    "grid.alpha": 0.3,
    "axes.spines.top": False,
    "axes.spines.right": False,
    "font.size": 9.5,
    "axes.titlesize": 10.5,
    "legend.fontsize": 8.5,
    "legend.frameon": False,
    # titles at a fixed height over the axes: matplotlib otherwise lays out every y axis's
    # ticks once more per title, before drawing, to lift it over top tick labels (a figure
    # with labels or an offset text up there pads its title itself)
    "axes.titley": 1.0,
}

#: default margins [in]: left, right, bottom, top, and the gaps between rows and columns
MARGINS = {"left": 0.8, "right": 0.2, "bottom": 0.55, "top": 0.4, "hgap": 0.5, "wgap": 0.8}
#: extra room above the axes for a figure title (suptitle) [in]
SUPTITLE = 0.3


#: the keywords of :func:`new_figure` that go to ``Figure.subplots`` (the others to ``Figure``)
_SUBPLOTS_KW = ("sharex", "sharey", "squeeze", "width_ratios", "height_ratios", "subplot_kw",
                "gridspec_kw")


def new_figure(nrows: int = 1, ncols: int = 1, margins: dict | None = None, **kw):
    """A figure and axes in the house style, as ``plt.subplots`` takes them. ``margins``
    overrides entries of :data:`MARGINS` [in]; they are applied when the figure is saved (a
    title added with ``suptitle`` gets :data:`SUPTITLE` more at the top). The figure is
    matplotlib's :class:`~matplotlib.figure.Figure` on an Agg canvas, not pyplot's: files
    only, no window, and the caller's pyplot backend (a notebook's) is left as it was."""
    sub = {k: kw.pop(k) for k in _SUBPLOTS_KW if k in kw}
    with matplotlib.rc_context(STYLE):
        fig = Figure(**kw)
        FigureCanvasAgg(fig)
        ax = fig.subplots(nrows, ncols, **sub)
    fig._flexlift_margins = {**MARGINS, **(margins or {}), "rows": nrows, "cols": ncols}
    return fig, ax


def apply_margins(fig) -> None:
    """Place the subplots of a :func:`new_figure` by its margins (no effect on others)."""
    m = getattr(fig, "_flexlift_margins", None)
    if m is None:
        return
    W, H = fig.get_size_inches()
    top = m["top"] + (SUPTITLE if fig._suptitle is not None else 0.0)
    axw = (W - m["left"] - m["right"] - (m["cols"] - 1) * m["wgap"]) / m["cols"]
    axh = (H - m["bottom"] - top - (m["rows"] - 1) * m["hgap"]) / m["rows"]
    fig.subplots_adjust(left=m["left"] / W, right=1 - m["right"] / W, bottom=m["bottom"] / H,
                        top=1 - top / H, wspace=m["wgap"] / max(axw, 0.1),
                        hspace=m["hgap"] / max(axh, 0.1))


_SUPERSCRIPT = str.maketrans("-0123456789", "⁻⁰¹²³⁴⁵⁶⁷⁸⁹")


def _decade_label(value: float, pos=None) -> str:
    """A log-axis label as plain text: "10⁻⁸" at a decade, "%g" elsewhere (matplotlib's
    default writes mathtext, whose parser costs 25 ms per new label)."""
    if value <= 0 or not np.isfinite(value):
        return ""
    e = np.log10(value)
    if abs(e - round(e)) < 1e-9:
        return "10" + str(int(round(e))).translate(_SUPERSCRIPT)
    return f"{value:g}"


def lean_log_axes(ax, max_decades: float = 4.0) -> None:
    """On a log axis: plain-text labels (:func:`_decade_label`); spanning more than
    ``max_decades``, no minor ticks and at most seven labelled decades (a tick is two lines
    and a text to lay out: they cost time, and so many add nothing to read)."""
    for axis, scale, lim in ((ax.xaxis, ax.get_xscale(), ax.get_xlim()),
                             (ax.yaxis, ax.get_yscale(), ax.get_ylim())):
        if scale != "log" or min(lim) <= 0:
            continue
        if isinstance(axis.get_major_formatter(), LogFormatterSciNotation):
            axis.set_major_formatter(FuncFormatter(_decade_label))
        if abs(np.log10(lim[1] / lim[0])) > max_decades:
            axis.set_minor_locator(NullLocator())
            axis.set_major_locator(LogLocator(numticks=7))


class InView(Locator):
    """The ticks of the locator ``base`` that lie in the view: matplotlib makes a tick (three
    lines and two texts, about a millisecond) for every value a locator returns, and most
    locators return one more beyond each end of the axis, never drawn (a fifth of all the
    ticks of the report). The labels stay the same: the formatters take their step and
    offset from the ticks in the view."""

    def __init__(self, base: Locator):
        self.base = base

    def set_axis(self, axis) -> None:
        super().set_axis(axis)
        self.base.set_axis(axis)

    def __call__(self):
        locs = np.asarray(self.base())
        if self.axis is None or locs.size == 0:
            return locs
        lo, hi = sorted(self.axis.get_view_interval())
        tol = 1e-9 * max(abs(lo), abs(hi), 1.0)
        return locs[(locs >= lo - tol) & (locs <= hi + tol)]

    def tick_values(self, vmin, vmax):
        return self.base.tick_values(vmin, vmax)

    def view_limits(self, vmin, vmax):
        return self.base.view_limits(vmin, vmax)

    def nonsingular(self, v0, v1):
        return self.base.nonsingular(v0, v1)


def ticks_in_view(ax) -> None:
    """Every major and minor locator of ``ax`` (and of its secondary axes) wrapped in
    :class:`InView` (shared axes share their locators: wrapped once)."""
    for a in (ax, *ax.child_axes):
        for axis in (a.xaxis, a.yaxis):
            for ticker, flag in ((axis.major, "isDefault_majloc"),
                                 (axis.minor, "isDefault_minloc")):
                loc = ticker.locator
                if isinstance(loc, (InView, NullLocator)):
                    continue
                default = getattr(axis, flag)
                wrapped = InView(loc)
                wrapped.set_axis(axis)
                ticker.locator = wrapped
                setattr(axis, flag, default)


def prepare(fig) -> None:
    """What a save does before drawing: the margins (:func:`apply_margins`), the log axes
    (:func:`lean_log_axes`) and the ticks in the view only (:func:`ticks_in_view`)."""
    apply_margins(fig)
    for ax in fig.axes:
        lean_log_axes(ax)
        ticks_in_view(ax)


#: zlib level of the PNG files: 2 writes them in half the time of matplotlib's 6 (a tenth of
#: the figures' time); stored as RGB (every figure is opaque), they are still 4 % smaller
PNG_COMPRESS_LEVEL = 2


def _write(fig, path: Path) -> None:
    """Lay out and draw ``fig`` into ``path`` atomically (one draw), as RGB when it is opaque
    (else RGBA) at :data:`PNG_COMPRESS_LEVEL`, at the house ``savefig.dpi``."""
    from PIL import Image, PngImagePlugin

    from flexlift.plumbing.atomic import atomic_file

    prepare(fig)
    with matplotlib.rc_context(STYLE):
        fig.set_dpi(STYLE["savefig.dpi"])
        canvas = fig.canvas  # Agg (new_figure): what savefig draws on, its facecolor, no crop
        if not isinstance(canvas, FigureCanvasAgg):
            canvas = FigureCanvasAgg(fig)
        canvas.draw()
    rgba = np.asarray(canvas.buffer_rgba())
    image = Image.fromarray(rgba[..., :3] if (rgba[..., 3] == 255).all() else rgba)
    info = PngImagePlugin.PngInfo()
    info.add_text("Software", f"flexlift, matplotlib {matplotlib.__version__}")
    with atomic_file(path, suffix=".png") as tmp:
        image.save(tmp, format="png", compress_level=PNG_COMPRESS_LEVEL, pnginfo=info,
                   dpi=(STYLE["savefig.dpi"],) * 2)


def save(fig, path: str | os.PathLike) -> Path:
    """Save ``fig`` as PNG atomically (one draw) in this process and close it; returns the
    path. (A figure already built here is drawn here: :func:`draw` is what hands a figure to
    the figure processes.)"""
    path = Path(path)
    try:
        _write(fig, path)
    finally:
        plt.close(fig)
    return path


def draw(path: str | os.PathLike, plot, *args, **kwargs) -> Path:
    """Build the figure ``plot(*args, **kwargs)`` and :func:`save` it to ``path``; inside
    :func:`figures_in_background` a figure process does both (``plot`` and its arguments are
    pickled to it; this process creates no matplotlib object at all). Returns the path."""
    path = Path(path)
    background = _BACKGROUND.get()
    if background is not None:
        background.submit(plot, args, kwargs, path)
        return path
    save(plot(*args, **kwargs), path)
    return path


#: the environment variable that sets :func:`figure_processes`
PROCESSES_ENV = "FLEXLIFT_FIGURE_PROCESSES"


def figure_processes() -> int:
    """How many figure processes ``flexlift run`` starts: the environment's
    ``FLEXLIFT_FIGURE_PROCESSES`` (0: none, every figure in the main process); by default 2
    where this process may use two cores or more and the machine's load leaves one of them
    free (the figures are most of the work: two figure processes take the core the main
    process leaves free and both once it is done), else 0: on a busy machine they would
    only compete. Always 0 without ``fork``."""
    if not hasattr(os, "fork"):
        return 0
    text = os.environ.get(PROCESSES_ENV, "").strip()
    if text:
        try:
            return max(0, int(text))
        except ValueError:
            pass
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    try:
        load = os.getloadavg()[0]
    except OSError:
        load = 0.0
    return 2 if (cores or 1) >= 2 and load <= (cores or 1) - 1 else 0


class FigureError(RuntimeError):
    """A figure process failed (its traceback went to stderr)."""


#: how much lower the figure processes' priority is than the main process's: the stages'
#: computation comes first (each figure waits for its data), the figures take the time it
#: leaves free
WORKER_NICENESS = 10


def _end_with_parent(parent: int) -> None:
    """Make this figure process end when its parent does, even killed (SIGKILL, out of
    memory): a worker waiting for its next figure would otherwise wait for ever, and an
    orphan could still write into a partial output folder. Linux: the kernel's
    parent-death signal; elsewhere a thread that polls the parent's id."""
    import threading

    try:
        import ctypes

        libc = ctypes.CDLL(None, use_errno=True)
        if libc.prctl(1, signal.SIGKILL, 0, 0, 0) == 0:  # PR_SET_PDEATHSIG
            if os.getppid() != parent:  # died before the signal was set
                os._exit(1)
            return
    except (OSError, AttributeError):
        pass

    def watch():
        import time

        while os.getppid() == parent:
            time.sleep(0.5)
        os._exit(1)

    threading.Thread(target=watch, daemon=True).start()


def _worker_start(parent: int) -> None:
    """A figure process's start: it ends with its parent (:func:`_end_with_parent`), Ctrl-C
    is the parent's to handle (it stops the figure processes), SIGTERM ends it, it runs at a
    lower priority (:data:`WORKER_NICENESS`), its figures are drawn here (not handed on), and
    its collector leaves the inherited heap alone (no pages copied for it)."""
    _end_with_parent(parent)
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)  # not the parent's handler
    with contextlib.suppress(OSError):
        os.nice(WORKER_NICENESS)
    _BACKGROUND.set(None)
    gc.freeze()


def _worker_draw(job: bytes, path: Path, roots: tuple[str, ...] = ()) -> str | None:
    """In a figure process: draw the pickled ``(plot, args, kwargs)`` into ``path``; None, or
    on failure the file's name (the traceback printed to stderr). ``roots``: the output
    folders the run is writing (its names are journaled there before they are created, even
    when this process was started before the run opened them)."""
    import pickle

    from flexlift.plumbing.marker import adopted

    try:
        plot, args, kwargs = pickle.loads(job)
        with adopted(roots):
            save(plot(*args, **kwargs), path)
        return None
    except Exception:
        traceback.print_exc()
        sys.stderr.flush()
        return path.name


def _draw_here(plot, args, kwargs, path: Path, why: str) -> None:
    """Draw a figure in this process instead of a figure process (``why``: the reason, for
    the debug log): its data do not pickle, or the figure processes are gone."""
    import logging

    logging.getLogger(__name__).debug("%s drawn in the main process: %s", path.name, why)
    save(plot(*args, **kwargs), path)


class _Background:
    """``n`` figure processes forked once, at the first figure (a
    :class:`concurrent.futures.ProcessPoolExecutor` of the ``fork`` context: they start with
    this process's imports), each drawing one figure at a time. A figure's plot function and
    data are pickled when it is handed over (so it shows the data as they were then); what
    does not pickle is drawn here at once. If a figure process dies (killed, out of memory),
    the figures it had not finished are drawn here at the end. (A process forked per figure,
    at most two at a time, cost this process ~40 ms a fork, and it waited for a free one.)"""

    def __init__(self, n: int):
        import multiprocessing
        from concurrent.futures import ProcessPoolExecutor

        self._before = set(multiprocessing.active_children())
        self.pool = ProcessPoolExecutor(n, multiprocessing.get_context("fork"),
                                        initializer=_worker_start, initargs=(os.getpid(),))
        self.pending: list[tuple] = []  # (future, plot, args, kwargs, path)

    @property
    def workers(self) -> list:
        """The figure processes started so far (:class:`multiprocessing.Process`)."""
        import multiprocessing

        return [p for p in multiprocessing.active_children() if p not in self._before]

    def submit(self, plot, args, kwargs, path: Path) -> None:
        """Hand ``plot(*args, **kwargs)`` into ``path`` to the next free figure process."""
        import pickle
        from concurrent.futures.process import BrokenProcessPool

        try:
            job = pickle.dumps((plot, args, kwargs), protocol=pickle.HIGHEST_PROTOCOL)
        except (pickle.PicklingError, TypeError, AttributeError) as exc:
            _draw_here(plot, args, kwargs, path, f"its data do not pickle ({exc})")
            return
        if not self.pending:
            sys.stdout.flush()
            sys.stderr.flush()  # the children must not write the pending output again
        try:
            with warnings.catch_warnings():  # Python >= 3.12 warns of BLAS's idle threads
                warnings.simplefilter("ignore", DeprecationWarning)
                future = self.pool.submit(_worker_draw, job, path, active_roots())
        except BrokenProcessPool:
            _draw_here(plot, args, kwargs, path, "a figure process died")
            return
        self.pending.append((future, plot, args, kwargs, path))

    def finish(self) -> None:
        """Wait for every figure handed over; :class:`FigureError` naming those that failed.
        The figures a dead figure process left are drawn here."""
        from concurrent.futures.process import BrokenProcessPool

        failed = []
        for future, plot, args, kwargs, path in self.pending:
            try:
                name = future.result()
            except BrokenProcessPool:
                _draw_here(plot, args, kwargs, path, "a figure process died")
                name = None
            if name:
                failed.append(name)
        self.pool.shutdown()
        if failed:
            raise FigureError(f"could not draw {', '.join(failed)} (see the traceback "
                              f"above; {PROCESSES_ENV}=0 draws in the main process)")

    def abort(self) -> None:
        """Stop the figure processes at once (the figures not yet drawn are not): killed, then
        reaped by the pool's own shutdown (joining them here as well raced with it)."""
        for p in self.workers:
            p.kill()
        self.pool.shutdown(wait=True, cancel_futures=True)


#: the figure processes of the innermost :func:`figures_in_background` block of this thread
#: (or task), None outside one
_BACKGROUND: contextvars.ContextVar[_Background | None] = contextvars.ContextVar(
    "flexlift_figure_processes", default=None)


_WARM = False


#: the font sizes [pt] the figures use (besides the house sizes of :data:`STYLE`)
_WARM_SIZES = (6.5, 7, 7.5, 8)


def _warm_up() -> None:
    """Draw a small figure, once in a process, so that the figure processes it forks start
    with matplotlib's caches warm: the fonts looked up and loaded at the sizes and weights
    the figures use, their glyphs, a log axis's labels, the 3D axes and the contouring
    imported (each figure process would otherwise do all of this again)."""
    global _WARM
    if _WARM:
        return
    import io

    import mpl_toolkits.mplot3d  # noqa: F401 (the fuzzy stage's surface)

    fig, ax = new_figure()
    ax.semilogy([1.0, 2.0], [1e-3, 1e3], label="x")
    ax.contourf([[0.0, 1.0], [1.0, 2.0]], levels=3)
    ax.set_title("Warm-up 0123456789", fontweight="bold")
    ax.set_xlabel("time [s]")
    for k, size in enumerate(_WARM_SIZES):
        ax.text(0.1 * k, 0.5, "Warm-up −0.5e+3 [m/s²]", fontsize=size, transform=ax.transAxes)
    ax.legend()
    fig.suptitle("Warm-up", fontweight="bold")
    try:
        with matplotlib.rc_context(STYLE):
            fig.savefig(io.BytesIO(), format="png")
    finally:
        plt.close(fig)
    _WARM = True


@contextlib.contextmanager
def figures_in_background(processes: int | None = None):
    """Within the block, :func:`draw` (in this thread or task) hands each figure to
    ``processes`` figure processes (default :func:`figure_processes`; 0: drawn in this
    process). Leaving the block waits for every figure and raises :class:`FigureError` if one
    failed; an exception in the block stops the figure processes before it propagates; either
    way none is left running. Inside another such block this one adds nothing: its figures go
    to the outer block's processes and are complete when that block ends. Yields the figure
    processes' pool (:class:`_Background`), or None when the figures are drawn here."""
    n = figure_processes() if processes is None else int(processes)
    outer = _BACKGROUND.get()
    if n <= 0 or outer is not None or not hasattr(os, "fork"):
        yield outer
        return
    _warm_up()
    bg = _Background(n)
    token = _BACKGROUND.set(bg)
    try:
        try:
            yield bg
        except BaseException:
            bg.abort()
            raise
        bg.finish()
    finally:
        bg.abort()
        _BACKGROUND.reset(token)
