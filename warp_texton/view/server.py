"""``warp-texton view``: an interactive texture explorer served to a web browser.

The page (``warp_texton/view/static/``: plain HTML, JavaScript and CSS, nothing
fetched from the network) draws an infinite canvas of texton noise cut into
tiles, the way slippy maps are, plus a ground-plane mode, a mixing mode, the
model in a side panel and exports; :mod:`warp_texton.view.viewer` computes what
it asks for.

The server is the standard library's ``ThreadingHTTPServer``: every request is a
plain GET of a small image or JSON document (and one POST to upload a second
image), so there is nothing an ASGI or WebSocket stack would add (see
docs/viewer.md). It binds 127.0.0.1 unless told otherwise, reads no path from a
request, answers bad requests with a one-line plain-text 4xx, lets the browser
cache tiles (their URLs name the input and every setting), and survives clients
that leave mid-tile.
"""

from __future__ import annotations

import json
import re
import select
import socket
import sys
import threading
import time
import warnings
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from importlib import resources
from urllib.parse import unquote, urlsplit

import numpy as np

from .._version import __version__
from ..core.errors import TextonError
from .viewer import ClientGone, Viewer
from .pictures import PNG_LEVEL
from .inputs import MAX_UPLOAD_BYTES, digest
from .queries import MNI_RANGE, ORDERS, TEXTON_SIZES, VIEW_FILTERS, Analysis, BadRequest, Noise, Query

LOOPBACK = ("127.0.0.1", "localhost", "::1")
#: The page's ?render= choices: the noise drawn by WebGL2 in the browser, by the server's tiles,
#: or auto (WebGL2 where it runs on a GPU, docs/viewer.md).
RENDER_MODES = ("auto", "webgl", "tiles")
#: The page's files: path -> (file in the package, content type).
STATIC = {"/": ("static/index.html", "text/html; charset=utf-8"),
          "/index.html": ("static/index.html", "text/html; charset=utf-8"),
          "/viewer.js": ("static/viewer.js", "text/javascript; charset=utf-8"),
          "/viewer.css": ("static/viewer.css", "text/css; charset=utf-8"),
          "/viewer_webgl.js": ("static/viewer_webgl.js", "text/javascript; charset=utf-8"),
          "/texton_noise.js": ("shaders/texton_noise.js", "text/javascript; charset=utf-8")}


# ------------------------------------------------------------------ HTTP
#: RFC 3986's host (a registered name, an IPv4 address, or an IPv6 address in
#: brackets) and an optional decimal port: nothing else (no userinfo, no path).
_HOST = re.compile(r"(?:\[(?P<v6>[0-9A-Fa-f:.]+)\]|(?P<name>[A-Za-z0-9](?:[A-Za-z0-9.-]{0,252}[A-Za-z0-9])?))"
                   r"(?::[0-9]{1,5})?")


def host_name(header: str) -> str | None:
    """The lower-case host of a Host header, or None when it is malformed.

    >>> host_name("127.0.0.1:8000"), host_name("[::1]:80"), host_name("127.0.0.1:80@evil.example")
    ('127.0.0.1', '::1', None)
    """
    m = _HOST.fullmatch(header)
    if m is None:
        return None
    return (m.group("v6") or m.group("name")).lower()


def _page(name: str) -> bytes:
    folder, file = name.split("/")
    package = "warp_texton.runtimes" if folder == "shaders" else "warp_texton.view"
    return resources.files(package).joinpath(folder).joinpath(file).read_bytes()


class _Handler(BaseHTTPRequestHandler):
    server: _Server
    protocol_version = "HTTP/1.1"
    server_version = f"warp-texton/{__version__}"
    #: idle keep-alive connections are closed after this many seconds
    timeout = 60

    # -- plumbing
    @property
    def viewer(self) -> Viewer:
        return self.server.viewer

    def log_message(self, format, *args):
        if self.server.verbose:
            sys.stderr.write(f"{self.address_string()} - {format % args}\n")

    def send_error(self, code, message=None, explain=None):
        """argparse-style: every error is one plain-text line, never an HTML page."""
        self._send_text(code, message or self.responses.get(code, ("error",))[0])

    def _send_text(self, status: int, text: str, extra=None) -> None:
        body = (" ".join(str(text).split()) + "\n").encode("utf-8", "replace")
        self._send(status, body, "text/plain; charset=utf-8", {"Cache-Control": "no-store", **(extra or {})})

    def _send(self, status: int, body: bytes, ctype: str, headers=None) -> None:
        try:
            self.send_response(status)
            self.send_header("Content-Type", ctype)
            self.send_header("Content-Length", str(len(body)))
            self.send_header("X-Content-Type-Options", "nosniff")
            for k, v in (headers or {}).items():
                self.send_header(k, v)
            self.end_headers()
            if self.command != "HEAD":
                self.wfile.write(body)
        except (BrokenPipeError, ConnectionResetError, ConnectionAbortedError, socket.timeout):
            self.close_connection = True

    def _json(self, obj) -> None:
        self._send(200, json.dumps(obj).encode(), "application/json", {"Cache-Control": "no-store"})

    def _alive(self) -> bool:
        """False once the client has closed its end (a dropped, stale tile request)."""
        try:
            readable, _, _ = select.select([self.connection], [], [], 0)
            if not readable:
                return True
            return self.connection.recv(1, socket.MSG_PEEK) != b""
        except (OSError, ValueError):
            return False

    def _host_ok(self) -> bool:
        """Refuse Host names other than the one served (DNS rebinding); a Host that
        is not exactly ``name[:port]`` is a bad request."""
        name = host_name(self.headers.get("Host", ""))
        if name is None:
            raise BadRequest("malformed Host header")
        return self.server.any_host or name in self.server.host_names

    def handle_one_request(self):
        try:
            super().handle_one_request()
        except (BrokenPipeError, ConnectionResetError, ConnectionAbortedError, socket.timeout):
            self.close_connection = True

    def do_HEAD(self):
        self.do_GET()

    def do_GET(self):
        self._dispatch(self._get)

    def do_POST(self):
        self._dispatch(self._post)

    def _dispatch(self, route) -> None:
        try:
            if not self._host_ok():
                raise BadRequest("unexpected Host header", 403)
            parts = urlsplit(self.path)
            route(parts.path, Query(parts.query))
        except BadRequest as exc:
            self._send_text(exc.status, str(exc), {"Retry-After": "1"} if exc.status == 503 else None)
        except TextonError as exc:
            self._send_text(400, str(exc))
        except ClientGone:
            self.close_connection = True
        except (BrokenPipeError, ConnectionResetError, ConnectionAbortedError, socket.timeout):
            self.close_connection = True
        except Exception as exc:  # a bug: report it in one line, keep serving
            self.log_error("internal error on %s: %r", self.path, exc)
            self._send_text(500, f"internal error: {type(exc).__name__}")

    # -- routes
    def _get(self, path: str, q: Query) -> None:
        if path in STATIC:
            if STATIC[path][0].endswith(".html"):
                q.choice("render", RENDER_MODES, default="auto")  # read by the page's script
            q.finish()
            name, ctype = STATIC[path]
            self._send(200, self.server.pages[name], ctype, {"Cache-Control": "no-cache"})
        elif path == "/api/info":
            q.finish()
            self._json(self.viewer.info())
        elif path == "/api/panel":
            self._check_src(q)
            self._json(self.viewer.panel_request(q))
        elif path == "/api/shader":
            self._check_src(q)
            self._json(self.viewer.shader_request(q, self._alive))
        elif path == "/tile":
            self._check_src(q)
            self._image(*self.viewer.tile_request(q))
        elif path == "/plane":
            self._check_src(q)
            self._image(*self.viewer.plane_request(q))
        elif path == "/api/plan":
            self._check_src(q)
            self._json(self.viewer.export_job(q).plan)
        elif path == "/export":
            self._check_src(q)
            job = self.viewer.export_job(q)
            body = self.viewer.export_bytes(job, self._alive)
            ctype = "image/png" if job.name.endswith(".png") else "image/x-exr"
            self._send(200, body, ctype, {"Cache-Control": "no-store",
                                          "Content-Disposition": f'attachment; filename="{job.name}"'})
        else:
            raise BadRequest(f"no such page: {path[:80]}", 404)

    def _check_src(self, q: Query) -> None:
        src = q.text("src")
        if src != self.viewer.src:
            raise BadRequest("this page was made for another input or server; reload it", 409)

    def _image(self, key, make) -> None:
        """An immutable image: its URL names the input (src) and every setting."""
        etag = '"' + digest(self.viewer.src, repr(key)) + '"'
        headers = {"Cache-Control": "public, max-age=31536000, immutable", "ETag": etag}
        if self.headers.get("If-None-Match") == etag:
            self._send(304, b"", "image/png", headers)
            return
        t0 = time.perf_counter()
        body = make(self._alive)
        headers["Server-Timing"] = f"compute;dur={1000 * (time.perf_counter() - t0):.1f}"
        self._send(200, body, "image/png", headers)

    def _post(self, path: str, q: Query) -> None:
        if path != "/api/upload":
            raise BadRequest(f"no such page: {path[:80]}", 404)
        if self.headers.get("X-Requested-With") != "warp-texton":
            raise BadRequest("uploads come from the viewer page (X-Requested-With: warp-texton)", 403)
        q.finish()
        try:
            length = int(self.headers.get("Content-Length", ""))
        except ValueError:
            raise BadRequest("an upload needs a Content-Length", 411) from None
        if length <= 0:
            raise BadRequest("empty upload")
        if length > MAX_UPLOAD_BYTES:
            self.close_connection = True
            raise BadRequest(f"upload larger than {MAX_UPLOAD_BYTES >> 20} MiB", 413)
        data = self.rfile.read(length)
        if len(data) != length:
            raise BadRequest("upload cut short")
        b = self.viewer.add_upload(data, unquote(self.headers.get("X-Filename", "upload")), self._alive)
        assert b.image is not None, "uploads are images"
        self._json({"id": b.digest, "name": b.name, "width": b.image.shape[1], "height": b.image.shape[0]})


class _Server(ThreadingHTTPServer):
    # set by serve() before the first request
    viewer: Viewer
    verbose: bool
    pages: dict[str, bytes]
    any_host: bool
    host_names: set[str]

    daemon_threads = True
    # a burst of tile requests must queue in the kernel, not be refused
    request_queue_size = 256
    allow_reuse_address = True

    def handle_error(self, request, client_address):
        exc = sys.exc_info()[1]
        if isinstance(exc, (BrokenPipeError, ConnectionResetError, ConnectionAbortedError, socket.timeout)):
            return
        super().handle_error(request, client_address)


class ViewerHandle:
    """A running viewer: ``url``, ``viewer`` (the :class:`Viewer`), ``close()``;
    also a context manager."""

    def __init__(self, server: _Server, viewer: Viewer, url: str):
        self._server = server
        self.viewer = viewer
        self.url = url
        self._thread = threading.Thread(target=server.serve_forever, kwargs={"poll_interval": 0.2},
                                        name="warp-texton-view", daemon=True)
        self._thread.start()
        self._closed = False

    @property
    def port(self) -> int:
        return self._server.server_address[1]

    def wait(self) -> None:
        """Block until the server stops (KeyboardInterrupt passes through)."""
        while self._thread.is_alive():
            self._thread.join(0.5)

    def close(self) -> None:
        """Stop serving and free the port and the temporary files."""
        if self._closed:
            return
        self._closed = True
        self._server.shutdown()
        self._server.server_close()
        self._thread.join()
        self.viewer.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def __repr__(self) -> str:
        return f"ViewerHandle({self.url!r}{', closed' if self._closed else ''})"


def _check_port(port) -> int:
    if isinstance(port, bool) or not isinstance(port, (int, np.integer)) or not 0 <= int(port) <= 65535:
        raise TextonError(f"port must be an integer in [0, 65535] (0: any free port), got {port!r}", param="port")
    return int(port)


def _check_host(host) -> tuple[str, int]:
    if not isinstance(host, str) or not host or any(c.isspace() for c in host):
        raise TextonError(f"host must be a host name or IP address, e.g. 127.0.0.1, got {host!r}", param="host")
    try:
        infos = socket.getaddrinfo(host, None, type=socket.SOCK_STREAM)
    except (socket.gaierror, UnicodeError):
        raise TextonError(f"host {host!r} does not resolve to an address of this machine", param="host") from None
    return host, infos[0][0]


def _cache_bytes(cache_mb) -> int:
    if isinstance(cache_mb, bool) or not isinstance(cache_mb, (int, float, np.integer, np.floating)) \
            or not 0 <= cache_mb < float(1 << 40):  # NaN and inf too
        raise TextonError(f"cache_mb must be a finite number >= 0 (MiB), got {cache_mb!r:.60}", param="cache_mb")
    return int(float(cache_mb) * (1 << 20))


def _start_settings(size, order, color_correction, seed, mni, filter) -> tuple[Analysis, Noise]:
    """The page's start settings, within the bounds its requests have."""
    if filter not in VIEW_FILTERS:
        raise TextonError(f"filter must be one of {', '.join(VIEW_FILTERS)}, got {filter!r}", param="filter")
    if isinstance(mni, bool) or not isinstance(mni, (int, float)) or not MNI_RANGE[0] <= mni <= MNI_RANGE[1]:
        raise TextonError(f"mni must be a number in [{MNI_RANGE[0]:g}, {MNI_RANGE[1]:g}], got {mni!r}", param="mni")
    if isinstance(seed, bool) or not isinstance(seed, int) or not 0 <= seed < 2**32:
        raise TextonError(f"seed must be an integer in [0, 2**32), got {seed!r}", param="seed")
    if isinstance(size, bool) or not isinstance(size, int) or not TEXTON_SIZES[0] <= size <= TEXTON_SIZES[1]:
        raise TextonError(f"size must be an integer in [{TEXTON_SIZES[0]}, {TEXTON_SIZES[1]}], got {size!r}",
                          param="size")
    if order not in ORDERS or isinstance(order, bool):
        raise TextonError(f"order must be one of {', '.join(map(str, ORDERS))}, got {order!r}", param="order")
    return Analysis(size, order, bool(color_correction)), Noise(seed, float(mni), 0.0, filter)


def serve(input, *, port: int = 8000, host: str = "127.0.0.1", device=None, mix=None, size: int = 64,
          order: int = 1, color_correction: bool = True, seed: int = 0, mni: float = 30.0,
          filter: str = "anisotropic", slots: int = 2, cache_mb: float = 256, png_level: int = PNG_LEVEL,
          open_browser: bool = False, verbose: bool = False) -> ViewerHandle:
    """Serve the interactive viewer of ``input`` and return at once.

    Parameters
    ----------
    input : path or Texton
        An example image (analysed at start with ``size``, ``order`` and
        ``color_correction``, and again when the page changes them) or a texton
        file (``.exr`` from :func:`warp_texton.analyze`, or ``.texton``).
    port : int
        TCP port; 0 picks a free one (see ``handle.url``).
    host : str
        Address to bind. The default serves this machine only; another address
        lets anyone who reaches it use the viewer (there is no authentication),
        with a warning. To view a remote machine, forward a port over SSH instead
        (docs/viewer.md).
    device : str, optional
        Warp device for every computation ("cpu", "cuda", "cuda:N"); default
        CUDA when available.
    mix : path or Texton, optional
        A second input for the mixing mode (more can be uploaded from the page).
    size : int
        Start value of the analysis's texton size (as in :func:`warp_texton.analyze`).
    order : {0, 1, 3, 5}
        Start value of the analysis's order.
    color_correction : bool
        Start value of the analysis's colour correction.
    seed : int
        Start value of the noise's seed shown by the page.
    mni : float
        Start value of the mean number of impacts per point.
    filter : {"none", "mip", "anisotropic"}
        Start value of the filter (the viewer offers the quick ones).
    slots : int
        Computations that run at once; other requests wait in turn.
    cache_mb : float
        Memory kept for computed tiles and plane views (LRU).
    png_level : int
        zlib level of the tiles, 0 (stored: the fastest to make) to 9; a higher
        level saves bandwidth over a slow link (about a quarter at 1).
    open_browser : bool
        Open the page in the default web browser.
    verbose : bool
        Log every request on stderr.

    Returns
    -------
    ViewerHandle
        ``.url`` to open, ``.close()`` to stop.

    Raises
    ------
    TextonError
        For a bad port or host, an unreadable input, or analysis settings the
        input cannot take; ``OSError`` subclasses become TextonError too.

    Examples
    --------
    >>> from warp_texton.view.server import serve
    >>> from warp_texton.demo import demo_texture_path
    >>> with serve(demo_texture_path(), port=0, size=32, device="cpu") as h:  # doctest: +SKIP
    ...     print(h.url)
    http://127.0.0.1:...
    """
    port = _check_port(port)
    host, family = _check_host(host)
    if isinstance(slots, bool) or not isinstance(slots, int) or not 1 <= slots <= 64:
        raise TextonError(f"slots must be an integer in [1, 64], got {slots!r}", param="slots")
    cache_bytes = _cache_bytes(cache_mb)
    if isinstance(png_level, bool) or not isinstance(png_level, int) or not 0 <= png_level <= 9:
        raise TextonError(f"png_level must be an integer in [0, 9], got {png_level!r}", param="png_level")
    analysis, noise = _start_settings(size, order, color_correction, seed, mni, filter)
    if host not in LOOPBACK:
        warnings.warn(f"serving on {host}: anyone who can reach this address can use the viewer "
                      "(no authentication); SSH port forwarding keeps it private (docs/viewer.md)", stacklevel=2)
    server_class = type("_ServerV6", (_Server,), {"address_family": socket.AF_INET6}) \
        if family == socket.AF_INET6 else _Server
    try:  # bind first: a port in use fails before the analysis
        server = server_class((host, port), _Handler)
    except OSError as exc:
        reason = "is in use" if exc.errno in (98, 48, 10048) else f"cannot be used ({exc.strerror or exc})"
        raise TextonError(f"port {port} on {host} {reason}; choose another with --port (0: any free port)",
                          param="port") from None
    try:
        viewer = Viewer(input, mix=mix, device=device, analysis=analysis, noise=noise, slots=slots,
                        cache_bytes=cache_bytes, png_level=png_level)
    except BaseException:
        server.server_close()
        raise
    server.viewer = viewer
    server.verbose = verbose
    server.pages = {name: _page(name) for name, _ in STATIC.values()}
    server.any_host = host in ("0.0.0.0", "::", "")
    server.host_names = {"127.0.0.1", "localhost", "::1", host.lower()}
    shown = "127.0.0.1" if server.any_host else host
    shown = f"[{shown}]" if ":" in shown else shown
    handle = ViewerHandle(server, viewer, f"http://{shown}:{server.server_address[1]}/")
    if open_browser:
        import webbrowser

        threading.Thread(target=webbrowser.open, args=(handle.url,), daemon=True).start()
    return handle
