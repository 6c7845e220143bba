"""The ``flexlift`` command: thin glue, the only place that prints, logs to the terminal or exits.

Each sub-command lives in its own module ``flexlift.cli.<name>`` exposing
``add_parser(subparsers)``, which registers the sub-command and sets ``func`` (a callable
taking the parsed ``argparse.Namespace`` and returning an exit code).

Exit codes: 0 success, 1 a criterion failed or the numerics failed, 2 bad input (one line on
stderr naming the field, the value and what is allowed; never a traceback), 130 interrupted
(Ctrl-C), 143 terminated (SIGTERM). An interrupted or terminated command removes its
half-built output and leaves the previous one intact. An unexpected exception (a bug, or
memory running out) is one line on stderr and exit 1; with ``-v`` its traceback is printed too.

:func:`main` may also be called from Python (a notebook, a benchmark): what it sets for the
command (the ``flexlift`` logger, the SIGTERM handler) is as the caller had it again when it
returns.
"""

from __future__ import annotations

import argparse
import atexit
import contextlib
import gc
import importlib
import logging
import signal
import sys
import traceback

import flexlift
from flexlift.errors import LINE_LIMIT, InputError, SimulationError, clean

#: sub-command modules, in the order of the analysis
COMMANDS = ("run", "modes", "loads", "statics", "reduce", "fuzzy", "simulate", "sweep",
            "contingency", "design", "rig", "live", "broker", "replay", "surfacing")


class _Parser(argparse.ArgumentParser):
    """argparse with one-line errors and exit code 2."""

    def error(self, message: str):  # noqa: D102 - argparse API
        sys.stderr.write(f"{self.prog}: error: {message} (see {self.prog} --help)\n")
        raise SystemExit(2)


def build_parser(command: str | None = None) -> argparse.ArgumentParser:
    """The command line's parser: every sub-command, or only ``command`` when it is one of
    :data:`COMMANDS` (each sub-command's module imports its own stage: ``flexlift sweep``
    need not import the modal analysis' or the ascent's compiled code to read its line)."""
    parser = _Parser(
        prog="flexlift",
        description="Raise a sunken flexible hull with controlled lift bags.",
    )
    parser.add_argument("--version", action="version", version=f"flexlift {flexlift.__version__}")
    parser.add_argument("-v", "--verbose", action="count", default=0, help="more log output")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    for name in (command,) if command in COMMANDS else COMMANDS:
        try:
            module = importlib.import_module(f"flexlift.cli.{name}")
        except ModuleNotFoundError as exc:  # a stage not built yet in this checkout
            if exc.name == f"flexlift.cli.{name}":
                continue
            raise
        module.add_parser(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    _exit_without_collecting()
    words = sys.argv[1:] if argv is None else list(argv)
    command = next((w for w in words if not w.startswith("-")), None)  # no global option takes a value
    if command in ("sweep", "contingency"):
        from flexlift.sweep import executors

        executors.start_early(words)  # the workers warm up meanwhile
        code = _main(argv, command)
        if code != 0:  # no result: the workers' server stops with the command
            executors.stop_forkserver()
        return code
    return _main(argv, command)


def _main(argv: list[str] | None, command: str | None) -> int:
    parser = build_parser(command)
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:  # --help, --version, or a one-line usage error (code 2)
        return int(exc.code or 0)
    if not getattr(args, "func", None):
        parser.print_help(sys.stderr)
        return 2
    held = _HeldWarnings()
    previous = _terminate_as_interrupt()
    try:
        with _command_logging(args.verbose, held):
            code = int(args.func(args) or 0)
    except InputError as exc:  # bad input: this one line only, warnings dropped
        sys.stderr.write(f"flexlift {args.command}: error: {clean(str(exc), LINE_LIMIT)}\n")
        return 2
    except (KeyboardInterrupt, Terminated) as exc:
        how = "terminated" if isinstance(exc, Terminated) else "interrupted"
        sys.stderr.write(f"flexlift {args.command}: {how}; previous output left intact\n")
        return 143 if isinstance(exc, Terminated) else 130
    except SimulationError as exc:  # the numerics failed with nothing to show
        sys.stderr.write(f"flexlift {args.command}: {clean(str(exc), LINE_LIMIT)}\n")
        return 1
    except MemoryError:  # a size no check foresaw (an option's value, not the scenario)
        if args.verbose:
            traceback.print_exc()
        sys.stderr.write(f"flexlift {args.command}: error: out of memory; use a smaller model "
                         "or fewer output values\n")
        return 1
    except Exception as exc:  # last resort: a bug, reported on one line (-v: with traceback)
        if args.verbose:
            traceback.print_exc()
        sys.stderr.write(f"flexlift {args.command}: internal error: {type(exc).__name__}: "
                         f"{clean(str(exc), 200)} (please report it; -v shows the traceback)\n")
        return 1
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)
    held.flush_to(sys.stderr)
    return code


def _exit_without_collecting() -> None:
    """Have the interpreter's exit freeze the garbage collector's objects (an atexit handler,
    registered once per process). Tearing down the modules a command imported (numpy,
    xarray, pandas, matplotlib, Dask) otherwise runs collections over the whole heap: 0.6-0.8
    s of a sweep's end, after its last output is written. Nothing else is skipped: the atexit
    handlers run, and the standard streams are flushed, as before."""
    global _EXIT_FROZEN
    if not _EXIT_FROZEN:
        atexit.register(gc.freeze)
        _EXIT_FROZEN = True


_EXIT_FROZEN = False


class Terminated(BaseException):
    """SIGTERM, raised like KeyboardInterrupt so that a half-built output is cleaned up."""


def _terminate_as_interrupt():
    """Make SIGTERM raise :class:`Terminated` (main thread only); returns the old handler."""

    def handler(signum, frame):
        raise Terminated()

    try:
        return signal.signal(signal.SIGTERM, handler)
    except ValueError:  # not the main thread (e.g. called from a worker): leave it alone
        return None


class _HeldWarnings(logging.Handler):
    """Keeps the library's warnings until the command ends, so that bad input stays one line
    on stderr; a command that completes prints them after its own output."""

    def __init__(self):
        super().__init__(level=logging.WARNING)
        self.setFormatter(logging.Formatter("flexlift: %(levelname)s: %(message)s"))
        self.lines: list[str] = []

    def emit(self, record: logging.LogRecord) -> None:
        line = self.format(record)
        if line not in self.lines:  # a stage repeated per control mode warns once
            self.lines.append(line)

    def flush_to(self, stream) -> None:
        for line in self.lines:
            stream.write(line + "\n")


@contextlib.contextmanager
def _command_logging(verbose: int, held: logging.Handler):
    """The ``flexlift`` logger as the command shows it, within the block only: warnings to
    ``held``, with ``-v`` the progress detail live on stderr, nothing passed on to the root
    logger. Afterwards its handlers, level and propagation are the caller's again (a
    notebook's own handler included)."""
    root = logging.getLogger("flexlift")
    saved = (list(root.handlers), root.level, root.propagate)
    for h in saved[0]:
        root.removeHandler(h)
    root.setLevel(logging.WARNING - 10 * min(verbose, 2))
    root.propagate = False
    root.addHandler(held)
    if verbose:  # progress detail streams live; warnings still wait for the end
        live = logging.StreamHandler(sys.stderr)
        live.setFormatter(logging.Formatter("flexlift: %(levelname)s: %(message)s"))
        live.addFilter(lambda r: r.levelno < logging.WARNING)
        root.addHandler(live)
    try:
        yield
    finally:
        for h in list(root.handlers):
            root.removeHandler(h)
        for h in saved[0]:
            root.addHandler(h)
        root.setLevel(saved[1])
        root.propagate = saved[2]


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
