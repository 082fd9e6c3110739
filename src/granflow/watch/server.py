"""The live page of a watch (``--serve``): a small HTTP server on the standard library that
serves one page (``page.html`` in this package, its script and style inline: nothing comes
from the network) and the watch's state as JSON at ``/state``, which the page fetches twice a
second."""

from __future__ import annotations

import json
import threading
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from importlib import resources

from granflow.errors import InvalidParameterError

__all__ = ["Server", "parse_address"]


def parse_address(text):
    """``(host, port)`` from ``[HOST:]PORT`` (host default 127.0.0.1; port 0: any free)."""
    host, _, port = str(text).rpartition(":")
    host = host.strip("[]") or "127.0.0.1"
    try:
        number = int(port)
    except ValueError:
        raise InvalidParameterError(
            f"--serve takes [HOST:]PORT, e.g. 8765 or 127.0.0.1:8765; got {text!r}"
        ) from None
    if not 0 <= number <= 65535:
        raise InvalidParameterError(f"--serve: the port must be 0 to 65535, got {number}")
    return host, number


class Server:
    """Serve the live page and the state in a background thread.

    Parameters
    ----------
    host : str
        The address to listen on.
    port : int
        The port (0: a free one; see :attr:`url`).
    """

    def __init__(self, host="127.0.0.1", port=0):
        page = resources.files("granflow.watch").joinpath("page.html").read_bytes()
        self._state = b"{}"
        self._lock = threading.Lock()
        owner = self

        class Handler(BaseHTTPRequestHandler):
            def do_GET(self):
                path = self.path.split("?", 1)[0]
                if path in ("/", "/index.html"):
                    self._send(page, "text/html; charset=utf-8")
                elif path == "/state":
                    with owner._lock:
                        body = owner._state
                    self._send(body, "application/json")
                elif path == "/favicon.ico":
                    self._send(b"", "image/x-icon", 204)
                else:
                    self._send(b"not found", "text/plain", 404)

            def _send(self, body, kind, status=200):
                self.send_response(status)
                self.send_header("Content-Type", kind)
                self.send_header("Cache-Control", "no-store")
                self.send_header("Content-Length", str(len(body)))
                self.end_headers()
                if body:
                    self.wfile.write(body)

            def log_message(self, format, *args):  # no access log on the terminal
                pass

        try:
            self._server = ThreadingHTTPServer((host, port), Handler)
        except OSError as exc:
            raise InvalidParameterError(
                f"--serve {host}:{port}: cannot listen there ({exc.strerror})"
            ) from None
        self._server.daemon_threads = True
        self._thread = threading.Thread(target=self._server.serve_forever, daemon=True)
        self._thread.start()

    @property
    def url(self):
        """The page's address."""
        host, port = self._server.server_address[:2]
        return f"http://{host}:{port}/"

    def publish(self, view):
        """Make ``view`` (JSON-safe) what ``/state`` returns."""
        body = json.dumps(view, allow_nan=False).encode()
        with self._lock:
            self._state = body

    def close(self):
        """Stop serving."""
        self._server.shutdown()
        self._server.server_close()
