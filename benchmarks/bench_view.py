"""Benchmark: the viewer's tile latency and the time to fill a view (``warp-texton view``).

Serves an RGB test texture (scikit-image's grass, gravel and brick mixed; 64² texton,
MNI 30) with ``warp_texton.view.server.serve`` on this machine and measures, over HTTP on
the loopback interface:

* tile latency: from sending a request to having read the last byte of its PNG,
  one request at a time on a kept-alive connection, for 256² tiles never asked
  before (no cache hit), unfiltered and anisotropic, at several zoom levels;
  p50 and p95, and the server's own share (``Server-Timing``: synthesize + PNG);
* encoding: what the PNG costs against the raster, per zlib level, and raw RGBA;
* filling a 1280 × 720 view from empty: the 24 tiles that cover a view whose
  corner is off the tile grid, fetched over 6 connections as a browser does,
  wall time from the first request to the last byte, for 1 to 3 computation
  slots (the server's ``slots``); and, where Chromium and Playwright are
  installed, the page itself: from a new view to every tile drawn.

    python benchmarks/bench_view.py            # full run, writes results/view.json and .md
    python benchmarks/bench_view.py --quick    # smoke run
"""

from __future__ import annotations

import http.client
import io
import shutil
import statistics
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from urllib.parse import urlencode

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from common import machine_line, make_texture, report_header, run_main  # noqa: E402

from warp_texton import synthesize, write_image  # noqa: E402
from warp_texton.view.server import serve  # noqa: E402
from warp_texton.view.pictures import PNG_LEVEL, png_bytes, to_8bit  # noqa: E402

VIEW = (1280, 720)
TILE = 256
CONNECTIONS = 6  # what a browser opens per host over HTTP/1.1


def percentile(values, q: float) -> float:
    return float(np.percentile(np.asarray(values), q))


class Connection:
    """One kept-alive HTTP connection: GET -> (seconds to the last byte, server ms, body)."""

    def __init__(self, port: int):
        self.conn = http.client.HTTPConnection("127.0.0.1", port, timeout=120)

    def get(self, path: str):
        t0 = time.perf_counter()
        self.conn.request("GET", path)
        r = self.conn.getresponse()
        body = r.read()
        elapsed = time.perf_counter() - t0
        if r.status != 200:
            raise RuntimeError(f"{path}: HTTP {r.status}: {body!r}")
        timing = r.getheader("Server-Timing", "")
        server_ms = float(timing.split("dur=")[1]) if "dur=" in timing else float("nan")
        return elapsed, server_ms, body


def tile_path(src: str, z: int, x: int, y: int, seed: int, filter: str) -> str:
    return "/tile?" + urlencode({"src": src, "z": z, "x": x, "y": y, "seed": seed, "filter": filter})


def latencies(handle, filter: str, z: int, n: int, seed: int) -> dict:
    c = Connection(handle.port)
    src = handle.viewer.src
    c.get(tile_path(src, z, -1, -1, seed, filter))  # first request of the connection, not counted
    total, server = [], []
    for k in range(n):
        t, s, _ = c.get(tile_path(src, z, k % 16, k // 16, seed, filter))
        total.append(t * 1000)
        server.append(s)
    return {"filter": filter, "zoom": z, "scale": 2.0 ** z, "tiles": n,
            "p50_ms": percentile(total, 50), "p95_ms": percentile(total, 95), "max_ms": max(total),
            "server_p50_ms": percentile(server, 50), "server_p95_ms": percentile(server, 95)}


def view_tiles(left: float, top: float):
    """Tiles of level 0 covering a VIEW-sized canvas whose corner is at pixel (left, top)."""
    w, h = VIEW
    xs = range(int(np.floor(left / TILE)), int(np.ceil((left + w) / TILE)))
    ys = range(int(np.floor(top / TILE)), int(np.ceil((top + h) / TILE)))
    return [(x, y) for y in ys for x in xs]


def fill_view(handle, seed: int, filter: str) -> tuple[float, int]:
    tiles = view_tiles(100.0 + 10_000 * seed, 100.0)
    src = handle.viewer.src
    conns = [Connection(handle.port) for _ in range(CONNECTIONS)]
    for c in conns:  # connections are open before the clock starts, as a browser's usually are
        c.get("/api/info")
    t0 = time.perf_counter()

    def fetch(k):
        x, y = tiles[k]
        return conns[k % CONNECTIONS].get(tile_path(src, 0, x, y, seed, filter))

    def lane(i):
        return [fetch(k) for k in range(i, len(tiles), CONNECTIONS)]

    with ThreadPoolExecutor(CONNECTIONS) as pool:
        list(pool.map(lane, range(CONNECTIONS)))
    return time.perf_counter() - t0, len(tiles)


def encoding(texton, repeat: int, device: str) -> list[dict]:
    img = synthesize(texton, (TILE, TILE), mni=30.0, seed=1, device=device)
    rows = []
    t = []
    for _ in range(repeat * 3):
        t0 = time.perf_counter()
        synthesize(texton, (TILE, TILE), mni=30.0, seed=1, offset=(1000.0 * len(t), 0.0), device=device)
        t.append(time.perf_counter() - t0)
    rows.append({"step": "synthesize 256² RGB", "ms": 1000 * min(t), "bytes": None})
    from PIL import Image

    q = to_8bit(img)
    for level in (0, 1, 6):
        t = []
        for _ in range(repeat * 3):
            t0 = time.perf_counter()
            buf = io.BytesIO()
            Image.fromarray(q).save(buf, format="PNG", compress_level=level)
            t.append(time.perf_counter() - t0)
        rows.append({"step": f"PNG, zlib level {level}", "ms": 1000 * min(t), "bytes": len(buf.getvalue())})
    t = []
    for _ in range(repeat * 3):
        t0 = time.perf_counter()
        raw = np.dstack([to_8bit(img), np.full((TILE, TILE, 1), 255, np.uint8)]).tobytes()
        t.append(time.perf_counter() - t0)
    rows.append({"step": "raw RGBA", "ms": 1000 * min(t), "bytes": len(raw)})
    assert len(png_bytes(img)) > 0
    return rows


def browser_fill(handle, repeat: int) -> dict | None:
    """Time for the page in headless Chromium to draw a new 1280 x 720 view (None without a browser)."""
    chromium = shutil.which("chromium") or shutil.which("chromium-browser")
    try:
        from playwright.sync_api import sync_playwright
    except ImportError:
        return None
    if chromium is None:
        return None
    times = []
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=chromium, args=["--no-sandbox"])
        page = browser.new_page(viewport={"width": 300 + VIEW[0], "height": VIEW[1]}, device_scale_factor=1)
        page.goto(handle.url)
        page.wait_for_function("window.viewer && window.viewer.pending() === 0", timeout=120_000)
        for k in range(repeat):
            ms = page.evaluate("""async (k) => {
                const t0 = performance.now();
                window.viewer.setView({left: 50000 * (k + 1) + 100, top: 100});
                await new Promise((r) => requestAnimationFrame(r));
                await window.viewer.idle();
                return performance.now() - t0;
            }""", k)
            times.append(ms)
        browser.close()
    return {"best_ms": min(times), "median_ms": statistics.median(times), "runs": len(times)}


def run(args) -> dict:
    report = report_header("view", args.device)
    side = 128 if args.quick else 256
    n = 12 if args.quick else 96
    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / "texture.png"
        write_image(path, make_texture(side))
        results, fills, enc, page = [], [], [], None
        for slots in ((2,) if args.quick else (1, 2, 3)):
            with serve(path, port=0, size=args.size, mni=args.mni, device=args.device, slots=slots,
                       filter="anisotropic") as handle:
                if slots == 2:
                    texton = handle.viewer.texton(handle.viewer.defaults[0])
                    levels = (0, -2) if args.quick else (0, -2, -4)
                    for z in levels:
                        for f in ("none", "anisotropic"):
                            results.append(latencies(handle, f, z, n, seed=len(results) + 1))
                            print(results[-1], flush=True)
                    enc = encoding(texton, args.repeat, args.device)
                    page = None if args.quick else browser_fill(handle, args.repeat)
                for f in ("none", "anisotropic"):
                    times = []
                    for k in range(args.repeat):
                        t, count = fill_view(handle, seed=1000 + 10 * slots + k + (500 if f == "none" else 0), filter=f)
                        times.append(t)
                    fills.append({"slots": slots, "filter": f, "tiles": count, "best_s": min(times),
                                  "median_s": statistics.median(times), "runs": len(times)})
                    print(fills[-1], flush=True)
    report["parameters"] = {"texture": side, "texton": args.size, "mni": args.mni, "tile": TILE, "view": VIEW,
                            "connections": CONNECTIONS, "png_level": PNG_LEVEL}
    report.update(latency=results, encoding=enc, fill=fills, browser_fill=page)
    return report


def markdown(report: dict) -> str:
    p = report["parameters"]
    lines = [
        f"# Viewer tile latency ({report['date']})", "",
        machine_line(report),
        f"RGB texture {p['texture']}², texton {p['texton']}², MNI {p['mni']:g}, {p['tile']}² RGB tiles as PNG "
        f"(zlib level {p['png_level']}), HTTP/1.1 on the loopback interface, tiles never computed before.", "",
        "Tile latency, one request at a time (request sent → last byte read); server: synthesize + PNG.", "",
        "| filter | zoom level | pixels per texel | p50 (ms) | p95 (ms) | server p50 (ms) | server p95 (ms) |",
        "|---|---|---|---|---|---|---|",
    ]
    for r in report["latency"]:
        lines.append(f"| {r['filter']} | {r['zoom']} | {r['scale']:g} | {r['p50_ms']:.1f} | {r['p95_ms']:.1f} | "
                     f"{r['server_p50_ms']:.1f} | {r['server_p95_ms']:.1f} |")
    lines += ["", f"Filling a {p['view'][0]}×{p['view'][1]} view from empty at level 0 (one pixel per texel) "
              f"over {p['connections']} connections; best of the runs (median in brackets).", "",
              "| computation slots | filter | tiles | time (ms) |", "|---|---|---|---|"]
    for r in report["fill"]:
        lines.append(f"| {r['slots']} | {r['filter']} | {r['tiles']} | {1000 * r['best_s']:.0f} "
                     f"({1000 * r['median_s']:.0f}) |")
    if report.get("browser_fill"):
        b = report["browser_fill"]
        lines += ["", f"In headless Chromium (the page, 2 slots, filter anisotropic): a new {p['view'][0]}×"
                  f"{p['view'][1]} view drawn in {b['best_ms']:.0f} ms (median {b['median_ms']:.0f} ms, "
                  f"{b['runs']} runs), including PNG decoding and drawing."]
    lines += ["", "Cost of one 256² RGB tile by step (best of the runs):", "",
              "| step | time (ms) | bytes |", "|---|---|---|"]
    for r in report["encoding"]:
        lines.append(f"| {r['step']} | {r['ms']:.2f} | {'' if r['bytes'] is None else r['bytes']} |")
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    return run_main(__doc__, "view", run, markdown, argv, repeat=5)


if __name__ == "__main__":
    sys.exit(main())
