"""Compile the ascent loop into numba's on-disk cache now: ``python -m flexlift.cli.warm``.

The install step (``./dev``) runs this once after installing, where a wait is expected, so the
first ``flexlift run`` loads the machine code from the cache instead of compiling it in
silence. It runs a one-second ascent of the built-in tanker in each default control mode of
``flexlift run`` (the same compiled entry points, into the same cache the run reads), and says
what it does: a line at the start when the cache is cold, a line at least every 10 s while
compiling, and the time it took. With a warm cache it takes a second or two and says so.

A read-only install (a system site-packages) cannot write a cache beside the package: numba
then uses its user-wide cache folder (``~/.cache`` or ``NUMBA_CACHE_DIR``), which this fills
the same way.
"""

from __future__ import annotations

import sys
import threading
import time

#: seconds before the first "compiling" line, and between the lines after it
FIRST_NOTICE_S, EVERY_S = 2.0, 8.0


def _notices(done: threading.Event, t0: float, say) -> None:
    if done.wait(FIRST_NOTICE_S):
        return
    say("compiling the ascent loop into numba's on-disk cache (once after an install or a "
        "change to the compiled code; about one to two minutes on two cores) ...")
    while not done.wait(EVERY_S):
        say(f"  still compiling ({time.monotonic() - t0:.0f} s)")


def warm(say=None) -> float:
    """Compile (or load) the ascent of ``flexlift run``'s default control modes; returns the
    seconds it took. ``say(line)`` reports progress (default: stderr)."""
    from flexlift.ascent import simulate
    from flexlift.cli.run import DEFAULT_CONTROLS
    from flexlift.loads.scenario import load_scenario

    if say is None:
        def say(line: str) -> None:
            print(f"flexlift: {line}", file=sys.stderr, flush=True)

    t0 = time.monotonic()
    done = threading.Event()
    notices = threading.Thread(target=_notices, args=(done, t0, say), daemon=True)
    notices.start()
    try:
        tanker = load_scenario("tanker")
        for mode in DEFAULT_CONTROLS:
            simulate(tanker, control=mode, duration=1.0)
    finally:
        done.set()
        notices.join()
    elapsed = time.monotonic() - t0
    if elapsed > FIRST_NOTICE_S:
        say(f"ascent loop compiled and cached in {elapsed:.0f} s; runs now load it in about "
            "a second")
    return elapsed


def main() -> int:
    warm()
    return 0


if __name__ == "__main__":
    sys.exit(main())
