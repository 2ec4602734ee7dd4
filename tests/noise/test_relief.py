"""Exact gradients, normal maps and height maps (warp_texton.noise.relief, kernels/noise_gradient.py).

Gradients are checked against central differences of ``evaluate`` at many random points (steps of 10⁻³
texels): the median relative error must stay below 0.02 (the issue's bar; float32 differences give about
10⁻³), for each model kind and option. Where the interpolation is not differentiable (order 1's kinks,
order 0) the value returned is checked exactly.
"""

import dataclasses

import numpy as np
import pytest
from scipy.ndimage import gaussian_filter

from warp_texton import TextonError, evaluate, gradient, height_map, normal_map, synthesize
from warp_texton.model.histogram import HistogramTransform
from warp_texton.model.lattice import Lattice
from warp_texton.model.tiling import TilingModel
from tests.helpers import random_texton

STEP = 1e-3
BAR = 0.02


def central_differences(model, pts, **kw):
    def ev(q):
        return evaluate(model, q, **kw).astype(np.float64)

    return np.stack([(ev(pts + [STEP, 0]) - ev(pts - [STEP, 0])) / (2 * STEP),
                     (ev(pts + [0, STEP]) - ev(pts - [0, STEP])) / (2 * STEP)], axis=-1)


def relative_errors(model, n=1500, reach=300.0, at=0, **kw):
    pts = np.random.default_rng(at).uniform(-reach, reach, (n, 2))
    g = gradient(model, pts, **kw)
    assert g.shape == (n, model.channels, 2) and g.dtype == np.float32
    fd = central_differences(model, pts, **kw)
    return np.linalg.norm(g - fd, axis=-1) / np.maximum(np.linalg.norm(fd, axis=-1), 1e-12)


def _smooth_example(channels=3, seed=0, shape=(96, 96)):
    rng = np.random.default_rng(seed)
    return (gaussian_filter(rng.normal(0, 1, shape + (channels,)), (2, 2, 0)) * 0.3 + 0.5).astype(np.float32)


class TestTextonGradient:
    @pytest.mark.parametrize("order", [3, 5])
    @pytest.mark.parametrize("channels", [1, 3])
    def test_smooth_orders_match_central_differences(self, order, channels, device):
        t = random_texton((10, 12), channels=channels, order=order, seed=order + channels)
        assert np.median(relative_errors(t, at=1, device=device)) < BAR

    @pytest.mark.parametrize("kw", [dict(period=(61.0, 47.5)), dict(poisson="gaussian"), dict(cell_factor=1.3),
                                    dict(mni=3.0, seed=12345)])
    def test_noise_options(self, kw, device):
        t = random_texton((10, 10), channels=3, order=3, seed=2)
        assert np.median(relative_errors(t, at=2, device=device, **kw)) < BAR

    def test_the_value_rows_are_evaluate(self, device):
        # the derivative kernels walk the value's impacts: their value row is evaluate's, to float rounding
        from warp_texton.noise.relief import value_slopes
        from warp_texton.noise.noise_options import NoiseOptions

        t = random_texton((9, 9), channels=3, order=3, seed=5)
        pts = np.random.default_rng(3).uniform(-1e4, 1e4, (500, 2))
        rows = value_slopes(t, pts, NoiseOptions(seed=7), 7, None, device, {})
        assert np.allclose(rows[:, 0, :3], evaluate(t, pts, seed=7, device=device), atol=2e-5)

    def test_histogram_tables_through_their_slopes(self, device):
        # a smooth, skewed example's tables (no 8-bit steps): T'(g) ∇g against the differences of the colours
        rng = np.random.default_rng(4)
        u = rng.gamma(2.0, 0.1, (64, 64, 3))
        base = random_texton((10, 10), channels=3, order=3, seed=6)
        t = dataclasses.replace(base, histogram=HistogramTransform.fit(u))
        assert t.histogram is not None
        assert np.median(relative_errors(t, at=4, device=device)) < BAR

    def test_order_1_is_exact_off_its_kinks_and_right_sided_on_them(self, device):
        # off the kinks the bilinear texton's slope is exact: forward differences inside a cell agree
        t = random_texton((10, 10), channels=3, order=1, seed=8)
        assert np.median(relative_errors(t, at=5, device=device)) < BAR
        # on a kink (an integer coordinate of y = x − x_j) the slope is the cell's to the right / below,
        # the one texton_value reads there: the forward difference, not the backward one
        import warp as wp

        from tests import relief_kernels
        from warp_texton.noise.engine import padded_coeffs

        wp.init()
        coeffs = wp.array(padded_coeffs(t), dtype=wp.vec3, device=device)
        rng = np.random.default_rng(6)
        ys = np.stack([rng.integers(0, 9, 200).astype(np.float32), rng.uniform(0.1, 8.9, 200)], -1)
        ys = np.concatenate([ys, ys[:, ::-1]])  # a kink in x, then one in y

        def run(y):
            slopes = wp.zeros(len(y), dtype=wp.mat33, device=device)
            values = wp.zeros(len(y), dtype=wp.vec3, device=device)
            wp.launch(relief_kernels.slope_and_value, dim=len(y), device=device,
                      inputs=[coeffs, 1, wp.array(y.astype(np.float32), dtype=wp.vec2, device=device), slopes, values])
            return slopes.numpy(), values.numpy()

        s, v = run(ys)
        e = 1.0 / 64  # exact in float32 steps
        axis = np.r_[np.zeros(200, int), np.ones(200, int)]
        shift = np.zeros_like(ys)
        shift[np.arange(400), axis] = e
        _, ahead = run(ys + shift)
        _, behind = run(ys - shift)
        slope = s[np.arange(400), 1 + axis]
        forward = (ahead - v) / e
        backward = (v - behind) / e
        assert np.allclose(slope, forward, atol=1e-4)
        assert np.abs(slope - backward).max() > 1e-2  # the kinks are real: the two sides differ

    def test_order_0_has_zero_gradient(self, device):
        t = random_texton((8, 8), channels=1, order=0, seed=1)
        g = gradient(t, np.random.default_rng(0).uniform(-50, 50, (300, 2)), device=device)
        assert not g.any()


class TestTilingGradient:
    MODELS = {
        "linear": dict(side=20.0),
        "linear-sharpness1": dict(side=20.0, sharpness=1),
        "variance": dict(side=20.0, sharpness=8, blend="variance"),
        "guided": dict(side=20.0, sharpness=4, guide_weight=3.0),
        "wrapped": dict(side=30.0, sharpness=4, blend="variance", wrap=(True, True)),
        "lattice-2d": dict(side=30.0, sharpness=4, blend="variance", wrap=(True, True),
                           lattice=[(16, 16), (16, -16)]),
        "lattice-1d": dict(side=30.0, sharpness=4, wrap=(True, True), lattice=[(16, 0)]),
    }

    @staticmethod
    def model(kind, channels=3):
        kw = dict(TestTilingGradient.MODELS[kind])
        ex = _smooth_example(channels)
        if "lattice" in kw:
            kw["lattice"] = Lattice.from_vectors(kw["lattice"], ex.shape, kw["wrap"])
        return TilingModel(ex, **kw)

    @pytest.mark.parametrize("kind", list(MODELS))
    def test_blends_match_central_differences(self, kind, device):
        assert np.median(relative_errors(self.model(kind), at=7, device=device)) < BAR

    def test_grey_periodic_and_tables(self, device):
        m = self.model("variance", channels=1)
        assert np.median(relative_errors(m, at=8, device=device, period=(70.0, 33.5))) < BAR
        rng = np.random.default_rng(9)
        tr = HistogramTransform.fit(rng.gamma(2.0, 0.1, (64, 64, 3)))
        m = TilingModel(_smooth_example(3), 20.0, sharpness=4, histogram=tr)
        assert np.median(relative_errors(m, at=9, device=device)) < BAR


class TestRasterGradient:
    @pytest.mark.parametrize("kind", ["texton", "tiling"])
    def test_pixel_derivatives_are_the_texel_gradient_times_the_step(self, kind, device):
        model = random_texton((10, 10), channels=3, order=3, seed=3) if kind == "texton" else \
            TilingModel(_smooth_example(3), 20.0, sharpness=4)
        kw = dict(scale=0.7, rotation=25.0, offset=(-31.5, 12.25), seed=5, device=device)
        shape = (13, 17)
        g = gradient(model, shape=shape, pixel_offset=(3, -4), **kw)
        assert g.shape == (13, 17, 3, 2) and g.dtype == np.float32
        from warp_texton.noise.raster import raster_geometry

        origin, step = raster_geometry(shape, 0.7, 25.0, (-31.5, 12.25))
        jj, ii = np.meshgrid(np.arange(17) - 4 + 0.5, np.arange(13) + 3 + 0.5)
        pts = (origin[:, None] + step @ np.stack([jj.ravel(), ii.ravel()])).T
        at = gradient(model, pts, seed=5, device=device)
        assert np.allclose(g.reshape(-1, 3, 2), at @ step, atol=1e-6)
        # and the pixels' own differences: the raster one pixel to the right, down (a 10⁻³ pixel shift)
        v = synthesize(model, shape, pixel_offset=(3, -4), **kw).astype(np.float64)
        right = synthesize(model, shape, pixel_offset=(3, -4), **{**kw, "offset": tuple(np.array(kw["offset"])
                                                                                      + step[:, 0] * STEP)})
        fd = (right - v) / STEP
        err = np.abs(g[..., 0] - fd) / np.maximum(np.abs(fd), 1e-3)
        assert np.median(err) < 0.05  # one-sided difference: O(step) error on top of float32


@pytest.fixture(scope="module")
def texton():
    return random_texton((12, 12), channels=3, order=3, seed=11)


class TestNormalMaps:
    def test_unit_normals_pointing_up(self, texton, device):
        n = normal_map(texton, (128, 128), strength=2.0, seed=3, device=device)
        assert n.shape == (128, 128, 3) and n.dtype == np.float32
        assert n.min() >= 0.0 and n.max() <= 1.0
        v = 2.0 * n.astype(np.float64) - 1.0
        assert np.allclose(np.linalg.norm(v, axis=-1), 1.0, atol=1e-5)
        assert v[..., 2].min() > 0.0
        # the relief is not flat, and its mean normal is up: a stationary height's mean gradient is 0, so the
        # mean tilt is within sampling error (about 16² independent patches of the texton's size here)
        assert v[..., :2].std() > 0.05
        assert np.all(np.abs(v[..., :2].mean(axis=(0, 1))) < 5 * v[..., :2].std(axis=(0, 1)) / 16)

    def test_directx_flips_y(self, texton, device):
        gl = normal_map(texton, (32, 48), seed=2, device=device)
        dx = normal_map(texton, (32, 48), seed=2, convention="directx", device=device)
        assert np.array_equal(gl[..., 0], dx[..., 0]) and np.array_equal(gl[..., 2], dx[..., 2])
        assert np.allclose(gl[..., 1] + dx[..., 1], 1.0, atol=1e-6)
        assert np.abs(gl[..., 1] - 0.5).max() > 0.05

    def test_the_normals_are_the_heights_gradient(self, texton, device):
        # opengl: n ∝ (−∂h/∂column, +∂h/∂row, 1), h = strength · (channel 1) / σ₁
        n = 2.0 * normal_map(texton, (16, 16), strength=3.0, channel=1, seed=4, device=device) - 1.0
        g = gradient(texton, shape=(16, 16), seed=4, device=device)[:, :, 1].astype(np.float64)
        sigma = np.sqrt(texton.covariance()[1, 1])
        expect = np.concatenate([-g[..., :1], g[..., 1:]], axis=-1) * 3.0 / sigma
        assert np.allclose(n[..., :2] / n[..., 2:], expect, rtol=1e-4, atol=1e-4)

    def test_tiling_models_and_height_maps(self, device):
        m = TilingModel(_smooth_example(3), 20.0, sharpness=4)
        n = normal_map(m, (40, 40), seed=1, device=device)
        assert np.allclose(np.linalg.norm(2.0 * n - 1.0, axis=-1), 1.0, atol=1e-5)
        h = height_map(m, (40, 40), seed=1, device=device)
        assert h.shape == (40, 40, 1) and 0.0 <= h.min() and h.max() <= 1.0 and h.std() > 0.01

    def test_errors(self, texton, device):
        with pytest.raises(TextonError, match="filter") as info:
            gradient(texton, shape=(8, 8), filter="mip", device=device)
        assert info.value.param == "filter"
        with pytest.raises(TextonError, match="either points"):
            gradient(texton, device=device)
        with pytest.raises(TextonError, match="either points"):
            gradient(texton, [[0.0, 0.0]], shape=(8, 8), device=device)
        with pytest.raises(TextonError, match="points must have shape"):
            gradient(texton, [[0.0, 0.0, 1.0]], device=device)
        with pytest.raises(TextonError, match="convention"):
            normal_map(texton, (8, 8), convention="vulkan", device=device)
        with pytest.raises(TextonError, match="channel"):
            normal_map(texton, (8, 8), channel=3, device=device)
        with pytest.raises(TextonError, match="strength"):
            normal_map(texton, (8, 8), strength=0.0, device=device)
        with pytest.raises(TextonError, match="order 0"):
            normal_map(random_texton((8, 8), order=0), (8, 8), device=device)
        with pytest.raises(TextonError, match="mni"):
            gradient(TilingModel(_smooth_example(1), 20.0), shape=(8, 8), mni=5.0, device=device)


def test_cli_writes_the_normal_map(tmp_path, texton, capsys):
    from tests.helpers import run_cli
    from warp_texton import read_image

    src = tmp_path / "t.texton"
    texton.save(src)
    out, nm = tmp_path / "n.exr", tmp_path / "normals.exr"
    assert run_cli(["synthesize", src, "-o", out, "--width", 40, "--height", 24, "--normal-map", nm,
                    "--normal-strength", 2, "--device", "cpu", "-q"]) == 0
    expect = normal_map(texton, (24, 40), strength=2.0, device="cpu")
    assert np.allclose(read_image(nm), expect, atol=1e-6)
    assert run_cli(["synthesize", src, "-o", out, "--width", 40, "--height", 24, "--normal-map", nm,
                    "--filter", "mip", "--device", "cpu"]) == 2
    assert "--normal-map" in capsys.readouterr().err
    assert run_cli(["synthesize", src, "-o", out, "--width", 40, "--height", 24, "--normal-map", nm,
                    "--normal-strength", -1, "--device", "cpu"]) == 2
    assert "--normal-strength" in capsys.readouterr().err
