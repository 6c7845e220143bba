"""The live dashboard: a web page, served from a background thread, that shows a lift as it
happens (per bag depth, speed, pitch, fill and purge against their limits, the hull's pitch,
the alarms and the state at a glance), updated over a websocket.

The one interface for the rest of flexlift::

    board = Dashboard(port=0)            # 0: a free port on 127.0.0.1
    url = board.start()                  # "http://127.0.0.1:PORT/"
    board.publish(DashboardSnapshot(...))  # from any thread, at least once a second
    board.stop()

See docs/guide/dashboard.md.
"""

from flexlift.live.dashboard.server import Dashboard
from flexlift.live.dashboard.snapshot import STATES, Alarm, BagView, DashboardSnapshot, Limits

__all__ = ["STATES", "Alarm", "BagView", "Dashboard", "DashboardSnapshot", "Limits"]
