"""The state-space stage (docs/theory/reduction.md): each bag's modal model, mode ranking by gain, and the four
reductions compared with the full model, as data, figures and tables.
"""

from __future__ import annotations

import logging
from pathlib import Path

import numpy as np

from flexlift.dynamics.reduce import (
    DEFAULT_ORDER,
    METHODS,
    Comparison,
    compare,
    kept_modes,
    reduce_all,
)
from flexlift.dynamics.statespace import (
    bag_siso,
    default_omega_lo,
    flexible_dc_gain,
    gain_ranking,
    mode_gains,
)
from flexlift.loads.liftplan import plan_lift
from flexlift.output.modenames import labels_of_numbers, mode_list
from flexlift.output.stage import Figure, StageOutput, Table
from flexlift.plumbing.atomic import write_text
from flexlift.structure.hull import hull_from_scenario
from flexlift.structure.modes import compute_modes

log = logging.getLogger(__name__)
NAME = "reduce"
TWO_PI = 2 * np.pi


def conclusion(cmp: Comparison, order: int, n_rigid: int) -> str:
    """One paragraph: which method is most accurate and why (from the numbers)."""
    best = cmp.row(cmp.most_accurate)
    d_mdc, d_del = cmp.row("unsorted_mdc"), cmp.row("unsorted_del")
    if abs(d_del.dc_error_pct - d_mdc.dc_error_pct) < 1e-9:
        return (f"{best.name.replace('_', ' ')} is the most accurate reduction "
                f"({best.dc_error_pct:+.3g} % gain error at ω_lo, {best.peak_error_pct:+.3g} % "
                "peak error); del and mdc coincide here because the eliminated modes have no "
                "static contribution to this output (a velocity).")
    text = (
        f"{best.name.replace('_', ' ')} is the most accurate reduction "
        f"({best.dc_error_pct:+.3g} % gain error at ω_lo, {best.peak_error_pct:+.3g} % peak "
        "error): mdc keeps the static contribution Σ φφ/ω² of the eliminated flexible modes "
        "as a feedthrough D, so its static flexible gain equals the full model's exactly, "
        f"whereas del drops it (unsorted del {d_del.dc_error_pct:+.3g} % against unsorted mdc "
        f"{d_mdc.dc_error_pct:+.3g} %)."
    )
    if order == n_rigid:
        text += (" At this order both orderings keep only the rigid modes, so sorted and "
                 "unsorted coincide.")
    res = best.resonance_error_pct
    if cmp.resonance_omega is not None and res is not None and abs(res) > 10:
        text += (f" No model of this order has the flexible resonance at "
                 f"{cmp.resonance_omega / TWO_PI:.2f} Hz ({res:+.0f} % there); keep more modes "
                 "if that resonance matters.")
    return text


def bag_summary(scenario, modes, bag, order: int, output: str | None = None, bags=()):
    """(summary dict, models, comparison, gains) of one bag's SISO model."""
    zeta = scenario.hull.modal_damping
    full = bag_siso(modes, bag, zeta, output, bags)
    w_lo = default_omega_lo(full)
    models = reduce_all(full, order, w_lo)
    cmp = compare(models, w_lo)
    gains = mode_gains(full, w_lo)
    static = flexible_dc_gain(full)[0, 0]
    labels = labels_of_numbers(full.mode_numbers, full.n_rigid)
    summary = {
        "bag": bag.name,
        "input": full.inputs[0],
        "output": full.outputs[0],
        "order": order,
        "states_full": full.n_states,
        "states_reduced": models[METHODS[0]].n_states,
        "omega_lo_rad_s": w_lo,
        "omega_lo_hz": w_lo / TWO_PI,
        "band_hz": [cmp.band[0] / TWO_PI, cmp.band[1] / TWO_PI],
        "resonance_hz": None if cmp.resonance_omega is None else cmp.resonance_omega / TWO_PI,
        # modes by label, as everywhere: "heave", "pitch", then flexible mode "1", "2", ...
        "mode_labels": labels,
        "gain_order": [labels[k] for k in gain_ranking(full, w_lo)],
        "gains_m_per_N": [float(g) for g in gains],
        "kept_modes": {
            o: [labels[k] for k in kept_modes(full, order, o, w_lo)]
            for o in ("unsorted", "sorted")
        },
        "flexible_static_gain_m_per_N": float(static),
        "methods": {
            r.name: {
                "dc_error_pct": r.dc_error_pct,
                "peak_error_pct": r.peak_error_pct,
                "resonance_error_pct": r.resonance_error_pct,
                "states": r.states,
                "modes": labels_of_numbers(r.modes, full.n_rigid),
                "flexible_static_gain_m_per_N": float(flexible_dc_gain(models[r.name])[0, 0]),
            }
            for r in cmp.rows
        },
        "most_accurate": cmp.most_accurate,
        "conclusion": conclusion(cmp, order, full.n_rigid),
    }
    return summary, models, cmp, gains


def _mdc_exact(s: dict) -> bool:
    ref = s["flexible_static_gain_m_per_N"]
    return all(
        abs(m["flexible_static_gain_m_per_N"] - ref) <= 1e-9 * abs(ref)
        for k, m in s["methods"].items() if k.endswith("_mdc")
    )


def model_key(bag) -> tuple:
    """What a bag's SISO model depends on: its kind and where its force acts (node, span,
    point). Bags with the same key (a cluster at one lift point) have the same model up to
    the names of its signals."""
    return (bag.kind, bag.node, bag.span, round(float(bag.x), 9))


def _renamed(s: dict, bag, output: str | None) -> dict:
    """A shared model's summary as the bag ``bag`` sees it: its own name and signals."""
    n = bag.name.removeprefix("bag_")
    return {**s, "bag": bag.name, "input": f"f_bag_{n}", "output": output or f"w_bag_{n}"}


def summaries(scenario, modes, bags, order: int, output: str | None = None, all_bags=()):
    """(per-bag summaries by name, the first bag's (bag, models, comparison, gains), the
    number of distinct models): the reduction runs once per :func:`model_key`, and every
    other bag of that key gets its summary with its own names (the numbers are the same:
    the model depends on the key only)."""
    done: dict[tuple, dict] = {}
    per_bag, first = {}, None
    for b in bags:
        key = model_key(b)
        if key not in done:
            s, models, cmp, gains = bag_summary(scenario, modes, b, order, output, all_bags)
            done[key] = s
            if first is None:
                first = (b, models, cmp, gains)
        per_bag[b.name] = _renamed(done[key], b, output)
    return per_bag, first, len(done)


def _worst(values: list[tuple[float | None, str]]) -> tuple[float | None, str]:
    """The signed value of largest magnitude and whose it is (None when there is none)."""
    known = [(v, who) for v, who in values if v is not None and np.isfinite(v)]
    if not known:
        return None, ""
    return max(known, key=lambda p: abs(p[0]))


def method_summary_rows(per_bag: dict) -> list[list]:
    """One row per method over every bag's model: states, kept modes (or "differ"), and the
    worst (largest in magnitude, signed) of each error with the bag it belongs to."""
    rows = []
    for m in METHODS:
        ms = [(name, s["methods"][m]) for name, s in per_bag.items()]
        kept = {mode_list(e["modes"]) for _, e in ms}
        row = [m, ms[0][1]["states"], kept.pop() if len(kept) == 1 else "differ by bag"]
        for field in ("dc_error_pct", "peak_error_pct", "resonance_error_pct"):
            v, who = _worst([(e[field], name) for name, e in ms])
            row += [v, who]
        rows.append(row)
    return rows


def _figures(fdir: Path, first, order: int) -> list[Figure]:
    """The gains, Bode and time-response figures of the first (or chosen) bag's models."""
    from flexlift.dynamics.reduce import band_grid
    from flexlift.output.plots._style import draw
    from flexlift.output.plots.reduce import plot_bode, plot_gains, plot_time

    b, models, cmp, gains = first
    full = models["full"]
    what = f"{b.name}: {full.inputs[0]} → {full.outputs[0]}"
    w = band_grid(full, cmp.omega_lo / 2, 3000)
    f1 = float(full.omega[~full.rigid].min()) / TWO_PI
    t = np.linspace(0.0, 10.0 / f1, 2001)
    return [
        Figure(draw(fdir / "reduce_gains.png", plot_gains, full, gains, cmp.omega_lo, what),
               f"Per-mode gain of {what}: by mode (heave, pitch, flexible modes 1, 2, ...), "
               "against frequency and sorted (flexible modes: dc gain; rigid modes: gain at "
               "ω_lo)."),
        Figure(draw(fdir / "reduce_bode.png", plot_bode, models, w, f"Bode, {what}"),
               f"Bode magnitude and phase of the full and the four {order}-mode models, "
               f"{what}."),
        Figure(draw(fdir / "reduce_time.png", plot_time, models, t, f"Time responses, {what}"),
               f"Step and impulse responses of the full and reduced models, {what}; right: "
               "with the rigid-body motion subtracted, leaving the flexible response."),
    ]


def run_stage(scenario, out: Path | None = None, bag: str | None = None,
              order: int = DEFAULT_ORDER, output: str | None = None) -> StageOutput:
    """Reduce each external bag's model (or only ``bag``) to ``order`` modes and compare the
    four methods, once per distinct model (:func:`model_key`: a cluster of bags at one lift
    point shares one); figures (for the first or chosen bag) and CSV tables under ``out``:
    every bag's rows in CSV, the worst over the bags on the page."""
    hull = hull_from_scenario(scenario)
    modes = compute_modes(hull)
    plan = plan_lift(scenario, hull, modes)
    if bag is not None:
        bags = [plan.bag(bag)]
    else:
        bags = list(plan.external) or list(plan.bags)
    per_bag, first, n_models = summaries(scenario, modes, bags, order, output, plan.bags)
    summary = dict(per_bag[bags[0].name])
    summary["bags"] = per_bag
    summary["distinct_models"] = n_models
    point = {b.name: round(float(b.x), 3) for b in bags}
    rows = [
        [name, point[name], m, s["states_reduced"], mode_list(s["methods"][m]["modes"]),
         s["methods"][m]["dc_error_pct"], s["methods"][m]["peak_error_pct"],
         s["methods"][m]["resonance_error_pct"]]
        for name, s in per_bag.items() for m in METHODS
    ]
    note = (f"ω_lo = {summary['omega_lo_hz']:.3g} Hz (one tenth of the first flexible "
            f"frequency); peak over {summary['band_hz'][0]:.3g}..{summary['band_hz'][1]:.4g} Hz; "
            "signed: negative means the reduced model is low; the resonance error is at the "
            f"full model's largest resonance ({summary['resonance_hz'] or 0:.3g} Hz).")
    worst_table = Table(
        f"Model reduction to {order} modes ({2 * order} states), errors against the full "
        f"{summary['states_full']}-state model: the worst over {len(bags)} bag(s) "
        f"({n_models} distinct model(s), one per lift point and bag type)",
        ["method", "states", "kept modes", "gain error at ω_lo [%]", "bag",
         "peak magnitude error [%]", "bag", "error at the first resonance [%]", "bag"],
        method_summary_rows(per_bag), note=note + " Every bag's rows are in the CSV.",
        csv="reduce_worst.csv",
    )
    table = Table(
        f"Model reduction to {order} modes, every bag",
        ["bag", "lift point x [m]", "method", "states", "kept modes", "gain error at ω_lo [%]",
         "peak magnitude error [%]", "error at the first resonance [%]"],
        rows, csv="reduce_comparison.csv", in_report=False,
    )
    gains_table = Table(
        "Per-mode gain of each bag's model (flexible: dc gain; rigid: gain at ω_lo) [m/N]",
        ["mode", "kind", "frequency [Hz]"] + [f"{b} [m/N]" for b in per_bag],
        [[summary["mode_labels"][k], "rigid" if k < modes.n_rigid else "flexible",
          float(modes.frequencies_hz[k])]
         + [s["gains_m_per_N"][k] for s in per_bag.values()] for k in range(modes.n_modes)],
        csv="reduce_gains.csv", in_report=False,
    )
    figures: list[Figure] = []
    if out is not None:
        figures = _figures(Path(out) / "figures", first, order)
        for t in (worst_table, table, gains_table):
            write_text(Path(out) / "tables" / t.csv, t.to_csv())
    criteria = {"mdc_static_gain_exact": all(_mdc_exact(s) for s in per_bag.values())}
    return StageOutput(name=NAME, summary=summary, figures=figures,
                       tables=[worst_table, table, gains_table],
                       criteria=criteria)
