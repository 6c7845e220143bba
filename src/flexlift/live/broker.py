"""Brokers: the embedded one (amqtt, in a background thread on a free loopback port, used when
``flexlift live`` or ``rig`` is given no ``--broker``) and broker URLs.

For a real lift the broker is a proper one (Mosquitto: docs/reference/messages.md); the
embedded broker is for one laptop running rig and live together.
"""

from __future__ import annotations

import asyncio
import logging
import socket
import threading
from typing import NamedTuple
from urllib.parse import urlsplit

from flexlift.errors import InputError

#: how long the embedded broker may take to start or stop [s]
START_TIMEOUT_S = 10.0


#: the URL schemes of a broker and their default ports: plain MQTT, MQTT over TLS
SCHEMES = {"mqtt": 1883, "mqtts": 8883}


class BrokerAddress(NamedTuple):
    """Where a broker listens, and whether it speaks TLS there (``mqtts://``)."""

    host: str
    port: int
    tls: bool = False

    @property
    def url(self) -> str:
        """As ``mqtt://host:port`` (``mqtts://`` with TLS)."""
        return f"{'mqtts' if self.tls else 'mqtt'}://{self.host}:{self.port}"


def parse_broker(url: str) -> BrokerAddress:
    """``mqtt://host[:port]`` (or ``host[:port]``; port 1883 by default) or, over TLS,
    ``mqtts://host[:port]`` (port 8883) as an address; InputError naming ``--broker``
    otherwise."""
    text = url if "://" in url else f"mqtt://{url}"
    try:
        parts = urlsplit(text)
        port = SCHEMES.get(parts.scheme) if parts.port is None else parts.port
    except ValueError:
        parts, port = None, None
    if parts is None or parts.scheme not in SCHEMES or not parts.hostname or not port \
            or parts.username is not None or parts.path not in ("", "/"):
        raise InputError("--broker", url, "use mqtt://HOST[:PORT], or mqtts://HOST[:PORT] "
                         "over TLS (an account: --user and --password-file)")
    return BrokerAddress(parts.hostname, port, parts.scheme == "mqtts")


def free_port(host: str = "127.0.0.1") -> int:
    """A TCP port free on ``host`` now."""
    with socket.socket() as s:
        s.bind((host, 0))
        return s.getsockname()[1]


class EmbeddedBroker:
    """An amqtt broker on 127.0.0.1 at a free port, run by its own event loop in a daemon
    thread; ``start()`` returns once it listens, ``stop()`` shuts it down."""

    def __init__(self, port: int | None = None):
        self.address = BrokerAddress("127.0.0.1", port or free_port())
        self._loop: asyncio.AbstractEventLoop | None = None
        self._broker = None
        self._thread: threading.Thread | None = None
        self._ready = threading.Event()
        self._error: BaseException | None = None

    def _config(self) -> dict:
        return {
            "listeners": {"default": {"type": "tcp",
                                      "bind": f"{self.address.host}:{self.address.port}"}},
            "plugins": {"amqtt.plugins.authentication.AnonymousAuthPlugin":
                        {"allow_anonymous": True}},
        }

    def _run(self) -> None:
        from amqtt.broker import Broker

        for name in ("amqtt", "transitions"):
            logging.getLogger(name).setLevel(logging.WARNING)
        self._loop = asyncio.new_event_loop()
        asyncio.set_event_loop(self._loop)
        try:
            self._broker = Broker(self._config(), loop=self._loop)
            self._loop.run_until_complete(self._broker.start())
        except BaseException as exc:  # noqa: BLE001 - reported by start()
            self._error = exc
            self._ready.set()
            return
        self._ready.set()
        self._loop.run_forever()
        self._loop.close()

    def start(self) -> EmbeddedBroker:
        """Start the broker; RuntimeError if it does not listen within START_TIMEOUT_S."""
        self._thread = threading.Thread(target=self._run, name="flexlift-broker", daemon=True)
        self._thread.start()
        if not self._ready.wait(START_TIMEOUT_S) or self._error is not None:
            raise RuntimeError(f"the embedded broker did not start: {self._error}")
        return self

    def stop(self) -> None:
        """Shut the broker down and end its thread."""
        if self._loop is None or self._broker is None or not self._loop.is_running():
            return
        done = asyncio.run_coroutine_threadsafe(self._broker.shutdown(), self._loop)
        try:
            done.result(START_TIMEOUT_S)
        except Exception:  # noqa: BLE001 - stopping anyway
            pass
        self._loop.call_soon_threadsafe(self._loop.stop)
        self._thread.join(START_TIMEOUT_S)

    def __enter__(self) -> EmbeddedBroker:
        return self.start()

    def __exit__(self, *exc) -> None:
        self.stop()
