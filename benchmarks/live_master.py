"""The master controller on the network's readings, without the network: what each of its
inputs does to the lift (docs/reference/live.md#what-it-achieves).

The rig's plant (the compiled loop in commanded mode, its sensors from
:class:`flexlift.sensors.tap.SensorTap`) and :class:`flexlift.live.master.Master` run in
lock step, one control period at a time: no broker, no wall clock, so a run is reproducible
and takes seconds. Each case replaces some of the laws' inputs by the plant's true values
(``z`` height, ``zd`` speed, ``V`` volume, ``sep`` the plant's own separation), or the true
speed delayed by ``delay`` seconds, and reports the plant's outcome, largest ascent speed and
pitch, and when live and the plant saw the separation; two more cases add white noise to
the true speed.

Run (about 10 s a case on one core at 1 Hz, 30 s at 5 Hz)::

    PYTHONPATH=src python benchmarks/live_master.py --seeds 3 1 2
    PYTHONPATH=src python benchmarks/live_master.py --rate 5 --noise 0 --force-noise 0 \
        --cases 0 --out benchmarks/live_master_5hz_quiet.json
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

#: the sensors of the measured lift (tests/test_live.py): gauges at every bag, every sensor
#: at ``--rate`` (the hull's inclinometer and the purge feedback too: the issue's "every
#: sensor at 10 Hz"; at 1 Hz as before)
SENSORS = """
sensors:
  seed: {seed}
  depth: {{rate_Hz: {rate}, noise_m: {noise}, latency_s: 0.2}}
  pitch: {{at: [hull], rate_Hz: {rate}}}
  sling_force: {{rate_Hz: {rate}, noise_N: {force_noise}, latency_s: 0.1, dropout: 0.02}}
  fill_flow: null
  purge: {{at: [bag_1, bag_2, bag_3, bag_4], rate_Hz: {rate}}}
  supply_pressure: null
"""
#: (name, true inputs, delay of the true speed [s], white noise on it [m/s], delay of the
#: plant's separation [s]) of each case
TRUE = ("z", "zd", "V", "sep")
CASES = (("network", (), 0.0, 0.0, 0.0), ("true z zd V sep", TRUE, 0.0, 0.0, 0.0),
         ("true zd V sep (z from network)", ("zd", "V", "sep"), 0.0, 0.0, 0.0),
         ("true z V sep (zd from network)", ("z", "V", "sep"), 0.0, 0.0, 0.0),
         ("true z zd (V, sep from network)", ("z", "zd"), 0.0, 0.0, 0.0),
         ("true, speed 0.3 s late", TRUE, 0.3, 0.0, 0.0),
         ("true, speed 0.6 s late", TRUE, 0.6, 0.0, 0.0),
         ("true, speed + 0.01 m/s noise", TRUE, 0.0, 0.01, 0.0),
         ("true, speed + 0.03 m/s noise", TRUE, 0.0, 0.03, 0.0),
         ("true, separation 1.5 s late", TRUE, 0.0, 0.0, 1.5),
         ("true, separation 3 s late", TRUE, 0.0, 0.0, 3.0))


def tanker(seed: int, folder: Path, rate: float = 1.0, noise: float = 0.02,
           force_noise: float = 5000.0) -> Path:
    """The tanker with the measured sensors (depth and sling force at ``rate`` [Hz], noise
    ``noise`` [m] and ``force_noise`` [N]), noise seed ``seed``, written into ``folder``."""
    path = folder / f"tanker-live-{seed}.yaml"
    text = (files("flexlift.scenarios") / "tanker.yaml").read_text()
    text = text.replace("output_interval_s: 1.0", f"output_interval_s: {min(1.0, 1 / rate):g}")
    path.write_text(text + SENSORS.format(seed=seed, rate=rate, noise=noise,
                                          force_noise=force_noise))
    return path


def _replace(master, state, bags, groups, truth, late_zd, sep_ok) -> None:
    for j, i in enumerate(bags):
        if "z" in truth:
            master._z[j] = state.z[i]
        if "zd" in truth:
            master._zd[j] = late_zd[j]
        if "V" in truth:
            master._V[j] = state.V[i]
        if "sep" in truth:
            master.separated[j] = state.sep[groups[i]] and sep_ok


def lockstep(scenario, truth=(), delay: float = 0.0, noise: float = 0.0,
             sep_delay: float = 0.0) -> dict:
    """One lift of ``scenario``: the plant and the master in lock step (module docstring);
    a true speed ``delay`` [s] late, with white noise of ``noise`` [m/s] a sample; the
    plant's separation told ``sep_delay`` [s] late."""
    run = prepare(scenario, "commanded")
    tap, master = SensorTap(run), Master(scenario)
    board = Board(master.plant.names, {s.name: s.period_s for s in tap.sensors}, rate=1.0)
    index = {run.plant.names[i]: j for j, i in enumerate(run.controllers.bags)}
    bags = [run.plant.names.index(b) for b in master.bags]
    groups, state, dt = run.plant.records.bags.group, run.state, run.settings.dt
    run.start()
    k_period, history, t_live = run.settings.k_ctrl, [], None
    rng, t_sep = np.random.default_rng(1), None
    while True:
        k, k_next = int(state.counters[0]), run.next_stop()
        if k_next is None or run.after_chunk(run._advance(min(k_next, k - k % k_period
                                                              + k_period))):
            break
        t = (int(state.counters[0]) - 1) * dt
        for r in tap.take():
            source, _, quantity = r.sensor.rpartition("/")
            board.add(Reading(r.time_s, source, quantity, r.value), r.time_s)
        history.append((t, state.zd[bags] + noise * rng.standard_normal(len(bags))))
        while history[0][0] < t - delay - 1e-9:
            history.pop(0)
        if not master.inputs(board, t):
            continue
        if t_sep is None and state.sep.any():
            t_sep = t
        _replace(master, state, bags, groups, truth, history[0][1],
                 t_sep is not None and t >= t_sep + sep_delay - 1e-9)
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
            "separation_plant_s": h["separation_time_s"], "separation_live_s": t_live,
            "estimator": "hull" if master.hull is not None else "bag",
            "separation_told_by": master.hull.how if master.hull is not None else "rise"}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--seeds", type=int, nargs="+", default=[3])
    p.add_argument("--rate", type=float, default=1.0, help="depth and sling-force rate [Hz]")
    p.add_argument("--noise", type=float, default=0.02, help="depth noise [m]")
    p.add_argument("--force-noise", type=float, default=5000.0, help="sling force noise [N]")
    p.add_argument("--cases", type=int, nargs="+", default=None,
                   help="the cases' numbers (0: all inputs from the network; default: all)")
    p.add_argument("--out", default=str(Path(__file__).with_name("live_master.json")))
    args = p.parse_args(argv)
    out, folder = [], Path(args.out).parent
    for seed in args.seeds:
        path = tanker(seed, folder, args.rate, args.noise, args.force_noise)
        scenario = load_scenario(path)
        cases = [CASES[i] for i in args.cases] if args.cases is not None else CASES
        for name, truth, delay, noise, sep_delay in cases if seed == args.seeds[0] else cases[:1]:
            t0 = time.monotonic()
            row = {"seed": seed, "case": name, "rate_Hz": args.rate, "depth_noise_m": args.noise,
                   **lockstep(scenario, truth, delay, noise, sep_delay),
                   "wall_s": round(time.monotonic() - t0, 1)}
            print(json.dumps(row), flush=True)
            out.append(row)
        path.unlink()
    Path(args.out).write_text(json.dumps({"cases": out, "numpy": np.__version__}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
