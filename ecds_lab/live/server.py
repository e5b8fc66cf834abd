"""Serve the live page of one run file on 127.0.0.1 (standard library ThreadingHTTPServer).

The snapshot is read at most once a second whatever the number of browsers; plots are drawn
for a snapshot only once. The server keeps serving after the run ends or dies.
"""

from __future__ import annotations

import json
import threading
import time
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path

from ecds_lab.live.figures import ModelCache, inductance_png, temperatures_png
from ecds_lab.live.page import page
from ecds_lab.live.snapshot import Snapshot, read_snapshot

SNAPSHOT_MAX_AGE_S = 1.0


class LiveRun:
    """The cached snapshot and plots of one run file, shared by the request threads."""

    def __init__(self, path: Path) -> None:
        self.path = Path(path)
        self._lock = threading.Lock()
        self._snap: Snapshot | None = None
        self._at = 0.0
        self._pngs: dict[str, bytes] = {}
        self._model = ModelCache()

    def snapshot(self) -> Snapshot:
        with self._lock:
            if self._snap is None or time.monotonic() - self._at > SNAPSHOT_MAX_AGE_S:
                self._snap, self._at, self._pngs = read_snapshot(self.path), time.monotonic(), {}
            return self._snap

    def png(self, name: str) -> bytes:
        snap = self.snapshot()
        with self._lock:
            if name not in self._pngs:
                self._pngs[name] = (inductance_png(snap, self._model) if name == "ls"
                                    else temperatures_png(snap))
            return self._pngs[name]


def make_server(path: Path, port: int = 0) -> ThreadingHTTPServer:
    """A server for ``path`` bound to 127.0.0.1 (port 0: a free one); call serve_forever to run it."""
    live = LiveRun(path)

    class Handler(BaseHTTPRequestHandler):
        def do_GET(self) -> None:
            route = self.path.split("?", 1)[0]
            if route == "/":
                self._send(200, "text/html; charset=utf-8", page(f"{live.path.name}").encode())
            elif route == "/status.json":
                self._send(200, "application/json", json.dumps(live.snapshot().to_json()).encode())
            elif route in ("/ls.png", "/temperatures.png"):
                self._send(200, "image/png", live.png(route[1:-4]))
            else:
                self._send(404, "text/plain", b"not found")

        def _send(self, code: int, content_type: str, body: bytes) -> None:
            self.send_response(code)
            self.send_header("Content-Type", content_type)
            self.send_header("Content-Length", str(len(body)))
            self.send_header("Cache-Control", "no-store")
            self.end_headers()
            self.wfile.write(body)

        def log_message(self, format: str, *args: object) -> None:
            pass

    server = ThreadingHTTPServer(("127.0.0.1", port), Handler)
    server.daemon_threads = True
    return server


def url_of(server: ThreadingHTTPServer) -> str:
    host, port = server.server_address[:2]
    return f"http://{host!s}:{port}/" if isinstance(host, str) else f"http://{host.decode()}:{port}/"


def serve_in_background(path: Path, port: int = 0) -> ThreadingHTTPServer:
    """Start serving ``path`` in a daemon thread (``run --watch``); returns the server."""
    server = make_server(path, port)
    threading.Thread(target=server.serve_forever, name="live-view", daemon=True).start()
    return server
