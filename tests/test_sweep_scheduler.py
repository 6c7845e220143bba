"""A Dask scheduler that never answers, or dies mid-sweep, never holds a sweep (issue 21):
the connection fails within the connect timeout + 5 s (one line, exit 2); a scheduler killed
mid-sweep ends it within 60 s (exit 1, the finished cases kept, the rerun command printed).

Only loopback addresses: the silent server and the scheduler listen on 127.0.0.1. Every test
carries its own time guard (signal.alarm, subprocess timeouts), so a regression fails."""

import contextlib
import os
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

import flexlift
from flexlift.cli import main
from flexlift.sweep.executors import DaskEngine

pytest.importorskip("distributed")

SRC = str(Path(flexlift.__file__).resolve().parents[1])  # the flexlift under test
#: a short ascent of the tanker (the sweep tests' SHORT), many cases: still running at the kill
SPEC = """base: tanker
control: [coordinated]
set: {control.target_height_m: 10, simulation.hold_time_s: 20, seabed.breakout_time_s: 40}
monte_carlo: {samples: %d, seed: 3,
              vary: {hydro.drag_coefficient: {dist: uniform, low: 1.0, high: 1.3}}}
"""


@contextlib.contextmanager
def alarm(seconds: int):
    """Fail (rather than hang) when the block takes longer than ``seconds``."""
    def fire(*_):
        raise TimeoutError(f"still waiting after {seconds} s")

    old = signal.signal(signal.SIGALRM, fire)
    signal.alarm(seconds)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)


@contextlib.contextmanager
def silent_server():
    """A TCP server on 127.0.0.1 that accepts every connection and never says a word."""
    srv = socket.socket()
    srv.bind(("127.0.0.1", 0))
    srv.listen(16)
    held = []
    stop = threading.Event()

    def accept():
        srv.settimeout(0.2)
        while not stop.is_set():
            with contextlib.suppress(OSError):
                held.append(srv.accept()[0])

    t = threading.Thread(target=accept, daemon=True)
    t.start()
    try:
        yield srv.getsockname()[1]
    finally:
        stop.set()
        t.join(5)
        for c in held:
            c.close()
        srv.close()


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_a_port_that_accepts_and_never_answers_is_refused_within_the_connect_timeout(
        tmp_path, capsys):
    import dask

    spec = tmp_path / "s.yaml"
    spec.write_text(SPEC % 2)
    with silent_server() as port, alarm(60), \
            dask.config.set({"distributed.comm.timeouts.connect": "2s"}):
        t0 = time.monotonic()
        rc = main(["sweep", str(spec), "--out", str(tmp_path / "o"),
                   "--scheduler", f"tcp://127.0.0.1:{port}"])
        took = time.monotonic() - t0
    assert rc == 2
    assert took < 2 + 5, took
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in err, err
    assert f"--scheduler tcp://127.0.0.1:{port}" in lines[0] and "cannot reach" in lines[0]


def test_the_engine_itself_is_bounded_on_a_silent_port():
    with silent_server() as port, alarm(30):
        t0 = time.monotonic()
        with pytest.raises(Exception, match="cannot reach"):
            DaskEngine(f"tcp://127.0.0.1:{port}", timeout=1.0)
        assert time.monotonic() - t0 < 1 + 5


def _spawn(args, env, log: Path) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", *args], env=env, stdout=subprocess.DEVNULL,
                            stderr=log.open("w"), start_new_session=True)


def _listening(port: int) -> bool:
    with contextlib.suppress(OSError), socket.create_connection(("127.0.0.1", port), 0.2):
        return True
    return False


def _stop(p: subprocess.Popen) -> None:
    if p.poll() is None:
        p.kill()
    with contextlib.suppress(subprocess.TimeoutExpired):
        p.wait(10)


def test_a_scheduler_killed_mid_sweep_ends_it_within_60_s_with_its_cases_kept(tmp_path):
    env = dict(os.environ, PYTHONPATH=SRC + os.pathsep + os.environ.get("PYTHONPATH", ""),
               DASK_DISTRIBUTED__COMM__TIMEOUTS__CONNECT="5s", MPLBACKEND="Agg")
    port = free_port()
    addr = f"tcp://127.0.0.1:{port}"
    spec = tmp_path / "s.yaml"
    spec.write_text(SPEC % 400)
    out = tmp_path / "out"
    sched = _spawn(["distributed.cli.dask_scheduler", "--host", "127.0.0.1", "--port", str(port),
                    "--no-dashboard"], env, tmp_path / "scheduler.log")
    worker = sweep = None
    try:
        worker = _spawn(["distributed.cli.dask_worker", addr, "--host", "127.0.0.1",
                         "--nthreads", "1", "--no-nanny", "--no-dashboard"],
                        env, tmp_path / "worker.log")
        # the sweep reconnects to a lost scheduler for its connect timeout before it ends: 2 s
        # (the scheduler listening first, as a sweep's scheduler is), not the others' 5 s
        t0 = time.monotonic()
        while not _listening(port):
            assert sched.poll() is None and time.monotonic() - t0 < 60, "no scheduler in 60 s"
            time.sleep(0.1)
        sweep = subprocess.Popen([sys.executable, "-m", "flexlift", "sweep", str(spec), "--quiet",
                                  "--scheduler", addr, "--out", str(out)],
                                 env=dict(env, DASK_DISTRIBUTED__COMM__TIMEOUTS__CONNECT="2s"),
                                 stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        t0 = time.monotonic()
        while len(list(out.glob("cases/*.json"))) < 3:  # a few cases finished
            assert sweep.poll() is None, sweep.communicate()
            assert time.monotonic() - t0 < 240, "no case finished on the Dask worker in 240 s"
            time.sleep(0.2)
        sched.kill()
        t1 = time.monotonic()
        try:
            stdout, stderr = sweep.communicate(timeout=90)
        except subprocess.TimeoutExpired:
            sweep.kill()
            pytest.fail("the sweep still ran 90 s after its scheduler was killed")
        took = time.monotonic() - t1
    finally:
        for p in (sweep, worker, sched):
            if p is not None:
                _stop(p)
    assert sweep.returncode == 1, stderr
    assert took < 60, took
    lines = stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in stderr, stderr
    assert "scheduler" in lines[0] and "lost" in lines[0]
    assert f"flexlift sweep {spec} --out {out} --scheduler {addr}" in lines[0]
    kept = sorted(out.glob("cases/*.json"))
    assert len(kept) >= 3  # the finished cases are kept: a rerun runs only the others
