"""Work done beside this process: a forked copy of it computes one function's value while this
process goes on with its own work (the sweep's end draws its report's figures so, on a core
its workers no longer use, when one is free: :func:`spare_core`).

Only where forking is safe and cheap: on Linux, in a process with no thread but its main one
(a thread holding a lock at the fork would leave the copy waiting on it for good; the sweep's
engine is closed and its imports joined first). Anywhere else :func:`start` returns None and the
caller does the work itself, as it does when the copy fails or takes longer than
:data:`LIMIT_S`: the outcome never depends on the copy, only the time does. The copy shares
this process's memory (copy-on-write), sends its value back pickled through a pipe and leaves
with ``os._exit`` (no atexit handler, no buffered output of this process written twice).
"""

from __future__ import annotations

import contextlib
import gc
import os
import pickle
import select
import signal
import sys
import threading
import time

#: the longest the copy may take before this process does the work itself [s]
LIMIT_S = 120.0


def spare_core() -> bool:
    """Whether a core is free for a copy now: fewer threads ready to run on this machine
    (``/proc/loadavg``'s running count, this process's included) than the cores this process
    may use. On a busy machine a copy would only share this process's core with it, and
    cost the copy's own start; where it cannot be told (not Linux), False."""
    try:
        with open("/proc/loadavg") as f:
            running = int(f.read().split()[3].split("/")[0])
        cores = len(os.sched_getaffinity(0))
    except (OSError, ValueError, IndexError, AttributeError):
        return False
    return running < cores


def can_fork() -> bool:
    """Whether a copy of this process may be forked here (module docstring)."""
    return (sys.platform.startswith("linux") and hasattr(os, "fork")
            and threading.active_count() == 1)


class Aside:
    """A forked copy computing a value; :meth:`result` waits for it, :meth:`close` ends it."""

    def __init__(self, pid: int, fd: int):
        self.pid, self.fd = pid, fd
        self._code: int | None = None

    def result(self, limit_s: float = LIMIT_S):
        """The copy's value, or None if it failed or took longer than ``limit_s`` seconds."""
        chunks, deadline = [], time.monotonic() + limit_s
        try:
            while True:
                left = deadline - time.monotonic()
                if left <= 0 or not select.select([self.fd], [], [], left)[0]:
                    return None  # too long: close() ends it
                chunk = os.read(self.fd, 1 << 20)
                if not chunk:
                    break
                chunks.append(chunk)
            if self._reap(block=True) != 0:
                return None
            return pickle.loads(b"".join(chunks))
        except Exception:
            return None
        finally:
            self.close()

    def close(self) -> None:
        """End the copy if it still runs, and reap it; idempotent."""
        if self.fd is not None:
            with contextlib.suppress(OSError):
                os.close(self.fd)
            self.fd = None
        if self.pid is not None and self._reap(block=False) is None:
            with contextlib.suppress(OSError):
                os.kill(self.pid, signal.SIGKILL)
            self._reap(block=True)

    def _reap(self, block: bool) -> int | None:
        """The copy's exit code once it has ended (None while it runs)."""
        if self.pid is None:
            return self._code
        try:
            pid, status = os.waitpid(self.pid, 0 if block else os.WNOHANG)
        except ChildProcessError:
            pid, status = self.pid, 1 << 8
        if pid == 0:
            return None
        self.pid, self._code = None, os.waitstatus_to_exitcode(status)
        return self._code


def start(fn, *args) -> Aside | None:
    """``fn(*args)`` computed in a forked copy of this process, or None where that is not
    safe (:func:`can_fork`) or the fork fails: then the caller computes it itself. The value
    must pickle."""
    if not can_fork():
        return None
    r, w = os.pipe()
    try:
        pid = os.fork()
    except OSError:
        os.close(r)
        os.close(w)
        return None
    if pid == 0:  # the copy: compute, send, leave without running this process's exit
        code = 1
        try:
            gc.disable()  # short-lived: a collection would touch (and copy) every page
            os.close(r)
            data = pickle.dumps(fn(*args), protocol=pickle.HIGHEST_PROTOCOL)
            with os.fdopen(w, "wb") as pipe:
                pipe.write(data)
            code = 0
        except BaseException:  # noqa: BLE001 - whatever happens, the caller does the work
            pass
        finally:
            os._exit(code)
    os.close(w)
    return Aside(pid, r)
