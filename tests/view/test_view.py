"""The viewer's server (``warp_texton.view.server``), without a browser: tiles are the
promised ``synthesize`` windows and join without seams, bad requests get a
one-line 4xx, work is bounded, bursts queue, disconnects are survived, exports
are the files their printed commands make."""

from __future__ import annotations

import contextlib
import http.client
import io
import json
import os
import re
import shlex
import signal
import socket
import struct
import subprocess
import sys
import threading
import time
import warnings
from pathlib import Path
from urllib.parse import urlencode

import numpy as np
import pytest
from PIL import Image

from warp_texton import (TextonError, analyze, load_texton, read_image, render_plane, synthesize,
                         synthesize_mixed)
from warp_texton.demo import demo_texture_path
from warp_texton.view.server import serve
from warp_texton.view.viewer import Viewer
from warp_texton.view.pictures import to_8bit
from warp_texton.view.queries import Analysis, Mix, Noise, Tile, rotate, tile_window, view_window
from helpers import ctrl_c_default

DEVICE = "cpu"
SIZE = 16  # texton side: small, so that tiles are quick


def small_rgb(path: Path) -> Path:
    """A 64 x 64 RGB texture made of three crops of the demo grass (correlated channels)."""
    g = read_image(demo_texture_path())[:, :, 0]
    rgb = np.stack([g[:64, :64], g[100:164, 30:94], g[40:104, 150:214]], axis=-1)
    rgb = rgb @ np.array([[0.7, 0.2, 0.1], [0.3, 0.5, 0.2], [0.1, 0.3, 0.6]]).T
    Image.fromarray(to_8bit(rgb)).save(path)
    return path


@pytest.fixture(scope="module")
def rgb_path(tmp_path_factory) -> Path:
    return small_rgb(tmp_path_factory.mktemp("view") / "rgb64.png")


@pytest.fixture(scope="module")
def texton(rgb_path):
    return analyze(read_image(rgb_path), size=SIZE, order=1, seed=0)


@pytest.fixture(scope="module")
def server(rgb_path):
    with serve(rgb_path, port=0, size=SIZE, device=DEVICE, filter="none") as handle:
        yield handle


class Client:
    """Plain HTTP requests to a viewer: (status, headers, body)."""

    def __init__(self, handle):
        self.handle = handle
        self.src = handle.viewer.src

    def request(self, path: str, method: str = "GET", body=None, headers=None):
        conn = http.client.HTTPConnection("127.0.0.1", self.handle.port, timeout=60)
        try:
            conn.request(method, path, body=body, headers=headers or {})
            r = conn.getresponse()
            return r.status, dict(r.getheaders()), r.read()
        finally:
            conn.close()

    def get(self, route: str, **params):
        return self.request(f"{route}?{urlencode({'src': self.src, **params})}")


def decode_png(body: bytes) -> np.ndarray:
    a = np.asarray(Image.open(io.BytesIO(body)))
    return a[:, :, None] if a.ndim == 2 else a


@pytest.fixture(scope="module")
def client(server):
    return Client(server)


# ----------------------------------------------------------------- tiles
@pytest.mark.parametrize("z, rotation, filter", [(0, 0.0, "none"), (1, 30.0, "none"), (-2, -75.0, "anisotropic")])
def test_tiles_are_windows_of_one_raster(texton, z, rotation, filter):
    """Four neighbouring tiles, far from the origin, assembled, are one synthesize window."""
    noise = Noise(seed=3, mni=20.0, rotation=rotation, filter=filter)
    t, x0, y0 = 64, 12345, -678
    tiles = {(dx, dy): synthesize(texton, w.shape, mni=noise.mni, seed=noise.seed, scale=w.scale, rotation=w.rotation, offset=w.offset,
                                  device=DEVICE, filter=filter)
             for dx in (0, 1) for dy in (0, 1)
             for w in [tile_window(Tile(z, x0 + dx, y0 + dy, t), noise)]}
    joined = np.concatenate([np.concatenate([tiles[0, 0], tiles[1, 0]], axis=1),
                             np.concatenate([tiles[0, 1], tiles[1, 1]], axis=1)], axis=0)
    s = 2.0 ** z
    whole = view_window(2 * t, 2 * t, s, rotation, x0 * t / s, y0 * t / s)
    big = synthesize(texton, whole.shape, mni=noise.mni, seed=noise.seed, scale=whole.scale, rotation=whole.rotation, offset=whole.offset,
                     device=DEVICE, filter=filter)
    assert np.abs(joined - big).max() < 2e-5
    # and the seams are not special: steps across them are like steps inside a tile
    across = np.abs(joined[:, t] - joined[:, t - 1]).mean()
    inside = np.abs(joined[:, t // 2] - joined[:, t // 2 - 1]).mean()
    assert across < 3 * inside + 1e-6


def test_rotation_turns_about_the_origin():
    """Tile pixels are at R(rotation) ((xT + j + 1/2)/s, (yT + i + 1/2)/s)."""
    w = tile_window(Tile(2, 3, -5, 128), Noise(rotation=30.0))
    u = (3 * 128 / 4, -5 * 128 / 4)
    assert w.offset == pytest.approx(rotate(30.0, u))
    assert w.scale == 4.0 and w.rotation == 30.0 and w.shape == (128, 128)


@pytest.mark.parametrize("steps, start, end", [(9, 20.0, 236.0), (33, 58.0, 70.0)])
def test_mixed_tiles_join(rgb_path, steps, start, end):
    """Mixed noise: tiles computed with their margins equal one big window with the same rho ramp
    (the ramps change texton in the margins left of a tile, and within a texel right of one)."""
    v = Viewer(rgb_path, mix=demo_texture_path(), device=DEVICE, analysis=Analysis(SIZE, 1, True))
    try:
        mix = Mix(v.start_b, steps, start, end)
        noise = Noise(seed=2, mni=15.0, rotation=0.0, filter="none")
        t = 64
        tiles = [v.mixed_tile(Tile(0, k, 1, t), Analysis(SIZE, 1, True), noise, mix) for k in (0, 1, 2, 3)]
        joined = np.concatenate(tiles, axis=1)
        textons = v.mixed_textons(Analysis(SIZE, 1, True), mix)
        # one raster with a margin, cut to the four tiles
        margin = 2 * SIZE
        h, w = t + 2 * margin, 4 * t + 2 * margin
        x = (np.arange(w) - margin + 0.5)
        rho = np.broadcast_to(mix.rho(x)[None, :], (h, w))
        big = synthesize_mixed(textons, rho, (h, w), mni=noise.mni, seed=noise.seed, scale=1.0, offset=(-margin, t - margin),
                               device=DEVICE)[margin:margin + t, margin:margin + 4 * t]
        assert np.abs(joined - big).max() < 2e-5
        assert not np.allclose(tiles[0], tiles[3], atol=0.05)  # it does change from A to B
    finally:
        v.close()


def test_http_tile_is_synthesize_rounded_to_8_bits(client, texton):
    status, headers, body = client.get("/tile", z=1, x=-3, y=2, seed=5, mni=12.5, rot=20, filter="none",
                                       size=SIZE, order=1, cc=1)
    assert status == 200 and headers["Content-Type"] == "image/png"
    w = tile_window(Tile(1, -3, 2, 256), Noise(5, 12.5, 20.0, "none"))
    want = synthesize(texton, w.shape, mni=12.5, seed=5, scale=w.scale, rotation=w.rotation, offset=w.offset, device=DEVICE)
    np.testing.assert_array_equal(decode_png(body), to_8bit(want))


def test_tiles_are_cached_by_server_and_browser(client):
    params = dict(z=0, x=7, y=7, seed=9, size=SIZE)
    status, headers, body = client.get("/tile", **params)
    assert status == 200
    assert "immutable" in headers["Cache-Control"] and headers["ETag"].startswith('"')
    status2, _, body2 = client.get("/tile", **params)
    assert status2 == 200 and body2 == body
    path = f"/tile?{urlencode({'src': client.src, **params})}"
    status3, _, body3 = client.request(path, headers={"If-None-Match": headers["ETag"]})
    assert status3 == 304 and body3 == b""
    # another setting is another tile
    status4, headers4, _ = client.get("/tile", **{**params, "seed": 10})
    assert status4 == 200 and headers4["ETag"] != headers["ETag"]


# ------------------------------------------------------------ bad input
BAD_TILES = [
    ({"mni": "abc"}, "mni must be a number"),
    ({"mni": "nan"}, "mni must be a number"),
    ({"mni": "1e400"}, "mni must be a number"),
    ({"mni": "0"}, "mni must be a number"),
    ({"z": "99"}, "z must be an integer in"),
    ({"z": "1.5"}, "z must be an integer"),
    ({"z": "-8", "filter": "none"}, "z must be an integer in [-6, 5]"),
    ({"x": str(10**12)}, "x must be an integer in"),
    ({"ts": "100000"}, "ts must be one of"),
    ({"filter": "supersample"}, "filter must be one of"),
    ({"seed": "-1"}, "seed must be an integer"),
    ({"seed": str(2**32)}, "seed must be an integer"),
    ({"size": "100000"}, "size must be an integer in [4, 128]"),
    ({"size": "65"}, "size"),  # larger than the 64 x 64 input: the analysis says why
    ({"order": "2"}, "order must be one of"),
    ({"cc": "yes"}, "cc must be one of"),
    ({"rot": "inf"}, "rot must be a number"),
    ({"bogus": "1"}, "unknown parameter 'bogus'"),
    ({"mode": "mix"}, "missing parameter 'b'"),
    ({"mode": "mix", "b": "nope", "ra": "0", "rb": "10"}, "unknown second input"),
]


def test_filters_come_from_the_registry(client):
    """The page offers the registry's interactive filters, each with its description,
    and the zoom reaches further out for those that filter footprints."""
    from warp_texton.noise.filter_options import FILTERS

    info = json.loads(client.request("/api/info")[2])
    offered = info["bounds"]["filters"]
    assert offered == [k for k, kind in FILTERS.items() if kind.interactive] and "supersample" not in offered
    assert info["filter_notes"] == {k: FILTERS[k].description for k in offered}
    assert {k: z < info["bounds"]["zoom_min"]["none"] for k, z in info["bounds"]["zoom_min"].items()} == \
        {k: FILTERS[k].footprint for k in offered}


@pytest.mark.parametrize("change, reason", BAD_TILES, ids=[r for _, r in BAD_TILES])
def test_bad_parameters_get_a_one_line_400(client, change, reason):
    params = {"z": 0, "x": 0, "y": 0, **change}
    status, headers, body = client.get("/tile", **params)
    text = body.decode()
    assert status in (400, 404), text
    assert headers["Content-Type"].startswith("text/plain")
    assert text.endswith("\n") and text.count("\n") == 1 and "Traceback" not in text
    assert reason in text


@pytest.mark.parametrize("path, status", [
    ("/tile?z=0&x=0&y=0", 400),                       # no src
    ("/tile?src=0000&z=0&x=0&y=0", 409),              # another input's page
    ("/tile?z=0&z=1", 400),                           # repeated
    ("/tile?%zz=1", 400),                             # malformed
    ("/tile?" + "a=1&" * 2000, 400),                  # long
    ("/../../etc/passwd", 404),
    ("/viewer.js/../../../etc/passwd", 404),
    ("/index.html?x=1", 400),
    ("/nothing", 404),
])
def test_malformed_requests(client, path, status):
    got, headers, body = client.request(path)
    assert got == status, body
    assert body.decode().count("\n") == 1 and b"<html" not in body.lower()


def test_no_path_is_read_from_a_request(client):
    """Only the page's three files are served; nothing under the package or the input's folder."""
    for path in ("/viewer.js", "/viewer.css", "/", "/index.html"):
        assert client.request(path)[0] == 200
    for path in ("/__init__.py", "/view.py", "/rgb64.png", "/data/grass_256.png", "/viewer/index.html"):
        assert client.request(path)[0] == 404


def test_other_methods_and_hosts_are_refused(client):
    status, _, body = client.request("/tile", method="DELETE")
    assert status == 501 and body.count(b"\n") == 1
    status, _, _ = client.request("/api/info", headers={"Host": "evil.example:8000"})
    assert status == 403
    status, _, _ = client.request("/api/info", headers={"Host": f"localhost:{client.handle.port}"})
    assert status == 200


@pytest.mark.parametrize("host", ["127.0.0.1:80@evil.example", "evil.example#127.0.0.1", "127.0.0.1:",
                                  "127.0.0.1:80:80", "127.0.0.1/x", "[::1", "127.0.0.1:123456", ""])
def test_malformed_hosts_are_bad_requests(client, host):
    # the name before the last colon is 127.0.0.1, but the host is evil.example's
    status, _, body = client.request("/api/info", headers={"Host": host})
    assert status == 400 and body == b"malformed Host header\n"


def test_requests_over_their_share_of_the_budget_are_413(client):
    viewer = client.handle.viewer
    saved = viewer.request_bytes
    viewer.request_bytes = 1 << 16  # the library's own estimate of this tile is far over
    try:
        status, _, body = client.get("/tile", z=1, x=7, y=5, ts=256, mni=30, filter="none")
    finally:
        viewer.request_bytes = saved
    assert status == 413 and body.count(b"\n") == 1, body
    assert b"over the memory budget of 64 KiB" in body and b"bounds per request: memory 64 KiB" in body
    assert client.get("/tile", z=1, x=7, y=5, ts=256, mni=30, filter="none")[0] == 200  # not cached as failed


def test_bounds_on_exports_and_planes(client):
    status, _, body = client.get("/export", w=5000, h=10, scale=1, left=0, top=0)
    assert status == 400 and b"w must be an integer in [1, 4096]" in body
    status, _, body = client.get("/export", w=4096, h=4097, scale=1, left=0, top=0)
    assert status == 400
    status, _, body = client.get("/plane", w=4000, h=4000)
    assert status == 400 and b"at most" in body
    status, _, body = client.get("/export", w=10, h=10, scale=1e6, left=0, top=0)
    assert status == 400 and b"scale must be a number" in body
    status, _, body = client.get("/export", w=10, h=10, scale=1, left=1e12, top=0)
    assert status == 400 and b"left must be a number" in body


# ------------------------------------------------------------- uploads
def upload(client, data: bytes, header=True):
    headers = {"Content-Type": "application/octet-stream", "X-Filename": "b.png"}
    if header:
        headers["X-Requested-With"] = "warp-texton"
    return client.request("/api/upload", method="POST", body=data, headers=headers)


def png(a) -> bytes:
    buf = io.BytesIO()
    Image.fromarray(a).save(buf, format="PNG")
    return buf.getvalue()


def test_uploads_are_checked(client):
    good = png(to_8bit(read_image(demo_texture_path())[:64, :64, 0]))
    assert upload(client, good, header=False)[0] == 403  # not from the page
    status, _, body = upload(client, b"not an image at all")
    assert status == 400 and b"not an image" in body
    status, _, body = upload(client, b"\x76\x2f\x31\x01" + bytes(100))  # an EXR
    assert status == 400 and b"PNG or JPEG" in body
    status, _, body = upload(client, png(np.zeros((5000, 5000), bool)))  # a tiny file of many pixels
    assert status == 413 and b"at most" in body
    with warnings.catch_warnings(record=True) as seen:  # 10⁸ pixels: past PIL's bomb warning
        warnings.simplefilter("always")
        status, _, body = upload(client, png(np.zeros((10000, 10000), bool)))
    assert status == 413 and b"10000x10000" in body
    assert not [w for w in seen if "DecompressionBomb" in type(w.message).__name__], seen
    status, _, body = upload(client, good)
    assert status == 200
    info = json.loads(body)
    assert info["width"] == 64 and re.fullmatch(r"[0-9a-f]{16}", info["id"])


def test_oversized_upload_is_refused_before_reading(client):
    s = socket.create_connection(("127.0.0.1", client.handle.port), timeout=10)
    with contextlib.closing(s):
        s.sendall(b"POST /api/upload HTTP/1.1\r\nHost: 127.0.0.1\r\nX-Requested-With: warp-texton\r\n"
                  b"Content-Length: 1073741824\r\n\r\n")
        reply = s.recv(4096)
    assert reply.startswith(b"HTTP/1.1 413")


def test_mixing_through_http(client, rgb_path):
    status, _, body = upload(client, png(to_8bit(read_image(demo_texture_path())[:96, :96, 0])))
    b = json.loads(body)["id"]
    status, headers, body = client.get("/tile", mode="mix", b=b, steps=3, ra=0, rb=300, z=0, x=0, y=0, size=SIZE)
    assert status == 200, body
    assert decode_png(body).shape == (256, 256, 3)
    # rotation and filters do not apply to mixing
    status, _, body = client.get("/tile", mode="mix", b=b, steps=3, ra=0, rb=300, z=0, x=0, y=0, rot=10)
    assert status == 400 and b"unknown parameter 'rot'" in body
    status, _, body = client.get("/tile", mode="mix", b=b, steps=3, ra=10, rb=10, z=0, x=0, y=0)
    assert status == 400 and b"ramp" in body
    status, _, body = client.get("/tile", mode="mix", b=b, steps=3, ra=0, rb=10, z=3, x=0, y=0)
    assert status == 400 and b"z must be an integer in [-6, 2]" in body


# ---------------------------------------------------- load and clients
def test_a_burst_of_200_tiles_queues(rgb_path, monkeypatch):
    with serve(rgb_path, port=0, size=SIZE, device=DEVICE, filter="none", slots=2) as handle:
        viewer = handle.viewer
        running, peak, lock = [0], [0], threading.Lock()
        real = viewer.tile

        def counted(*args, **kwargs):
            with lock:
                running[0] += 1
                peak[0] = max(peak[0], running[0])
            try:
                return real(*args, **kwargs)
            finally:
                with lock:
                    running[0] -= 1

        monkeypatch.setattr(viewer, "tile", counted)
        client = Client(handle)
        results = [None] * 200
        start = threading.Barrier(200)

        def fetch(k):
            start.wait()
            results[k] = client.get("/tile", z=0, x=k % 20, y=k // 20, ts=128, size=SIZE)[0]

        threads = [threading.Thread(target=fetch, args=(k,)) for k in range(200)]
        for t in threads:
            t.start()
        for t in threads:
            t.join(120)
        assert results == [200] * 200
        assert peak[0] <= 2
        assert client.request("/api/info")[0] == 200


def raw_get(port: int, path: str) -> socket.socket:
    s = socket.create_connection(("127.0.0.1", port), timeout=10)
    s.sendall(f"GET {path} HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n".encode())
    return s


def reset(s: socket.socket) -> None:
    """Close with a TCP reset, as a browser tab that goes away may."""
    s.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, struct.pack("ii", 1, 0))
    s.close()


def test_clients_that_leave_are_survived_and_skipped(rgb_path, monkeypatch, capfd):
    with serve(rgb_path, port=0, size=SIZE, device=DEVICE, filter="anisotropic", slots=1) as handle:
        viewer = handle.viewer
        calls, release = [], threading.Event()
        real = viewer.tile

        def slow(tile, *args, **kwargs):
            calls.append(tile)
            if tile.x == 0 and tile.y == 0:
                release.wait(20)  # hold the only slot
            return real(tile, *args, **kwargs)

        monkeypatch.setattr(viewer, "tile", slow)
        client = Client(handle)
        q = {"src": client.src, "size": SIZE, "z": -3, "y": 5}
        blocker = raw_get(handle.port, "/tile?" + urlencode({**q, "x": 0, "y": 0}))
        time.sleep(0.3)
        # stale requests: sent while the slot is busy, abandoned before it frees
        stale = [raw_get(handle.port, "/tile?" + urlencode({**q, "x": k})) for k in range(1, 11)]
        time.sleep(0.3)
        for k, s in enumerate(stale):
            s.close() if k % 2 else reset(s)
        time.sleep(0.3)
        release.set()
        reset(blocker)  # and the first client leaves before its answer is written
        time.sleep(0.5)
        # the server is alive, and computed none of the abandoned tiles
        status, _, _ = client.get("/tile", **{k: v for k, v in q.items() if k != "src"}, x=99)
        assert status == 200
        assert [t.x for t in calls] == [0, 99]
    err = capfd.readouterr().err
    assert "Traceback" not in err


def test_closing_frees_the_port(rgb_path):
    handle = serve(rgb_path, port=0, size=SIZE, device=DEVICE)
    port = handle.port
    handle.close()
    handle.close()  # twice is fine
    with pytest.raises(OSError):
        socket.create_connection(("127.0.0.1", port), timeout=2).close()


# ------------------------------------------------------------------ serve
def test_serve_refuses_bad_arguments(rgb_path, tmp_path):
    for port in (-1, 70000, "80", 1.5, True):
        with pytest.raises(TextonError, match="port must be an integer"):
            serve(rgb_path, port=port)
    for host in ("", "no such host!", 7):
        with pytest.raises(TextonError, match="host"):
            serve(rgb_path, port=0, host=host)
    with pytest.raises(TextonError, match="no such file"):
        serve(tmp_path / "missing.png", port=0)
    bad = tmp_path / "bad.png"
    bad.write_bytes(b"\x89PNG not really")
    with pytest.raises(TextonError, match="not an image"):
        serve(bad, port=0)
    with pytest.raises(TextonError, match="size"):
        serve(rgb_path, port=0, size=65, device=DEVICE)  # larger than the 64 x 64 input
    with pytest.raises(TextonError, match="filter must be one of"):
        serve(rgb_path, port=0, filter="supersample")
    for cache_mb in (float("inf"), float("nan"), -1, np.array([4, 4]), None):
        with pytest.raises(TextonError, match="cache_mb must be a finite number >= 0"):
            serve(rgb_path, port=0, cache_mb=cache_mb)


def test_serve_fits_cache_and_slots_in_the_budget(rgb_path):
    from warp_texton.core.limits import set_memory_budget

    set_memory_budget("1G")
    try:
        with pytest.raises(TextonError, match=r"cache_mb=700 and slots=2 leave .* to each computation"):
            serve(rgb_path, port=0, size=SIZE, device=DEVICE, cache_mb=700)
        with serve(rgb_path, port=0, size=SIZE, device=DEVICE, cache_mb=256, slots=2) as h:
            # cache + kept uploads + both slots' shares fit the budget
            assert h.viewer.request_bytes == ((1 << 30) - (256 << 20) - (256 << 20)) // 2
    finally:
        set_memory_budget(None)


def test_port_in_use(rgb_path):
    with serve(rgb_path, port=0, size=SIZE, device=DEVICE) as handle:
        with pytest.raises(TextonError, match=f"port {handle.port} on 127.0.0.1 is in use"):
            serve(rgb_path, port=handle.port, size=SIZE, device=DEVICE)


def test_another_host_warns(rgb_path):
    with pytest.warns(UserWarning, match="anyone who can reach"):
        handle = serve(rgb_path, port=0, host="0.0.0.0", size=SIZE, device=DEVICE)
    with handle:
        assert Client(handle).request("/api/info")[0] == 200
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        serve(rgb_path, port=0, size=SIZE, device=DEVICE).close()


def test_texton_file_input(texton, tmp_path):
    path = tmp_path / "t.exr"
    texton.save(path)
    with serve(path, port=0, device=DEVICE, filter="none") as handle:
        c = Client(handle)
        info = json.loads(c.request("/api/info")[2])
        assert info["kind"] == "texton" and info["input_size"] is None
        status, _, body = c.get("/tile", z=0, x=1, y=1, seed=4)
        w = tile_window(Tile(0, 1, 1, 256), Noise(4, 30.0, 0.0, "none"))
        np.testing.assert_array_equal(decode_png(body), to_8bit(synthesize(
            load_texton(path), w.shape, mni=30.0, seed=4, scale=w.scale, rotation=w.rotation, offset=w.offset, device=DEVICE)))
        plan = json.loads(c.get("/api/plan", w=32, h=16, scale=1, left=0, top=0, seed=4)[2])
        assert plan["cli"][0].startswith(f"warp-texton synthesize {shlex.quote(str(path))} ")
        panel = json.loads(c.get("/api/panel")[2])
        assert panel["model_error"] == texton.metadata["model_error"]  # kept in the EXR's metadata
        assert "input" not in panel and panel["spectrum_noise"].startswith("data:image/png;base64,")


# --------------------------------------------------------------- panel
def test_panel_reanalyses_once_per_setting(client, rgb_path):
    viewer = client.handle.viewer
    for size, cc in ((12, 1), (12, 0), (12, 1)):
        status, _, body = client.get("/api/panel", size=size, order=3, cc=cc, seed=1)
        assert status == 200
        panel = json.loads(body)
        want = analyze(read_image(rgb_path), size=size, order=3, seed=0, color_correction=bool(cc))
        assert panel["texton_size"] == [size, size] and panel["order"] == 3
        assert panel["model_error"] == pytest.approx(want.metadata["model_error"], abs=1e-12)
        for key in ("input", "gaussian", "texton", "spectrum_input", "spectrum_texton", "spectrum_noise"):
            assert panel[key].startswith("data:image/png;base64,")
    assert Analysis(12, 3, True) in viewer._textons and Analysis(12, 3, False) in viewer._textons


# --------------------------------------------------------------- export
def run_cli(lines: list[str], cwd: Path) -> None:
    from warp_texton.cli.parser import main

    old = os.getcwd()
    os.chdir(cwd)
    try:
        for line in lines:
            argv = shlex.split(line)
            assert argv[0] == "warp-texton"
            assert main(argv[1:] + ["-q"]) == 0, line
    finally:
        os.chdir(old)


@pytest.mark.parametrize("fmt", ["png", "exr"])
def test_export_view_is_what_its_commands_make(client, texton, tmp_path, fmt):
    params = dict(w=96, h=40, scale=0.5, left=-1234.25, top=87.5, rot=-33, seed=6, mni=18, filter="anisotropic",
                  size=SIZE, format=fmt)
    status, _, body = client.get("/api/plan", **params)
    plan = json.loads(body)
    assert plan["file"] == f"noise_96x40_seed6.{fmt}" and (plan["width"], plan["height"]) == (96, 40)
    status, headers, data = client.get("/export", **params)
    assert status == 200 and headers["Content-Disposition"] == f'attachment; filename="{plan["file"]}"'
    got = tmp_path / "download" / plan["file"]
    got.parent.mkdir()
    got.write_bytes(data)
    w = view_window(96, 40, 0.5, -33.0, -1234.25, 87.5)
    want = synthesize(texton, w.shape, mni=18.0, seed=6, scale=w.scale, rotation=w.rotation, offset=w.offset, device=DEVICE, filter="anisotropic")
    values = read_image(got)
    if fmt == "png":
        np.testing.assert_array_equal(to_8bit(values), to_8bit(want))
    else:
        np.testing.assert_allclose(values, want, atol=1e-6)
    # the printed command line makes the same file
    run_cli(plan["cli"], tmp_path)
    np.testing.assert_allclose(read_image(tmp_path / plan["file"]), values, atol=1e-6 if fmt == "exr" else 0)
    # and so does the Python call
    scope: dict = {}
    old = os.getcwd()
    os.chdir(tmp_path / "download")
    try:
        exec(plan["python"], scope)
    finally:
        os.chdir(old)
    np.testing.assert_allclose(read_image(got), values, atol=1e-6 if fmt == "exr" else 0)
    np.testing.assert_allclose(scope["image"], want, atol=1e-6)


def test_export_tile_is_seamless(client, texton, tmp_path):
    params = dict(kind="tile", w=64, h=48, scale=2, seed=2, filter="none", size=SIZE, format="exr")
    plan = json.loads(client.get("/api/plan", **params)[2])
    assert "--period 32.0 24.0" in plan["cli"][-1] and "--offset 0.0 0.0" in plan["cli"][-1]
    path = tmp_path / plan["file"]
    path.write_bytes(client.get("/export", **params)[2])
    tile = read_image(path)
    # two by two copies of the tile are one window of the periodic noise
    big = synthesize(texton, (96, 128), mni=30.0, seed=2, scale=2.0, rotation=0.0, offset=(0.0, 0.0), period=(32.0, 24.0), device=DEVICE)
    np.testing.assert_allclose(np.tile(tile, (2, 2, 1)), big, atol=1e-5)
    run_cli(plan["cli"], tmp_path / "..")
    np.testing.assert_allclose(read_image(tmp_path / ".." / plan["file"]), tile, atol=1e-6)


def test_export_plane(client, texton, tmp_path):
    params = dict(mode="plane", w=48, h=32, tilt=75, height=1.5, fov=50, texel=0.01, seed=3, mni=25,
                  filter="anisotropic", size=SIZE)
    plan = json.loads(client.get("/api/plan", **params)[2])
    assert "render-plane" in plan["cli"][-1]
    (tmp_path / "dl").mkdir()
    (tmp_path / "dl" / plan["file"]).write_bytes(client.get("/export", **params)[2])
    want = render_plane(texton, (32, 48), height=1.5, tilt=75.0, fov=50.0, texel_size=0.01, mni=25.0, seed=3,
                        filter="anisotropic", device=DEVICE)
    got = read_image(tmp_path / "dl" / plan["file"])
    np.testing.assert_array_equal(to_8bit(got), to_8bit(want))
    run_cli(plan["cli"], tmp_path)
    np.testing.assert_array_equal(to_8bit(read_image(tmp_path / plan["file"])), to_8bit(got))
    # the plane view the page shows is the same image
    status, _, body = client.get("/plane", w=48, h=32, tilt=75, height=1.5, fov=50, texel=0.01, seed=3, mni=25,
                                 filter="anisotropic", size=SIZE)
    np.testing.assert_array_equal(decode_png(body), to_8bit(want))


def test_export_mix_python_call(client, tmp_path):
    b = json.loads(upload(client, png(to_8bit(read_image(demo_texture_path())[:64, :64, 0])))[2])["id"]
    params = dict(mode="mix", b=b, steps=3, ra=10, rb=90, w=100, h=30, scale=1, left=0, top=0, seed=1, size=SIZE,
                  format="exr")
    plan = json.loads(client.get("/api/plan", **params)[2])
    assert plan["cli"][0].startswith("#")
    path = tmp_path / plan["file"]
    path.write_bytes(client.get("/export", **params)[2])
    # the snippet names the uploaded file by its name; give it one
    (tmp_path / "b.png").write_bytes(png(to_8bit(read_image(demo_texture_path())[:64, :64, 0])))
    old = os.getcwd()
    os.chdir(tmp_path)
    try:
        scope: dict = {}
        exec(plan["python"], scope)
    finally:
        os.chdir(old)
    np.testing.assert_allclose(read_image(path), scope["image"], atol=1e-6)


# ------------------------------------------------------------------ CLI
def test_cli_view_stops_cleanly_on_ctrl_c(rgb_path):
    proc = subprocess.Popen([sys.executable, "-m", "warp_texton.cli.parser", "view", str(rgb_path), "--port", "0",
                             "--size", str(SIZE), "--device", DEVICE],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, preexec_fn=ctrl_c_default)
    try:
        line = proc.stdout.readline()
        url = re.search(r"http://127\.0\.0\.1:(\d+)/", line)
        assert url, line + proc.stderr.read()
        conn = http.client.HTTPConnection("127.0.0.1", int(url.group(1)), timeout=30)
        conn.request("GET", "/api/info")
        assert conn.getresponse().status == 200
        conn.close()
        proc.send_signal(signal.SIGINT)
        out, err = proc.communicate(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 0
    assert "Traceback" not in err and "stopped" in err


def test_cli_view_errors_are_one_line(rgb_path, capsys):
    from warp_texton.cli.parser import main

    assert main(["view", str(rgb_path), "--port", "70000"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("warp-texton: error: --port must be") and err.count("\n") == 1


def test_info_names_the_device(rgb_path):
    """/api/info says which device the noise runs on, also when none was chosen (issue 33)."""
    from warp_texton.core.runtime import resolve_device

    with serve(rgb_path, port=0, size=SIZE) as handle:
        info = json.loads(Client(handle).request("/api/info")[2])
    assert info["device"] == str(resolve_device(None)) and info["device"] is not None
    with serve(rgb_path, port=0, size=SIZE, device="cpu") as handle:
        assert json.loads(Client(handle).request("/api/info")[2])["device"] == "cpu"
