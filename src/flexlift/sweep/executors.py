"""Where the cases run: in this process, in local processes, or on a Dask cluster.

Each engine hands out :class:`concurrent.futures.Future` objects for :func:`~flexlift.sweep.
worker.run_case` and says how many cases it can usefully hold at once (``window``):

- :class:`Serial`: in this process, one after the other (``--workers 1``);
- :class:`Processes`: a :class:`~concurrent.futures.ProcessPoolExecutor` (the default, one
  worker per core). Workers are started with ``forkserver``: never forked from a parent that
  holds threads; the server imports flexlift and loads the compiled ascent once
  (:mod:`.warm`), so each worker starts with both and runs case after case. A worker that dies breaks the pool: every case in
  flight fails with ``BrokenProcessPool``, and the next submission starts a new pool;
- :class:`DaskEngine`: ``distributed.Client.get_executor()`` on an existing scheduler
  (``--scheduler tcp://host:8786``) or a ``LocalCluster`` started here (``--dask-local N``).
  Dask is imported only here, and only when asked for.

Workers ignore Ctrl-C (the coordinating process handles it and stops them), and their own
log records are collected per case by the worker, not printed.
"""

from __future__ import annotations

import concurrent.futures as cf
import contextlib
import logging
import multiprocessing
import os
import signal
import threading

from flexlift.errors import InputError, clean

log = logging.getLogger(__name__)


def local_cores() -> int:
    """The cores this process may use (its CPU affinity), at least 1."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - not Linux
        return max(1, os.cpu_count() or 1)


def _init_worker(alive) -> None:
    """In each local worker: Ctrl-C is the coordinator's to handle; warnings go to the case's
    record, not to a stray handler; and the worker ends when the coordinating process is gone
    (killed outright, nothing would collect its results): ``alive`` is the reading end of a
    pipe only the coordinator can write to, which reads as ended once it has died."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    threading.Thread(target=_watch, args=(alive,), name="flexlift-watch", daemon=True).start()
    root = logging.getLogger("flexlift")
    root.handlers.clear()
    root.addHandler(logging.NullHandler())
    root.propagate = False
    root.setLevel(logging.WARNING)


def _watch(alive) -> None:
    try:
        alive.recv_bytes()
    except (EOFError, OSError):
        pass
    os._exit(0)


class Serial:
    """Every case in this process, when submitted."""

    name = "serial"
    workers = 1
    window = 1

    def submit(self, fn, *args) -> cf.Future:
        f: cf.Future = cf.Future()
        try:
            f.set_result(fn(*args))
        except Exception as exc:  # a worker function that raised: the caller decides
            f.set_exception(exc)
        return f

    def close(self, cancel: bool = False) -> None:
        pass


class Processes:
    """A pool of ``workers`` local processes."""

    name = "processes"

    def __init__(self, workers: int):
        self.workers = int(workers)
        self.window = 2 * self.workers
        self._ctx = multiprocessing.get_context("forkserver")
        # imported (and the compiled ascent loaded) once in the fork server, not per worker
        self._ctx.set_forkserver_preload(["flexlift.sweep.worker", "flexlift.sweep.warm"])
        self._alive_r, self._alive_w = self._ctx.Pipe(duplex=False)  # see _init_worker
        self._pool = self._new()

    def _new(self) -> cf.ProcessPoolExecutor:
        return cf.ProcessPoolExecutor(max_workers=self.workers, mp_context=self._ctx,
                                      initializer=_init_worker, initargs=(self._alive_r,))

    def submit(self, fn, *args) -> cf.Future:
        """Submit to the pool; a pool broken by a worker that died is replaced first (its
        cases in flight have failed with ``BrokenProcessPool``: the caller retries them)."""
        try:
            return self._pool.submit(fn, *args)
        except cf.process.BrokenProcessPool:
            with contextlib.suppress(Exception):
                self._pool.shutdown(wait=False, cancel_futures=True)
            self._pool = self._new()
            return self._pool.submit(fn, *args)

    def close(self, cancel: bool = False) -> None:
        if cancel:  # interrupted: stop the workers now, not after the queued cases
            procs = list((getattr(self._pool, "_processes", None) or {}).values())
            self._pool.shutdown(wait=False, cancel_futures=True)
            for p in procs:
                with contextlib.suppress(Exception):
                    p.terminate()
            for p in procs:
                with contextlib.suppress(Exception):
                    p.join(5)
        else:
            self._pool.shutdown(wait=True)
        for end in (self._alive_w, self._alive_r):
            with contextlib.suppress(OSError):
                end.close()


class DaskEngine:
    """Cases as Dask tasks through ``Client.get_executor()``.

    scheduler : address of an existing scheduler (``tcp://host:8786``), or None to start a
        ``LocalCluster`` of ``local_workers`` single-threaded worker processes here
    timeout : how long to wait for the scheduler [s]
    processes : the LocalCluster's workers are processes (False: threads of this process)
    """

    name = "dask"

    def __init__(self, scheduler: str | None = None, local_workers: int | None = None,
                 timeout: float | None = None, processes: bool = True):
        try:
            import dask
            from dask.utils import parse_timedelta
            from distributed import Client, LocalCluster
        except ImportError:
            raise InputError.from_line(
                "--scheduler/--dask-local need Dask: pip install 'flexlift[dask]'") from None
        if timeout is None:  # Dask's own setting (DASK_DISTRIBUTED__COMM__TIMEOUTS__CONNECT)
            timeout = parse_timedelta(dask.config.get("distributed.comm.timeouts.connect"), "s")
        self.cluster = None
        where = f"--scheduler {clean(str(scheduler), 80)}" if scheduler else "--dask-local"
        try:
            if scheduler is None:
                # a worker that dies fails its task at once; the sweep retries it once itself
                with dask.config.set({"distributed.scheduler.allowed-failures": 0}):
                    self.cluster = LocalCluster(n_workers=int(local_workers or local_cores()),
                                                threads_per_worker=1, processes=processes,
                                                dashboard_address=None,
                                                silence_logs=logging.ERROR)
                self.client = Client(self.cluster, timeout=timeout)
            else:
                self.client = Client(scheduler, timeout=timeout)
        except (OSError, TimeoutError, ValueError, TypeError) as exc:
            self._close_cluster()
            why = clean(str(exc), 140) or type(exc).__name__
            raise InputError.from_line(
                f"{where}: cannot reach the Dask scheduler ({why}); give a running "
                "scheduler's address such as tcp://host:8786") from None
        threads = sum(self.client.nthreads().values()) or 1
        self.workers = threads
        self.window = 2 * threads
        self.address = self.client.scheduler.address
        self._executor = self.client.get_executor(pure=False)

    def submit(self, fn, *args) -> cf.Future:
        return self._executor.submit(fn, *args)

    def close(self, cancel: bool = False) -> None:
        with contextlib.suppress(Exception):
            self._executor.shutdown(wait=not cancel)
        with contextlib.suppress(Exception):
            self.client.close()
        self._close_cluster()

    def _close_cluster(self) -> None:
        if self.cluster is not None:
            with contextlib.suppress(Exception):
                self.cluster.close()
            self.cluster = None


def make_engine(workers: int | None = None, scheduler: str | None = None,
                dask_local: int | None = None, **dask_options):
    """The engine the options ask for: Dask with ``scheduler`` or ``dask_local``; else
    :class:`Serial` for ``workers`` 1; else :class:`Processes` (default: every local core)."""
    if scheduler is not None and dask_local is not None:
        raise InputError.from_line("--scheduler and --dask-local: give one of them (an existing "
                                   "cluster, or a local one started here)")
    if scheduler is not None or dask_local is not None:
        if workers is not None:
            raise InputError.from_line(f"--workers {workers}: local processes, not for Dask (its "
                                       "workers are the cluster's; --dask-local N sets them)")
        return DaskEngine(scheduler, dask_local, **dask_options)
    n = local_cores() if workers is None else int(workers)
    if n < 1:
        raise InputError("--workers", n, "at least 1")
    return Serial() if n == 1 else Processes(n)
