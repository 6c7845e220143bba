"""``flexlift fuzzy``: the supervisory fuzzy controller (docs/theory/control.md#supervisor) — draw it, tabulate it,
evaluate it; or any MATLAB ``.fis`` file.

Without ``--fis`` the built-in supervisory system is used, with the operators of the
scenario's ``control.supervisor`` section: inputs the normalised error ``ze`` and error rate
``w`` in [-1, 1]. ``--fis FILE`` loads a MATLAB ``.fis`` file instead: Mamdani or Sugeno, any
number of inputs and outputs. Values beyond an input's range are saturated (clipped) to it;
``--extrapolate`` evaluates the sets there instead, as MATLAB's evalfis does.

  --grid N --json   {"ze": [N], "w": [N], "u": [[N x N]]} with u[i][j] at (ze[i], w[j]), over
                    each input's range (two-input systems; with several outputs u[i][j] lists
                    them)
  --eval X1,..,XN   {"u": value} with --json, one value per input (a list for several
                    outputs); write --eval=-0.5,0.2 for a negative first value
  --out DIR         figures (figures/fuzzy_*.png; the control surface for two-input,
                    one-output systems), tables (tables/fuzzy_*.csv) and the system as
                    fuzzy_supervisor.fis
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np

from flexlift.cli._common import (
    add_json_arg,
    add_out_arg,
    add_scenario_arg,
    checked,
    emit_json,
    help_text,
    scenario_from,
    writing,
)
from flexlift.errors import InputError
from flexlift.scenario.types import whole
from flexlift.stages.fuzzy import NAME, grid_values, load_system, plain, run_stage

#: the largest --grid: 1001 x 1001 = 1e6 evaluations, ~20 s and 20 MB of JSON on a busy core
#: (--grid 1000000 would be 1e12 evaluations and terabytes)
MAX_GRID = 1001


def _eval_point(text: str) -> tuple[float, ...]:
    try:
        values = tuple(float(t) for t in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"--eval needs numbers separated by a comma such as 0.2,-0.1, got {text!r}") from None
    if not all(math.isfinite(v) for v in values):
        raise argparse.ArgumentTypeError(f"--eval needs finite numbers, got {text!r}")
    return values


def add_parser(sub) -> None:
    p = sub.add_parser(NAME, help="the supervisory fuzzy controller: sets, rules, surface",
                       description=help_text(__doc__), formatter_class=argparse.RawDescriptionHelpFormatter)
    add_scenario_arg(p)
    p.add_argument("--fis", type=Path, default=None,
                   help="a MATLAB .fis file to use instead of the built-in supervisory system")
    what = p.add_mutually_exclusive_group()
    what.add_argument("--grid", type=checked("--grid", whole(2, MAX_GRID)), default=None,
                      help=f"tabulate u on an N x N grid of the two inputs, N 2..{MAX_GRID}")
    what.add_argument("--eval", type=_eval_point, default=None, metavar="X1,..,XN",
                      help="evaluate the output(s) at one point: one value per input")
    p.add_argument("--extrapolate", action="store_true",
                   help="evaluate the sets beyond an input's range, as MATLAB (default: saturate)")
    add_out_arg(p, "figures, tables and the .fis file")
    add_json_arg(p)
    p.set_defaults(func=_main)


def _main(args) -> int:
    scenario = scenario_from(args)
    if args.eval is None and args.grid is None:
        with writing(args.out, "fuzzy") as out:
            res = run_stage(scenario, out, fis_file=args.fis, extrapolate=args.extrapolate)
        if args.json:
            emit_json(res.summary)
            return 0
        s = res.summary
        w = sys.stdout.write
        n_out = len(s.get("outputs", [s.get("output")]))
        grid_note = f" on {s['resolution']} points" if s["type"] == "mamdani" else ""
        w(f"{s['system']} ({s['source']}): {s['type']}, {len(s['inputs'])} inputs, {n_out} "
          f"output{'s' if n_out > 1 else ''}, {s['n_rules']} rules, "
          f"{'/'.join(s['operators'].values())}{grid_note}\n")
        if "surface" in s:
            w(f"  interpolated surface {s['surface']['grid']}x{s['surface']['grid']}: max error "
              f"{s['surface']['max_error']:.2e} (bound {s['surface']['error_bound']:.2e})\n")
        if args.out is not None:
            w(f"  figures and tables written under {args.out}\n")
        return 0
    fis = load_system(scenario, args.fis, args.extrapolate)
    if args.eval is not None:
        if len(args.eval) != fis.n_inputs:
            raise InputError("--eval", ",".join(map(str, args.eval)),
                             f"{fis.n_inputs} comma-separated numbers, one per input "
                             f"({', '.join(v.name for v in fis.inputs)})")
        result = {"u": plain(fis(np.array(args.eval)) if fis.n_inputs > 1
                              else fis(args.eval[0]))}
    else:
        result = grid_values(fis, args.grid)
    if args.out is not None:
        with writing(args.out, "fuzzy") as out:
            run_stage(scenario, out, fis_file=args.fis, extrapolate=args.extrapolate)
    if args.json:
        emit_json(result)
    elif args.eval is not None:
        values = np.atleast_1d(result["u"])
        sys.stdout.write(", ".join(f"{v.name} = {u:.6g}" for v, u in zip(fis.outputs, values))
                         + "\n")
    else:
        u = np.array(result["u"])
        sys.stdout.write(f"u on a {args.grid}x{args.grid} grid: min {u.min():.4g}, max "
                         f"{u.max():.4g} (use --json for the values)\n")
    return 0


