"""A paho-mqtt 2.x client for rig and live: connects in the background (as an account, over
TLS for an ``mqtts://`` broker: paho's own ``username_pw_set`` and ``tls_set``), reconnects
by itself when the broker goes down and comes back (subscribing again), and hands every
received message to a thread-safe queue with its receive time."""

from __future__ import annotations

import queue
import ssl
import sys
import threading
import time
import uuid

import paho.mqtt.client as mqtt

#: QoS of readings (a lost reading is replaced by the next) and of commands (at least once:
#: the receiver drops repeats by their sequence numbers)
QOS_READING, QOS_COMMAND = 0, 1
#: the most messages held unread; beyond, new ones are dropped and counted (a flood)
QUEUE_MAX = 200_000


class Link:
    """One connection to the broker at ``address`` subscribed to ``topics``; as ``username``
    with ``password`` on a broker with accounts (docs/reference/live.md#the-lifts-broker);
    over TLS when ``address.tls``, trusting the CA certificate in the PEM file ``tls_ca``
    (None: the system's CAs) and checking that the broker's certificate names its host.
    ``refused`` is the broker's reason when it refused the last connection (its CONNACK, or
    a TLS handshake that failed: ``TLS: ...``), else None; ``failure`` the reason the last
    attempt failed without an answer (None once connected)."""

    def __init__(self, address, topics=(), name: str = "flexlift", username: str | None = None,
                 password: str | None = None, tls_ca: str | None = None):
        self.address, self.username, self.tls_ca = address, username, tls_ca
        self.refused: str | None = None
        self.failure: str | None = None
        self.untrusted = False  # the TLS refusal was the broker's certificate, not trusted
        self.topics = list(topics)
        self.inbox: queue.SimpleQueue = queue.SimpleQueue()
        self.overflow = 0
        self.connected = threading.Event()
        self._answered = threading.Event()  # the broker accepted or refused a connection
        self.connects = 0
        self._size = 0
        self._lock = threading.Lock()
        self.client = mqtt.Client(mqtt.CallbackAPIVersion.VERSION2,
                                  client_id=f"{name}-{uuid.uuid4().hex[:8]}",
                                  reconnect_on_failure=True)
        if username is not None:
            self.client.username_pw_set(username, password)
        if getattr(address, "tls", False):
            _tls(self.client, tls_ca)
        self.client.reconnect_delay_set(min_delay=0.2, max_delay=1.0)
        self.client.max_queued_messages_set(10_000)
        self.client.on_connect = self._on_connect
        self.client.on_disconnect = self._on_disconnect
        self.client.on_connect_fail = self._on_connect_fail
        self.client.on_message = self._on_message

    def _on_connect_fail(self, client, userdata) -> None:
        # paho calls this inside its ``except OSError`` around the attempt: the error is
        # the one being handled
        error = sys.exc_info()[1]
        if isinstance(error, ssl.SSLError):  # a TLS listener that answered, and refused us
            why = getattr(error, "verify_message", None) or error.reason or str(error)
            self.refused = f"TLS: {why}"
            self.untrusted = isinstance(error, ssl.SSLCertVerificationError)
            self._answered.set()
        else:
            self.failure = str(error) if error is not None else "no connection"

    def _on_connect(self, client, userdata, flags, reason, properties) -> None:
        if reason.is_failure:
            self.refused = str(reason)
            self._answered.set()
            return
        self.refused = self.failure = None
        for topic in self.topics:
            client.subscribe(topic, qos=QOS_COMMAND)
        self.connects += 1
        self.connected.set()
        self._answered.set()

    def _on_disconnect(self, client, userdata, flags, reason, properties) -> None:
        if not self.connected.is_set() and self.refused is None:  # dropped before answering
            hint = "" if getattr(self.address, "tls", False) else \
                ": a TLS listener? give mqtts:// and --tls-ca"
            self.failure = f"closed before the broker answered ({reason}){hint}"
        self.connected.clear()

    def _on_message(self, client, userdata, message) -> None:
        with self._lock:
            if self._size >= QUEUE_MAX:
                self.overflow += 1
                return
            self._size += 1
        self.inbox.put((time.monotonic(), message.topic, message.payload))

    def start(self, wait_s: float = 10.0) -> bool:
        """Connect (in the background; retried until the broker answers, and after a refusal)
        and start the network thread; whether connected within ``wait_s`` [s] (False at once
        when the broker refuses: see ``refused``)."""
        self.client.connect_async(self.address.host, self.address.port, keepalive=5)
        self.client.loop_start()
        self._answered.wait(wait_s)
        return self.connected.is_set()

    def drain(self, limit: int = 1_000_000) -> list[tuple[float, str, bytes]]:
        """The messages received so far (receive time [monotonic s], topic, payload)."""
        out = []
        while len(out) < limit:
            try:
                out.append(self.inbox.get_nowait())
            except queue.Empty:
                break
        with self._lock:
            self._size -= len(out)
        return out

    def publish(self, topic: str, payload: bytes, qos: int = QOS_READING):
        """Publish (queued by paho while disconnected, up to its limit); paho's
        ``MQTTMessageInfo`` (``wait_for_publish``: the broker has it, QoS 1)."""
        return self.client.publish(topic, payload, qos=qos)

    def stop(self) -> None:
        """Disconnect and end the network thread."""
        try:
            self.client.disconnect()
        finally:
            self.client.loop_stop()


def start_or_refuse(link: Link, wait_s: float = 10.0) -> bool:
    """``link.start(wait_s)``: whether connected; InputError (the link stopped) when the
    broker refused it at once: an account it does not know, a certificate the client does
    not trust, no TLS where the client asked for it. A broker not answering is no error: the
    link keeps trying in the background (``failure`` says why it has not connected)."""
    from flexlift.errors import InputError

    if link.start(wait_s) or link.refused is None:
        return link.connected.is_set()
    link.stop()
    url, why = link.address.url, link.refused
    if link.untrusted:
        raise InputError("--tls-ca", link.tls_ca or "the system's CAs",
                         f"the broker at {url} is not trusted ({why}): give the CA that signed "
                         "its certificate, which must name the host dialled")
    if why.startswith("TLS: "):
        raise InputError("--broker", url, f"the TLS handshake failed ({why}): give the port of "
                         "the broker's TLS listener, or mqtt:// for a plain one")
    if link.username is None:
        raise InputError("--broker", url, f"it refused a client without an account ({why}): "
                         "give --user and --password-file")
    raise InputError("--user", link.username, f"the broker at {url} refused this account "
                     f"({why}): give the account and the password file flexlift broker "
                     "wrote for it")


def _tls(client, ca: str | None) -> None:
    """TLS 1.2 or later on ``client`` (paho's ``tls_set_context``), trusting the CA
    certificate in the PEM file ``ca`` (None: the system's), the broker's certificate
    required and checked against the host dialled; InputError naming ``--tls-ca`` if that
    file holds no certificate."""
    from flexlift.errors import InputError

    try:
        context = ssl.create_default_context(ssl.Purpose.SERVER_AUTH, cafile=ca)
    except (OSError, ssl.SSLError) as exc:  # SSLError: not a certificate
        why = getattr(exc, "reason", None) or getattr(exc, "strerror", None) or str(exc)
        raise InputError("--tls-ca", ca, f"give the PEM file of the CA certificate that signed "
                         f"the broker's ({why})") from None
    context.minimum_version = ssl.TLSVersion.TLSv1_2
    context.verify_mode, context.check_hostname = ssl.CERT_REQUIRED, True
    client.tls_set_context(context)
