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
    # the rasters' float64 operations in their order, (origin + step_x J) + step_y I, so that far points agree
    cj, ci = jj.ravel(), ii.ravel()
    return np.stack([origin[0] + step[0, 0] * cj + step[0, 1] * ci, origin[1] + step[1, 0] * cj + step[1, 1] * ci], 1)


@pytest.fixture(params=[True, False], ids=["simd", "scalar"])
def loop_form(request, monkeypatch):
    """Both forms of the CPU's native run loop (kernels/noise_tiling_native.py): the vector form where the CPU
    has vector registers (SIMD = True), and the plain C++ form."""
    import warp_texton.noise.tiling as T

    monkeypatch.setattr(T, "SIMD", request.param)
    return request.param


# every branch of the run kernels: grey and RGB, the guide (the Warp run kernel), the sharpnesses whose weights
# underflow, both blends, scales that put several triangles in a run and rotations that revisit vertices; offsets
# that put every pixel on a texel centre (scale 1, whole offsets: the texel itself), some lanes of a block on
# one and others not (scale 2, quarter offsets), and far ones
@pytest.mark.parametrize("channels, sharpness, guide, blend, scale, rotation, offset", [
    (1, 16, 0.0, "variance", 1.0, 0.0, (-1234.5, 987.25)),
    (3, 16, 0.0, "variance", 0.37, 20.0, (-1234.5, 987.25)),
    (1, 64, 0.0, "linear", 2.3, -33.0, (-1234.5, 987.25)),
    (3, 1, 0.0, "linear", 0.11, 71.0, (-1234.5, 987.25)),
    (1, 4, 2.0, "variance", 0.7, 10.0, (-1234.5, 987.25)),
    (3, 8, 5.0, "linear", 1.0, 90.0, (-1234.5, 987.25)),
    (1, 16, 0.0, "variance", 1.0, 0.0, (0.0, 0.0)),
    (3, 16, 0.0, "variance", 1.0, 0.0, (-300.0, 41.0)),
    (3, 32, 0.0, "variance", 2.0, 0.0, (0.25, 0.25)),
    (1, 2, 0.0, "linear", 1.0, 180.0, (7.0, -3.0)),
    (3, 4, 0.0, "variance", 0.8, -120.0, (3.0e7, -2.5e7)),
    (1, 64, 0.0, "variance", 1.3, 45.0, (-6.0e8, 1.0e8)),
])
def test_raster_runs_equal_the_reference_points(channels, sharpness, guide, blend, scale, rotation, offset,
                                               loop_form):
    m = TilingModel(_example(channels), side=12.0, sharpness=sharpness, guide_weight=guide, blend=blend)
    shape = (37, 203)
    raster = synthesize(m, shape, seed=6, scale=scale, rotation=rotation, offset=offset, device="cpu")
    points = evaluate(m, _positions(shape, scale, rotation, offset), seed=6, device="cpu")
    assert np.array_equal(raster.reshape(-1, channels), points)
    assert raster.std() > 0.05  # patches, not a constant


@pytest.mark.parametrize("channels, side", [(1, 12.0), (3, 9.5)])
def test_periodic_raster_equals_the_periodic_points(channels, side, loop_form):
    # the native run loop's periodic lattice against lattice_points (blend_at), rotated and not
    m = TilingModel(_example(channels), side=side, sharpness=8, blend="variance")
    shape = (29, 77)
    for kw in (dict(scale=1.0, rotation=0.0, offset=(0.0, 0.0)), dict(scale=0.6, rotation=-25.0, offset=(-90.5, 13.0))):
        raster = synthesize(m, shape, period=(70, 33.5), seed=4, device="cpu", **kw)
        points = evaluate(m, _positions(shape, kw["scale"], kw["rotation"], kw["offset"]), period=(70, 33.5), seed=4,
                          device="cpu")
        assert np.array_equal(raster.reshape(-1, channels), points)


#: Lattices of the example's shape: two vectors (a diagonal grid), one (courses).
LATTICES = {"none": None, "2d": [(16, 16), (16, -16)], "1d": [(16, 0)]}


def _wrapped_model(channels, wrap, lattice, **kw):
    from warp_texton.model.lattice import Lattice

    ex = _example(channels)
    lat = None if LATTICES[lattice] is None else Lattice.from_vectors(LATTICES[lattice], ex.shape, wrap)
    return TilingModel(ex, wrap=wrap, lattice=lat, **kw)


# the native run loop's wrapped addressing and lattice (the snap, the residual blend around the lattice-periodic
# mean) against tiling_value: wrapped on either axis or both (patch points past the border on each side, side 30
# > the clamped margin allows), clamped with a lattice (the centres' box narrowed by its half cell); texel centres
# (scale 1, whole offsets), mixed lanes (scale 2, quarter offsets), rotations and far offsets
@pytest.mark.parametrize("channels, wrap, lattice, sharpness, blend", [
    (1, (True, True), "none", 16, "variance"),
    (3, (True, False), "none", 4, "linear"),
    (3, (True, True), "2d", 16, "variance"),
    (1, (True, True), "2d", 2, "linear"),
    (3, (False, True), "1d", 8, "variance"),
    (1, (True, False), "1d", 64, "linear"),
    (3, (False, False), "2d", 4, "variance"),
    (1, (False, False), "1d", 16, "linear"),
])
@pytest.mark.parametrize("scale, rotation, offset", [
    (1.0, 0.0, (0.0, 0.0)), (1.0, 0.0, (-300.0, 41.0)), (2.0, 0.0, (0.25, 0.25)), (0.37, 20.0, (-1234.5, 987.25)),
    (0.8, -120.0, (3.0e7, -2.5e7)),
])
def test_wrapped_and_lattice_runs_equal_the_reference_points(channels, wrap, lattice, sharpness, blend, scale,
                                                            rotation, offset, loop_form):
    side = 30.0 if any(wrap) else 12.0
    m = _wrapped_model(channels, wrap, lattice, side=side, sharpness=sharpness, blend=blend)
    shape = (29, 111)
    raster = synthesize(m, shape, seed=6, scale=scale, rotation=rotation, offset=offset, device="cpu")
    points = evaluate(m, _positions(shape, scale, rotation, offset), seed=6, device="cpu")
    assert np.array_equal(raster.reshape(-1, channels), points)
    assert raster.std() > 0.05


@pytest.mark.parametrize("channels, wrap, lattice", [
    (3, (True, True), "2d"), (1, (True, False), "1d"), (1, (False, False), "2d"), (3, (False, True), "none"),
])
def test_periodic_wrapped_and_lattice_rasters_equal_the_periodic_points(channels, wrap, lattice, loop_form):
    # the periodic lattice snaps at the period's own vertex: the native loop against lattice_points (blend_at)
    m = _wrapped_model(channels, wrap, lattice, side=9.5, sharpness=8, blend="variance")
    shape = (29, 77)
    for kw in (dict(scale=1.0, rotation=0.0, offset=(0.0, 0.0)), dict(scale=0.6, rotation=-25.0, offset=(-90.5, 13.0))):
        raster = synthesize(m, shape, period=(70, 33.5), seed=4, device="cpu", **kw)
        points = evaluate(m, _positions(shape, kw["scale"], kw["rotation"], kw["offset"]), period=(70, 33.5), seed=4,
                          device="cpu")
        assert np.array_equal(raster.reshape(-1, channels), points)


def _host_simd() -> str:
    """The vector instruction set the native run loop should be built for here."""
    import platform
    from pathlib import Path

    if platform.machine().lower() in ("arm64", "aarch64"):
        return "neon"
    try:
        flags = Path("/proc/cpuinfo").read_text().split("\nflags", 1)[1].split("\n", 1)[0].split()
    except (OSError, IndexError):
        pytest.skip("no /proc/cpuinfo flags on this system")
    return "avx512" if "avx512f" in flags else "avx2" if "avx2" in flags else "scalar"


def test_vector_run_loop_is_built_where_the_cpu_has_simd():
    # a build that lost the vector form would give the same values, only slower
    from warp_texton.noise.tiling import simd_loops

    assert simd_loops("cpu") == _host_simd()


#: Run in a fresh process: the run loop built for AVX2 (no AVX-512 gathers), both forms against tiling_value.
AVX2_ONLY = """
import numpy as np, warp as wp
wp.config.quiet = True
wp.config.cpu_compiler_flags = (wp.config.cpu_compiler_flags or "-march=native").replace(
    "-march=native", "-march=native -target-feature -avx512f")
import warp_texton.noise.tiling as T
from warp_texton import evaluate, synthesize
from warp_texton.model.lattice import Lattice
from warp_texton.model.tiling import TilingModel
from warp_texton.noise.raster import raster_geometry
print(T.simd_loops("cpu"))
rng = np.random.default_rng(11)
examples = [rng.random((90, 100, c)).astype(np.float32) for c in (1, 3)]
models = [TilingModel(ex, side=12.0, sharpness=8, blend="variance") for ex in examples]
models += [TilingModel(ex, side=30.0, sharpness=8, blend="variance", wrap=(True, True),
                       lattice=Lattice.from_vectors([(16, 16), (16, -16)], ex.shape, (True, True))) for ex in examples]
for m in models:
    c = m.channels
    origin, step = raster_geometry((31, 70), 0.7, 15.0, (-40.5, 3.0))
    jj, ii = np.meshgrid(np.arange(70) + 0.5, np.arange(31) + 0.5)
    J, I = jj.ravel(), ii.ravel()
    pts = np.stack([origin[0] + step[0, 0] * J + step[0, 1] * I, origin[1] + step[1, 0] * J + step[1, 1] * I], 1)
    ref = evaluate(m, pts, seed=2, device="cpu")
    for simd in (True, False):
        T.SIMD = simd
        out = synthesize(m, (31, 70), seed=2, scale=0.7, rotation=15.0, offset=(-40.5, 3.0), device="cpu")
        print(np.array_equal(out.reshape(-1, c), ref))
"""


@pytest.mark.slow
def test_avx2_build_takes_the_vector_run_loop(tmp_path):
    # on an AVX-512 CPU, the build for AVX2 only (in a fresh process: the flags are part of every module's build)
    # must take the vector form (its lane-loop lookups instead of AVX-512's gathers) with the reference's values,
    # plain and wrapped with a lattice
    import subprocess
    import sys

    if _host_simd() != "avx512":
        pytest.skip("needs an AVX-512 CPU (an AVX2 one runs this form in every test)")
    script = tmp_path / "avx2.py"
    script.write_text(AVX2_ONLY)
    done = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.split() == ["avx2"] + ["True"] * 8


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
