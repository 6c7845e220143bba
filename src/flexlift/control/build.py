"""Controller constants from a scenario and a plant, and the fuzzy maps they use."""

from __future__ import annotations

import functools
import math
import os

import numpy as np

from flexlift import constants as C
from flexlift.control.controller import MODE_CODES, ControlArrays, ControlState, new_state
from flexlift.control.profile import valve_profile
from flexlift.control.sequence import start_times
from flexlift.errors import InputError
from flexlift.fuzzy.tables import Table2D

#: grid of the supervisor's lookup table over [-1, 1]^2
TABLE_GRID = 201
#: the default breakout pull as a fraction of the suction H_0 (the tanker's 150 t of 835 t)
DEFAULT_PULL_FRACTION = 0.18


def breakout_pull(scenario, H0: float) -> float:
    """The breakout pull [N]: ``control.breakout_pull_t``, or by default
    :data:`DEFAULT_PULL_FRACTION` of the suction ``H0`` [N]."""
    t = scenario.control.breakout_pull_t
    if t is None:
        return DEFAULT_PULL_FRACTION * H0
    return t * C.TONNE * scenario.environment.gravity_m_s2


def shaped_pull(total: float, x_bags, x_centroid: float) -> np.ndarray:
    """Split a pull ``total`` [any unit] over bags at ``x_bags`` [m] so that its resultant acts
    at ``x_centroid`` [m] (the suction's centroid), as close to equal shares as possible
    (least-norm correction); equal shares for a single bag."""
    x = np.asarray(x_bags, dtype=float)
    n = x.size
    equal = np.full(n, total / n)
    if n < 2 or np.ptp(x) == 0:
        return equal
    A = np.vstack([np.ones(n), x])
    rhs = np.array([0.0, total * x_centroid - equal @ x])
    return equal + A.T @ np.linalg.solve(A @ A.T, rhs)


def planned_profile(scenario, plant):
    """The valve-limited planned ascent of ``plant``'s external bags (None: the trapezoid)."""
    c = scenario.control
    bags = np.flatnonzero(plant.external)
    if not bags.size:
        return None
    return valve_profile(c.target_height_m, c.ascent_speed_m_s, c.ascent_acceleration_m_s2,
                         plant.neutral_volume[bags], plant.bags.capacity[bags], plant.bags.purge_max[bags],
                         c.purge_margin, plant.bags.water_depth, plant.bags.p_atm, plant.bags.rho_g)


def _stamp(path: str | None, key: str):
    """(path, size, modification time) of a user's file: a changed file is read again."""
    if path is None:
        return None
    try:
        st = os.stat(path)
    except OSError as exc:
        raise InputError(key, path, f"cannot be read ({exc.strerror}); give the path of a MATLAB "
                         ".fis file, relative to the scenario file's folder") from None
    return (path, st.st_size, st.st_mtime_ns)


@functools.lru_cache(maxsize=16)
def _user_fis(stamp, role: str, resolution: int):
    from flexlift.fuzzy.fis import load_controller_fis

    return load_controller_fis(stamp[0], role, resolution=resolution)


def _supervisor_of(settings):
    from flexlift.fuzzy.rulebase import supervisor_fis_from

    stamp = _stamp(settings.fis_file, "control.supervisor.fis_file")
    if stamp is None:
        return supervisor_fis_from(settings)
    return _user_fis(stamp, "supervisor", settings.resolution)


def supervisor_fis_of(scenario):
    """The scenario's supervisory fuzzy system: the user's .fis file
    (``control.supervisor.fis_file``) or the built-in rule base with the scenario's operators."""
    return _supervisor_of(scenario.control.supervisor)


@functools.lru_cache(maxsize=16)
def _supervisor_table_of(settings, stamp) -> Table2D:
    return Table2D.sample(_supervisor_of(settings), TABLE_GRID)


def _supervisor_table(settings) -> Table2D:
    """The supervisor of ``control.supervisor`` settings sampled into a lookup table (once
    per settings and file: 40,401 exact evaluations take ~0.2 s)."""
    return _supervisor_table_of(settings, _stamp(settings.fis_file, "control.supervisor.fis_file"))


@functools.lru_cache(maxsize=16)
def _fill_map_of(stamp):
    from flexlift.fuzzy.rulebase import FillMap, fill_fis

    if stamp is None:
        return fill_fis()
    return FillMap(_user_fis(stamp, "fill", 101), normalise=False,
                   source="control.fill.fis_file")


def fill_map_of(scenario):
    """The scenario's SIFSMC fill map: the user's .fis file (``control.fill.fis_file``) or
    the built-in one."""
    return _fill_map_of(_stamp(scenario.control.fill.fis_file, "control.fill.fis_file"))


def fuzzy_maps(scenario, engine="table"):
    """(supervisor table or None, external supervisor or None, fill map) for an ``engine``:
    "table" (the supervisor sampled into a lookup table, default), "exact" (exact inference,
    evaluated outside the compiled loop at every sample), a callable supervisor (points (n, 2)
    -> u (n,)), or a pair (supervisor, fill) of callables."""
    from flexlift.fuzzy.rulebase import FillMap

    fill = fill_map_of(scenario)
    if isinstance(engine, str):
        if engine not in ("table", "exact"):
            raise InputError("engine", engine, "use 'table', 'exact', a callable or a pair")
        if engine == "table":
            return _supervisor_table(scenario.control.supervisor), None, fill
        return None, supervisor_fis_of(scenario), fill
    if callable(engine):
        return None, engine, fill
    supervisor, fill_fn = engine
    return None, supervisor, FillMap(fill_fn)


def bag_pulls(scenario, plant, mode: str = "decentralized") -> np.ndarray:
    """The breakout pull of each of ``plant``'s external bags as gas volume [m^3]: the pull of
    :func:`breakout_pull` shaped so that its resultant sits on the suction's centroid
    (``control.shape_breakout_pull``, coupled plant, closed-loop modes), else equal shares."""
    x = plant.x_point[np.flatnonzero(plant.external)]
    pull = breakout_pull(scenario, float(plant.seabed.H0.sum())) / plant.bags.rho_g  # [m^3]
    if not x.size:
        return np.zeros(0)
    if (mode in ("coordinated", "decentralized") and scenario.control.shape_breakout_pull
            and plant.kind == "coupled"):
        share = (plant.seabed.H0 / plant.seabed.H0.sum())[plant.strips.group] if plant.seabed.H0.sum() > 0 else 1.0 / plant.seabed.ng
        hold_centroid = float(np.sum(plant.strips.weight * plant.strips.hold * share * plant.strip_x))
        return shaped_pull(pull, x, hold_centroid)
    return np.full(x.size, pull / max(x.size, 1))


def controller_for(scenario, plant, mode: str, table: Table2D | None, fill_map
                   ) -> tuple[ControlArrays, ControlState]:
    """Constants and memory of the controllers of ``plant``'s external bags in ``mode``."""
    c = scenario.control
    bags = np.flatnonzero(plant.external)
    x = plant.x_point[bags]
    V_pull = bag_pulls(scenario, plant, mode)
    half = 0.5 * np.ptp(x) if x.size > 1 else 1.0
    s = c.supervisor
    values = table.values if table is not None else np.zeros((2, 2))
    prof = planned_profile(scenario, plant)
    arrays = ControlArrays(
        mode=MODE_CODES[mode], bags=bags.astype(np.int64), period=1.0 / c.sample_rate_Hz,
        target=c.target_height_m, speed=c.ascent_speed_m_s, accel=c.ascent_acceleration_m_s2,
        lever=(x - x.mean()) / (half or 1.0), x=x, V_neutral=plant.neutral_volume[bags].copy(),
        V_pull=V_pull, dV_max=s.volume_authority * plant.bags.capacity[bags],
        e_scale=s.error_scale_m, r_scale=s.rate_scale_m_s, lam=c.fill.slope_1_s,
        d_scale=c.fill.distance_scale_m3_s, kp=c.purge.kp_1_m3, ki=c.purge.ki_1_m3s,
        kd=c.purge.kd_s_m3, fill_max=scenario.gas.fill_rate_max_m3_s,
        deadband=c.volume_deadband_m3, k_pitch=c.coordination.pitch_gain_m3_rad,
        k_pitch_rate=c.coordination.pitch_rate_gain_m3s_rad,
        k_height=c.height_integral_gain_m2_s, filter_time=c.measurement_filter_s,
        filter_gain=(1.0 - math.exp(-(1.0 / c.sample_rate_Hz) / c.measurement_filter_s)
                     if c.measurement_filter_s > 0.0 else 0.0),
        ref_T=prof.duration if prof else 0.0, ref_z=prof.z if prof else np.zeros(2),
        ref_v=prof.v if prof else np.zeros(2),
        table=np.ascontiguousarray(values), fill_v=fill_map.table.values,
        start=start_times(scenario, plant.names, plant.x_point, plant.external)[bags],
        staged=c.sequence is not None, weight=np.ones(bags.size))
    return arrays, new_state(bags.size)
