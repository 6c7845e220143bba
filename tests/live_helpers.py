"""Live-operation test helpers: Debian's Mosquitto on a free 127.0.0.1 port with its own
configuration, stopped (and restartable) by its PID; bounded waits; throwaway TLS
certificates made by Debian's ``openssl``."""

from __future__ import annotations

import os
import shutil
import signal
import socket
import subprocess
import time
from pathlib import Path
from typing import NamedTuple

import pytest

MOSQUITTO = "/usr/sbin/mosquitto"
OPENSSL = shutil.which("openssl") or "/usr/bin/openssl"
#: the names the test broker's certificate is valid for (X.509 subjectAltName)
SERVER_NAMES = "IP:127.0.0.1,DNS:localhost"


class Certificates(NamedTuple):
    """PEM files: a CA, the broker's certificate signed by it and its key, a second CA that
    signed nothing of the broker's, and a certificate (and key) signed by the first CA for
    another host name only."""

    ca: Path
    cert: Path
    key: Path
    other_ca: Path
    elsewhere_cert: Path
    elsewhere_key: Path


def _openssl(*args: str, cwd: Path) -> None:
    subprocess.run([OPENSSL, *args], cwd=cwd, check=True, capture_output=True, timeout=30)


def _ca(folder: Path, name: str) -> Path:
    """A self-signed CA (P-256, one day) as ``name``.pem and ``name``.key."""
    _openssl("req", "-x509", "-newkey", "ec", "-pkeyopt", "ec_paramgen_curve:prime256v1",
             "-nodes", "-keyout", f"{name}.key", "-out", f"{name}.pem", "-days", "1",
             "-subj", f"/CN=flexlift test {name}",
             "-addext", "basicConstraints=critical,CA:TRUE",
             "-addext", "keyUsage=critical,keyCertSign,cRLSign", cwd=folder)
    return folder / f"{name}.pem"


def _server(folder: Path, name: str, names: str, serial: int) -> tuple[Path, Path]:
    """A server certificate for ``names`` (subjectAltName) signed by ca.pem: its .pem, .key."""
    (folder / f"{name}.ext").write_text(
        f"subjectAltName={names}\nbasicConstraints=critical,CA:FALSE\n"
        "keyUsage=critical,digitalSignature\nextendedKeyUsage=serverAuth\n"
        "subjectKeyIdentifier=hash\nauthorityKeyIdentifier=keyid\n")
    _openssl("req", "-new", "-newkey", "ec", "-pkeyopt", "ec_paramgen_curve:prime256v1",
             "-nodes", "-keyout", f"{name}.key", "-out", f"{name}.csr", "-subj", f"/CN={name}",
             cwd=folder)
    _openssl("x509", "-req", "-in", f"{name}.csr", "-CA", "ca.pem", "-CAkey", "ca.key",
             "-set_serial", str(serial), "-days", "1", "-extfile", f"{name}.ext",
             "-out", f"{name}.pem", cwd=folder)
    return folder / f"{name}.pem", folder / f"{name}.key"


def make_certificates(folder: Path) -> Certificates:
    """A throwaway CA and a broker certificate for :data:`SERVER_NAMES` signed by it,
    another CA, and a certificate of the first for another name, made in ``folder`` by
    ``openssl`` subprocesses."""
    folder.mkdir(parents=True, exist_ok=True)
    ca, other = _ca(folder, "ca"), _ca(folder, "other-ca")
    cert, key = _server(folder, "localhost", SERVER_NAMES, 2)
    return Certificates(ca, cert, key, other,
                        *_server(folder, "elsewhere", "DNS:elsewhere.invalid", 3))


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def listening(port: int) -> bool:
    """Whether something accepts TCP connections on 127.0.0.1:``port``."""
    try:
        socket.create_connection(("127.0.0.1", port), 0.2).close()
        return True
    except OSError:
        return False


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

    def __init__(self, folder: Path, port: int | None = None, conf: Path | None = None,
                 more_ports: tuple[int, ...] = ()):
        """``conf``: a configuration of its own (listening on 127.0.0.1:``port``, and on
        ``more_ports``), else an open broker's is written in ``folder``."""
        self.folder, self.port, self.more_ports = Path(folder), port or free_port(), more_ports
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
        if not wait_until(lambda: all(listening(p) for p in (self.port, *self.more_ports)),
                          5.0):
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


#: the live tests' sensors (appended to the built-in tanker's scenario)
SENSORS = """
sensors:
  seed: 3
  depth: {rate_Hz: 1.0, noise_m: 0.02, latency_s: 0.2}
  pitch: {at: [hull]}
  sling_force: {rate_Hz: 1.0, latency_s: 0.1, dropout: 0.02}
  fill_flow: null
  purge: {at: [bag_1, bag_2, bag_3, bag_4], rate_Hz: 1.0}
  supply_pressure: null
"""

#: every sensor at 10 Hz, the configuration the master is measured safe with
#: (docs/reference/live.md#what-it-achieves; benchmarks/live_network.py takes it too)
SENSORS_10HZ = """
sensors:
  seed: 3
  depth: {rate_Hz: 10, noise_m: 0.02, latency_s: 0.2}
  pitch: {at: [hull], rate_Hz: 10}
  sling_force: {rate_Hz: 10, noise_N: 5000.0, latency_s: 0.1, dropout: 0.02}
  fill_flow: null
  purge: {at: [bag_1, bag_2, bag_3, bag_4], rate_Hz: 10}
  supply_pressure: null
"""
