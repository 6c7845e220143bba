"""``flexlift reduce``: modal state space of each lift bag, mode ranking by gain, and the four
truncations (unsorted/sorted × del/mdc) compared with the full model (the paper's Table 2).

Each bag's model is SISO: the bag's force [N] to its own displacement [m] (at its node; for
an internal bag the displacement averaged over its span). Without --bag every external bag is
reduced (every bag if there are none) and the top-level JSON keys describe the first of them;
with --bag only that bag. --order is the number of modes kept (default 2: the rigid modes,
the 4-state model). Errors are in percent; frequencies in Hz unless the key says rad_s;
modes are named as everywhere: "heave", "pitch", then flexible modes "1", "2", ... (flexible
mode 1 is the first flexible mode, as lift.layout_flexible_mode counts them).
"""

from __future__ import annotations

import sys

from flexlift.cli._common import (
    add_json_arg,
    add_out_arg,
    add_scenario_arg,
    emit_json,
    help_text,
    positive_int,
    scenario_from,
    writing,
)
from flexlift.dynamics.reduce import (
    DEFAULT_ORDER,
    METHODS,
)
from flexlift.output.modenames import mode_list
from flexlift.stages.reduce import NAME, run_stage


def add_parser(sub) -> None:
    p = sub.add_parser(
        NAME,
        help="modal state space per bag, mode ranking by dc gain, model order reduction",
        description=help_text(__doc__),
    )
    add_scenario_arg(p)
    p.add_argument("--bag", default=None, help="reduce only this bag (e.g. bag_2); default: "
                   "every external bag")
    p.add_argument("--order", type=positive_int("--order"), default=DEFAULT_ORDER,
                   help="number of modes kept, rigid included (default 2: the 4-state model)")
    p.add_argument("--output", default=None, help="output signal instead of the bag's own "
                   "displacement, e.g. w_node_6, v_bag_2, theta_node_1 (nodes 1-based)")
    add_out_arg(p, "figures (figures/reduce_*.png) and tables (tables/reduce_*.csv)")
    add_json_arg(p)
    p.set_defaults(func=_main)


def _main(args) -> int:
    scenario = scenario_from(args)
    with writing(args.out, "reduce") as out:
        res = run_stage(scenario, out, bag=args.bag, order=args.order, output=args.output)
    s = res.summary
    if args.json:
        emit_json(s)
        return 0
    w = sys.stdout.write
    w(f"{scenario.name}: {s['states_full']}-state modal models reduced to {s['order']} modes "
      f"({s['states_reduced']} states); ω_lo = {s['omega_lo_hz']:.3g} Hz\n")
    for name, b in s["bags"].items():
        w(f"  {name} ({b['input']} -> {b['output']}), largest gains first: "
          f"{mode_list(b['gain_order'][:6])}, ...\n")
        for m in METHODS:
            e = b["methods"][m]
            w(f"    {m:13s} modes {mode_list(e['modes']):30s} gain error {e['dc_error_pct']:+8.3f} %  "
              f"peak error {e['peak_error_pct']:+8.3f} %\n")
    w(s["conclusion"] + "\n")
    for f in res.figures:
        w(f"  wrote {f.path}\n")
    return 0


