"""What the dashboard shows: one frozen snapshot of the lift, made by whoever watches it.

Every quantity is in SI units (the page converts pitch to degrees for reading). A reading that
is missing (the lift has no such sensor, or it has gone silent) is ``None``, as is any
non-finite number once the snapshot is sent to the page.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

#: the states at a glance, in the order a lift passes through them
STATES = ("filling", "breaking out", "ascending", "holding", "stopped")


def _number(value, name: str) -> float | None:
    """``value`` as a finite float, or None when missing or not finite; a wrong type raises."""
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise TypeError(f"{name} must be a number or None, not {type(value).__name__}")
    value = float(value)
    return value if math.isfinite(value) else None


@dataclass(frozen=True)
class Limits:
    """The limits the page draws each reading against.

    Parameters
    ----------
    speed_m_s : float
        Largest allowed ascent speed of a bag's lift point [m/s].
    pitch_rad : float
        Largest allowed pitch, of a bag's inclinometer and of the hull, either way [rad].
    water_depth_m : float
        Depth of the seabed below the surface: the full scale of the depth bars [m].
    """

    speed_m_s: float
    pitch_rad: float
    water_depth_m: float

    @classmethod
    def of_scenario(cls, scenario) -> Limits:
        """The limits of a loaded scenario: its ascent speed and pitch limits, its water depth."""
        return cls(speed_m_s=float(scenario.limits.ascent_velocity_m_s),
                   pitch_rad=math.radians(float(scenario.limits.pitch_deg)),
                   water_depth_m=float(scenario.environment.water_depth_m))

    def __post_init__(self):
        for name in ("speed_m_s", "pitch_rad", "water_depth_m"):
            value = getattr(self, name)
            if _number(value, name) is None or value <= 0:
                raise ValueError(f"Limits.{name} must be a positive finite number, not {value!r}")


@dataclass(frozen=True)
class BagView:
    """One bag as the page shows it.

    Parameters
    ----------
    name : str
        The bag's name (``"bag_1"`` ...).
    depth_m : float or None
        Depth of the bag's lift point below the surface [m].
    speed_m_s : float or None
        Its ascent speed, positive upwards [m/s].
    pitch_rad : float or None
        Its inclinometer's pitch, bow up positive [rad].
    fill : float or None
        Fill valve as a fraction of the bag's largest fill rate: 0 shut, 1 full flow [-].
    purge : float or None
        Purge valve opening: 0 shut, 1 fully open [-].
    """

    name: str
    depth_m: float | None = None
    speed_m_s: float | None = None
    pitch_rad: float | None = None
    fill: float | None = None
    purge: float | None = None

    def __post_init__(self):
        if not isinstance(self.name, str) or not self.name:
            raise ValueError(f"BagView.name must be a non-empty string, not {self.name!r}")
        for name in ("depth_m", "speed_m_s", "pitch_rad", "fill", "purge"):
            _number(getattr(self, name), f"BagView.{name}")


@dataclass(frozen=True)
class Alarm:
    """One alarm: when it was raised, of which kind, on which bag, in words.

    Parameters
    ----------
    time_s : float
        Lift time at which it was raised, seconds since filling began [s].
    kind : str
        Its kind (``"speed"``, ``"pitch"``, ``"silent"``, ``"not obeyed"``, ``"range"``, ...).
    bag : str or None
        The bag it concerns, or None for the hull or the whole lift.
    message : str
        One line for the salvage master.
    """

    time_s: float
    kind: str
    bag: str | None
    message: str


@dataclass(frozen=True)
class DashboardSnapshot:
    """The lift at one moment, as the dashboard shows it.

    Parameters
    ----------
    time_s : float
        Lift time, seconds since filling began [s].
    state : str
        The state at a glance, one of :data:`STATES`.
    bags : tuple of BagView
        Every bag, stern to bow (the order the page draws them in).
    limits : Limits
        The limits each reading is drawn against.
    hull_pitch_rad : float or None
        The hull's pitch, bow up positive [rad].
    alarms : tuple of Alarm
        The alarms standing, newest last.
    lift : str
        The lift's name, for the title.
    mode : str
        How the valves are driven (``"master"``, ``"advise"``, ...), shown beside the state.
    """

    time_s: float
    state: str
    bags: tuple[BagView, ...]
    limits: Limits
    hull_pitch_rad: float | None = None
    alarms: tuple[Alarm, ...] = field(default_factory=tuple)
    lift: str = ""
    mode: str = ""

    def __post_init__(self):
        if self.state not in STATES:
            raise ValueError(f"DashboardSnapshot.state must be one of {', '.join(STATES)}, not {self.state!r}")
        if _number(self.time_s, "DashboardSnapshot.time_s") is None:
            raise ValueError(f"DashboardSnapshot.time_s must be finite, not {self.time_s!r}")
        object.__setattr__(self, "bags", tuple(self.bags))
        object.__setattr__(self, "alarms", tuple(self.alarms))
        _number(self.hull_pitch_rad, "DashboardSnapshot.hull_pitch_rad")

    def to_json(self) -> dict:
        """The snapshot as plain JSON-able data (non-finite numbers as None)."""
        return {
            "time_s": float(self.time_s),
            "state": self.state,
            "lift": self.lift,
            "mode": self.mode,
            "hull_pitch_rad": _number(self.hull_pitch_rad, "hull_pitch_rad"),
            "limits": {k: float(getattr(self.limits, k)) for k in ("speed_m_s", "pitch_rad", "water_depth_m")},
            "bags": [
                {"name": b.name, **{k: _number(getattr(b, k), k)
                                    for k in ("depth_m", "speed_m_s", "pitch_rad", "fill", "purge")}}
                for b in self.bags
            ],
            "alarms": [
                {"time_s": _number(a.time_s, "time_s"), "kind": str(a.kind), "bag": a.bag, "message": str(a.message)}
                for a in self.alarms
            ],
        }
