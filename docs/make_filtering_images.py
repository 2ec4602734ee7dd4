"""Render the filtering pictures of docs/ (CGF Fig. 3): the benchmark's plane view.

The view, texture and texton are those of benchmarks/bench_filtering.py
(1024², tilt 70°, fov 40°, texton 64² of the scikit-image grass/gravel/brick
mix, MNI 30, seed 1), so the pictures are the renders whose errors and times
docs/benchmarks.md reports. Written: the far (top) halves of the unfiltered,
"mip", "anisotropic" and 20 × 20 supersampled renders, and close-ups. The
same linear contrast stretch (mean ± 3σ to [0, 1]) is applied to all of them so
that the aliasing is visible; the EXR files next to nothing else are not kept.

    python docs/make_filtering_images.py            # about 10 minutes on 2 CPU cores
    python docs/make_filtering_images.py --side 512 # quicker, smaller
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))

from bench_filtering import plane_view  # noqa: E402
from common import make_texture  # noqa: E402

from warp_texton import FilterOptions, analyze, write_image  # noqa: E402
from warp_texton.noise.ground_plane import plane_pixels  # noqa: E402

OUT = ROOT / "docs" / "images" / "filtering"
FILTERS = ("none", "mip", "anisotropic", "supersample")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--side", type=int, default=1024, help="image side in pixels")
    parser.add_argument("--supersample", type=int, default=20, help="reference samples per pixel side")
    parser.add_argument("--device", default="cpu")
    args = parser.parse_args(argv)
    texton = analyze(make_texture(512), size=64, seed=0)
    sigma = float(np.sqrt(np.mean(np.diag(np.atleast_2d(texton.covariance())))))
    view = plane_view(args.side)
    h, w = view.shape
    lo, hi = texton.mean - 3 * sigma, texton.mean + 3 * sigma
    OUT.mkdir(parents=True, exist_ok=True)
    images = {}
    for f in FILTERS:
        img = plane_pixels(texton, view, np.arange(h * w), mni=30.0, seed=1,
                           filter=FilterOptions(f, supersample=args.supersample), device=args.device, progress=True)
        images[f] = np.clip((img.reshape(h, w, -1) - lo) / (hi - lo), 0, 1)
        name = "reference" if f == "supersample" else f
        # the far half, where the filters differ (the near half is the same in all four)
        write_image(OUT / f"plane_{name}.png", images[f][: h // 2])
        print(f"{OUT / f'plane_{name}.png'}", flush=True)
    # close-ups: a far and a middle window of each render, enlarged 3x, side by side
    size = h // 8
    windows = [(h // 16, w // 2 - size // 2), (h * 5 // 16, w // 4)]
    gap = np.ones((size * 3, 4, 3), np.float32)
    rows = []
    for r0, c0 in windows:
        tiles = []
        for f in ("none", "mip", "anisotropic", "supersample"):
            crop = images[f][r0:r0 + size, c0:c0 + size]
            tiles += [np.repeat(np.repeat(crop, 3, axis=0), 3, axis=1), gap]
        rows += [np.concatenate(tiles[:-1], axis=1), np.ones((4, tiles[0].shape[1] * 4 + 12, 3), np.float32)]
    write_image(OUT / "closeups.png", np.concatenate(rows[:-1], axis=0))
    print(OUT / "closeups.png")
    return 0


if __name__ == "__main__":
    sys.exit(main())
