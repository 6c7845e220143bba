"""A paho-mqtt 2.x client for rig and live: connects in the background, reconnects by itself
when the broker goes down and comes back (subscribing again), and hands every received
message to a thread-safe queue with its receive time."""

from __future__ import annotations

import queue
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
    with ``password`` on a broker with accounts (docs/reference/live.md#the-lifts-broker).
    ``refused`` is the broker's reason when it refused the last connection, else None."""

    def __init__(self, address, topics=(), name: str = "flexlift", username: str | None = None,
                 password: str | None = None):
        self.address = address
        self.refused: str | None = None
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
        self.client.reconnect_delay_set(min_delay=0.2, max_delay=1.0)
        self.client.max_queued_messages_set(10_000)
        self.client.on_connect = self._on_connect
        self.client.on_disconnect = self._on_disconnect
        self.client.on_message = self._on_message

    def _on_connect(self, client, userdata, flags, reason, properties) -> None:
        if reason.is_failure:
            self.refused = str(reason)
            self._answered.set()
            return
        self.refused = None
        for topic in self.topics:
            client.subscribe(topic, qos=QOS_COMMAND)
        self.connects += 1
        self.connected.set()
        self._answered.set()

    def _on_disconnect(self, client, userdata, flags, reason, properties) -> None:
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
