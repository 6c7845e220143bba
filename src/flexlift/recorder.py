"""Recording an ascent while it runs: sampled time histories, running maxima, events, gas
accounting and the strength snapshots (used by :mod:`flexlift.simulate`)."""

from __future__ import annotations

import numpy as np

from flexlift.results import Result, build_result


class Recorder:
    """Collects what the loop produces; :meth:`finish` turns it into a :class:`Result`."""

    def __init__(self, P, scenario, mode: str, dt: float):
        sim = scenario.simulation
        self.P, self.scenario, self.mode, self.dt = P, scenario, mode, dt
        self.k_out = max(1, int(round(sim.output_interval_s / dt)))
        self.k_str = max(1, int(round(sim.strength_interval_s / dt)))
        self.rows: dict[str, list] = {}
        self.snap: list[dict] = []
        self.events: list[dict] = []
        self.kinds: set[str] = set()
        nb = P.nb
        self.arrival = np.full(nb, np.nan)
        self.gas_local = np.zeros(nb)
        self.gas_free = np.zeros(nb)
        self.vented = np.zeros(nb)
        self.vmax = 0.0
        self.pmax = 0.0
        self.last = None
        self.limits = scenario.limits
        self.liftoff = False
        self.resettled = False
        self.inv_patm = 1.0 / P.gas.p_atm
        self._mdc = None  # see _mdc_matrices

    def _mdc_matrices(self):
        """Static correction of the eliminated modes: their generalised force per unit strip
        line load, per unit bag point force and of the weight, divided by omega^2; and the
        heave displacement per unit coordinate (computed once, for the output rows)."""
        if self._mdc is None:
            P = self.P
            nr = P.nr
            inv_om2 = 1.0 / P.omega2[nr:]
            self._mdc = (
                np.ascontiguousarray((P.psi_s[:, nr:] * P.ws[:, None]).T * inv_om2[:, None]),
                np.ascontiguousarray(P.psi_b[:, nr:].T * inv_om2[:, None]),
                P.Q_weight[nr:] * inv_om2,
                float(P.psi_s[0, 0]),
            )
        return self._mdc

    # ------------------------------------------------------------------ events
    def event(self, t: float, kind: str, bag: str | None, detail: str = "") -> None:
        self.events.append({"time_s": round(float(t), 3), "kind": kind, "bag": bag, "detail": detail})
        self.kinds.add(kind)

    def has(self, kind: str) -> bool:
        return kind in self.kinds

    def arrivals(self, t: float, within: np.ndarray, z_prev=None, z=None, lo=None, hi=None,
                 dt: float = 0.0) -> None:
        """Record the first arrival of the bags ``within`` tolerance at time ``t`` [s]; with the
        heights of the previous step ``z_prev`` and this one ``z`` [m], the time is interpolated
        to the crossing of the band [lo, hi] [m] inside the step."""
        new = within & np.isnan(self.arrival)
        if new.any():
            for i in np.flatnonzero(new):
                ta = t
                if z_prev is not None:
                    a, b = float(z_prev[i]), float(z[i])
                    edge = lo if a < lo else (hi if a > hi else None)
                    if edge is not None and a != b:
                        ta = t - dt + dt * min(max((edge - a) / (b - a), 0.0), 1.0)
                self.arrival[i] = ta
                self.event(ta, "arrival", self.P.names[i])

    def account(self, aux, dt: float) -> None:
        """Gas filled over a step of ``dt`` [s] with the fill flows of ``aux`` (the flows the
        state integrates: at local pressure and as free air)."""
        fdt = aux.fill * dt
        self.gas_local += fdt
        self.gas_free += fdt * aux.pressure * self.inv_patm

    def vent(self, volume_local: np.ndarray) -> None:
        self.vented += volume_local

    # ------------------------------------------------------------------ samples
    @property
    def all_arrived(self) -> bool:
        return not np.isnan(self.arrival).any()

    def sample(self, k, t, x, aux, u, cmd, ext, sw) -> None:
        P = self.P
        if not sw.separated:
            self._keep(k, t, x, aux, u, cmd, ext, sw)
            return
        if sw.intact:  # every sling holds: the largest |zdot| without the array round trips
            v = max(map(abs, aux.zdot.tolist()))
        else:
            v = float(np.abs(aux.zdot * sw.attached).max())
        pitch = abs(float(x[1]) * P.pitch_slope)
        if v > self.vmax:
            self.vmax = v
            if v > self.limits.ascent_velocity_m_s and not self.has("limit_ascent_velocity"):
                i = int(np.argmax(np.abs(aux.zdot) * sw.attached))
                self.event(t, "limit_ascent_velocity", P.names[i], f"{v:.2f} m/s")
        if pitch > self.pmax:
            self.pmax = pitch
            if np.degrees(pitch) > self.limits.pitch_deg and not self.has("limit_pitch"):
                self.event(t, "limit_pitch", None, f"{np.degrees(pitch):.1f} deg")
        if sw.separated and not self.resettled:
            wmin = aux.w_min
            if not self.liftoff and wmin > 0.05:
                self.liftoff = True
                self.event(t, "liftoff", None, "the whole hull is clear of the seabed")
            elif self.liftoff and wmin < 0.0:
                self.resettled = True
                self.event(t, "resettle", None, "the hull touched the seabed again")
        self._keep(k, t, x, aux, u, cmd, ext, sw)

    def _keep(self, k, t, x, aux, u, cmd, ext, sw) -> None:
        """Remember the latest state; store a row and a strength snapshot at their intervals."""
        self.last = (t, x, aux, u, cmd, ext, sw.separated, sw.attached)
        if k % self.k_out == 0:
            self._store()
            self.stored_t = t
        if k % self.k_str == 0:
            self._snapshot(t, x, aux, sw)

    def _store(self) -> None:
        t, x, aux, u, cmd, ext, separated, attached = self.last
        P = self.P
        nb, nr = P.nb, P.nr
        # static (mdc) correction of the eliminated modes at the bag points
        mdc_line, mdc_point, mdc_weight, heave = self._mdc_matrices()
        if aux.line is not None:
            qs = np.concatenate((x[:nr], mdc_line @ aux.line + mdc_point @ aux.point + mdc_weight))
        else:
            qs = np.zeros(P.modes.n_modes)
            qs[:nr] = x[:nr]
        z = P.psi_p @ qs
        theta = P.dpsi_p @ qs
        theta_rate = P.dpsi_p[:, :nr] @ x[nr : 2 * nr]
        full = np.full(nb, np.nan)

        def on_ext(vals):
            out = full.copy()
            out[ext] = vals
            return out

        row = {
            "time": t,
            "height": z,
            "reference_height": on_ext(cmd[4]) if len(cmd) > 4 else full,
            "ascent_velocity": aux.zdot,
            "pitch_angle": theta,
            "pitch_rate": theta_rate,
            "net_flow": aux.fill - aux.purge,
            "gas_volume": aux.volume,
            "lift": aux.bag_force,
            "fill_rate": aux.fill,
            "purge_opening": np.where(P.external, u[nb:], np.nan),
            "supervisor_output": on_ext(cmd[2]),
            "desired_volume": on_ext(cmd[3]),
            "heave": float(heave * x[0]),
            "pitch": float(x[1] * P.pitch_slope),
            "holding_force": float(x[-1]),
            "uplift": aux.uplift,
            "contact_force": float(P.ws @ aux.contact) if aux.contact is not None else np.nan,
        }
        for key, val in row.items():
            self.rows.setdefault(key, []).append(val)

    def _snapshot(self, t, x, aux, sw) -> None:
        nr = self.P.nr
        self.snap.append(
            {
                "t": t,
                "q": x[:nr].copy(),
                "v": x[nr : 2 * nr].copy(),
                "a": aux.accel.copy(),
                "H": float(x[-1]),
                "separated": sw.separated,
                "point": aux.point.copy(),
                "volume": aux.volume.copy(),
                "attached": sw.attached.copy(),
                "current": sw.current,
                "noise": sw.noise_s.copy(),
            }
        )

    def finish(self, error: str | None) -> Result:
        if self.last is not None and (not self.rows or self.stored_t != self.last[0]):
            self._store()
        return build_result(self, error)
