"""The paper's configuration (SPEC §8): every external bag on its own reduced 4-state model.

Each external bag i sees only the unsorted-mdc 4-state model of :func:`flexlift.reduce.
paper_bag_model` (the two rigid modes of the wet hull kept, the flexible modes folded into
the feedthrough D) from the vertical force at its node to the displacement there, with no
coupling to the other bags. The force on it is its own buoyancy minus its tributary share
(by hull length, the hull divided at the midpoints between bag points) of the wet weight net
of the internal bags' constant buoyancy, of the suction and of the hull drag, plus its own bag
drag and a seabed spring over its tributary length. Each bag breaks out on its own: its
holding force starts at its tributary share of H_0 (in the holding shape) and follows SPEC §6
with its own uplift. Each bag starts neutral on its own model (gas for its tributary share of
the net wet weight), and its controllers take that as their neutral volume. The controllers are the decentralized ones. The hull's heave and pitch
are reported as the least-squares line through the bag points (pitch = its arctangent); no
strength is computed.
"""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import scipy.linalg as sla

from flexlift.control import Controller, control_params, fuzzy_engines
from flexlift.plant import build_plant
from flexlift.recorder import Recorder
from flexlift.reduce import paper_bag_model


def paper_models(P):
    """Block-diagonal (A, B, C, CA, D) of the external bags' 4-state models and their
    tributary lengths [m]."""
    ext = np.flatnonzero(P.external)
    blocks = []
    for i in ext:
        node = P.hull.nearest_node(P.x_point[i])
        blocks.append(paper_bag_model(P.modes, int(node), zeta=P.zeta))
    A = sla.block_diag(*[m.A for m in blocks])
    B = sla.block_diag(*[m.B for m in blocks])
    Cm = sla.block_diag(*[m.C for m in blocks])
    D = np.array([float(m.D.ravel()[0]) for m in blocks])
    x = P.x_point[ext]
    order = np.argsort(x)
    edges = np.concatenate([[0.0], 0.5 * (x[order][1:] + x[order][:-1]), [P.hull.length]])
    trib = np.empty(x.size)
    trib[order] = np.diff(edges)
    lo = np.empty(x.size)
    lo[order] = edges[:-1]
    return A, B, Cm, Cm @ A, D, trib, lo


def simulate_paper(scenario, T_end: float, engine="table", progress=None):
    from flexlift.simulate import check_faults

    P = build_plant(scenario)
    check_faults(scenario, P.names)
    ext = np.flatnonzero(P.external)
    ne = ext.size
    A, B, Cm, CA, D, trib, lo = paper_models(P)
    L = P.hull.length
    g = P.gas
    rg = g.rho * g.g
    V0 = P.neutral_volumes()
    net_weight = P.wet_weight - rg * V0[~P.external].sum()
    W = net_weight * trib / L
    sb = P.seabed
    hold = np.array([sb.shape(np.linspace(a, a + l, 201), L).mean() * l for a, l in zip(lo, trib)])
    H0 = sb.H0 * hold / hold.sum()
    kL, cL = sb.stiffness * trib, sb.damping * trib
    drag = P.drag_line * trib + P.drag_bag[ext]
    cap = P.capacity[ext]
    dt = scenario.simulation.time_step_s
    n_steps = int(math.ceil(T_end / dt - 1e-9))
    k_ctrl = max(1, int(round(1.0 / scenario.control.sample_rate_Hz / dt)))
    V_share = W / rg  # each bag neutral on its own model
    cp = control_params(scenario, P.x_point[ext], V_share, cap, g.rho, g.g, None, "decentralized")
    cp = type(cp)(**{**cp.__dict__, "mode": "paper"})
    sup, fill = fuzzy_engines(scenario, engine)
    ctrl = Controller(cp, sup, fill)
    ns = 4 * ne

    def matrix(active):
        K = np.diag(kL * active)
        Cc = np.diag(cL * active)
        J = A - B @ (K @ Cm + Cc @ CA)
        return np.linalg.inv(np.eye(ns) - 0.5 * dt * J)

    cache = {}
    s = np.zeros(ns)
    n = g.moles(V_share, g.pressure(np.zeros(ne)))
    H = H0.copy()
    sep = np.zeros(ne, dtype=bool)
    u_fill, u_open = np.zeros(ne), np.zeros(ne)
    cmd = (u_fill, u_open, np.zeros(ne), V_share.copy(), np.zeros(ne))
    Pn = SimpleNamespace(names=tuple(P.names[i] for i in ext), x_point=P.x_point[ext],
                         external=np.ones(ne, dtype=bool), gas=g, nb=ne, pitch_slope=0.0)
    rec = Recorder(Pn, scenario, "paper", dt)
    tol, target = scenario.limits.arrival_tolerance_m, scenario.control.target_height_m
    top_limit = g.water_depth - scenario.limits.surface_clearance_m - P.top_offset[ext]
    hold_since = None
    xs = P.x_point[ext] - P.x_point[ext].mean()
    rows: dict = {}
    for k in range(n_steps + 1):
        t = k * dt
        y = Cm @ s
        yd = CA @ s
        p = g.p_atm + rg * np.maximum(g.water_depth - y, 0.0)
        V = np.minimum(n * g.RT / p, cap)
        lift = rg * V
        if k % k_ctrl == 0:
            cmd = ctrl.step(t, y, yd, V, sep)
            u_fill, u_open = cmd[0], cmd[1]
        qc = -kL * y - cL * yd
        active = np.where(sep, (y < 0) & (qc > 0), True)
        Fc = qc * active
        F = lift - W - drag * np.abs(yd) * yd + Fc - np.where(sep, H, 0.0)
        purge = g.purge_max * u_open * np.sqrt(V / cap)
        ndot = p * (u_fill - purge) / g.RT
        U = lift - W
        Hdot = np.where(sep, -H / sb.release_time,
                        np.where(U > 0, -(H0 / sb.breakout_time) * np.minimum(U / np.maximum(H0, 1e-12), 1.0), 0.0))
        # record
        rec.gas_local += u_fill * dt
        rec.gas_free += u_fill * p / g.p_atm * dt
        v = float(np.abs(yd).max())
        rec.vmax = max(rec.vmax, v)
        if v > scenario.limits.ascent_velocity_m_s and not rec.has("limit_ascent_velocity"):
            rec.event(t, "limit_ascent_velocity", Pn.names[int(np.argmax(np.abs(yd)))], f"{v:.2f} m/s")
        theta = math.atan(float(xs @ y / (xs @ xs)))
        rec.pmax = max(rec.pmax, abs(theta))
        if k % rec.k_out == 0:
            for key, val in (("time", t), ("height", y + D * F), ("ascent_velocity", yd),
                             ("pitch_angle", np.full(ne, theta)), ("pitch_rate", np.full(ne, float(xs @ yd / (xs @ xs)))),
                             ("net_flow", u_fill - purge), ("gas_volume", V), ("lift", lift),
                             ("fill_rate", u_fill), ("purge_opening", u_open), ("supervisor_output", cmd[2]),
                             ("desired_volume", cmd[3]), ("reference_height", cmd[4]),
                             ("heave", float(y.mean())), ("pitch", theta), ("holding_force", float(H.sum())),
                             ("uplift", float(U.sum())), ("contact_force", float(Fc.sum()))):
                rows.setdefault(key, []).append(np.array(val, dtype=float).copy())
        newsep = ~sep & (U > H)
        for i in np.flatnonzero(newsep):
            rec.event(t, "separation", Pn.names[i], "this bag's share of the hull lifts off")
        sep = sep | newsep
        if sep.all() and not rec.has("breakout") and np.all(H < 1e-3 * H0):
            rec.event(t, "breakout", None, "holding force below 0.1 % of H0 at every bag")
        if np.any(y > top_limit):
            rec.event(t, "surface_breach", Pn.names[int(np.argmax(y - top_limit))], "the run ends at the surface")
            break
        if sep.any():
            within = np.abs(y - target) <= tol
            rec.arrivals(t, within)
            if within.all():
                hold_since = t if hold_since is None else hold_since
                if t - hold_since >= scenario.simulation.hold_time_s - 1e-9:
                    rec.event(t, "target_held", None, f"held {scenario.simulation.hold_time_s:.0f} s")
                    break
            else:
                hold_since = None
        if k == n_steps:
            break
        key = tuple(active)
        if key not in cache:
            cache[key] = matrix(np.array(key, dtype=float))
        s = s + cache[key] @ (dt * (A @ s + B @ F))
        n = np.minimum(n + dt * ndot, g.max_moles(p, cap, np.zeros(ne, dtype=bool)))
        H = np.maximum(H + dt * Hdot, 0.0)
        if progress is not None and k % max(1, n_steps // 100) == 0:
            progress(k / n_steps)
    rec.rows = {k: v for k, v in rows.items()}
    rec.stored_t = rows["time"][-1]
    rec.last = None
    return rec.finish(None)
