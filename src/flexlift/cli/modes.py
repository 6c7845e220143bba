"""``flexlift modes``: natural frequencies and mode shapes of the hull as a free-free beam,
the nodes of its first flexible modes, and a convergence study against element count.

Modes are numbered 1.. overall: 1 and 2 are the rigid heave and pitch, 3..7 the first five
flexible modes. Nodes are numbered 1..N+1 from the aft end. Frequencies are dry, in Hz.
"""

from __future__ import annotations

import sys

from flexlift.cli._common import (
    add_json_arg,
    add_out_arg,
    add_scenario_arg,
    emit_json,
    help_text,
    key_option,
    positive_int,
    scenario_from,
    writing,
)
from flexlift.stages.modes import NAME, run_stage


def add_parser(sub) -> None:
    p = sub.add_parser(
        NAME,
        help="natural frequencies, mode shapes and nodes of the free-free hull; convergence",
        description=help_text(__doc__),
    )
    add_scenario_arg(p)
    p.add_argument("--elements", type=key_option("--elements", "hull.elements"), default=None,
                   help="re-mesh the hull with this many equal elements (default: the scenario's)")
    p.add_argument("--modes", type=positive_int("--modes"), default=None,
                   help="total number of modes, rigid included, 3..2(N+1) (default: all up to "
                   "400 elements, else 22)")
    p.add_argument("--solver", choices=("auto", "sparse", "dense"), default="auto",
                   help="eigen solver (default auto = sparse flexibility Lanczos)")
    add_out_arg(p, "figures (figures/modes_*.png) and tables (tables/modes_*.csv)")
    add_json_arg(p)
    p.set_defaults(func=_main)


#: flexible modes printed at most
CLI_MODES = 10


def _main(args) -> int:
    from flexlift.scenario.cost import check_modes

    scenario = scenario_from(args)
    elements = args.elements or scenario.hull.elements
    if args.modes is None or 3 <= args.modes <= 2 * elements + 2:  # else the stage says so
        check_modes(elements, args.modes, "--elements/--modes")
    with writing(args.out, "modes") as out:
        res = run_stage(scenario, out, elements=args.elements, n_modes=args.modes,
                        solver=args.solver)
    s = res.summary
    if args.json:
        emit_json(s)
        return 0
    w = sys.stdout.write
    f = s["frequencies_hz"]
    w(f"{scenario.name}: {s['elements']} elements, {len(f)} modes "
      f"({s['rigid_modes']} rigid, exact)\n")
    if s["modes_resolved"] < s["modes_requested"]:
        w(f"  only {s['modes_resolved']} of the {s['modes_requested']} requested modes are "
          "resolved to Phi^T M Phi = I, Phi^T K Phi = diag(omega^2); ask for fewer\n")
    fa = s["analytic_hz"] or []
    fw = s["wet_frequencies_hz"]
    nr = s["rigid_modes"]
    w(f"  {', '.join(s['mode_labels'][:nr])}: rigid, 0 Hz\n")
    n_res = s["mesh_resolved_flexible_modes"]
    shown = nr + min(n_res, CLI_MODES)
    for i in range(nr, shown):
        j = i - nr
        ref = f"  (analytic {fa[j]:.4f})" if j < len(fa) else ""
        wet = f"  wet {fw[i]:10.4f} Hz" if fw[i] is not None else ""
        nodes = s["mode_nodes"].get(s["mode_labels"][i])
        at = f"  nodes {nodes}" if nodes else ""
        w(f"  flexible mode {s['mode_labels'][i]:>3s}: dry {f[i]:12.4f} Hz{wet}{ref}{at}\n")
    if nr + n_res > shown:
        w(f"  ... flexible modes {shown - nr + 1} to {n_res}, also resolved (see --json)\n")
    if len(f) > nr + n_res:
        w(f"  flexible modes {n_res + 1} to {len(f) - nr}: computed, beyond what "
          f"{s['elements']} elements resolve (mode k <= N/2; see --json)\n")
    c = s.get("convergence")
    if c:
        rates = ", ".join("n/a" if r is None else f"{r:.2f}" for r in c["rates"])
        w(f"  convergence vs {c['reference']}: error ~ elements^p, p = {rates}\n")
    for name, ok in res.criteria.items():
        w(f"  [{'ok' if ok else 'FAIL'}] {name}\n")
    if args.out is not None:
        w(f"  figures and tables written under {args.out}\n")
    return 0


