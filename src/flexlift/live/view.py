"""What the dashboard shows of a live run (:class:`flexlift.live.session.Live`): one
:class:`~flexlift.live.dashboard.DashboardSnapshot` per control period, from the readings
board, the valve set-points sent and the alarms raised (docs/guide/dashboard.md).

The state at a glance: ``stopped`` while the readings are stale (filling stopped);
``holding`` once every controlled bag is within the arrival tolerance of the target. Else a
bag has *risen* once it is :data:`MOVING_M` shallower than at its first reading (the hull
lifting off the seabed; five times a depth gauge's few centimetres of noise): ``ascending``
once risen and the bags' mean upward speed is past :data:`MOVING_M_S` (the mean: one noisy
gauge's 2 s slope alone passes it on the seabed), ``breaking out`` once risen with a fill
valve open, ``filling`` before that.
"""

from __future__ import annotations

from flexlift.live.dashboard import Alarm, BagView, DashboardSnapshot, Limits

#: a bag rising faster than this is ascending [m/s]
MOVING_M_S = 0.02
#: a bag this much shallower than at its first reading has left the seabed [m]
MOVING_M = 0.1
#: the alarms the page lists, newest last
SHOWN_ALARMS = 12


def snapshot_of(live, t: float) -> DashboardSnapshot:
    """The dashboard's snapshot of ``live`` at lift time ``t`` [s]."""
    board, fill_max = live.board, float(live.master.controllers.fill_max)
    bags = []
    for bag in board.bags:
        fill, opening = live.sent.get(bag, (None, None))
        bags.append(BagView(bag, depth_m=board.value(bag, "depth"),
                            speed_m_s=board.speed(bag), pitch_rad=board.value(bag, "pitch"),
                            fill=None if fill is None or fill_max <= 0 else fill / fill_max,
                            purge=opening))
    names = set(board.bags)
    alarms = tuple(Alarm(t_a, kind, source if source in names else None, text)
                   for t_a, kind, source, text in live.alarms.raised[-SHOWN_ALARMS:])
    return DashboardSnapshot(time_s=t, state=_state(live, bags), bags=tuple(bags),
                             limits=Limits.of_scenario(live.scenario),
                             hull_pitch_rad=board.value("hull", "pitch"), alarms=alarms,
                             lift=live.lift, mode=live.control)


def _state(live, bags: list[BagView]) -> str:
    if live.stale:
        return "stopped"
    if live.arrived():
        return "holding"
    for b in bags:  # each bag's first depth read: where it lay on the seabed
        if b.depth_m is not None:
            live.first_depth.setdefault(b.name, b.depth_m)
    risen = any(b.depth_m is not None and live.first_depth[b.name] - b.depth_m > MOVING_M
                for b in bags)
    speeds = [b.speed_m_s for b in bags if b.speed_m_s is not None]
    if risen and speeds and sum(speeds) / len(speeds) > MOVING_M_S:
        return "ascending"
    filling = any((b.fill or 0.0) > 0.0 for b in bags)
    return "breaking out" if risen and filling else "filling"
