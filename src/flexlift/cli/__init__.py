"""The ``flexlift`` command: thin glue, the only place that prints, logs to the terminal or exits.

Each sub-command lives in its own module ``flexlift.cli.<name>`` exposing
``add_parser(subparsers)``, which registers the sub-command and sets ``func`` (a callable
taking the parsed ``argparse.Namespace`` and returning an exit code).

Exit codes: 0 success, 1 a criterion failed or the numerics failed, 2 bad input (one line on
stderr naming the field, the value and what is allowed; never a traceback), 130 interrupted.
"""

from __future__ import annotations

import argparse
import importlib
import logging
import sys

from flexlift import __version__
from flexlift.errors import InputError

#: sub-command modules, in the order of the analysis
COMMANDS = ("run", "modes", "loads", "reduce", "fuzzy", "simulate")


class _Parser(argparse.ArgumentParser):
    """argparse with one-line errors and exit code 2."""

    def error(self, message: str):  # noqa: D102 - argparse API
        sys.stderr.write(f"{self.prog}: error: {message} (see {self.prog} --help)\n")
        raise SystemExit(2)


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="flexlift",
        description="Raise a sunken flexible hull with controlled lift bags.",
    )
    parser.add_argument("--version", action="version", version=f"flexlift {__version__}")
    parser.add_argument("-v", "--verbose", action="count", default=0, help="more log output")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    for name in COMMANDS:
        try:
            module = importlib.import_module(f"flexlift.cli.{name}")
        except ModuleNotFoundError as exc:  # a stage not built yet in this checkout
            if exc.name == f"flexlift.cli.{name}":
                continue
            raise
        module.add_parser(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:  # --help, --version, or a one-line usage error (code 2)
        return int(exc.code or 0)
    logging.basicConfig(
        level=logging.WARNING - 10 * min(args.verbose, 2),
        format="flexlift: %(levelname)s: %(message)s",
        stream=sys.stderr,
    )
    if not getattr(args, "func", None):
        parser.print_help(sys.stderr)
        return 2
    try:
        return int(args.func(args) or 0)
    except InputError as exc:
        sys.stderr.write(f"flexlift {args.command}: error: {exc}\n")
        return 2
    except KeyboardInterrupt:
        sys.stderr.write(f"flexlift {args.command}: interrupted; previous output left intact\n")
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
