"""Discrete spot noise (EUSIPCO Algorithm 1).

f = m + (Σ_i α(x − x_i) − λ Σα) / √λ with impacts a Poisson process on Z² of
intensity λ = mni / |S| (|S| = non-zero coefficients). Its cumulants are those of
shot noise: mean m, covariance Σ_y α(y) α(y + τ)ᵀ, third cumulant Σ α³ / √λ and
excess kurtosis Σ α⁴ / (λ (Σ α²)²). Statistical checks use 1024² fields cut into
64² blocks; the sampling error is estimated from the blocks (block jackknife for
ratios), and each tolerance is Z of those standard deviations.
"""

from __future__ import annotations

import re

import numpy as np
import pytest

from warp_texton import Texton, TextonError, dsn
from warp_texton.model.analysis import support_mask

Z = 5.0
FIELD = (1024, 1024)
BLOCK = 64


def blocks(f: np.ndarray) -> np.ndarray:
    """(n_blocks, BLOCK², C) view of a field: blocks far apart are independent."""
    h, w, c = f.shape
    return (
        f.reshape(h // BLOCK, BLOCK, w // BLOCK, BLOCK, c)
        .transpose(0, 2, 1, 3, 4)
        .reshape(-1, BLOCK * BLOCK, c)
    )


def block_mean_and_sd(values: np.ndarray):
    """Mean over blocks of per-block statistics (n_blocks, ...) and its standard error."""
    n = values.shape[0]
    return values.mean(axis=0), values.std(axis=0, ddof=1) / np.sqrt(n)


def jackknife(stat, parts: list[np.ndarray]):
    """stat(*means over blocks) and its block-jackknife standard error."""
    n = parts[0].shape[0]
    full = stat(*(p.mean(axis=0) for p in parts))
    loo = np.array([stat(*((p.sum(axis=0) - p[i]) / (n - 1) for p in parts)) for i in range(n)])
    return full, np.sqrt((n - 1) / n * ((loo - loo.mean(axis=0)) ** 2).sum(axis=0))


@pytest.fixture(scope="module")
def disk_texton() -> Texton:
    """7 × 7 grey texton on a disk (|S| = 37 < 49), positive coefficients, order 0."""
    mask = support_mask(7, "disk")
    a = np.abs(np.random.default_rng(0).standard_normal((7, 7, 1))) * mask[:, :, None]
    return Texton(a.astype(np.float32), [0.5], 0)


@pytest.fixture(scope="module")
def color_texton(color_kernel) -> Texton:
    """The 8 × 8 correlated-channel kernel of conftest as an RGB texton."""
    return Texton(color_kernel.astype(np.float32), [0.2, 0.5, 0.7], 0)


def nonzero(t: Texton) -> int:
    return int(np.count_nonzero(np.any(t.coeffs != 0, axis=2)))


class TestDsnSmoke:
    def test_shape_and_dtype(self, disk_texton, color_texton):
        g = dsn(disk_texton, (33, 47))
        assert g.shape == (33, 47, 1) and g.dtype == np.float32
        assert dsn(color_texton, (20, 5), mni=3.5).shape == (20, 5, 3)

    def test_deterministic(self, color_texton):
        a = dsn(color_texton, (64, 80), seed=12)
        np.testing.assert_array_equal(a, dsn(color_texton, (64, 80), seed=12))
        assert not np.allclose(a, dsn(color_texton, (64, 80), seed=13))

    def test_zero_texton_gives_the_mean(self):
        t = Texton(np.zeros((4, 4, 3)), [0.1, 0.2, 0.3])
        expected = np.broadcast_to(np.float32([0.1, 0.2, 0.3]), (16, 16, 3))
        np.testing.assert_array_equal(dsn(t, (16, 16)), expected)


class TestDsnImpacts:
    """Three channels that differ by a single coefficient see the same impacts, so their
    differences expose the impact-count image itself (exactly, up to float rounding)."""

    R, S = 5, 7

    def counts(self, mni, shape, seed):
        r, s = self.R, self.S
        a = np.ones((r, s, 3), dtype=np.float32)
        a[0, 0, 1] += 1.0  # channel 1 = ones + δ at (0, 0)
        a[r - 1, s - 1, 2] += 1.0  # channel 2 = ones + δ at (r − 1, s − 1)
        t = Texton(a, [0.25, 0.25, 0.25], 0)
        lam = mni / (r * s)
        f = dsn(t, shape, mni=mni, seed=seed).astype(np.float64)
        # undo the normalisation: D_c(x) = Σ_i α_c(x − x_i), sums of whole copies of α_c
        d = (f - 0.25) * np.sqrt(lam) + lam * a.sum(axis=(0, 1), dtype=np.float64)
        return d[:, :, 1] - d[:, :, 0], d[:, :, 2] - d[:, :, 0], lam

    def test_spots_are_whole_unflipped_copies(self):
        p0, p1, _ = self.counts(mni=2.0, shape=(96, 120), seed=4)
        # with λ = mni / |S| and 1/√λ undone, the differences are integer impact counts
        np.testing.assert_allclose(p0, np.round(p0), atol=1e-3)
        np.testing.assert_allclose(p1, np.round(p1), atol=1e-3)
        p0, p1 = np.round(p0), np.round(p1)
        assert p0.min() >= 0 and p0.max() >= 1
        # h(x − x_i): the bottom-right coefficient lands (r − 1, s − 1) below-right of the
        # top-left one, for every impact
        np.testing.assert_array_equal(p1[self.R - 1:, self.S - 1:], p0[: -(self.R - 1), : -(self.S - 1)])

    def test_impacts_cover_the_extended_domain(self):
        # p1(x) counts impacts at x − (r − 1, s − 1): its first rows and columns count impacts
        # above and left of the raster, which must arrive at the same rate λ (Ω̄ = Ω − S).
        _, p1, lam = self.counts(mni=2.0, shape=(256, 256), seed=5)
        p1 = np.round(p1)
        border = np.r_[p1[: self.R - 1].ravel(), p1[:, : self.S - 1].ravel()]
        inner = p1[self.R - 1:, self.S - 1:]
        for sample in (border, inner):
            # Poisson counts: mean λ, standard error √(λ / n)
            assert abs(sample.mean() - lam) < Z * np.sqrt(lam / sample.size)
        assert np.var(inner) == pytest.approx(lam, rel=Z * np.sqrt(2.0 / inner.size) + 0.02)


class TestDsnStatistics:
    @pytest.mark.parametrize("mni", [1.0, 30.0])
    def test_mean_and_variance(self, disk_texton, mni):
        f = dsn(disk_texton, FIELD, mni=mni, seed=1).astype(np.float64) - 0.5
        b = blocks(f)[:, :, 0]
        mean, sd_mean = block_mean_and_sd(b.mean(axis=1))
        var, sd_var = block_mean_and_sd((b**2).mean(axis=1))
        alpha = disk_texton.coeffs.astype(np.float64)
        assert abs(mean) < Z * sd_mean
        # the discrete spot: variance Σ α² whatever the MNI
        assert abs(var - (alpha**2).sum()) < Z * sd_var
        assert sd_var < 0.02 * (alpha**2).sum()

    @pytest.mark.parametrize("order", [0, 1])
    def test_excess_kurtosis(self, disk_texton, order):
        # shot noise of intensity λ = mni / |S| with |S| = 37 non-zero coefficients; using
        # the full 49-texel square (or the spline support) would give a 32 % larger value.
        # DSN ignores the order (it uses α as a discrete spot), so order 1 gives the same.
        t = Texton(disk_texton.coeffs, disk_texton.mean, order)
        mni = 1.0
        lam = mni / nonzero(t)
        assert nonzero(t) == 37
        f = dsn(t, FIELD, mni=mni, seed=2).astype(np.float64) - 0.5
        b = blocks(f)[:, :, 0]
        m2, m3, m4 = ((b**k).mean(axis=1) for k in (2, 3, 4))
        alpha = t.coeffs.astype(np.float64)
        s2, s3, s4 = ((alpha**k).sum() for k in (2, 3, 4))

        kurt, sd_k = jackknife(lambda a2, a4: a4 / a2**2 - 3.0, [m2, m4])
        expected = s4 / (lam * s2**2)
        assert abs(kurt - expected) < Z * sd_k
        assert sd_k < 0.05 * expected  # resolves the |S| vs r·s confusion (32 %)

        skew, sd_s = jackknife(lambda a2, a3: a3 / a2**1.5, [m2, m3])
        assert abs(skew - s3 / (np.sqrt(lam) * s2**1.5)) < Z * sd_s

    def test_high_mni_is_nearly_gaussian(self, disk_texton):
        # kurtosis decays as 1 / mni
        lo = dsn(disk_texton, FIELD, mni=1.0, seed=3).astype(np.float64) - 0.5
        hi = dsn(disk_texton, FIELD, mni=100.0, seed=3).astype(np.float64) - 0.5

        def kurt(f):
            return np.mean(f**4) / np.mean(f**2) ** 2 - 3.0

        assert kurt(hi) < 0.05 * kurt(lo)

    def test_color_covariance_and_lags(self, color_texton):
        # Cov(f(x), f(x + τ)) = Σ_y α(y) α(y + τ)ᵀ: lag 0 holds the colour cross-covariance
        f = dsn(color_texton, FIELD, mni=10.0, seed=4).astype(np.float64) - color_texton.mean
        alpha = color_texton.coeffs.astype(np.float64)
        r, s, _ = alpha.shape
        for dy, dx in [(0, 0), (0, 1), (1, 0), (2, -3)]:
            a0 = alpha[max(0, -dy): r - max(0, dy), max(0, -dx): s - max(0, dx)]
            a1 = alpha[max(0, dy): r + min(0, dy), max(0, dx): s + min(0, dx)]
            expected = np.einsum("ijc,ijd->cd", a0, a1)
            g0 = f[max(0, -dy): f.shape[0] - max(0, dy), max(0, -dx): f.shape[1] - max(0, dx)]
            g1 = f[max(0, dy): f.shape[0] + min(0, dy), max(0, dx): f.shape[1] + min(0, dx)]
            h = (g0.shape[0] // BLOCK) * BLOCK
            w = (g0.shape[1] // BLOCK) * BLOCK
            prod = g0[:h, :w, :, None] * g1[:h, :w, None, :]
            per_block = blocks(prod.reshape(h, w, 9)).mean(axis=1).reshape(-1, 3, 3)
            est, sd = block_mean_and_sd(per_block)
            assert np.all(np.abs(est - expected) < Z * sd), (dy, dx, est, expected, sd)
        # the mean of each channel
        mean, sd = block_mean_and_sd(blocks(f).mean(axis=1))
        assert np.all(np.abs(mean) < Z * sd)


class TestDsnExceptions:
    def test_not_a_texton(self):
        with pytest.raises(TextonError, match="texton must be a Texton"):
            dsn(np.ones((4, 4, 1)), (16, 16))

    @pytest.mark.parametrize(
        "shape, message",
        [
            ((0, 16), r"shape\[0\] \(height\) must be at least 1"),
            ((16, 0), r"shape\[1\] \(width\) must be at least 1"),
            ((16.0, 16), r"shape\[0\] \(height\) must be an integer"),
            ((16,), "shape must be a pair"),
            (None, "shape must be a pair"),
            ((1 << 15, 1 << 14), "too large"),
        ],
    )
    def test_bad_shape(self, disk_texton, shape, message):
        with pytest.raises(TextonError, match=message):
            dsn(disk_texton, shape)

    @pytest.mark.parametrize("mni", [0, -1.0, np.nan, np.inf])
    def test_non_positive_mni(self, disk_texton, mni):
        with pytest.raises(TextonError, match="mni must be a finite number > 0"):
            dsn(disk_texton, (16, 16), mni=mni)

    @pytest.mark.parametrize("mni", ["30", None, True])
    def test_mni_not_a_number(self, disk_texton, mni):
        with pytest.raises(TextonError, match="mni must be a positive number"):
            dsn(disk_texton, (16, 16), mni=mni)

    @pytest.mark.parametrize("seed", [-1, 2**32, 2.0, "1"])
    def test_bad_seed(self, disk_texton, seed):
        with pytest.raises(TextonError, match=re.escape("seed must be an integer in [0, 2**32)")):
            dsn(disk_texton, (16, 16), seed=seed)
