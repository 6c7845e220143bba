"""The dashboard's web server: FastAPI served by uvicorn in a background thread.

The page (``static/``: plain HTML, CSS and JavaScript, no build step, nothing fetched from the
internet) opens a websocket to ``/ws`` and draws every snapshot it receives; ``/snapshot``
returns the latest one as JSON. :meth:`Dashboard.publish` only swaps the latest snapshot under
a lock, so it is cheap and safe from any thread; each websocket sends a new snapshot within
:data:`SEND_PERIOD_S` of its publication.
"""

from __future__ import annotations

import asyncio
import json
import socket
import threading
import time
from importlib import resources

# at module level, not inside _app: FastAPI reads the websocket route's annotation by name
# (with postponed annotations a name local to _app is not found, and the route refuses: 403)
from fastapi import WebSocket, WebSocketDisconnect

#: how often each websocket looks for a new snapshot [s]
SEND_PERIOD_S = 0.2
#: longest wait for the server to start listening, or to stop [s]
START_TIMEOUT_S = 10.0
STOP_TIMEOUT_S = 5.0


def _static_dir() -> str:
    return str(resources.files("flexlift.live.dashboard") / "static")


class Dashboard:
    """The live dashboard, served on ``host``:``port`` (0: a free port) from a thread.

    Parameters
    ----------
    host : str
        Address to listen on; the default serves this machine only.
    port : int
        TCP port; 0 takes a free one (see the url :meth:`start` returns).
    """

    def __init__(self, host: str = "127.0.0.1", port: int = 0):
        self.host = host
        self.port = int(port)
        self._lock = threading.Lock()
        self._latest: str | None = None  # the latest snapshot, as JSON text
        self._version = 0
        self._stopping = threading.Event()
        self._server = None
        self._thread: threading.Thread | None = None
        self.url: str | None = None

    def publish(self, snapshot) -> None:
        """Show ``snapshot`` (a :class:`DashboardSnapshot`); safe from any thread."""
        text = json.dumps(snapshot.to_json(), allow_nan=False)
        with self._lock:
            self._latest = text
            self._version += 1

    def latest(self) -> tuple[int, str | None]:
        """The version number and JSON text of the latest snapshot."""
        with self._lock:
            return self._version, self._latest

    def start(self) -> str:
        """Start serving; returns the page's url. Raises RuntimeError if it does not start."""
        import uvicorn

        if self._thread is not None:
            raise RuntimeError("the dashboard is already started")
        sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            sock.bind((self.host, self.port))
        except OSError as exc:
            sock.close()
            raise RuntimeError(f"the dashboard cannot listen on {self.host}:{self.port}: {exc}") from None
        self.port = sock.getsockname()[1]
        config = uvicorn.Config(self._app(), log_level="warning", lifespan="off",
                                timeout_graceful_shutdown=2)
        self._server = uvicorn.Server(config)
        self._thread = threading.Thread(target=self._server.run, kwargs={"sockets": [sock]},
                                        name="flexlift-dashboard", daemon=True)
        self._thread.start()
        deadline = time.monotonic() + START_TIMEOUT_S
        while not self._server.started and time.monotonic() < deadline and self._thread.is_alive():
            time.sleep(0.02)
        if not self._server.started:
            self.stop()
            sock.close()
            raise RuntimeError("the dashboard's web server did not start")
        self.url = f"http://{self.host}:{self.port}/"
        return self.url

    def stop(self) -> None:
        """Stop serving: close the websockets, stop the server, join its thread (bounded)."""
        self._stopping.set()
        if self._server is not None:
            self._server.should_exit = True
        if self._thread is not None:
            self._thread.join(STOP_TIMEOUT_S)
            if self._thread.is_alive():
                self._server.force_exit = True
                self._thread.join(STOP_TIMEOUT_S)
        self._thread = None

    def __enter__(self):
        self.start()
        return self

    def __exit__(self, *exc):
        self.stop()

    def _app(self):
        from fastapi import FastAPI
        from fastapi.responses import FileResponse, Response
        from fastapi.staticfiles import StaticFiles

        app = FastAPI(title="flexlift dashboard", docs_url=None, redoc_url=None, openapi_url=None)
        static = _static_dir()
        app.mount("/static", StaticFiles(directory=static), name="static")

        @app.get("/")
        def index():
            return FileResponse(f"{static}/index.html", media_type="text/html")

        @app.get("/snapshot")
        def snapshot():
            _, text = self.latest()
            return Response(text or "null", media_type="application/json")

        @app.websocket("/ws")
        async def stream(ws: WebSocket):
            await ws.accept()
            sent = -1
            try:
                while not self._stopping.is_set():
                    version, text = self.latest()
                    if version != sent and text is not None:
                        await ws.send_text(text)
                        sent = version
                    await asyncio.sleep(SEND_PERIOD_S)
                await ws.close()
            except (WebSocketDisconnect, RuntimeError, OSError):  # the page went away
                return

        return app
