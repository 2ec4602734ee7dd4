"""Benchmark: the viewer's WebGL2 mode against its tiles, frame time in headless Chromium.

Serves an RGB test texture (scikit-image's grass, gravel and brick mixed; 64²
texton, MNI 30, the anisotropic filter: the viewer's defaults) with
``warp_texton.view.server.serve`` and opens the page in headless Chromium (Debian's
``chromium`` through Playwright) with a 1280 × 720 canvas, then measures in the
same run:

* WebGL2: the page draws a new view with the exported GLSL (a one-texel pan each
  frame), and waits for the frame to be finished (a one-pixel ``readPixels``);
  the mean of N frames. WebGL2 runs wherever Chromium finds it: on a machine
  without a GPU that is SwiftShader, a software rasterizer on the CPU (the
  renderer's name is recorded);
* tiles, cold: from a new view never asked before (the server computes every
  tile) to every tile drawn;
* tiles, warm: the same views in a new browser context (its cache empty) while
  the server still holds the tiles: HTTP, PNG decoding and drawing only.

    python benchmarks/bench_viewer_webgl.py            # full run: writes results/viewer_webgl.json and .md
    python benchmarks/bench_viewer_webgl.py --quick    # smoke run (320 × 180)
"""

from __future__ import annotations

import shutil
import statistics
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
if str(HERE) not in sys.path:
    sys.path.insert(0, str(HERE))

from common import machine_line, make_texture, report_header, run_main  # noqa: E402

from warp_texton import write_image  # noqa: E402
from warp_texton.view.server import serve  # noqa: E402

VIEW = (1280, 720)
QUICK_VIEW = (320, 180)
PANEL = 300  # the page's side panel, CSS pixels

# a new view k: far from every other (no tile shared), its corner off the tile grid
_NEW_VIEW = """async (k) => {
    const t0 = performance.now();
    window.viewer.setView({left: 50000 * (k + 1) + 100, top: 100});
    await new Promise((r) => requestAnimationFrame(r));
    await window.viewer.idle();
    return performance.now() - t0;
}"""


def available() -> str | None:
    """Why the browser measurement cannot run here, or None."""
    if shutil.which("chromium") is None and shutil.which("chromium-browser") is None:
        return "no Chromium on PATH"
    try:
        import playwright.sync_api  # noqa: F401
    except ImportError:
        return "Playwright is not installed"
    return None


def measure(view=VIEW, *, frames: int = 5, runs: int = 3, texton: int = 64, mni: float = 30.0,
            image_side: int = 256, device: str = "cpu", filter: str = "anisotropic") -> dict:
    """Frame times of both modes of the page for a ``view`` = (width, height) canvas, in ms."""
    from playwright.sync_api import sync_playwright

    chromium = shutil.which("chromium") or shutil.which("chromium-browser")
    width, height = view
    viewport = {"width": PANEL + width, "height": height}
    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / "texture.png"
        write_image(path, make_texture(image_side))
        with serve(path, port=0, size=texton, mni=mni, device=device, filter=filter) as handle, \
                sync_playwright() as p:
            browser = p.chromium.launch(executable_path=chromium, args=["--no-sandbox"])

            def page_of(render: str):
                ctx = browser.new_context(viewport=viewport, device_scale_factor=1)
                page = ctx.new_page()
                page.goto(f"{handle.url}?render={render}")
                page.wait_for_function("window.viewer && window.viewer.pending() === 0", timeout=600_000)
                page.evaluate("window.viewer.idle()")
                assert page.evaluate("[window.viewer.view().width, window.viewer.view().height]") == [width, height]
                return ctx, page

            ctx, page = page_of("webgl")
            gl = page.evaluate("window.viewer.render()")
            assert gl["drawing"] == "webgl", gl
            frame_ms = page.evaluate("(n) => window.viewer.glFrames(n)", frames)
            ctx.close()
            ctx, page = page_of("tiles")
            cold = [page.evaluate(_NEW_VIEW, k) for k in range(runs)]
            ctx.close()
            ctx, page = page_of("tiles")
            warm = [page.evaluate(_NEW_VIEW, k) for k in range(runs)]
            ctx.close()
            version = browser.version
            browser.close()
    stats = lambda t: {"mean_ms": statistics.fmean(t), "best_ms": min(t), "runs": len(t),  # noqa: E731
                       "times_ms": [round(v, 1) for v in t]}
    return {"view": [width, height], "texton": texton, "mni": mni, "filter": filter, "server_device": device,
            "chromium": version, "renderer": gl["renderer"],
            "webgl": {"mean_ms": frame_ms, "frames": frames},
            "tiles_cold": stats(cold), "tiles_warm": stats(warm)}


def run(args) -> dict:
    report = report_header("viewer_webgl", args.device)
    why = available()
    if why is not None:
        raise SystemExit(f"bench_viewer_webgl: {why}")
    view = QUICK_VIEW if args.quick else VIEW
    result = measure(view, frames=2 if args.quick else 5, runs=args.repeat, texton=32 if args.quick else args.size,
                     mni=args.mni, image_side=128 if args.quick else 256, device=args.device)
    print(result, flush=True)
    report.update(result)
    return report


def table_lines(r: dict) -> list[str]:
    """The Markdown table of one measurement (shared with the runner's report)."""
    w, h = r["view"]
    web = r["webgl"]["mean_ms"]
    return [
        f"A {w}×{h} canvas, texton {r['texton']}², MNI {r['mni']:g}, filter {r['filter']}; server on "
        f"`{r['server_device']}`; Chromium {r['chromium']}, WebGL2 renderer: {r['renderer']}.", "",
        "| path | time per frame (ms) | WebGL2's frame ÷ this |", "|---|---|---|",
        f"| WebGL2, a new view (mean of {r['webgl']['frames']} frames) | {web:.0f} | 1 |",
        f"| tiles, new view, cold (mean of {r['tiles_cold']['runs']}) | {r['tiles_cold']['mean_ms']:.0f} | "
        f"{web / r['tiles_cold']['mean_ms']:.1f} |",
        f"| tiles, same views, server cache warm (mean of {r['tiles_warm']['runs']}) | "
        f"{r['tiles_warm']['mean_ms']:.0f} | {web / r['tiles_warm']['mean_ms']:.1f} |",
    ]


def markdown(report: dict) -> str:
    return "\n".join([f"# Viewer: WebGL2 mode against tiles ({report['date']})", "", machine_line(report), "",
                      *table_lines(report)]) + "\n"


def main(argv=None) -> int:
    return run_main(__doc__, "viewer_webgl", run, markdown, argv, repeat=3)


if __name__ == "__main__":
    sys.exit(main())
