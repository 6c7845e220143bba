"""House style for figures a naval architect would put in a report, and an atomic saver.

Figures are laid out by fixed margins in inches (:func:`new_figure`), not by a layout engine:
matplotlib's constrained layout draws every figure twice (once to measure, once to render),
which was half of the time of ``flexlift run``. Each save is one draw at ``savefig.dpi``.

Inside :func:`figures_in_background` (``flexlift run`` uses it) :func:`save` hands the drawing
and writing of each PNG to a forked child process and returns at once, so the figures are
drawn while the next stage computes; at most :func:`figure_processes` children run at a
time (by default two where two cores are free, none on a busy machine), and leaving the
block waits for them all (an error in one is raised there; an exception or Ctrl-C in the
block kills them first). ``FLEXLIFT_FIGURE_PROCESSES=0`` (or a platform without ``fork``)
draws every figure in the calling process, as the single-stage commands always do.
"""

from __future__ import annotations

import contextlib
import gc
import os
import signal
import sys
import traceback
import warnings
from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # files only; nothing in flexlift opens a window

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.backends.backend_agg import FigureCanvasAgg  # noqa: E402
from matplotlib.ticker import (  # noqa: E402
    FuncFormatter,
    Locator,
    LogFormatterSciNotation,
    LogLocator,
    NullLocator,
)

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


def new_figure(nrows: int = 1, ncols: int = 1, margins: dict | None = None, **kw):
    """A figure and axes in the house style. ``margins`` overrides entries of
    :data:`MARGINS` [in]; they are applied when the figure is saved (a title added with
    ``suptitle`` gets :data:`SUPTITLE` more at the top)."""
    with plt.rc_context(STYLE):
        fig, ax = plt.subplots(nrows, ncols, **kw)
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

    from flexlift.output.files import atomic_file

    prepare(fig)
    with plt.rc_context(STYLE):
        fig.set_dpi(STYLE["savefig.dpi"])
        canvas = fig.canvas  # Agg (see the top): what savefig draws on, its facecolor, no crop
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
    """Save ``fig`` as PNG atomically (one draw) and close it; returns the path. Inside
    :func:`figures_in_background` the file is written by a child process, complete by the
    end of that block."""
    path = Path(path)
    try:
        if _BACKGROUND is not None:
            _BACKGROUND.submit(lambda: fig, path)
        else:
            _write(fig, path)
    finally:
        plt.close(fig)
    return path


def draw(path: str | os.PathLike, plot, *args, **kwargs) -> Path:
    """Build the figure ``plot(*args, **kwargs)`` and :func:`save` it to ``path``; inside
    :func:`figures_in_background` a child process does both (this process creates no
    matplotlib object at all). Returns the path."""
    path = Path(path)
    if _BACKGROUND is not None:
        _BACKGROUND.submit(lambda: plot(*args, **kwargs), path)
        return path
    fig = plot(*args, **kwargs)
    try:
        _write(fig, path)
    finally:
        plt.close(fig)
    return path


#: the environment variable that sets :func:`figure_processes`
PROCESSES_ENV = "FLEXLIFT_FIGURE_PROCESSES"


def figure_processes() -> int:
    """How many figures ``flexlift run`` draws at once in child processes: the environment's
    ``FLEXLIFT_FIGURE_PROCESSES`` (0: none, every figure in the main process); by default 2
    where this process may use two cores or more and the machine's load leaves one of them
    free (the figures are two thirds of the work: two figure processes and the main one
    keep two cores busy), else 0: on a busy machine they would only compete, and each
    copy-on-write page and cold cache of a child costs CPU time. Always 0 without ``fork``."""
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


class _Background:
    """Forked children drawing figures, at most ``n`` at a time (pid -> path)."""

    def __init__(self, n: int):
        self.n = n
        self.running: dict[int, Path] = {}
        self.failed: list[str] = []

    def submit(self, make, path: Path) -> None:
        """Draw ``make()`` (a figure) into ``path`` in a new child process."""
        while len(self.running) >= self.n:
            self._reap_oldest()
        sys.stdout.flush()
        sys.stderr.flush()  # the child must not write the parent's pending output again
        outer = gc.get_freeze_count() > 0  # a caller froze the heap (and releases it)
        gc.freeze()  # the child's collector then leaves the parent's objects (and pages) alone
        pid = -1
        try:
            with warnings.catch_warnings():  # Python >= 3.12 warns of BLAS's idle threads
                warnings.simplefilter("ignore", DeprecationWarning)
                pid = os.fork()
        finally:
            if pid != 0 and not outer:
                gc.unfreeze()
        if pid == 0:  # the child: draw, write, leave without running the parent's cleanup
            code = 1
            try:
                gc.disable()  # short-lived: no collection copying shared pages
                signal.signal(signal.SIGINT, signal.SIG_DFL)
                signal.signal(signal.SIGTERM, signal.SIG_DFL)
                fig = make()
                _write(fig, path)
                plt.close(fig)
                code = 0
            except BaseException:
                traceback.print_exc()
                sys.stderr.flush()
            finally:
                os._exit(code)
        self.running[pid] = path

    def _reap_oldest(self) -> None:
        pid = next(iter(self.running))
        path = self.running.pop(pid)
        _, status = os.waitpid(pid, 0)
        if os.waitstatus_to_exitcode(status) != 0:
            self.failed.append(path.name)

    def finish(self) -> None:
        while self.running:
            self._reap_oldest()
        if self.failed:
            raise FigureError(f"could not draw {', '.join(self.failed)} (see the traceback "
                              f"above; {PROCESSES_ENV}=0 draws in the main process)")

    def abort(self) -> None:
        for pid in self.running:
            with contextlib.suppress(ProcessLookupError):
                os.kill(pid, signal.SIGKILL)
        for pid in self.running:
            with contextlib.suppress(ChildProcessError):
                os.waitpid(pid, 0)
        self.running.clear()


_BACKGROUND: _Background | None = None


def _warm_up() -> None:
    """Draw a small figure here once, so that every figure process inherits matplotlib's
    caches warm (the fonts loaded, their glyphs and text layouts, the mathtext parser of the
    log-axis labels) instead of rebuilding them in each child."""
    import io

    fig, ax = new_figure()
    ax.semilogy([1.0, 2.0], [1e-3, 1e3], label="x")
    ax.set_title("Warm-up 0123456789", fontweight="bold")
    ax.set_xlabel("time [s]")
    ax.legend()
    try:
        with plt.rc_context(STYLE):
            fig.savefig(io.BytesIO(), format="png")
    finally:
        plt.close(fig)


@contextlib.contextmanager
def figures_in_background(processes: int | None = None):
    """Within the block, :func:`save` draws in up to ``processes`` child processes (default
    :func:`figure_processes`; 0, or already inside such a block: in this process). Leaving
    the block waits for every figure and raises :class:`FigureError` if one failed; an
    exception in the block kills the children before it propagates."""
    global _BACKGROUND
    n = figure_processes() if processes is None else int(processes)
    if n <= 0 or _BACKGROUND is not None or not hasattr(os, "fork"):
        yield
        return
    _warm_up()
    _BACKGROUND = bg = _Background(n)
    try:
        try:
            yield
        except BaseException:
            bg.abort()
            raise
        bg.finish()
    finally:
        bg.abort()
        _BACKGROUND = None
