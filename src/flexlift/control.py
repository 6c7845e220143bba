"""The ascent controllers (SPEC §7), vectorised over the controlled (external) bags.

Per bag, sampled at ``control.sample_rate_Hz`` with zero-order hold:

- reference ``z_ref(t)``: from the height at separation, a trapezoidal velocity profile
  (accelerate at ``ascent_acceleration_m_s2`` to ``ascent_speed_m_s``, cruise, decelerate) that
  stops at ``target_height_m``; before separation the desired volume holds a breakout pull;
- supervisory Mamdani controller on the normalised error e = (z_ref - z) / error_scale and
  rate ė = (ż_ref - ż) / rate_scale -> u in [-1, 1]; desired volume V_d = V_neutral + u ΔV_max;
- primary (fill) controller, SIFSMC: ε = V_d - V, s = ε' + λ ε, signed distance
  d = s / sqrt(1 + λ^2), normalised by ``distance_scale_m3_s`` and mapped by the fill fuzzy map to
  a fill fraction of Q_in,max (ε' from a filtered difference, time constant ``DERIV_TAU``);
- secondary (purge) controller: PID on the excess V - V_d, valve opening in [0, 1], with
  conditional-integration anti-windup. Authority goes to the fill controller while the bag is
  short of V_d and to the purge controller while it has too much (never both).

Modes: ``decentralized`` (each bag on its own measurements; the separation is the one shared
signal), ``coordinated`` (one heave reference for all bags from their mean height, pitch-
levelling corrections -(k_θ θ + k_θ' θ') ξ_i with ξ_i the bag's normalised lever about the
bags' centre, and the breakout pull shaped like the suction so the hull separates level),
``paper`` (as decentralized, on the paper's uncoupled plant) and ``open-loop`` (fill to the
breakout volume, never purge).

The fuzzy systems come from :mod:`flexlift.rulebase`. Exact Mamdani inference costs ~0.25 ms
per call, too slow for 40 000 control steps, so by default the loop uses lookup tables sampled
from the exact systems once (201 x 201 bilinear for the supervisor, 401 points for the fill
map; max deviation from exact inference below 1e-3, tested); ``engine="exact"`` (or a callable)
uses exact inference.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from flexlift import constants as C

#: time constant of the filter on the volume-deficit derivative of the SIFSMC [s]
DERIV_TAU = 1.0


class SupervisorTable:
    """Bilinear lookup of a two-input fuzzy map sampled on a ``grid`` x ``grid`` lattice over
    [-1, 1]^2; inputs saturated. ``table(x)`` with x (n, 2) -> (n,); ``table.pair(e, r)``
    takes the two columns separately."""

    def __init__(self, fis, grid: int = 201):
        g = np.linspace(-1.0, 1.0, grid)
        E, R = np.meshgrid(g, g, indexing="ij")
        self.values = np.asarray(fis(np.column_stack([E.ravel(), R.ravel()]))).reshape(grid, grid)
        self.grid = grid
        self.h = 2.0 / (grid - 1)
        self.flat = self.values.ravel()
        self.flat_list = self.flat.tolist()

    def __call__(self, x):
        x = np.asarray(x, dtype=float)
        return self.pair(x[:, 0], x[:, 1])

    def pair(self, e, r):
        top = self.grid - 1 - 1e-9
        inv_h = 1.0 / self.h
        se = np.minimum(np.maximum((e + 1.0) * inv_h, 0.0), top)
        sr = np.minimum(np.maximum((r + 1.0) * inv_h, 0.0), top)
        ie, ir = se.astype(np.intp), sr.astype(np.intp)
        fe, fr = se - ie, sr - ir
        k = ie * self.grid + ir
        T = self.flat
        c00, c10, c01, c11 = T[k], T[k + self.grid], T[k + 1], T[k + self.grid + 1]
        lo = c00 + fe * (c10 - c00)
        return lo + fr * (c01 + fe * (c11 - c01) - lo)

    def scalar(self, e: float, r: float) -> float:
        """:meth:`pair` for two floats (the same arithmetic, no array overhead)."""
        if e != e or r != r:
            return float("nan")
        top = self.grid - 1 - 1e-9
        inv_h = 1.0 / self.h
        se = min(max((e + 1.0) * inv_h, 0.0), top)
        sr = min(max((r + 1.0) * inv_h, 0.0), top)
        ie, ir = int(se), int(sr)
        fe, fr = se - ie, sr - ir
        g = self.grid
        k = ie * g + ir
        T = self.flat_list
        c00, c10, c01, c11 = T[k], T[k + g], T[k + 1], T[k + g + 1]
        lo = c00 + fe * (c10 - c00)
        return lo + fr * (c01 + fe * (c11 - c01) - lo)


class FillTable:
    """Linear lookup of the one-input fill map on ``grid`` points over [-1, 1]."""

    def __init__(self, fill, grid: int = 401):
        self.x = np.linspace(-1.0, 1.0, grid)
        self.y = np.asarray(fill(self.x), dtype=float)

        self._xl, self._yl = self.x.tolist(), self.y.tolist()
        self._n, self._inv_h = grid, (grid - 1) / 2.0

    def __call__(self, d):
        return np.interp(d, self.x, self.y)

    def scalar(self, d: float) -> float:
        """:meth:`__call__` for one float (np.interp's arithmetic, no array overhead)."""
        xs, ys = self._xl, self._yl
        if d >= xs[-1]:
            return ys[-1]
        if d <= xs[0]:
            return ys[0]
        if d != d:
            return d
        j = int((d + 1.0) * self._inv_h)
        j = 0 if 0 > j else j
        j = self._n - 2 if self._n - 2 < j else j
        while j > 0 and xs[j] > d:
            j -= 1
        while xs[j + 1] <= d:
            j += 1
        if d == xs[j]:
            return ys[j]
        return (ys[j + 1] - ys[j]) / (xs[j + 1] - xs[j]) * (d - xs[j]) + ys[j]


def fuzzy_engines(scenario, engine="table"):
    """(supervisor, fill) callables for a scenario: ``"table"`` (lookup, default), ``"exact"``
    (exact inference), or a (supervisor, fill) pair of callables to use as given."""
    if not isinstance(engine, str):
        return engine
    from flexlift.rulebase import fill_fis, supervisor_fis

    s = scenario.control.supervisor
    fis = supervisor_fis(
        and_method=s.and_method,
        or_method=s.or_method,
        implication=s.implication,
        aggregation=s.aggregation,
        defuzzification=s.defuzzification,
        resolution=s.resolution,
    )
    fill = fill_fis()
    if engine == "exact":
        return fis, fill
    if engine == "table":
        return SupervisorTable(fis), FillTable(fill)
    from flexlift.errors import InputError

    raise InputError("engine", engine, "use 'table', 'exact' or a (supervisor, fill) pair")


def trapezoid(tau, distance, speed: float, accel: float):
    """Position and velocity along a trapezoidal-velocity move of ``distance`` [m] (array)
    at time ``tau`` [s] after its start (vectorised; tau < 0 gives the start)."""
    D = np.abs(distance)
    sgn = np.sign(distance)
    vp = np.minimum(speed, np.sqrt(D * accel))
    ta = vp / accel
    tc = np.where(vp > 0, (D - vp * ta) / np.where(vp > 0, vp, 1.0), 0.0)
    T = 2 * ta + tc
    tau = np.clip(tau, 0.0, None)
    s1 = 0.5 * accel * tau**2
    s2 = 0.5 * vp * ta + vp * (tau - ta)
    r = np.clip(T - tau, 0.0, None)
    s3 = D - 0.5 * accel * r**2
    pos = np.where(tau < ta, s1, np.where(tau < ta + tc, s2, s3))
    vel = np.where(tau < ta, accel * tau, np.where(tau < ta + tc, vp, accel * r))
    return sgn * pos, sgn * vel


def shaped_pull(total: float, x_bags, x_centroid: float) -> np.ndarray:
    """Split a pull ``total`` [any unit] over bags at ``x_bags`` [m] so that its resultant acts
    at ``x_centroid`` [m] (the suction's centroid), as close to equal shares as possible
    (least-norm correction); falls back to equal shares for a single bag."""
    x = np.asarray(x_bags, dtype=float)
    n = x.size
    equal = np.full(n, total / n)
    if n < 2 or np.ptp(x) == 0:
        return equal
    A = np.vstack([np.ones(n), x])
    rhs = np.array([0.0, total * x_centroid - equal @ x])
    return equal + A.T @ np.linalg.solve(A @ A.T, rhs)


@dataclass(frozen=True)
class ControlParams:
    """Controller constants for the controlled bags (arrays over them), SI."""

    mode: str
    period: float  # [s]
    target: float  # [m]
    speed: float  # [m/s]
    accel: float  # [m/s^2]
    x: np.ndarray  # bag points [m]
    lever: np.ndarray  # normalised lever about the bags' centre [-]
    V_neutral: np.ndarray  # [m^3]
    V_pull: np.ndarray  # breakout pull as volume [m^3]
    dV_max: np.ndarray  # supervisor authority [m^3]
    e_scale: float  # [m]
    r_scale: float  # [m/s]
    lam: float  # [1/s]
    d_scale: float  # [m^3/s]
    kp: float  # [1/m^3]
    ki: float  # [1/(m^3 s)]
    kd: float  # [s/m^3]
    fill_max: float  # [m^3/s]
    k_pitch: float  # [m^3/rad]
    k_pitch_rate: float  # [m^3 s/rad]
    deadband: float = 0.0  # [m^3]


def control_params(scenario, x, V_neutral, capacity, rho, g, hold_centroid=None, mode=None):
    """:class:`ControlParams` for bags at ``x`` [m] with neutral volumes and capacities [m^3];
    ``hold_centroid`` [m] is where the suction's resultant acts (for the shaped pull)."""
    c = scenario.control
    mode = mode or c.mode
    x = np.asarray(x, dtype=float)
    pull_total = c.breakout_pull_t * C.TONNE * g / (rho * g)  # [m^3]
    if mode == "coordinated" and c.coordination.shape_breakout_pull and hold_centroid is not None:
        V_pull = shaped_pull(pull_total, x, hold_centroid)
    else:
        V_pull = np.full(x.size, pull_total / max(x.size, 1))
    half = 0.5 * np.ptp(x) if x.size > 1 else 1.0
    return ControlParams(
        mode=mode,
        period=1.0 / c.sample_rate_Hz,
        target=c.target_height_m,
        speed=c.ascent_speed_m_s,
        accel=c.ascent_acceleration_m_s2,
        x=x,
        lever=(x - x.mean()) / (half or 1.0),
        V_neutral=np.asarray(V_neutral, dtype=float),
        V_pull=V_pull,
        dV_max=c.supervisor.volume_authority * np.asarray(capacity, dtype=float),
        e_scale=c.supervisor.error_scale_m,
        r_scale=c.supervisor.rate_scale_m_s,
        lam=c.fill.slope_1_s,
        d_scale=c.fill.distance_scale_m3_s,
        kp=c.purge.kp_1_m3,
        ki=c.purge.ki_1_m3s,
        kd=c.purge.kd_s_m3,
        fill_max=scenario.gas.fill_rate_max_m3_s,
        k_pitch=c.coordination.pitch_gain_m3_rad,
        k_pitch_rate=c.coordination.pitch_rate_gain_m3s_rad,
        deadband=c.volume_deadband_m3,
    )


class Controller:
    """The sampled controllers of all controlled bags (mutable state, vectorised)."""

    def __init__(self, params: ControlParams, supervisor, fill):
        self.p = params
        self.supervisor = supervisor
        self.fill = fill
        n = params.x.size
        self.integ = np.zeros(n)
        self.prev_excess = np.zeros(n)
        self.prev_eps = None
        self.eps_rate = np.zeros(n)
        self.t_sep = np.full(n, np.nan)
        self.pending = True  # some bag has not separated yet
        self.z0 = np.zeros(n)
        self.active = np.ones(n, dtype=bool)  # False once a bag is lost (sling break)
        self.zeros = np.zeros(n)
        self.prof = None
        self._lev = None
        self._lost = False
        self.n = n
        self.started = False  # some bag has separated
        self.open_loop = params.mode == "open-loop"
        self.V_hold = params.V_neutral + params.V_pull
        self.inv_e, self.inv_r, self.inv_T = 1 / params.e_scale, 1 / params.r_scale, 1 / params.period
        self.a_filt = params.period / (DERIV_TAU + params.period)
        self.d_gain = 1.0 / np.sqrt(1.0 + params.lam**2) / params.d_scale
        self.coordinated = params.mode == "coordinated" and n > 1
        # float-by-float arithmetic for the few bags of a hull (same operations, no array
        # overhead) when both fuzzy maps are lookup tables
        self._scalar = isinstance(supervisor, SupervisorTable) and isinstance(fill, FillTable)
        self._Vn, self._dV = params.V_neutral.tolist(), params.dV_max.tolist()
        self._ref_l = None  # (profile, signs, start heights) as lists for the flat profile
        self._sup = getattr(supervisor, "pair", None) or (
            lambda e, r: np.asarray(supervisor(np.column_stack([np.clip(e, -1, 1), np.clip(r, -1, 1)])), dtype=float)
        )

    @property
    def n_active(self) -> int:
        return int(self.active.sum()) if self._lost else self.n

    def lose(self, k: int) -> None:
        """Bag k is lost (its sling broke): its controllers stop."""
        self.active[k] = False
        self._lost = True

    def reference(self, t: float):
        """(z_ref, ż_ref) per bag [m, m/s]; a bag not yet separated keeps its start height."""
        if self.prof is None:
            p = self.p
            D = np.abs(p.target - self.z0)
            vp = np.minimum(p.speed, np.sqrt(D * p.accel))
            ta = vp / p.accel
            tc = np.where(vp > 0, (D - vp * ta) / np.where(vp > 0, vp, 1.0), 0.0)
            t0 = np.where(np.isnan(self.t_sep), np.inf, self.t_sep)
            flat = None
            if np.all(t0 == t0[0]) and np.all(vp == p.speed):
                flat = (float(t0[0]), float(ta[0]), float(p.speed), float((ta + tc).min()))
            self.prof = (np.sign(p.target - self.z0), D, vp, ta, ta + tc, 2 * ta + tc, t0, flat)
        sgn, D, vp, ta, tb, T, t0, flat = self.prof
        a = self.p.accel
        if flat is not None:  # one start time, cruise reached by every bag: scalar phases
            t_start, ta_s, vp_s, tb_min = flat
            tau = max(t - t_start, 0.0)
            if tau < ta_s:
                return self.z0 + sgn * (0.5 * a * tau * tau), sgn * (a * tau)
            if tau < tb_min:
                return self.z0 + sgn * (vp_s * (tau - 0.5 * ta_s)), sgn * vp_s
        tau = np.maximum(t - t0, 0.0)
        r = np.maximum(T - tau, 0.0)
        pos = np.where(tau < ta, (0.5 * a) * tau * tau,
                       np.where(tau < tb, vp * (tau - 0.5 * ta), D - (0.5 * a) * r * r))
        vel = np.minimum(np.minimum(a * tau, vp), a * r)
        return self.z0 + sgn * pos, sgn * vel

    def _reference_lists(self, t: float):
        """:meth:`reference` as two lists of floats (the same arithmetic)."""
        if self.prof is None:
            self.reference(t)  # builds the profile
        prof = self.prof
        if self._ref_l is None or self._ref_l[0] is not prof:
            self._ref_l = (prof, self.z0.tolist()) + tuple(v.tolist() for v in prof[:7])
        _, z0, sgn, D, vp, ta, tb, T, t0 = self._ref_l
        a = self.p.accel
        flat = prof[-1]
        if flat is not None:  # one start time, cruise reached by every bag: scalar phases
            t_start, ta_s, vp_s, tb_min = flat
            tau = max(t - t_start, 0.0)
            if tau < tb_min:
                if tau < ta_s:
                    s, v = 0.5 * a * tau * tau, a * tau
                else:
                    s, v = vp_s * (tau - 0.5 * ta_s), vp_s
                return [z0[i] + sgn[i] * s for i in range(len(sgn))], [g * v for g in sgn]
        zr, zdr = [], []
        half_a = 0.5 * a
        for i in range(len(sgn)):
            tau = max(t - t0[i], 0.0)
            r = max(T[i] - tau, 0.0)
            if tau < ta[i]:
                pos = half_a * tau * tau
            elif tau < tb[i]:
                pos = vp[i] * (tau - 0.5 * ta[i])
            else:
                pos = D[i] - half_a * r * r
            zr.append(z0[i] + sgn[i] * pos)
            zdr.append(sgn[i] * min(min(a * tau, vp[i]), a * r))
        return zr, zdr

    def _levelling(self):
        """Lever arms about the live bags' centre and 1 / sum of their squares (cached)."""
        key = self.active.tobytes()
        if self._lev is None or self._lev[0] != key:
            live = self.active
            xl = np.where(live, self.p.x - self.p.x[live].mean(), 0.0)
            self._lev = (key, xl / float(xl @ xl))
        return self._lev[1]

    def idle(self, deadband: float) -> bool:
        """True if the last sample left every valve shut and the next samples keep them shut
        while the measurements stay the same (before separation: the desired volume is fixed)."""
        if self.started or self.prev_eps is None or self.integ.any():
            return False
        return bool(np.all(np.abs(self.prev_eps) <= deadband))

    def step(self, t: float, z, zdot, V, separated):
        """One control sample from measured heights [m], velocities [m/s] and gas volumes
        [m^3]; ``separated`` a bool (the hull) or one per bag (the paper's uncoupled bags).
        Returns (fill [m^3/s], purge opening [-], supervisor u [-], V_d [m^3], z_ref [m])."""
        p = self.p
        if self.pending and (separated is True or (separated is not False and np.any(separated))):
            new = np.asarray(separated, dtype=bool) & np.isnan(self.t_sep)
            self.t_sep = np.where(new, t, self.t_sep)
            live = self.active
            if p.mode == "coordinated":
                self.z0 = np.full_like(self.z0, float(np.mean(z[live])) if live.any() else 0.0)
            else:
                self.z0 = np.where(new, z, self.z0)
            self.prof = None
            self.pending = bool(np.isnan(self.t_sep).any())
            self.started = True
        if self._scalar and (separated is True or separated is False):
            return self._step_scalar(t, z, zdot, V)
        if self.open_loop or not self.started:
            V_d = self.V_hold
            u = self.zeros
            z_ref = self.zeros
        else:
            z_ref, zd_ref = self.reference(t)
            u = self._sup((z_ref - z) * self.inv_e, (zd_ref - zdot) * self.inv_r)
            V_d = p.V_neutral + u * p.dV_max
            if self.pending:
                pre = np.isnan(self.t_sep)
                V_d = np.where(pre, self.V_hold, V_d)
                u = np.where(pre, 0.0, u)
        if self.coordinated and self.n_active > 1:
            w = self._levelling()
            V_d = V_d - (p.k_pitch * float(w @ z) + p.k_pitch_rate * float(w @ zdot)) * p.lever
        eps = V_d - V
        if self.prev_eps is None:
            self.prev_eps = eps
        self.eps_rate += self.a_filt * ((eps - self.prev_eps) * self.inv_T - self.eps_rate)
        self.prev_eps = eps
        d = (self.eps_rate + p.lam * eps) * self.d_gain
        fill = self.fill(np.minimum(np.maximum(d, -1.0), 1.0)) * ((eps > p.deadband) * p.fill_max)
        if self.open_loop:
            opening = self.zeros
        else:
            excess = -eps
            raw = p.kp * excess + p.ki * self.integ
            if p.kd:
                raw = raw + p.kd * (excess - self.prev_excess) * self.inv_T
                self.prev_excess = excess
            # anti-windup: no integration while the valve is saturated open by the excess
            # the purge PID starts beyond the deadband and keeps authority while its integral
            # is positive (a steady opening against the expansion during the ascent)
            on = (excess > p.deadband) | (self.integ > 0.0)
            hold = ((raw >= 1.0) & (excess > 0)) | ~on
            self.integ = np.maximum(self.integ + np.where(hold, 0.0, excess * p.period), 0.0)
            opening = np.minimum(np.maximum(raw, 0.0), 1.0) * on
            fill = fill * (opening <= 0.0)
        if self.n_active < self.n:
            fill = fill * self.active
            opening = opening * self.active
        return fill, opening, u, V_d, z_ref

    def _step_scalar(self, t: float, z, zdot, V):
        """:meth:`step` after the separation bookkeeping, bag by bag on floats (lookup tables,
        one separation flag for all bags)."""
        p = self.p
        n = self.n
        zl, zdl, Vl = z.tolist(), zdot.tolist(), V.tolist()
        if self.open_loop or not self.started:
            Vd = self.V_hold.tolist()
            u = z_ref = None
        else:
            zr, zdr = self._reference_lists(t)
            inv_e, inv_r = self.inv_e, self.inv_r
            Vn, dV = self._Vn, self._dV
            S = self.supervisor  # SupervisorTable.scalar inlined (the same arithmetic)
            Tf, g = S.flat_list, S.grid
            top, inv_h = g - 1 - 1e-9, 1.0 / S.h
            u = [0.0] * n
            Vd = [0.0] * n
            for i in range(n):
                e = (zr[i] - zl[i]) * inv_e
                r = (zdr[i] - zdl[i]) * inv_r
                if e != e or r != r:
                    ui = float("nan")
                else:
                    # min(max(., 0), top) as conditional expressions (the same semantics)
                    se, sr = (e + 1.0) * inv_h, (r + 1.0) * inv_h
                    se = 0.0 if 0.0 > se else se
                    se = top if top < se else se
                    sr = 0.0 if 0.0 > sr else sr
                    sr = top if top < sr else sr
                    ie, ir = int(se), int(sr)
                    fe, fr = se - ie, sr - ir
                    k = ie * g + ir
                    c00, c10, c01, c11 = Tf[k], Tf[k + g], Tf[k + 1], Tf[k + g + 1]
                    lo = c00 + fe * (c10 - c00)
                    ui = lo + fr * (c01 + fe * (c11 - c01) - lo)
                u[i] = ui
                Vd[i] = Vn[i] + ui * dV[i]
            if self.pending:
                hold = self.V_hold.tolist()
                for i, pre in enumerate(np.isnan(self.t_sep).tolist()):
                    if pre:
                        Vd[i], u[i] = hold[i], 0.0
            z_ref = zr
        if self.coordinated and self.n_active > 1:
            w = self._levelling()
            corr = p.k_pitch * float(w @ z) + p.k_pitch_rate * float(w @ zdot)
            lever = p.lever.tolist()
            Vd = [Vd[i] - corr * lever[i] for i in range(n)]
        eps = [Vd[i] - Vl[i] for i in range(n)]
        prev = eps if self.prev_eps is None else self.prev_eps.tolist()
        a, inv_T, lam, gain = self.a_filt, self.inv_T, p.lam, self.d_gain
        rate = self.eps_rate.tolist()
        fill_map = self.fill.scalar
        db, fmax = p.deadband, p.fill_max
        fill = [0.0] * n
        opening = [0.0] * n
        purge = not self.open_loop
        integ = self.integ.tolist()
        prev_x = self.prev_excess.tolist()
        kp, ki, kd, T = p.kp, p.ki, p.kd, p.period
        for i in range(n):
            e = eps[i]
            r = rate[i] + a * ((e - prev[i]) * inv_T - rate[i])
            rate[i] = r
            d = (r + lam * e) * gain
            d = -1.0 if -1.0 > d else d
            f = fill_map(1.0 if 1.0 < d else d) * ((e > db) * fmax)
            if purge:
                excess = -e
                raw = kp * excess + ki * integ[i]
                if kd:
                    raw = raw + kd * (excess - prev_x[i]) * inv_T
                    prev_x[i] = excess
                on = excess > db or integ[i] > 0.0
                hold_i = (raw >= 1.0 and excess > 0) or not on
                ii = integ[i] + (0.0 if hold_i else excess * T)
                integ[i] = 0.0 if 0.0 > ii else ii
                op = 0.0 if 0.0 > raw else raw
                op = (1.0 if 1.0 < op else op) * on
                opening[i] = op
                f = f * (op <= 0.0)
            fill[i] = f
        self.eps_rate = np.array(rate)
        self.prev_eps = np.array(eps)
        if purge:
            self.integ = np.array(integ)
            if kd:
                self.prev_excess = np.array(prev_x)
        fill, opening = np.array(fill), np.array(opening)
        if self._lost:
            fill = fill * self.active
            opening = opening * self.active
        if u is None:
            u = z_ref = self.zeros
        else:
            u, z_ref = np.array(u), np.array(z_ref)
        return fill, opening, u, np.array(Vd), z_ref
