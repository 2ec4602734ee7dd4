"""Gaussian models of an image: periodic component, kernel, OT distance / RME, ADSN sampling.

Statistical tests draw a fixed number of samples with fixed seeds; each tolerance
is a multiple (Z) of the sampling standard deviation, either derived from the
model (chi-square periodograms) or estimated from the independent samples.
"""

from __future__ import annotations

import re

import numpy as np
import pytest

from warp_texton import TextonError, gaussian_texture, periodic_component
from warp_texton.model.gaussian import normalized_kernel, ot_distance, relative_model_error

#: Tolerance in standard deviations of the sampling error. With fixed seeds the tests are
#: deterministic; 5σ keeps them valid for any seed with probability > 1 − 1e-6 per check.
Z = 5.0


def lap_per(a: np.ndarray) -> np.ndarray:
    """Circular 5-point Laplacian over axes (0, 1)."""
    return (
        np.roll(a, 1, 0) + np.roll(a, -1, 0) + np.roll(a, 1, 1) + np.roll(a, -1, 1) - 4.0 * a
    )


def lap_free(a: np.ndarray) -> np.ndarray:
    """Moisan's Δ_free: Σ over the in-image 4-neighbours y of x of (a(y) − a(x))."""
    out = np.zeros_like(a)
    out[1:] += a[:-1] - a[1:]
    out[:-1] += a[1:] - a[:-1]
    out[:, 1:] += a[:, :-1] - a[:, 1:]
    out[:, :-1] += a[:, 1:] - a[:, :-1]
    return out


def autocorrelation(t: np.ndarray, dy: int, dx: int) -> np.ndarray:
    """Non-periodic Σ_y t(y) t(y + τ)ᵀ over the pairs inside the array (C × C)."""
    m, n, _ = t.shape
    a0 = t[max(0, -dy): m - max(0, dy), max(0, -dx): n - max(0, dx)]
    a1 = t[max(0, dy): m + min(0, dy), max(0, dx): n + min(0, dx)]
    return np.einsum("ijc,ijd->cd", a0, a1)


def lagged_products(g: np.ndarray, dy: int, dx: int) -> np.ndarray:
    """Spatial mean of g(x) g(x + τ)ᵀ over the raster (C × C); g already centred."""
    return autocorrelation(g, dy, dx) / (
        (g.shape[0] - abs(dy)) * (g.shape[1] - abs(dx))
    )


# --------------------------------------------------------------------------- #
@pytest.fixture(scope="module")
def images(grass_image, adsn_sampler, color_kernel):
    """Non-periodic images: a real texture, a ramp (strong border jump) and a colour ramp."""
    ramp = np.linspace(0.0, 1.0, 72)[None, :] + np.linspace(0.0, 0.5, 60)[:, None]
    color = adsn_sampler(color_kernel, (60, 72), seed=0)
    return {
        "grass": grass_image[:96, :80],
        "ramp+noise": ramp + 0.05 * np.random.default_rng(0).standard_normal((60, 72)),
        "color": color + ramp[:, :, None] * np.array([1.0, 0.5, -0.3]),
    }


class TestPeriodicComponent:

    def test_shapes_and_dtype(self, images):
        p = periodic_component(images["grass"])
        assert p.shape == (96, 80, 1) and p.dtype == np.float32
        assert periodic_component(images["color"]).shape == (60, 72, 3)

    @pytest.mark.parametrize("name", ["grass", "ramp+noise", "color"])
    def test_mean_preserved(self, images, name):
        u = np.atleast_3d(images[name]).astype(np.float64)
        p = periodic_component(u).astype(np.float64)
        np.testing.assert_allclose(p.mean(axis=(0, 1)), u.mean(axis=(0, 1)), atol=1e-6)

    @pytest.mark.parametrize("name", ["grass", "ramp+noise", "color"])
    def test_smooth_part_is_harmonic_inside(self, images, name):
        # s = u − p solves Δ_per s = v, and v lives on the border only
        u = np.atleast_3d(images[name]).astype(np.float32).astype(np.float64)
        s = u - periodic_component(u).astype(np.float64)
        inner = lap_per(s)[1:-1, 1:-1]
        scale = np.abs(lap_per(u)).max()
        assert np.abs(inner).max() < 1e-5 * scale
        # ... while s itself is far from zero on these non-periodic images
        assert np.abs(s).max() > 100 * np.abs(inner).max()

    @pytest.mark.parametrize("name", ["grass", "ramp+noise", "color"])
    def test_periodic_laplacian_is_free_laplacian(self, images, name):
        # Moisan 2011: Δ_per p = Δ_free u and mean(p) = mean(u), which determine p uniquely
        # (the kernel of Δ_per is the constants).
        u = np.atleast_3d(images[name]).astype(np.float32).astype(np.float64)
        p = periodic_component(u).astype(np.float64)
        lf = lap_free(u)
        np.testing.assert_allclose(lap_per(p), lf, rtol=0, atol=1e-5 * np.abs(lf).max())
        # and it is not a tautology: u's own circular Laplacian differs on the border
        assert np.abs(lap_per(u) - lf).max() > 0.1 * np.abs(lf).max()

    def test_border_jump_free_image_unchanged(self):
        # v = 0 when opposite borders coincide, so s = 0 and p = u. (A sampled periodic
        # function such as sin(2πj/N) is *not* left unchanged: its border jump is a
        # regular neighbour difference, yet Δ_free still drops it; p − u is then O(1/N).)
        u = np.random.default_rng(3).random((40, 52, 3))
        u[-1] = u[0]
        u[:, -1] = u[:, 0]
        u = u.astype(np.float32)
        np.testing.assert_allclose(periodic_component(u), u, rtol=0, atol=1e-6)

    def test_linear(self, images):
        a, b = images["grass"][:60, :72], images["ramp+noise"]
        lhs = periodic_component(2.0 * a - 0.5 * b).astype(np.float64)
        rhs = 2.0 * periodic_component(a).astype(np.float64) - 0.5 * periodic_component(b)
        np.testing.assert_allclose(lhs, rhs, rtol=0, atol=1e-5)

    def test_tiling_seam_removed(self, images):
        # the mean squared jump across the tile border drops to the interior's level
        u = images["ramp+noise"]
        p = periodic_component(u)[:, :, 0].astype(np.float64)

        def seam(a):
            return np.mean((a[:, -1] - a[:, 0]) ** 2) + np.mean((a[-1] - a[0]) ** 2)

        def inner(a):
            return np.mean(np.diff(a, axis=1) ** 2) + np.mean(np.diff(a, axis=0) ** 2)

        assert seam(u) > 50 * inner(u)
        assert seam(p) < 3 * inner(p)

    def test_non_finite(self):
        u = np.zeros((16, 16))
        u[2, 2] = np.nan
        with pytest.raises(TextonError, match="NaN or infinite"):
            periodic_component(u)

    def test_two_channels(self):
        with pytest.raises(TextonError, match="has 2 channels"):
            periodic_component(np.zeros((16, 16, 2)))

    def test_empty(self):
        with pytest.raises(TextonError, match="empty"):
            periodic_component(np.zeros((0, 16)))


class TestNormalizedKernel:
    def test_definition_without_periodic(self, gravel_image):
        u = gravel_image[:50, :70].astype(np.float64)
        m, t = normalized_kernel(u, periodic=False)
        np.testing.assert_allclose(m, [u.mean()], rtol=1e-6)
        np.testing.assert_allclose(t[:, :, 0], (u - u.mean()) / np.sqrt(50 * 70), atol=1e-8)

    def test_periodic_uses_periodic_component(self, gravel_image):
        u = gravel_image[:50, :70]
        m, t = normalized_kernel(u, periodic=True)
        p = periodic_component(u).astype(np.float64)
        np.testing.assert_allclose(t, (p - m) / np.sqrt(50 * 70), atol=1e-8)

    @pytest.mark.parametrize("periodic", [True, False])
    def test_zero_sum(self, adsn_sampler, color_kernel, periodic):
        # t̂_u(0) = 0: the model's kernel carries no mean
        _, t = normalized_kernel(adsn_sampler(color_kernel, (40, 50), seed=1), periodic=periodic)
        np.testing.assert_allclose(t.sum(axis=(0, 1)), 0.0, atol=1e-6)

    @pytest.mark.parametrize("periodic", [True, False])
    def test_constant(self, periodic):
        with pytest.raises(TextonError, match="constant"):
            normalized_kernel(np.full((20, 30), 3.0), periodic=periodic)


@pytest.fixture(scope="module")
def spectra():
    """Two random kernels' DFTs, (32, 24, C), for grey and colour."""
    rng = np.random.default_rng(5)
    return {
        name: tuple(np.fft.fft2(rng.standard_normal((32, 24, c)), axes=(0, 1)) for _ in range(2))
        for name, c in (("grey", 1), ("color", 3))
    }


class TestRelativeModelError:

    @pytest.mark.parametrize("kind", ["grey", "color"])
    def test_identity_and_symmetry(self, spectra, kind):
        a, b = spectra[kind]
        assert relative_model_error(a, a) == pytest.approx(0.0, abs=1e-7)
        assert ot_distance(a, b) == pytest.approx(ot_distance(b, a), rel=1e-12)
        assert ot_distance(a, b) > 0

    @pytest.mark.parametrize("kind", ["grey", "color"])
    @pytest.mark.parametrize("c", [0.0, 0.3, 1.0, 1.7, 3.0])
    def test_scaled_model(self, spectra, kind, c):
        # RME(t, c t)² = Σ (1 + c² − 2c)|t̂|² / Σ |t̂|²: exactly |1 − c| with eq. (1)'s factor 2
        a, _ = spectra[kind]
        # compared squared: the square root amplifies rounding near c = 1
        assert relative_model_error(a, c * a) ** 2 == pytest.approx((1.0 - c) ** 2, abs=1e-12)

    def test_zero_frequency_ignored(self, spectra):
        a, b = spectra["color"]
        b2 = b.copy()
        b2[0, 0] += 100.0
        assert ot_distance(a, b2) == pytest.approx(ot_distance(a, b), rel=1e-12)

    def test_phase_blind_in_grey(self, spectra):
        # a translated kernel is the same stationary model
        a, _ = spectra["grey"]
        t = np.fft.ifft2(a, axes=(0, 1)).real
        shifted = np.fft.fft2(np.roll(t, (5, -3), axis=(0, 1)), axes=(0, 1))
        assert relative_model_error(np.fft.fft2(t, axes=(0, 1)), shifted) == pytest.approx(0, abs=1e-7)

    def test_relative_colour_phase_matters(self, spectra):
        # a common shift is the same model; shifting one channel alone decorrelates the colours
        a, _ = spectra["color"]
        t = np.fft.ifft2(a, axes=(0, 1)).real
        common = np.fft.fft2(np.roll(t, (2, 1), axis=(0, 1)), axes=(0, 1))
        one = t.copy()
        one[:, :, 1] = np.roll(one[:, :, 1], (2, 1), axis=(0, 1))
        t_hat = np.fft.fft2(t, axes=(0, 1))
        assert relative_model_error(t_hat, common) == pytest.approx(0, abs=1e-7)
        assert relative_model_error(t_hat, np.fft.fft2(one, axes=(0, 1))) > 0.2

    def test_triangle_inequality(self):
        # d_OT is a distance between Gaussian models
        rng = np.random.default_rng(9)
        for _ in range(20):
            a, b, c = (np.fft.fft2(rng.standard_normal((12, 10, 3)), axes=(0, 1)) for _ in range(3))
            dab, dbc, dac = (np.sqrt(ot_distance(x, y)) for x, y in ((a, b), (b, c), (a, c)))
            assert dac <= dab + dbc + 1e-12

    @pytest.mark.parametrize("kind", ["grey", "color"])
    def test_true_model_against_one_sample(self, adsn_sampler, grey_kernel, color_kernel, kind):
        # |t̂_u|² = |k̂|² E with E ~ Exp(1) per frequency (Rayleigh modulus), so even the true
        # kernel scores RME² = (E[E] + 1 − 2 E[√E]) / E[E] = 2 − √π against a single sample.
        # Measured seed-to-seed std at 256²: 0.0018, so ≈ 0.001 at 512²; tolerance 5σ.
        k = grey_kernel if kind == "grey" else color_kernel
        u = adsn_sampler(k, (512, 512), seed=6)
        _, t = normalized_kernel(u, periodic=False)
        rme = relative_model_error(
            np.fft.fft2(t, axes=(0, 1)), np.fft.fft2(k, s=(512, 512), axes=(0, 1))
        )
        assert rme == pytest.approx(np.sqrt(2.0 - np.sqrt(np.pi)), abs=0.005)


class TestGaussianTexture:
    def test_smoke_shapes(self, grass_image, adsn_sampler, color_kernel):
        u = grass_image[:40, :48]
        g = gaussian_texture(u)
        assert g.shape == (40, 48, 1) and g.dtype == np.float32
        assert gaussian_texture(u, shape=(17, 100)).shape == (17, 100, 1)
        c = adsn_sampler(color_kernel, (32, 32), seed=0)
        assert gaussian_texture(c, shape=(50, 20)).shape == (50, 20, 3)

    @pytest.mark.parametrize("shape", [None, (70, 30)])
    def test_deterministic(self, grass_image, shape):
        u = grass_image[:40, :48]
        a = gaussian_texture(u, shape, seed=3)
        np.testing.assert_array_equal(a, gaussian_texture(u, shape, seed=3))
        assert not np.allclose(a, gaussian_texture(u, shape, seed=4))

    @pytest.mark.parametrize("periodic", [True, False])
    def test_circular_sample_mean_is_exact(self, grass_image, periodic):
        # Σ t_u = 0, so every circular sample has exactly the mean of u
        u = grass_image[:64, :80]
        g = gaussian_texture(u, seed=1, periodic=periodic)
        assert g.astype(np.float64).mean() == pytest.approx(float(u.astype(np.float64).mean()), abs=1e-6)

    @pytest.mark.parametrize("periodic", [True, False])
    def test_periodogram_at_own_shape(self, grass_image, periodic):
        # ADSN at u's shape: fft2(g − m) = t̂_u Ŵ with |Ŵ|²/(MN) ~ Exp(1), so the periodogram
        # |fft2(g − m)|²/(MN) divided by |t̂_u|² is Exp(1) per frequency: over K samples its
        # mean has std 1/√K, and its variance across frequencies is 1/K (0 for random phase).
        u = grass_image[:96, :128]
        m, n = u.shape
        mean, t = normalized_kernel(u, periodic=periodic)
        ref = np.abs(np.fft.fft2(t[:, :, 0])) ** 2
        k = 32
        pgram = np.zeros((m, n))
        for seed in range(k):
            g = gaussian_texture(u, seed=seed, periodic=periodic)[:, :, 0].astype(np.float64)
            pgram += np.abs(np.fft.fft2(g - mean[0])) ** 2 / (m * n)
        ratio = pgram / k / np.where(ref > 0, ref, 1.0)
        ratio[0, 0] = np.nan
        # half the frequencies are independent (ξ and −ξ agree)
        n_indep = m * n / 2
        assert abs(np.nanmean(ratio) - 1.0) < Z / np.sqrt(k * n_indep)
        # 8 × 8 blocks: 64 frequencies each, std 1/√(64K)
        blocks = np.nanmean(ratio.reshape(m // 8, 8, n // 8, 8), axis=(1, 3))
        assert np.abs(blocks - 1.0).max() < Z / np.sqrt(64 * k)
        # Gaussian white noise, not a random phase: the spread is that of a Gamma(K)/K
        assert np.nanvar(ratio) * k == pytest.approx(1.0, abs=0.1)

    def test_other_shape_covariance(self, grass_image):
        # non-periodic ADSN on Z²: Cov(g(x), g(x + τ)) = Σ_y t_u(y) t_u(y + τ), t_u zero outside
        u = grass_image[:32, :40]
        mean, t = normalized_kernel(u)
        h, w = 160, 200
        lags = [(0, 0), (0, 1), (1, 0), (1, 1), (2, -3), (-1, 4)]
        k = 16
        est = np.array(
            [
                [lagged_products(gaussian_texture(u, (h, w), seed=s).astype(np.float64) - mean, *lag)[0, 0]
                 for lag in lags]
                for s in range(k)
            ]
        )
        expected = np.array([autocorrelation(t, *lag)[0, 0] for lag in lags])
        sd = est.std(axis=0, ddof=1) / np.sqrt(k)
        assert np.all(np.abs(est.mean(axis=0) - expected) < Z * sd), (est.mean(axis=0), expected, sd)
        # the estimate is precise enough for the check to mean something
        assert np.all(sd < 0.05 * expected[0])

    def test_other_shape_does_not_wrap(self, grass_image):
        # opposite borders of a non-periodic sample are independent (they would be neighbours,
        # correlated by Σ t(y) t(y + (0, 1)), if the convolution wrapped on the output grid)
        u = grass_image[:32, :40]
        mean, t = normalized_kernel(u)
        k = 16
        wrap = []
        for s in range(k):
            g = gaussian_texture(u, (160, 200), seed=s)[:, :, 0].astype(np.float64) - mean[0]
            wrap.append(np.r_[g[:, 0] * g[:, -1], g[0, :] * g[-1, :]].mean())
        sd = np.std(wrap, ddof=1) / np.sqrt(k)
        neighbour = autocorrelation(t, 0, 1)[0, 0]
        assert abs(np.mean(wrap)) < Z * sd
        # a wrapped sample would average `neighbour`: far outside the accepted band
        assert neighbour > 4 * Z * sd

    def test_other_shape_mean(self, grass_image):
        u = grass_image[:32, :40]
        k = 16
        means = [gaussian_texture(u, (120, 90), seed=s).astype(np.float64).mean() for s in range(k)]
        sd = np.std(means, ddof=1) / np.sqrt(k)
        assert abs(np.mean(means) - u.astype(np.float64).mean()) < Z * sd
        assert sd < 0.01  # the check resolves a 5 % error of the mean

    @pytest.mark.parametrize("shape", [None, (100, 120)])
    def test_color_cross_covariance(self, adsn_sampler, color_kernel, shape):
        # one white noise for all channels keeps the 3 × 3 covariance t_uᵀ t_u
        u = adsn_sampler(color_kernel, (64, 64), mean=[0.2, 0.5, 0.7], seed=8)
        mean, t = normalized_kernel(u)
        expected = autocorrelation(t, 0, 0)
        k = 32
        est = np.array(
            [lagged_products(gaussian_texture(u, shape, seed=s).astype(np.float64) - mean, 0, 0)
             for s in range(k)]
        )
        sd = est.std(axis=0, ddof=1) / np.sqrt(k)
        assert np.all(np.abs(est.mean(axis=0) - expected) < Z * sd + 1e-12)
        # the channels are strongly correlated: independent noises per channel (zero
        # cross-covariance) would fall far outside the accepted band
        corr = expected / np.sqrt(np.outer(np.diag(expected), np.diag(expected)))
        off = np.triu_indices(3, 1)
        assert corr[0, 1] > 0.5
        assert np.all(np.abs(expected[off]) > 2 * Z * sd[off])

    @pytest.mark.parametrize(
        "shape, message",
        [
            ((0, 10), r"shape\[0\] \(height\) must be at least 1"),
            ((10, -2), r"shape\[1\] \(width\) must be at least 1"),
            ((10.5, 10), r"shape\[0\] \(height\) must be an integer"),
            ((10,), "shape must be a pair"),
            ((10, 10, 3), "shape must be a pair"),
            (12, "shape must be a pair"),
            ((1 << 15, 1 << 14), "too large"),
        ],
    )
    def test_bad_shape(self, grass_image, shape, message):
        with pytest.raises(TextonError, match=message):
            gaussian_texture(grass_image[:32, :32], shape=shape)

    @pytest.mark.parametrize("seed", [-1, 2**32, 0.5, None])
    def test_bad_seed(self, grass_image, seed):
        with pytest.raises(TextonError, match=re.escape("seed must be an integer in [0, 2**32)")):
            gaussian_texture(grass_image[:32, :32], seed=seed)

    def test_constant_image(self):
        with pytest.raises(TextonError, match="constant"):
            gaussian_texture(np.ones((16, 16, 3)))

    def test_non_finite(self):
        u = np.random.default_rng(0).random((16, 16))
        u[0, 0] = np.inf
        with pytest.raises(TextonError, match="NaN or infinite"):
            gaussian_texture(u)
