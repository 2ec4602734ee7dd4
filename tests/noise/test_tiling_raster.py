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


@pytest.mark.parametrize("period", [(64, 48), (100, 37), (13.5, 80.25), (7, 7), (500, 300)])
def test_periodic_tiles_wrap(period):
    # a raster twice the period (scale 1): its second copy is the first, so the first column continues the last
    m = TilingModel(_example(3), side=12.0, blend="variance")
    px, py = period
    if float(px).is_integer() and float(py).is_integer():
        w, h = int(px), int(py)
        tile = synthesize(m, (h, w), period=period, seed=2, device="cpu")
        twice = synthesize(m, (2 * h, 2 * w), period=period, seed=2, device="cpu")
        assert np.array_equal(np.tile(tile, (2, 2, 1)), twice)
    # at any scale, rotation and offset: whole periods apart, the same pixels (positions differ by exact periods)
    kw = dict(period=period, seed=5, scale=0.6, rotation=25.0, offset=(3.25, -8.5), device="cpu")
    base = synthesize(m, (30, 40), **kw)
    kw2 = dict(kw, offset=(3.25 - 3 * px, -8.5 + 2 * py))
    assert np.allclose(synthesize(m, (30, 40), **kw2), base, atol=1e-5)
    assert base.std() > 0.05  # the patches themselves, not a constant


def test_periodic_points_equal_the_raster():
    m = TilingModel(_example(1), side=10.0, sharpness=4, guide_weight=1.5)
    shape, kw = (23, 61), dict(scale=0.8, rotation=-15.0, offset=(40.0, 9.0))
    raster = synthesize(m, shape, period=(70, 33), seed=3, device="cpu", **kw)
    points = evaluate(m, _positions(shape, kw["scale"], kw["rotation"], kw["offset"]), period=(70, 33), seed=3,
                      device="cpu")
    assert np.array_equal(raster.reshape(-1, 1), points)


def test_periodic_lattice_keeps_patches_inside_the_side():
    # the lattice shrinks to a whole number of triangles per period: never larger than the side
    from warp_texton.noise.tiling import period_lattice

    m = TilingModel(_example(1), side=12.0)
    for px, py in ((64, 48), (13.5, 80.25), (7, 7), (1e6, 3e5)):
        cols, rows = period_lattice(m, (px, py))
        assert rows % 2 == 0
        assert px / cols <= 12.0 and py / rows <= 12.0 * np.sqrt(3) / 2 + 1e-12
        assert px / cols > 12.0 * (cols - 1) / cols - 1e-9 or cols == 1


@pytest.mark.parametrize("period", [(0, 64), (64,), (float("nan"), 3), (2.0**31, 5)])
def test_bad_periods(period):
    from warp_texton import TextonError

    m = TilingModel(_example(1), side=12.0)
    with pytest.raises(TextonError) as info:
        synthesize(m, (8, 8), period=period, device="cpu")
    assert "period" in (info.value.param or "")
