"""Live's alarms: a bag too fast, the hull pitched past its limit, a sensor silent past twice
its period, a command not obeyed, a reading out of range. Each is raised once when its cause
appears (``kind``, ``source``) and cleared when it goes."""

from __future__ import annotations

import math

from flexlift.live.messages import QUANTITIES

#: a valve's feedback may differ from its command this long before the alarm [s]
OBEY_S = 3.0
#: ... by more than this: an opening [-], and a fill as a fraction of the largest fill
OBEY_OPENING, OBEY_FILL_FRACTION = 0.1, 0.1


class Alarms:
    """The alarms of a lift (``limits``: the scenario's; ``water_depth`` [m];
    ``fill_max`` [m^3/s])."""

    def __init__(self, limits, water_depth: float, fill_max: float):
        self.v_up = limits.ascent_velocity_m_s
        self.v_down = limits.descent_velocity_m_s
        self.pitch = math.radians(90.0 if limits.pitch_deg is None else limits.pitch_deg)
        self.water_depth, self.fill_max = water_depth, fill_max
        self.active: dict[tuple[str, str], str] = {}
        self.raised: list[tuple[float, str, str, str]] = []
        self._differs: dict[tuple[str, str], float] = {}

    def reading(self, reading) -> str | None:
        """Why a reading is out of range (None: it is not)."""
        lo, hi = QUANTITIES[reading.quantity][2:]
        if reading.quantity == "depth":
            hi = self.water_depth * 1.1
        if not lo <= reading.value <= hi:
            return f"{reading.value:.6g} outside [{lo:.6g}, {hi:.6g}]"
        return None

    def check(self, t: float, board, commanded: dict, silent: list[str],
              out_of_range: dict) -> list[tuple[float, str, str, str]]:
        """The alarms at lift time ``t`` [s]; returns those newly raised (time, kind, source,
        text). ``commanded``: {bag: (fill, opening)} last sent; ``out_of_range``: sensor ->
        why, for the readings of this period."""
        now: dict[tuple[str, str], str] = {}
        for bag in board.bags:
            v = board.speed(bag)
            if v is not None and (v > self.v_up or -v > self.v_down):
                now[("speed", bag)] = f"{v:+.3f} m/s past the limit {self.v_up:g} m/s"
        p = board.value("hull", "pitch")
        if p is not None and abs(p) > self.pitch:
            now[("pitch", "hull")] = (f"{math.degrees(p):+.2f} deg past the limit "
                                      f"{math.degrees(self.pitch):g} deg")
        for sensor in silent:
            now[("silent", sensor)] = "no reading for more than twice its period"
        for sensor, why in out_of_range.items():
            now[("range", sensor)] = why
        self._obeyed(t, board, commanded, now)
        new = [(t, k, s, text) for (k, s), text in now.items() if (k, s) not in self.active]
        for kind, source in list(self.active):
            if (kind, source) not in now and kind != "range":
                del self.active[(kind, source)]
        self.active.update(now)
        self.raised.extend(new)
        return new

    def _obeyed(self, t: float, board, commanded: dict, now: dict) -> None:
        """A valve whose feedback has differed from its command for OBEY_S."""
        for bag, (fill, opening) in commanded.items():
            for quantity, want, tol in (("purge", opening, OBEY_OPENING),
                                        ("fill_flow", fill, OBEY_FILL_FRACTION * self.fill_max)):
                got = board.value(bag, quantity)
                key = (quantity, bag)
                if got is None or abs(got - want) <= tol:
                    self._differs.pop(key, None)
                    continue
                since = self._differs.setdefault(key, t)
                if t - since >= OBEY_S:
                    now[("not_obeyed", f"{bag}/{quantity}")] = (
                        f"commanded {want:.3g}, reads {got:.3g} for {t - since:.0f} s")

    def command_changed(self, bag: str, quantity: str) -> None:
        """A new command restarts the wait for its valve."""
        self._differs.pop((quantity, bag), None)
