"""Regenerate docs/images/viewer.png: the viewer (``warp-texton view``) in headless Chromium.

The same browser set-up as tests/test_view_browser.py: Debian's ``chromium``
driven by Playwright (``apt-get install chromium``, ``pip install playwright``).
The input is the gallery's walnut pattern (docs/images/gallery/walnut_input.png
shows it tiled 2 × 2; its top-left 128² is the pattern itself, GPL-3+ from GIMP's
``gimp-data``), analysed with a 64² texton; the view is turned by 20° and
zoomed in to two pixels per texel. The picture is saved with 256 colours
(dithered): noise hardly compresses, and the full-colour PNG is twice as large.

    python docs/make_viewer_screenshot.py [--device cpu] [--out docs/images/viewer.png]
"""

from __future__ import annotations

import argparse
import io
import shutil
import sys
import tempfile
from pathlib import Path

import numpy as np

from warp_texton import read_image, write_image
from warp_texton.files.images import atomic_path
from warp_texton.view.server import serve

HERE = Path(__file__).resolve().parent
WALNUT = HERE / "images" / "gallery" / "walnut_input.png"
VIEWPORT = {"width": 1280, "height": 960}


def set_input(page, selector: str, value, event: str = "input") -> None:
    page.evaluate("([sel, value, event]) => { const e = document.querySelector(sel); e.value = value; "
                  "e.dispatchEvent(new Event(event, { bubbles: true })); }", [selector, str(value), event])


def wait_idle(page) -> None:
    page.wait_for_function("window.viewer && window.viewer.pending() === 0 && !window.viewer.panelPending()",
                           timeout=120_000)
    page.evaluate("window.viewer.idle()")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0],
                                     formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    parser.add_argument("--device", default="cpu", help="Warp device of the server")
    parser.add_argument("--out", type=Path, default=HERE / "images" / "viewer.png", help="the PNG to write")
    args = parser.parse_args(argv)
    chromium = shutil.which("chromium") or shutil.which("chromium-browser")
    if chromium is None:
        print("no Chromium on PATH: apt-get install chromium", file=sys.stderr)
        return 1
    from playwright.sync_api import sync_playwright

    with tempfile.TemporaryDirectory() as tmp:
        pattern = Path(tmp) / "walnut.png"
        write_image(pattern, np.ascontiguousarray(read_image(WALNUT)[:128, :128]))
        with serve(pattern, port=0, size=64, seed=1, device=args.device) as handle, sync_playwright() as p:
            browser = p.chromium.launch(executable_path=chromium, args=["--no-sandbox"])
            page = browser.new_page(viewport=VIEWPORT, device_scale_factor=1)
            page.goto(handle.url)
            wait_idle(page)
            page.click("#zoom-in")
            set_input(page, "#rot", 20)
            wait_idle(page)
            png = page.screenshot()
            browser.close()
    args.out.parent.mkdir(parents=True, exist_ok=True)
    from PIL import Image

    picture = Image.open(io.BytesIO(png)).convert("RGB").quantize(256, dither=Image.Dither.FLOYDSTEINBERG)
    with atomic_path(args.out) as part:
        picture.save(part, format="PNG", optimize=True)
    print(args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
