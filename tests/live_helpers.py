"""Live-operation test helpers: Debian's Mosquitto on a free 127.0.0.1 port with its own
configuration, stopped (and restartable) by its PID; bounded waits."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import time
from pathlib import Path

import pytest

MOSQUITTO = "/usr/sbin/mosquitto"


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def wait_until(condition, timeout: float, step: float = 0.05) -> bool:
    """Poll ``condition`` at most ``timeout`` seconds."""
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if condition():
            return True
        time.sleep(step)
    return bool(condition())


class Mosquitto:
    """One Mosquitto process on 127.0.0.1:``port`` with the configuration in ``folder``."""

    def __init__(self, folder: Path, port: int | None = None, conf: Path | None = None):
        """``conf``: a configuration of its own (listening on 127.0.0.1:``port``), else an
        open broker's is written in ``folder``."""
        self.folder, self.port = Path(folder), port or free_port()
        self.conf = conf or self.folder / "mosquitto.conf"
        if conf is None:
            self.conf.write_text(f"listener {self.port} 127.0.0.1\nallow_anonymous true\n"
                                 "persistence false\nmax_queued_messages 100000\n")
        self.proc: subprocess.Popen | None = None

    @property
    def url(self) -> str:
        return f"mqtt://127.0.0.1:{self.port}"

    def start(self) -> Mosquitto:
        log = open(self.folder / "mosquitto.log", "ab")  # noqa: SIM115 - the child's
        self.proc = subprocess.Popen([MOSQUITTO, "-c", str(self.conf)], stdout=log,
                                     stderr=subprocess.STDOUT)
        log.close()

        def listening():
            try:
                socket.create_connection(("127.0.0.1", self.port), 0.2).close()
                return True
            except OSError:
                return False
        if not wait_until(listening, 5.0):
            self.stop()
            raise RuntimeError("mosquitto did not start: "
                               + (self.folder / "mosquitto.log").read_text()[-500:])
        return self

    def stop(self) -> None:
        """Stop it by its PID (SIGTERM, then SIGKILL after 5 s)."""
        if self.proc is None or self.proc.poll() is not None:
            return
        os.kill(self.proc.pid, signal.SIGTERM)
        try:
            self.proc.wait(5)
        except subprocess.TimeoutExpired:
            os.kill(self.proc.pid, signal.SIGKILL)
            self.proc.wait(5)


@pytest.fixture
def mosquitto(tmp_path):
    """A fresh Mosquitto for one test, stopped by its PID afterwards."""
    if not os.access(MOSQUITTO, os.X_OK):
        pytest.skip("Debian's mosquitto is not installed (.ci/run installs it)")
    broker = Mosquitto(tmp_path).start()
    try:
        yield broker
    finally:
        broker.stop()
