"""Statistical properties of the tiling model's blend, with tolerances from the sampling error.

Set-up that makes the expectations exact: the example repeats a tile of P × P texels, and the
range of the patches' centres (``W − 2 margin`` texels on each axis) is a multiple of P, so every
patch, read at texel centres (scale 1, points at texel centres), shows a uniformly drawn texel of
the tile. A point's three patches come from three vertices whose centres are drawn independently,
so over the draws the value at a point is μ + Σ k_n (X_n − μ) / √(Σ k_n²) (variance-preserving
blend) with X_n independent draws of the tile's colours: its mean is the tile's mean μ and its
covariance the tile's Σ, exactly, whatever the weights. The linear blend Σ k_n X_n keeps the mean
and lowers the covariance to Σ k_n² Σ. Points far apart (uniform over ±10⁶ texels, triangles of side
15) share no vertex, so the values at N points are N independent draws; one seed.

Tolerances: Z standard errors (Z = 5, two-sided, a false failure about once in 3.5 million per
check), each standard error estimated from the sample (the mean's from the sample variance, a
covariance entry's from the variance of the products of centred values). Histograms: the
Dvoretzky–Kiefer–Wolfowitz bound of the Kolmogorov–Smirnov distance between N draws and their
distribution at the same false-failure rate, plus the tables' resolution in probability (a grid
step of the Gaussian tables times the largest Gaussian density) and the tile's largest atom; the
per-channel W1 distance within Z times its bound in expectation. Each check also fails, as it
must, on a wrong blend (the linear one; colours blended without the tables).
"""

import numpy as np
import pytest

from warp_texton import analyze, evaluate
from warp_texton.model.histogram import GAUSS_RANGE, LUT_SIZE
from warp_texton.model.tiling import TilingModel

TILE = 32
REPEAT = 8  # the example: 256 × 256 texels
SIDE = 15.0  # margin 16: centres over 256 − 32 = 224 = 7 tiles on each axis
N = 40000
Z = 5.0
#: P(sup |F_N − F| > ε) ≤ 2 exp(−2 N ε²) (DKW); at the Z-sigma false-failure rate
FALSE_RATE = 2.9e-7


def tile_example(channels: int, seed: int = 0) -> np.ndarray:
    """A repeated tile of skewed, correlated colours (gamma marginals)."""
    rng = np.random.default_rng(seed)
    g = rng.gamma(1.5, 1.0, (TILE, TILE, 3))
    mix = np.array([[1.0, 0.0, 0.0], [0.6, 0.8, 0.0], [0.3, -0.4, 0.9]])
    t = 0.08 * (g @ mix.T) + np.array([0.2, 0.3, 0.5])
    t = t[..., :channels]
    return np.tile(t, (REPEAT, REPEAT, 1)).astype(np.float32)


def far_points(seed: int = 9) -> np.ndarray:
    """N texel centres spread over ±10⁶ texels: independent triangles."""
    rng = np.random.default_rng(seed)
    return rng.integers(-10**6, 10**6, (N, 2)).astype(np.float64) + 0.5


def moments_within(values: np.ndarray, mean: np.ndarray, cov: np.ndarray) -> tuple[bool, bool, np.ndarray]:
    """(mean within Z standard errors, every covariance entry within Z standard errors, cov z-scores)."""
    v = values.astype(np.float64)
    n = v.shape[0]
    m = v.mean(axis=0)
    se_mean = v.std(axis=0, ddof=1) / np.sqrt(n)
    d = v - m
    products = d[:, :, None] * d[:, None, :]
    c = products.mean(axis=0)
    se_cov = products.std(axis=0, ddof=1) / np.sqrt(n)
    zc = (c - cov) / se_cov
    return bool(np.all(np.abs(m - mean) <= Z * se_mean)), bool(np.all(np.abs(zc) <= Z)), zc


def tile_moments(example: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    t = example[:TILE, :TILE].reshape(-1, example.shape[2]).astype(np.float64)
    d = t - t.mean(axis=0)
    return t.mean(axis=0), d.T @ d / t.shape[0]


@pytest.mark.parametrize("channels", [1, 3])
@pytest.mark.parametrize("sharpness", [1, 4, 16])
def test_variance_preserving_blend_keeps_mean_and_covariance(channels, sharpness):
    example = tile_example(channels)
    model = TilingModel(example, SIDE, sharpness, blend="variance")
    assert (example.shape[0] - 2 * model.margin) % TILE == 0
    values = evaluate(model, far_points(), seed=1, device="cpu")
    mean, cov = tile_moments(example)
    ok_mean, ok_cov, zc = moments_within(values, mean, cov)
    assert ok_mean and ok_cov, zc


def test_linear_blend_fails_the_same_check():
    # the check is sharp enough to catch a wrong blend: the linear blend (sharpness 1: three patches
    # averaged with barycentric weights) keeps the mean but lowers the covariance to E[Σ k²] Σ ≈ Σ / 2
    example = tile_example(3)
    values = evaluate(TilingModel(example, SIDE, 1, blend="linear"), far_points(), seed=1, device="cpu")
    mean, cov = tile_moments(example)
    ok_mean, ok_cov, zc = moments_within(values, mean, cov)
    assert ok_mean and not ok_cov
    assert np.all(zc[np.diag_indices(3)] < -Z)  # every channel's variance is too low
    ratio = np.diag(np.cov(values.T.astype(np.float64))) / np.diag(cov)
    assert np.all((ratio > 0.4) & (ratio < 0.6)), ratio  # E[Σ w²] = 1/2 for uniform barycentric weights


def ks_bound() -> float:
    """The largest KS distance N independent draws of F show with probability 1 − FALSE_RATE (DKW), plus
    the tables' resolution in probability and the tile's largest atom."""
    dkw = np.sqrt(np.log(2.0 / FALSE_RATE) / (2.0 * N))
    table = (2.0 * GAUSS_RANGE / (LUT_SIZE - 1)) / np.sqrt(2.0 * np.pi)
    return float(dkw + table + 1.0 / TILE ** 2)


def ks_to_tile(values: np.ndarray, example: np.ndarray) -> np.ndarray:
    """Per channel, sup |F_values − F_tile| (the tile's discrete distribution, both sides of its steps)."""
    out = []
    n = values.shape[0]
    for c in range(example.shape[2]):
        pop = np.sort(example[:TILE, :TILE, c].ravel().astype(np.float64))
        v = np.sort(values[:, c].astype(np.float64))
        grid = np.concatenate([pop, v])
        f_pop_hi = np.searchsorted(pop, grid, "right") / pop.size
        f_pop_lo = np.searchsorted(pop, grid, "left") / pop.size
        f_v_hi = np.searchsorted(v, grid, "right") / n
        f_v_lo = np.searchsorted(v, grid, "left") / n
        out.append(max(np.abs(f_v_hi - f_pop_hi).max(), np.abs(f_v_lo - f_pop_lo).max()))
    return np.array(out)


@pytest.mark.parametrize("channels", [1, 3])
def test_histogram_preserving_blend_keeps_each_channels_histogram(channels):
    example = tile_example(channels)
    model = analyze(example, method="tiling", side=int(SIDE), histogram="preserve")
    blend_everywhere = TilingModel(model.example, SIDE, 1, blend="variance", histogram=model.histogram)
    values = evaluate(blend_everywhere, far_points(), seed=2, device="cpu")
    ks = ks_to_tile(values, example)
    assert np.all(ks <= ks_bound()), (ks, ks_bound())
    # and the W1 distance per channel: E[W1] of N draws is at most J / √N, J = ∫ √(F (1 − F)) dx
    # (Bobkov & Ledoux 2019, Thm 3.5); Z times that
    for c in range(channels):
        pop = np.sort(example[:TILE, :TILE, c].ravel().astype(np.float64))
        f = np.arange(1, pop.size) / pop.size
        j = np.sum(np.sqrt(f * (1.0 - f)) * np.diff(pop))
        v = np.sort(values[:, c].astype(np.float64))
        w1 = np.abs(v - pop[np.minimum((np.arange(N) * pop.size) // N, pop.size - 1)]).mean()
        assert w1 <= Z * j / np.sqrt(N), (w1, j / np.sqrt(N))


@pytest.mark.parametrize("wrong", ["linear blend of the Gaussian values", "variance blend of the colours"])
def test_wrong_blends_fail_the_histogram_check(wrong):
    example = tile_example(3)
    model = analyze(example, method="tiling", side=int(SIDE), histogram="preserve")
    if wrong.startswith("linear"):
        m = TilingModel(model.example, SIDE, 1, blend="linear", histogram=model.histogram)
    else:  # skewed colours blended directly: sums of gamma variables are less skewed
        m = TilingModel(example, SIDE, 1, blend="variance")
    ks = ks_to_tile(evaluate(m, far_points(), seed=2, device="cpu"), example)
    assert np.all(ks > ks_bound()), (ks, ks_bound())
