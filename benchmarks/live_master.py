"""The master controller on the network's readings, without the network: what each of its
inputs does to the lift (docs/reference/live.md#what-it-achieves).

The rig's plant (the compiled loop in commanded mode, its sensors from
:class:`flexlift.sensors.tap.SensorTap`) and :class:`flexlift.live.master.Master` run in
lock step, one control period at a time: no broker, no wall clock, so a run is reproducible
and takes seconds. Each case replaces some of the laws' inputs by the plant's true values
(``z`` height, ``zd`` speed, ``V`` volume, ``sep`` the plant's own separation), or the true
speed delayed by ``delay`` seconds, and reports the plant's outcome, largest ascent speed and
pitch, and when live and the plant saw the separation.

Run (about 10 s a case on one core)::

    PYTHONPATH=src python benchmarks/live_master.py [--seeds 3 1 2] [--out benchmarks/live_master.json]
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from importlib.resources import files
from pathlib import Path

import numpy as np

from flexlift import load_scenario
from flexlift.ascent.loop import prepare
from flexlift.control.controller import sample
from flexlift.live.board import Board
from flexlift.live.master import Master
from flexlift.live.messages import Reading
from flexlift.sensors.tap import SensorTap

#: the sensors of the measured lift (tests/test_live.py): 1 Hz gauges at every bag
SENSORS = """
sensors:
  seed: {seed}
  depth: {{rate_Hz: 1.0, noise_m: 0.02, latency_s: 0.2}}
  pitch: {{at: [hull]}}
  sling_force: {{rate_Hz: 1.0, latency_s: 0.1, dropout: 0.02}}
  fill_flow: null
  purge: {{at: [bag_1, bag_2, bag_3, bag_4], rate_Hz: 1.0}}
  supply_pressure: null
"""
#: (name, true inputs, delay of the true speed [s]) of each case
CASES = (("network", (), 0.0), ("true z zd V sep", ("z", "zd", "V", "sep"), 0.0),
         ("true zd V sep (z from network)", ("zd", "V", "sep"), 0.0),
         ("true z V sep (zd from network)", ("z", "V", "sep"), 0.0),
         ("true z zd (V, sep from network)", ("z", "zd"), 0.0),
         ("true, speed 0.3 s late", ("z", "zd", "V", "sep"), 0.3),
         ("true, speed 0.6 s late", ("z", "zd", "V", "sep"), 0.6))


def tanker(seed: int, folder: Path) -> Path:
    """The tanker with the measured sensors, noise seed ``seed``, written into ``folder``."""
    path = folder / f"tanker-live-{seed}.yaml"
    path.write_text((files("flexlift.scenarios") / "tanker.yaml").read_text()
                    + SENSORS.format(seed=seed))
    return path


def _replace(master, state, bags, groups, truth, late_zd) -> None:
    for j, i in enumerate(bags):
        if "z" in truth:
            master._z[j] = state.z[i]
        if "zd" in truth:
            master._zd[j] = late_zd[j]
        if "V" in truth:
            master._V[j] = state.V[i]
        if "sep" in truth:
            master.separated[j] = state.sep[groups[i]]


def lockstep(scenario, truth=(), delay: float = 0.0) -> dict:
    """One lift of ``scenario``: the plant and the master in lock step (module docstring)."""
    run = prepare(scenario, "commanded")
    tap, master = SensorTap(run), Master(scenario)
    board = Board(master.plant.names, {s.name: s.period_s for s in tap.sensors}, rate=1.0)
    index = {run.plant.names[i]: j for j, i in enumerate(run.controllers.bags)}
    bags = [run.plant.names.index(b) for b in master.bags]
    groups, state, dt = run.plant.records.bags.group, run.state, run.settings.dt
    run.start()
    k_period, history, t_live = run.settings.k_ctrl, [], None
    while True:
        k, k_next = int(state.counters[0]), run.next_stop()
        if k_next is None or run.after_chunk(run._advance(min(k_next, k - k % k_period
                                                              + k_period))):
            break
        t = (int(state.counters[0]) - 1) * dt
        for r in tap.take():
            source, _, quantity = r.sensor.rpartition("/")
            board.add(Reading(r.time_s, source, quantity, r.value), r.time_s)
        history.append((t, state.zd[bags].copy()))
        while history[0][0] < t - delay - 1e-9:
            history.pop(0)
        if not master.inputs(board, t):
            continue
        _replace(master, state, bags, groups, truth, history[0][1])
        sample(t, master._z, master._zd, master._V, master.separated, master.controllers,
               master.state)
        for j, b in enumerate(master.bags):
            run.command(index[b], fill=float(master.state.fill[j]),
                        opening=float(master.state.opening[j]))
        if t_live is None and master.separated.any():
            t_live = round(t, 1)
    result = run.finish(summary_only=True)
    h = result.headline
    return {"outcome": result.outcome.get("kind"), "max_ascent_velocity_ms":
            h["max_ascent_velocity_ms"], "max_pitch_deg": h["max_pitch_deg"],
            "separation_plant_s": h["separation_time_s"], "separation_live_s": t_live}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--seeds", type=int, nargs="+", default=[3])
    p.add_argument("--out", default=str(Path(__file__).with_name("live_master.json")))
    args = p.parse_args(argv)
    out, folder = [], Path(args.out).parent
    for seed in args.seeds:
        path = tanker(seed, folder)
        scenario = load_scenario(path)
        for name, truth, delay in CASES if seed == args.seeds[0] else CASES[:1]:
            t0 = time.monotonic()
            row = {"seed": seed, "case": name, **lockstep(scenario, truth, delay),
                   "wall_s": round(time.monotonic() - t0, 1)}
            print(json.dumps(row), flush=True)
            out.append(row)
        path.unlink()
    Path(args.out).write_text(json.dumps({"cases": out, "numpy": np.__version__}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
