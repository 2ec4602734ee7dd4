"""A tiling model in your own Warp kernel: a window of bricks, drawn where it is used.

The host packs the model once (``pack_tiling``, the kernels' ``Tiling`` struct, and
``pack_colours``, the histogram tables of a model analysed with
``histogram="preserve"``); the kernel calls ``tiling_value`` at each pixel's point and
maps the blend with ``colour_value``, placing the point as
``synthesize`` does: pixel (i, j) at offset + R(rotation) ((j + ½)/scale,
(i + ½)/scale), in float64. The pixels are ``synthesize``'s, bit for bit on
the same device (the test suite runs this file and checks it). Run it as

    python docs/examples/warp_tiling.py bricks.png --device cpu

(without a path it writes into a new temporary folder).
"""

from __future__ import annotations

import argparse
import math
import tempfile
from pathlib import Path

import numpy as np
import warp as wp

from warp_texton import analyze, write_image
from warp_texton.runtimes import warp_api as td


@wp.kernel
def draw(t: td.Tiling, cmap: td.ColourMap, offset: wp.vec2d, step_j: wp.vec2d, step_i: wp.vec2d,
         out: wp.array2d(dtype=wp.vec3)):
    i, j = wp.tid()
    x = offset + step_j * (wp.float64(j) + wp.float64(0.5)) + step_i * (wp.float64(i) + wp.float64(0.5))
    # the blend, then the model's histogram tables (values pass through a model without tables)
    out[i, j] = td.colour_value(cmap, td.tiling_value(t, x))


def window(model, shape, *, seed=0, scale=1.0, rotation=0.0, offset=(0.0, 0.0), device=None):
    """The (H, W, 3) float32 window of ``model``: ``synthesize(model, shape, ...)``'s pixels."""
    t = td.pack_tiling(model, seed=seed, device=device)
    cmap = td.pack_colours(model, device=device)
    th = math.radians(rotation)
    step_j = wp.vec2d(math.cos(th) / scale, math.sin(th) / scale)
    step_i = wp.vec2d(-math.sin(th) / scale, math.cos(th) / scale)
    out = wp.zeros(shape, dtype=wp.vec3, device=device)
    wp.launch(draw, dim=shape, inputs=[t, cmap, wp.vec2d(*offset), step_j, step_i, out], device=device)
    return out.numpy()


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("output", nargs="?", help="PNG to write")
    p.add_argument("--device", default=None)
    args = p.parse_args(argv)
    from skimage import data  # scikit-image's brick (CC0) as the example

    model = analyze(data.brick().astype(np.float32) / 255.0, method="tiling", histogram="preserve")
    values = window(model, (384, 512), seed=3, scale=0.75, rotation=15.0, device=args.device)
    path = Path(args.output) if args.output else Path(tempfile.mkdtemp()) / "bricks.png"
    write_image(path, np.clip(values[..., :1], 0.0, 1.0))
    print(path)


if __name__ == "__main__":
    main()
