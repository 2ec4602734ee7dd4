"""Tiling rasters: the run kernel (tiling_runs) equals the reference tiling_value bit for bit; periodic tiles."""

import numpy as np
import pytest

from warp_texton import evaluate, synthesize
from warp_texton.model.tiling import TilingModel
from warp_texton.noise.raster import raster_geometry


def _example(channels):
    rng = np.random.default_rng(11)
    return rng.random((90, 100, channels)).astype(np.float32)


def _positions(shape, scale, rotation, offset):
    h, w = shape
    origin, step = raster_geometry((h, w), scale, rotation, offset)
    jj, ii = np.meshgrid(np.arange(w) + 0.5, np.arange(h) + 0.5)
    return (origin[:, None] + step @ np.stack([jj.ravel(), ii.ravel()])).T


# every branch of the run kernel: grey and RGB, the guide, the sharpnesses whose weights underflow, both blends,
# scales that put several triangles in a run and rotations that revisit vertices
@pytest.mark.parametrize("channels, sharpness, guide, blend, scale, rotation", [
    (1, 16, 0.0, "variance", 1.0, 0.0),
    (3, 16, 0.0, "variance", 0.37, 20.0),
    (1, 64, 0.0, "linear", 2.3, -33.0),
    (3, 1, 0.0, "linear", 0.11, 71.0),
    (1, 4, 2.0, "variance", 0.7, 10.0),
    (3, 8, 5.0, "linear", 1.0, 90.0),
])
def test_raster_runs_equal_the_reference_points(channels, sharpness, guide, blend, scale, rotation):
    m = TilingModel(_example(channels), side=12.0, sharpness=sharpness, guide_weight=guide, blend=blend)
    shape, offset = (37, 203), (-1234.5, 987.25)
    raster = synthesize(m, shape, seed=6, scale=scale, rotation=rotation, offset=offset, device="cpu")
    points = evaluate(m, _positions(shape, scale, rotation, offset), seed=6, device="cpu")
    assert np.array_equal(raster.reshape(-1, channels), points)
