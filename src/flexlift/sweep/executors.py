"""Where the cases run: in this process, in local processes, or on a Dask cluster.

Each engine hands out :class:`concurrent.futures.Future` objects for :func:`~flexlift.sweep.
worker.run_case` and says how many cases it can usefully hold at once (``window``):

- :class:`Serial`: in this process, one after the other (``--workers 1``);
- :class:`Processes`: a :class:`~concurrent.futures.ProcessPoolExecutor` (the default, one
  worker per core). Workers are started with ``forkserver``: never forked from a parent that
  holds threads; the server imports flexlift and loads the compiled ascent once
  (:mod:`.warm`), so each worker starts with both and runs case after case; the server sets
  one BLAS thread per worker before numpy loads (:mod:`flexlift._threads`). A worker that dies breaks the pool: every case in
  flight fails with ``BrokenProcessPool``, and the next submission starts a new pool;
- :class:`DaskEngine`: ``distributed.Client.get_executor()`` on an existing scheduler
  (``--scheduler tcp://host:8786``) or a ``LocalCluster`` started here (``--dask-local N``).
  Dask is imported only here, and only when asked for.

Nothing waits forever on Dask: the scheduler is probed first, the whole handshake bounded by
the connect timeout (``distributed.comm.timeouts.connect``, ``DASK_DISTRIBUTED__COMM__TIMEOUTS
__CONNECT``; Dask's own connect bounds the TCP connection but not the reply, so a port that
accepts and never answers would hold ``Client()`` for good): an unreachable or silent scheduler
is one line (:class:`~flexlift.errors.InputError`, exit 2) within that timeout plus a few
seconds. While the sweep runs, :meth:`DaskEngine.check` is called at every poll: once the
client has lost its scheduler and not reconnected within ``LOST_GRACE_S`` (or its own
reconnection gave up), it raises :class:`SchedulerLost`; the sweep ends with its finished
cases kept.

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
import time

from flexlift.errors import InputError, clean

log = logging.getLogger(__name__)
#: how long a lost Dask scheduler may take to come back before the sweep ends [s] (the cases
#: in flight were cancelled by Dask when the connection dropped; they run again on reconnect)
LOST_GRACE_S = 20.0
#: the most a Client's close may take once its scheduler is gone [s]
CLOSE_S = 5.0
#: the most local workers (``--workers``, ``--dask-local``) per core: no sweep runs faster with
#: more workers than cores (a case is one busy core), and each worker holds ~150 MB plus its
#: case's 100-300 MB, so four per core bound the memory at ~2 GB per core; ``--workers 100000``
#: would start 100,000 processes before the first case (a Dask cluster's own workers, with
#: ``--scheduler``, are the cluster's business)
WORKERS_PER_CORE = 4


def max_workers() -> int:
    """The most local workers: ``WORKERS_PER_CORE`` per core this process may use."""
    return WORKERS_PER_CORE * local_cores()


#: imported (and the compiled ascent loaded) once in the fork server, not per worker; first,
#: before numpy loads there, one BLAS thread per worker (flexlift._threads)
PRELOAD = ["flexlift._worker_process", "flexlift.sweep.worker", "flexlift.sweep.warm"]


def start_forkserver():
    """The ``forkserver`` context with the fork server started (once per process): its
    imports and warm-up (:mod:`.warm`, seconds) run while this process goes on reading the
    SPEC; the first worker is forked once they are done."""
    from multiprocessing import forkserver

    ctx = multiprocessing.get_context("forkserver")
    ctx.set_forkserver_preload(PRELOAD)
    forkserver.ensure_running()
    return ctx


def start_early(argv: list[str]) -> None:
    """Start the fork server first thing for ``flexlift sweep`` or ``flexlift contingency`` run
    on local processes (the default), before the command line's own imports: ``argv`` the
    command's arguments."""
    if any(a in ("-h", "--help", "--scheduler", "--dask-local") or a.startswith(
            ("--scheduler=", "--dask-local=", "--workers=1")) for a in argv):
        return
    if any(a == "--workers" and b.strip() == "1" for a, b in zip(argv, argv[1:])):
        return
    if local_cores() > 1 or "--workers" in argv:
        with contextlib.suppress(Exception):  # the engine starts it later, or says why not
            start_forkserver()


def stop_forkserver() -> None:
    """Stop this process's fork server now, if it runs, even inside its preload (which can
    compile the loop for two minutes on a new machine, and reads its stop signal only after
    it): SIGTERM, then reaped. For a command that ends without a result (bad input, an
    interruption): nothing it started goes on working after it. A later sweep in this
    process starts a new server."""
    from multiprocessing import forkserver

    server = forkserver._forkserver
    pid = getattr(server, "_forkserver_pid", None)
    if pid is None:
        return
    with contextlib.suppress(ProcessLookupError):
        os.kill(pid, signal.SIGTERM)
    with contextlib.suppress(Exception):  # closes its pipe, reaps it, forgets it
        server._stop()


class SchedulerLost(RuntimeError):
    """The Dask scheduler went away during a sweep (killed, or its machine lost)."""


def local_cores() -> int:
    """The cores this process may use (its CPU affinity), at least 1."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - not Linux
        return max(1, os.cpu_count() or 1)


def _init_worker(alive) -> None:
    """In each local worker: a process of flexlift's own (:func:`~flexlift.sweep.worker.
    own_process`); Ctrl-C is the coordinator's to handle; warnings go to the case's
    record, not to a stray handler; and the worker ends when the coordinating process is gone
    (killed outright, nothing would collect its results): ``alive`` is the reading end of a
    pipe only the coordinator can write to, which reads as ended once it has died."""
    from flexlift.sweep.worker import own_process

    own_process()
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

    def check(self) -> None:
        """Nothing to lose: the cases run here."""


class Processes:
    """A pool of ``workers`` local processes."""

    name = "processes"

    def __init__(self, workers: int):
        self.workers = int(workers)
        self.window = 2 * self.workers
        self._ctx = start_forkserver()
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

    def check(self) -> None:
        """A dead worker breaks only its cases (retried by the sweep): nothing to raise."""


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
        # Dask's own records of a lost connection are tracebacks (its loggers' and those of
        # tornado, its event loop, on a stream closed under a callback); the sweep says it in
        # one line
        self._log_levels = {**_quiet("distributed"), **_quiet("tornado")}
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
                probe(scheduler, timeout)
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
        self.timeout = float(timeout)
        self._executor = self.client.get_executor(pure=False)
        self._lost_since: float | None = None

    def submit(self, fn, *args) -> cf.Future:
        return self._executor.submit(fn, *args)

    def check(self) -> None:
        """Raise :class:`SchedulerLost` once the scheduler has been gone ``LOST_GRACE_S``
        (Dask reconnects for its connect timeout; a short break is waited out) or the client
        gave up reconnecting."""
        status = self.client.status
        if status == "running":
            self._lost_since = None
            return
        now = time.monotonic()
        if self._lost_since is None:
            self._lost_since = now
        if status in ("closing", "closed", "failed") or now - self._lost_since > LOST_GRACE_S:
            raise SchedulerLost(f"the Dask scheduler {self.address} was lost (the client is "
                                f"{status} since {now - self._lost_since:.0f} s)")

    def close(self, cancel: bool = False) -> None:
        lost = self.client.status != "running"
        with contextlib.suppress(Exception):
            self._executor.shutdown(wait=not (cancel or lost))
        with contextlib.suppress(Exception):
            self.client.close(timeout=CLOSE_S if (cancel or lost) else None)
        self._close_cluster()

    def _close_cluster(self) -> None:
        if self.cluster is not None:
            with contextlib.suppress(Exception):
                self.cluster.close()
            self.cluster = None
        for name, level in self._log_levels.items():
            logging.getLogger(name).setLevel(level)
        self._log_levels = {}


def _quiet(prefix: str) -> dict[str, int]:
    """Raise the loggers named ``prefix``/``prefix.*`` that have a level of their own (Dask
    configures several, each with its own handler) to CRITICAL; return their old levels."""
    names = [prefix] + [n for n, lg in logging.root.manager.loggerDict.items()
                        if n.startswith(prefix + ".") and isinstance(lg, logging.Logger)
                        and lg.level != logging.NOTSET]
    old = {n: logging.getLogger(n).level for n in names}
    for n in names:
        logging.getLogger(n).setLevel(logging.CRITICAL)
    return old


def probe(address: str, timeout: float) -> None:
    """Connect to the scheduler at ``address`` and wait for its handshake, all within
    ``timeout`` seconds: :class:`TimeoutError` (or :class:`OSError`) when it does not answer.
    Dask's ``connect`` bounds the TCP connection, not the handshake that follows it."""
    import asyncio

    from distributed.comm import connect

    async def handshake():
        comm = await asyncio.wait_for(connect(address, timeout=timeout), timeout)
        await comm.close()

    try:
        asyncio.run(asyncio.wait_for(handshake(), timeout + 1.0))
    except TimeoutError:
        raise TimeoutError(f"no answer within {timeout:g} s") from None


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
        if dask_local is not None and not 1 <= int(dask_local) <= max_workers():
            raise InputError("--dask-local", dask_local, f"1..{max_workers()} workers "
                             f"({WORKERS_PER_CORE} per core)")
        return DaskEngine(scheduler, dask_local, **dask_options)
    n = local_cores() if workers is None else int(workers)
    if not 1 <= n <= max_workers():
        raise InputError("--workers", n, f"1..{max_workers()} local processes "
                         f"({WORKERS_PER_CORE} per core)")
    return Serial() if n == 1 else Processes(n)
