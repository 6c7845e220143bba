"""Arguments and output helpers shared by the sub-commands."""

from __future__ import annotations

import argparse
import contextlib
import json
import math
import sys
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from flexlift.output import output_folder
from flexlift.scenario import Scenario, load_scenario


def add_scenario_arg(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "scenario",
        nargs="?",
        default="tanker",
        help="a built-in scenario name or a YAML file (default: the built-in tanker)",
    )


def add_out_arg(p: argparse.ArgumentParser, what: str) -> None:
    p.add_argument("--out", type=Path, default=None, help=f"folder for {what} (default: none)")


def add_json_arg(p: argparse.ArgumentParser) -> None:
    p.add_argument("--json", action="store_true", help="print a JSON summary on stdout")


def scenario_from(args: argparse.Namespace) -> Scenario:
    return load_scenario(args.scenario)


def positive_int(name: str):
    """argparse type: an integer >= 1, with a one-line error naming the option."""

    def parse(text: str) -> int:
        try:
            v = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{name} must be a whole number, got {text!r}") from None
        if v < 1:
            raise argparse.ArgumentTypeError(f"{name} must be at least 1, got {v}")
        return v

    return parse


def positive_float(name: str):
    """argparse type: a finite number > 0."""

    def parse(text: str) -> float:
        try:
            v = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{name} must be a number, got {text!r}") from None
        if not math.isfinite(v) or v <= 0:
            raise argparse.ArgumentTypeError(f"{name} must be a positive number, got {text}")
        return v

    return parse


def _jsonable(o):
    if isinstance(o, np.generic):
        return o.item()
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, Path):
        return str(o)
    raise TypeError(f"not JSON serialisable: {type(o).__name__}")


def to_json(obj) -> str:
    return json.dumps(obj, default=_jsonable, allow_nan=False)


def emit_json(obj) -> None:
    """Print one JSON object on stdout."""
    sys.stdout.write(to_json(obj) + "\n")


@contextlib.contextmanager
def writing(out: Path | None, command: str) -> Iterator[Path | None]:
    """The folder a command writes into: None without ``--out``, else a temporary folder that
    :func:`flexlift.output.output_folder` swaps in for ``out`` when the block succeeds."""
    if out is None:
        yield None
        return
    with output_folder(out, command) as tmp:
        yield tmp
