"""Regenerate docs/images/demo_strip.png, the picture at the top of the README.

Runs the demo (``warp_texton.demo.run_demo``) into a temporary folder and puts
four of its pictures side by side: the input texture, its Gaussian version,
the texton preview and a window of the texton noise. Every panel is PANEL
pixels high: the textures are centre-cropped (they are stationary, any window
shows them), the 64 × 64 texton is enlarged 3× with nearest-neighbour so that
its texels stay visible, and the noise (512 × 512, one pixel per texel, like
the input) is cropped to NOISE_WIDTH × PANEL. The crops keep the file small.

    python docs/make_readme_image.py [--out docs/images/demo_strip.png]
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

from PIL import Image

from warp_texton.demo import run_demo
from warp_texton.files.images import atomic_path

PANEL = 192  # height of every panel, a multiple of the texton side
NOISE_WIDTH = 2 * PANEL  # the noise panel is wider: the noise has any size
#: (demo file, panel width), left to right
PANELS = (
    ("input.png", PANEL),
    ("gaussian.png", PANEL),
    ("texton_preview.png", PANEL),
    ("noise.png", NOISE_WIDTH),
)
GAP = 8  # white pixels between panels


def fit(im: Image.Image, width: int) -> Image.Image:
    """Enlarge a small image by an integer factor, then centre-crop to width × PANEL."""
    if im.width < width or im.height < PANEL:
        k = max(-(-width // im.width), -(-PANEL // im.height))
        im = im.resize((im.width * k, im.height * k), Image.NEAREST)
    x0, y0 = (im.width - width) // 2, (im.height - PANEL) // 2
    return im.crop((x0, y0, x0 + width, y0 + PANEL))


def compose(folder: Path) -> Image.Image:
    images = [fit(Image.open(folder / name).convert("L"), width) for name, width in PANELS]
    strip = Image.new("L", (sum(im.width for im in images) + (len(images) - 1) * GAP, PANEL), 255)
    x = 0
    for im in images:
        strip.paste(im, (x, 0))
        x += im.width + GAP
    return strip


def main() -> None:
    here = Path(__file__).resolve().parent
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0],
                                     formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    parser.add_argument("--out", type=Path, default=here / "images" / "demo_strip.png", help="output PNG")
    parser.add_argument("--seed", type=int, default=0, help="demo seed")
    args = parser.parse_args()

    with tempfile.TemporaryDirectory() as tmp:
        run_demo(tmp, seed=args.seed, progress=False)
        strip = compose(Path(tmp))
    args.out.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(args.out) as part:
        strip.save(part, format="PNG", optimize=True)
    print(f"{args.out}: {strip.width}x{strip.height}, {args.out.stat().st_size // 1024} KiB")


if __name__ == "__main__":
    main()
