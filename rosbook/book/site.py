"""The built book as a browser gets it: served over http on loopback, pages opened in Chromium.

Used by the browser tests and the page-weight benchmark. :func:`serve` serves the built
HTML on 127.0.0.1; :func:`visit` opens one page in a fresh browser context with every
request to another host blocked and recorded, and collects what a reader's console and
network panel would show (errors, warnings, failed requests, bytes transferred).
"""

from __future__ import annotations

import functools
import gzip
import io
import re
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from http.server import SimpleHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path
from typing import Any
from urllib.parse import urlsplit

from rosbook.viz.scene import SCENE_CLASS

DESKTOP = {"width": 1280, "height": 900}
# Notes from the software GL driver (SwiftShader) about its own speed, e.g. "GPU stall due
# to ReadPixels": the test machine's renderer talking, not the page.
_GL_NOTE = re.compile(r"\[\.WebGL-[0-9a-fx]+\]GL Driver Message \(OpenGL, Performance")
PHONE = {"width": 390, "height": 844}
#: Generous hang guard for a page to load on a loaded machine (a timeout, not a verdict).
LOAD_TIMEOUT_MS = 180_000


#: What a static host (GitHub Pages, nginx's gzip_static) sends compressed.
COMPRESSED_TYPES = {".html", ".js", ".css", ".svg", ".json", ".txt", ".map", ".ttf"}


class _StaticHost(SimpleHTTPRequestHandler):
    """Files as a static web host sends them: text gzip-compressed when the browser
    accepts it (so the bytes transferred are what a reader downloads), no access log."""

    _gzipped: dict[Path, bytes] = {}

    def send_head(self) -> Any:
        path = Path(self.translate_path(self.path))
        if path.is_dir():
            path = path / "index.html"
        accepts = "gzip" in self.headers.get("Accept-Encoding", "")
        if not (accepts and path.suffix in COMPRESSED_TYPES and path.is_file()):
            return super().send_head()
        if path not in self._gzipped:
            self._gzipped[path] = gzip.compress(path.read_bytes(), compresslevel=6)
        body = self._gzipped[path]
        self.send_response(200)
        self.send_header("Content-Type", self.guess_type(str(path)))
        self.send_header("Content-Encoding", "gzip")
        self.send_header("Content-Length", str(len(body)))
        self.end_headers()
        return io.BytesIO(body)

    def log_message(self, format: str, *args: Any) -> None:
        pass


@contextmanager
def serve(root: Path) -> Iterator[str]:
    """Serve ``root`` on 127.0.0.1 (a free port); yields the base URL ``http://.../``."""
    handler = functools.partial(type("Host", (_StaticHost,), {"_gzipped": {}}), directory=str(root))
    server = ThreadingHTTPServer(("127.0.0.1", 0), handler)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        yield f"http://127.0.0.1:{server.server_address[1]}/"
    finally:
        server.shutdown()
        server.server_close()
        thread.join()


@dataclass
class Visit:
    """What loading one page showed: console, network, and the open Playwright page."""

    url: str
    page: Any
    console: list[str] = field(default_factory=list)  # "error: ..." / "warning: ..."
    failed: list[str] = field(default_factory=list)  # requests that failed or got >= 400
    outside: list[str] = field(default_factory=list)  # requests to another host (blocked)
    load_seconds: float = 0.0
    #: The requests that finished while the page loaded; weighed when first asked
    #: (``transferred``, ``decoded``), inside the ``visit`` block: two calls into the
    #: browser per request, which most visits never need.
    finished: list[Any] = field(default_factory=list)

    @property
    def transferred(self) -> dict[str, int]:
        """URL -> bytes on the wire."""
        return self._weights[0]

    @property
    def decoded(self) -> dict[str, int]:
        """URL -> bytes uncompressed."""
        return self._weights[1]

    @functools.cached_property
    def _weights(self) -> tuple[dict[str, int], dict[str, int]]:
        return _weigh(self.finished)

    @property
    def total_bytes(self) -> int:
        """Bytes transferred: what the reader downloads (compressed where the host does)."""
        return sum(self.transferred.values())

    @property
    def decoded_bytes(self) -> int:
        """The same files uncompressed."""
        return sum(self.decoded.values())


@contextmanager
def visit(
    browser: Any, url: str, viewport: dict[str, int] = DESKTOP, javascript: bool = True
) -> Iterator[Visit]:
    """Open ``url`` in a fresh context (empty cache), wait until the network is idle."""
    context = browser.new_context(viewport=viewport, java_script_enabled=javascript)
    host = urlsplit(url).netloc
    page = context.new_page()
    seen = Visit(url, page)

    def route(request_route: Any) -> None:
        request_url = request_route.request.url
        if urlsplit(request_url).scheme in ("http", "https", "ws", "wss") and (
            urlsplit(request_url).netloc != host
        ):
            seen.outside.append(request_url)
            request_route.abort()
        else:
            request_route.continue_()

    def on_response(response: Any) -> None:
        if response.status >= 400:
            seen.failed.append(f"{response.status} {response.url}")

    context.route("**/*", route)

    def on_console(message: Any) -> None:
        if message.type in ("error", "warning") and not _GL_NOTE.match(message.text):
            seen.console.append(f"{message.type}: {message.text}")

    page.on("console", on_console)
    page.on("pageerror", lambda e: seen.console.append(f"error: {e}"))
    page.on("response", on_response)
    finished: list[Any] = []
    page.on("requestfinished", lambda request: finished.append(request))
    # Requests in flight and the time of the last change: the page is loaded when the
    # network has been quiet a while (Playwright's "networkidle" comes from the page's
    # renderer, which a busy WebGL page on a loaded machine can starve for minutes).
    network: dict[str, Any] = {"inflight": set(), "changed": time.perf_counter()}

    def track(request: Any, done: bool) -> None:
        (network["inflight"].discard if done else network["inflight"].add)(request)
        network["changed"] = time.perf_counter()

    page.on("request", lambda request: track(request, False))
    page.on("requestfinished", lambda request: track(request, True))
    page.on("requestfailed", lambda request: track(request, True))
    page.on("requestfailed", lambda r: urlsplit(r.url).netloc == host and seen.failed.append(
        f"{r.failure} {r.url}"))  # fmt: skip
    try:
        started = time.perf_counter()
        page.goto(url, wait_until="load", timeout=LOAD_TIMEOUT_MS)
        _wait_until_quiet(page, network, started)
        seen.load_seconds = time.perf_counter() - started
        seen.finished = list(finished)  # what loading fetched, not what came after
        yield seen
    finally:
        context.close()


#: How long the network must be quiet for a page to count as loaded.
QUIET_SECONDS = 0.5


def _wait_until_quiet(page: Any, network: dict[str, Any], started: float) -> None:
    """Wait until no request has been in flight for :data:`QUIET_SECONDS`."""
    while network["inflight"] or time.perf_counter() - network["changed"] < QUIET_SECONDS:
        if time.perf_counter() - started > LOAD_TIMEOUT_MS / 1000:
            pending = ", ".join(r.url for r in network["inflight"]) or "none"
            raise TimeoutError(
                f"timeout: {page.url} still loading after {LOAD_TIMEOUT_MS / 1000:.0f} s"
                f" (in flight: {pending})"
            )
        page.wait_for_timeout(100)  # lets Playwright deliver the network events


def _weigh(requests: list[Any]) -> tuple[dict[str, int], dict[str, int]]:
    """Bytes on the wire (encoded) and uncompressed, by URL, for each request that got a
    body."""
    transferred: dict[str, int] = {}
    decoded: dict[str, int] = {}
    for request in requests:
        response = request.response()
        if response is None or response.status >= 400 or request.url.startswith("data:"):
            continue
        encoded = request.sizes()["responseBodySize"]
        try:
            body = len(response.body())
        except Exception:  # a body the browser already discarded
            body = encoded
        transferred[request.url] = encoded
        decoded[request.url] = body
    return transferred, decoded


def scene_ids(page: Any) -> list[str]:
    """The element ids of the MeshCat scenes on an open page."""
    return page.eval_on_selector_all(f".{SCENE_CLASS}", "els => els.map(e => e.id)")


def wait_for_first_frame(page: Any, scene: str, timeout_ms: int = LOAD_TIMEOUT_MS) -> None:
    """Wait until ``scene`` has drawn a frame (its player counts them in ``data-frames``)."""
    page.wait_for_function(
        "id => +(document.getElementById(id).dataset.frames || 0) >= 1",
        arg=scene,
        timeout=timeout_ms,
    )


def scroll_off_screen(page: Any, scenes: list[str]) -> bool:
    """Scroll the page to its top, or else to its bottom, so that none of ``scenes`` is
    on the screen; whether that worked (a short page may show one wherever it is)."""
    return page.evaluate(
        """ids => {
            const shown = () => ids.some(id => {
                const r = document.getElementById(id).getBoundingClientRect();
                return r.bottom > 0 && r.top < window.innerHeight;
            });
            window.scrollTo(0, 0);
            if (shown()) { window.scrollTo(0, document.body.scrollHeight); }
            return !shown();
        }""",
        scenes,
    )
