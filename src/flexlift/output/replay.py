"""The folder of ``flexlift replay`` (docs/guide/replay.md): ``summary.json``, the estimated
histories ``estimates.nc``, the figure ``replay.png`` and ``report.html``."""

from __future__ import annotations

import html
import io
from pathlib import Path

import numpy as np

from flexlift.estimate.replay import PER_BAG
from flexlift.plumbing.atomic import atomic_file, write_bytes, write_json, write_text

#: the estimated histories' units and meanings (named as in results.nc)
UNITS = {"height": ("m", "height of the bag's point above the seabed"),
         "gas_volume": ("m3", "gas volume in the bag"),
         "leak": ("1/s", "the bag's gas leak rate"),
         "heave": ("m", "rigid heave of the hull's centre of mass above the seabed"),
         "pitch": ("rad", "rigid pitch angle of the hull, bow-up positive"),
         "holding_force": ("N", "suction holding force H"),
         "weight_factor": ("1", "submerged weight over the scenario's")}


def histories(result: dict):
    """The estimated histories as an xarray Dataset: each quantity of
    :meth:`flexlift.estimate.filter.Estimator.state` over (``time``, ``quantile``[, ``bag``])."""
    import xarray as xr

    times = np.array([t for t, _ in result["history"]])
    names = result["names"]
    data = {}
    for name, (unit, meaning) in UNITS.items():
        stack = np.array([np.asarray(state[name]) for _, state in result["history"]])
        if name in PER_BAG:
            data[name] = (("time", "quantile", "bag"), stack,
                          {"units": unit, "long_name": meaning})
        else:
            data[name] = (("time", "quantile"), stack[:, :, 0],
                          {"units": unit, "long_name": meaning})
    ds = xr.Dataset(data, coords={"time": ("time", times, {"units": "s"}),
                                  "quantile": ("quantile", np.array([5.0, 50.0, 95.0]),
                                               {"units": "%"}),
                                  "bag": ("bag", np.array(names, dtype="S32"))})
    ds.attrs["title"] = "flexlift replay: the lift as estimated from its sensor log"
    return ds


def write_replay(folder: Path, result: dict) -> None:
    """Everything of a replay into ``folder`` (an output folder being built)."""
    summary = result["summary"]
    write_json(folder / "summary.json", summary)
    with atomic_file(folder / "estimates.nc", suffix=".nc") as tmp:
        histories(result).to_netcdf(tmp, engine="scipy")
    write_bytes(folder / "replay.png", _figure(result))
    write_text(folder / "report.html", _report(summary))


def _figure(result: dict) -> bytes:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    s = result["summary"]
    times = np.array([t for t, _ in result["history"]])
    heave = np.array([np.asarray(state["heave"])[:, 0] for _, state in result["history"]])
    fig, (a, b) = plt.subplots(2, 1, figsize=(9, 6.5), sharex=True)
    a.fill_between(times, heave[:, 0], heave[:, 2], color="#9ecae1", label="5-95 %")
    a.plot(times, heave[:, 1], color="#08519c", lw=1.2, label="median")
    for alarm in s["alarms"]:
        a.axvline(alarm["time_s"], color="#cb181d", lw=0.8)
        a.annotate(f"{alarm['kind']} {alarm['bag']}", (alarm["time_s"], a.get_ylim()[1]),
                   rotation=90, va="top", ha="right", fontsize=7, color="#cb181d")
    a.set_ylabel("heave, estimated [m]")
    a.legend(loc="upper left", fontsize=8)
    a.set_title(f"{s['scenario']}: the lift as estimated from its sensor log")
    for key, colour, label in (("breakout_time_s", "#54278f", "breakout"),
                               ("arrival_time_s", "#006d2c", "arrival")):
        pts = [(f["time_s"], f[key]) for f in s["forecasts"] if f.get(key)]
        if pts:
            t = np.array([p[0] for p in pts])
            q = np.array([[p[1]["p5"], p[1]["p50"], p[1]["p95"]] for p in pts])
            b.fill_between(t, q[:, 0], q[:, 2], color=colour, alpha=0.2)
            b.plot(t, q[:, 1], color=colour, marker="o", ms=3, label=f"{label} (p50, 5-95 %)")
    b.set_xlabel("lift time [s]")
    b.set_ylabel("forecast time [s]")
    if s["forecasts"]:
        b.legend(loc="upper left", fontsize=8)
    else:
        b.text(0.5, 0.5, "no forecasts (--forecast-every 0)", ha="center",
               transform=b.transAxes)
    fig.tight_layout()
    out = io.BytesIO()
    fig.savefig(out, format="png", dpi=110)
    plt.close(fig)
    return out.getvalue()


def _band(b) -> str:
    return "-" if not b else f"{b['p50']:,.0f} s ({b['p5']:,.0f} to {b['p95']:,.0f})"


def _report(s: dict) -> str:
    e = html.escape
    alarms = s["alarms"]
    last = s["forecasts"][-1] if s["forecasts"] else None
    f = s["filter"]
    lead = (f"{len(alarms)} alarm(s): " + "; ".join(
        f"{a['kind']} at {a['bag']} at {a['time_s']:.0f} s" for a in alarms[:5])
        if alarms else "No fault detected.")
    parts = [f"<h1>flexlift replay: {e(s['scenario'])}</h1>", f"<p><b>{e(lead)}</b></p>"]
    if last:
        parts.append(f"<p>Last forecast, at {last['time_s']:.0f} s: breakout "
                     f"{_band(last['breakout_time_s'])}, arrival "
                     f"{_band(last['arrival_time_s'])}, P(unsafe) {last['p_unsafe']:.2f} "
                     f"({last['members']} members).</p>")
    parts.append("<img src='replay.png' alt='the estimated heave with its band, the alarms "
                 "and the forecasts'>")
    if alarms:
        parts.append("<h2>Alarms</h2><table><tr><th>time s</th><th>kind</th><th>bag</th>"
                     "<th>confidence</th><th>message</th><th>advice</th></tr>" + "".join(
                         f"<tr><td>{a['time_s']:.1f}</td><td>{e(a['kind'])}</td>"
                         f"<td>{e(a['bag'])}</td><td>{a['confidence']:.2f}</td>"
                         f"<td>{e(a['message'])}</td><td>{e(a['advice'])}</td></tr>"
                         for a in alarms) + "</table>")
    parts.append(f"<h2>The filter</h2><p>{f['assimilated']:,} readings assimilated, "
                 f"{f['gated']:,} gated, {f['late']:,} late, {f['updates']:,} updates, "
                 f"resampled {f['resampled']} times, widened {f['widened']} times (the "
                 "ensemble had lost the lift: its estimate then is not to be trusted); "
                 f"{s['lift_time_s']:,.0f} s of lift in {s['wall_time_s']:.1f} s "
                 f"({s['speed_x_real_time']:.0f}x real time).</p>")
    bad = s["log_report"]
    parts.append(f"<h2>The log</h2><p>{bad.get('lines', 0):,} lines, "
                 f"{bad.get('readings', 0):,} readings; bad lines by reason: "
                 f"{e(str(bad.get('bad') or 'none'))}.</p>")
    return ("<!doctype html><html><head><meta charset='utf-8'><title>flexlift replay"
            "</title></head><body>" + "\n".join(parts) + "</body></html>\n")
