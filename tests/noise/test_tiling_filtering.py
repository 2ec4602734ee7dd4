"""Filtered tiling models: mip, anisotropic and supersampled footprints in synthesize and render_plane."""

import numpy as np
import pytest

from warp_texton import FilterOptions, TextonError, render_plane, synthesize
from warp_texton.model.tiling import TilingModel
from warp_texton.noise.ground_plane import PlaneCamera, plane_pixels


@pytest.fixture(scope="module", params=["crop", "lattice"])
def brick(request):
    # a crop of a photograph, and a seamless brick wall read wrapped with its lattice (the mean image's
    # levels filtered beside the example's, the residual's contrast reduced)
    if request.param == "lattice":
        from tests.helpers import running_bond
        from warp_texton.model.lattice import Lattice

        u = running_bond((128, 128), channels=1)
        return TilingModel(u, 48.0, 16, 0.0, {}, "variance", None, (True, True),
                           Lattice.from_vectors([(16, 16), (16, -16)], u.shape, (True, True)))
    from skimage import data

    u = data.brick().astype(np.float32)[:256, :256, None] / 255.0
    return TilingModel(u, side=48.0, sharpness=16, blend="variance")


def rms(a, b):
    return float(np.sqrt(np.mean((np.asarray(a, np.float64) - b) ** 2)))


def test_far_anisotropic_view_converges_to_the_mean(brick):
    # looking at the horizon: the top rows' footprints cover thousands of texels, so the filtered pixels are
    # the example's mean, while the unfiltered ones keep the example's full contrast (aliasing)
    kw = dict(tilt=80.0, fov=18.0, texel_size=0.002, seed=3, device="cpu")
    far = render_plane(brick, (48, 96), filter="anisotropic", **kw)[:6]
    raw = render_plane(brick, (48, 96), filter="none", **kw)[:6]
    mean, sd = float(brick.mean[0]), float(brick.example.std())
    assert raw.std() > 0.5 * sd
    assert abs(float(far.mean()) - mean) < 0.02 * sd + 1e-6
    assert far.std() < 0.05 * sd


# "mip" blurs round footprints as wide as their major axis (over-blurs across a plane's stretched ones):
# measured 0.2-0.45 of the unfiltered error (docs/tiling.md), so its bound here is a half
@pytest.mark.parametrize("kind, bound", [("anisotropic", 1 / 3), ("mip", 1 / 2)])
def test_filtered_plane_error_is_a_third_of_the_unfiltered(brick, kind, bound):
    # RMS error against a heavy supersampled reference (24 x 24 jittered samples a pixel) on a view whose
    # footprints grow from about one texel to past the example's size
    kw = dict(tilt=75.0, fov=40.0, texel_size=0.004, seed=2, device="cpu")
    ref = render_plane(brick, (48, 48), filter=FilterOptions("supersample", supersample=24), **kw)
    none = render_plane(brick, (48, 48), filter="none", **kw)
    filtered = render_plane(brick, (48, 48), filter=kind, **kw)
    assert rms(filtered, ref) <= rms(none, ref) * bound


def test_filtered_raster_error_is_a_third_of_the_unfiltered(brick):
    kw = dict(scale=0.08, rotation=25.0, offset=(-300.0, 1e4), seed=1, device="cpu")
    ref = synthesize(brick, (32, 40), filter=FilterOptions("supersample", supersample=24), **kw)
    none = synthesize(brick, (32, 40), **kw)
    aniso = synthesize(brick, (32, 40), filter="anisotropic", **kw)
    assert rms(aniso, ref) <= rms(none, ref) / 3.0


@pytest.mark.parametrize("filt", ["mip", "anisotropic", FilterOptions("supersample", supersample=3)])
def test_filtered_windows_are_the_same_pixels(brick, filt):
    J = np.zeros((40, 56, 2, 2))
    J[..., 0, 0] = np.linspace(1.0, 9.0, 56)[None, :]
    J[..., 1, 1] = np.linspace(2.0, 30.0, 40)[:, None]
    kw = dict(scale=0.3, rotation=-40.0, offset=(77.0, -5.5), seed=4, filter=filt, device="cpu")
    whole = synthesize(brick, (40, 56), jacobian=J, **kw)
    part = synthesize(brick, (12, 20), jacobian=J[9:21, 30:50], pixel_offset=(9, 30), **kw)
    assert np.array_equal(part, whole[9:21, 30:50])


@pytest.mark.parametrize("filt", ["mip", "anisotropic", FilterOptions("supersample", supersample=2)])
def test_plane_pixels_equal_the_view(brick, filt):
    # the filtered evaluation at a pixel's centre and footprint is the pixel, bit for bit
    camera = PlaneCamera((32, 40), height=1.0, tilt=70.0, fov=40.0, texel_size=0.003)
    view = render_plane(brick, (32, 40), texel_size=0.003, seed=5, filter=filt, device="cpu")
    keys = np.array([0, 7, 500, 777, 32 * 40 - 1])
    some = plane_pixels(brick, camera, keys, seed=5, filter=filt, device="cpu")
    assert np.array_equal(some, view.reshape(-1, 1)[keys])


def test_footprints_of_a_texel_are_the_unfiltered_tiling(brick):
    kw = dict(seed=2, offset=(10.0, 20.0), device="cpu")
    plain = synthesize(brick, (24, 24), **kw)
    for filt in ("mip", "anisotropic"):
        assert np.array_equal(synthesize(brick, (24, 24), filter=filt, **kw), plain)


def test_periodic_filtered_tiles_wrap(brick):
    kw = dict(period=(200.0, 150.0), scale=0.25, seed=6, filter="anisotropic", device="cpu")
    a = synthesize(brick, (20, 30), **kw)
    b = synthesize(brick, (20, 30), offset=(400.0, -150.0), **kw)
    assert np.allclose(a, b, atol=1e-5) and a.std() > 0.01


@pytest.mark.parametrize("call, param", [
    (lambda m: synthesize(m, (8, 8), filter=FilterOptions("mip", fade_energy=0.3), device="cpu"), "fade_energy"),
    (lambda m: synthesize(m, (8, 8), filter="trilinear", device="cpu"), "filter"),
    (lambda m: synthesize(m, (8, 8), filter="mip", jacobian=np.eye(3), device="cpu"), "jacobian"),
    (lambda m: synthesize(m, (8, 8), filter="mip", jacobian=np.full((2, 2), np.nan), device="cpu"), "jacobian"),
    (lambda m: render_plane(m, (8, 8), mni=10.0, device="cpu"), "mni"),
    (lambda m: render_plane(m, (8, 8), filter=FilterOptions("anisotropic", fade_energy=0.0), device="cpu"),
     "fade_energy"),
])
def test_bad_filter_options(brick, call, param):
    with pytest.raises(TextonError) as info:
        call(brick)
    assert info.value.param == param


def test_filtered_points_equal_the_filtered_raster(brick):
    # tiling_filtered at a pixel's position and footprint (the kernels' filtered point evaluation) is the pixel
    from warp_texton.noise.raster import raster_geometry
    from warp_texton.noise.tiling_filtering import tiling_filtered_at, tiling_options

    shape, kw = (16, 24), dict(scale=0.2, rotation=30.0, offset=(-50.0, 80.0))
    raster = synthesize(brick, shape, filter="anisotropic", seed=9, device="cpu", **kw)
    origin, step = raster_geometry(shape, kw["scale"], kw["rotation"], kw["offset"])
    jj, ii = np.meshgrid(np.arange(shape[1]) + 0.5, np.arange(shape[0]) + 0.5)
    x = origin[0] + step[0, 0] * jj + step[0, 1] * ii  # the kernel's order: origin + step_x J + step_y I
    y = origin[1] + step[1, 0] * jj + step[1, 1] * ii
    pts = np.stack([x.ravel(), y.ravel()], 1)
    values = tiling_filtered_at(brick, pts, step[None], tiling_options(FilterOptions("anisotropic")), 9, "cpu")
    assert np.array_equal(values, raster.reshape(-1, 1))


class TestDeviceMatchesCpu:
    """The --device (a GPU) gives the CPU's tiling, to float rounding (a rounding flip may move a lookup by a
    texel on a few pixels); ``output="warp"`` keeps the raster on the device with the same values."""

    @pytest.mark.parametrize("channels", [1, 3])
    @pytest.mark.parametrize("kw", [dict(), dict(scale=0.4, rotation=20.0), dict(period=(90.0, 70.0), scale=0.8),
                                    dict(scale=0.1, rotation=-30.0, filter="anisotropic"),
                                    dict(scale=0.2, filter="mip"),
                                    dict(scale=0.2, filter=FilterOptions("supersample", supersample=3))])
    def test_synthesize_matches_cpu(self, channels, kw, gpu):
        rng = np.random.default_rng(channels)
        m = TilingModel(rng.random((96, 112, channels)).astype(np.float32), side=20.0, blend="variance")
        a = synthesize(m, (40, 56), seed=3, offset=(-70.0, 33.0), device="cpu", **kw)
        b = synthesize(m, (40, 56), seed=3, offset=(-70.0, 33.0), device=gpu, **kw)
        close = np.all(np.abs(a - b) <= 1e-4, axis=-1)
        assert close.mean() >= 0.99
        w = synthesize(m, (40, 56), seed=3, offset=(-70.0, 33.0), device=gpu, output="warp", **kw)
        assert w.shape == b.shape and np.array_equal(w.numpy(), b)

    @pytest.mark.parametrize("filt", ["none", "anisotropic"])
    def test_plane_matches_cpu(self, brick, filt, gpu):
        kw = dict(tilt=75.0, texel_size=0.004, seed=2, filter=filt)
        a = render_plane(brick, (32, 48), device="cpu", **kw)
        b = render_plane(brick, (32, 48), device=gpu, **kw)
        assert np.mean(np.abs(a - b)[..., 0] <= 1e-4) >= 0.99
