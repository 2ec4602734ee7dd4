"""Texture mixing (CGF §7): textons along the OT geodesic, and spatially varying texton noise.

mix_textons: the Gaussian models of u and v (kernels t_u, t_v) are joined by the optimal
transport geodesic τ_ρ = (1 − ρ) τ_0 + ρ t_v, τ_0 = t_u rephased onto t_v (Xia et al. 2014);
a texton is computed for each τ_ρ from one white-noise start. The properties checked are
exact ones (the endpoints are the single-model textons, the distances of EUSIPCO eq. (1)
along the path, the interpolated means) and the continuity in ρ.

synthesize_mixed: g(x) = m(x) + Σ_j ε_j h_{r(x_j)}(x − x_j) / √λ, ε_j = ±1. Given the
impacts' labels the field is linear in the textons, which gives exact checks of the labelling
(which impacts use which texton); the statistics (spectrum, local variance, means) are
compared with the exact second-order model. Each statistical tolerance is derived from the
sampling error of the statistic, next to it; seeds are fixed.
"""

from __future__ import annotations

import functools
import math
import re
from pathlib import Path

import numpy as np
import pytest
import scipy.ndimage as ndi
from PIL import Image

from helpers import anisotropic_texton, random_texton, run_cli
from texton_models import block_zscores, expected_periodogram, model_covariance
from warp_texton import Texton, TextonError, analyze, mix_textons, read_image, synthesize, synthesize_mixed
from warp_texton.model.bspline import bspline
from warp_texton.model.gaussian import normalized_kernel, ot_distance, relative_model_error
from warp_texton.noise.mixing import barycentre_spectrum

ITER = 20  # alternating projections: enough for the properties below, cheap on 48 × 48 grids


# --------------------------------------------------------------------------- #
# Example textures: exact samples of known Gaussian models                    #
# --------------------------------------------------------------------------- #
def adsn(kernel, shape, mean, seed) -> np.ndarray:
    """m + k ⊛ W on a circular grid, one white noise W shared by the channels (EUSIPCO §2.2)."""
    k = np.asarray(kernel, np.float64)
    k = k[:, :, None] if k.ndim == 2 else k
    w_hat = np.fft.fft2(np.random.default_rng(seed).standard_normal(shape))
    g = np.fft.ifft2(np.fft.fft2(k, s=shape, axes=(0, 1)) * w_hat[:, :, None], axes=(0, 1)).real
    return (g + np.asarray(mean, np.float64)).astype(np.float32)


@functools.lru_cache(maxsize=None)
def pair(channels: int, shape=(48, 48)):
    """Two textures of clearly different models: an isotropic blob and an x-elongated one.

    v's kernel is twice as strong, so the two variances differ by about 4; the means differ.
    """
    rng = np.random.default_rng(100 + channels)
    ku = ndi.gaussian_filter(rng.standard_normal((8, 8, channels)), (1.0, 1.0, 0))
    kv = ndi.gaussian_filter1d(rng.standard_normal((8, 8, channels)), 1.5, axis=1)
    if channels == 3:  # correlated colour channels, as in photographs
        mix = np.array([[1.0, 0.0, 0.0], [0.8, 0.6, 0.0], [0.5, 0.3, 0.8]])
        ku, kv = ku @ mix.T, kv @ mix[::-1].T
    mu, mv = ([0.3] * channels, [0.7] * channels) if channels == 1 else ([0.2, 0.3, 0.4], [0.7, 0.5, 0.6])
    # standard deviations ≈ 0.15 and 0.3 (grey): textures of an 8-bit range
    u = adsn(0.05 * ku / np.abs(ku).max(), shape, mu, seed=1)
    v = adsn(0.10 * kv / np.abs(kv).max(), shape, mv, seed=2)
    return u, v


def full_kernel_spectrum(img) -> np.ndarray:
    """Full-grid DFT of t = (u − m)/√(MN) of the periodic component (as analysed by default)."""
    _, t = normalized_kernel(img, periodic=True)
    return np.fft.fft2(t, axes=(0, 1))


def scaled(t: Texton, factor: float, mean=None) -> Texton:
    return Texton(factor * t.coeffs, t.mean if mean is None else mean, t.order)


def rel_diff(a: Texton, b: Texton) -> float:
    return float(np.linalg.norm(a.coeffs - b.coeffs) / np.linalg.norm(b.coeffs))


# --------------------------------------------------------------------------- #
# The exact second-order model of (mixed) texton noise                        #
# --------------------------------------------------------------------------- #
class NodeModel:
    """h of a texton on Gauss–Legendre nodes of cells of side 1/sub covering supp h.

    h is a polynomial of degree ≤ k per axis on each unit cell (knots on the integers for odd k,
    on the half-integers for k = 0), so 2k + 1 nodes per cell integrate h⁴ exactly. Nodes repeat
    with period n·sub per texel, which turns integer lags into index shifts and lets integrals
    over [0, 1)² of periodised functions be computed by folding.
    """

    def __init__(self, texton: Texton, sub: int = 2):
        a = texton.coeffs.astype(np.float64)
        r, s, _ = a.shape
        k = texton.order
        n = 2 * k + 1
        self.per_texel = n * sub
        x, w = np.polynomial.legendre.leggauss(n)
        x, w = (x + 1) / (2 * sub), w / (2 * sub)

        def axis(count):
            edges = -(k + 1) / 2 + np.arange((count + k) * sub) / sub
            y = (edges[:, None] + x[None, :]).ravel()
            return bspline(y[:, None] - np.arange(count)[None, :], k), np.tile(w, (count + k) * sub), y

        by, self.wy, _ = axis(r)
        bx, self.wx, self.x = axis(s)  # self.x: the x-offset d of each node column from the impact
        self.h = np.einsum("pi,ijc,qj->pqc", by, a, bx)

    def vertical_lag_terms(self, lags: int = 16):
        """Per node column q and vertical lag τ ∈ [−lags, lags] (grey): ∫ h h_τ dy, ∫ |h h_τ| dy, ∫ h² h²_τ dy."""
        h = self.h[:, :, 0]
        pad = lags * self.per_texel
        hp = np.pad(h, ((pad, pad), (0, 0)))
        out = np.zeros((3, h.shape[1], 2 * lags + 1))
        for t, tau in enumerate(range(-lags, lags + 1)):
            shifted = hp[pad + tau * self.per_texel: pad + tau * self.per_texel + h.shape[0]]
            out[0, :, t] = self.wy @ (h * shifted)
            out[1, :, t] = self.wy @ np.abs(h * shifted)
            out[2, :, t] = self.wy @ (h**2 * shifted**2)
        return out

    def folded_square_integral(self, p: np.ndarray) -> float:
        """∫_[0,1)² (Σ_{n∈Z²} p(y + n))² dy for p given on the nodes."""
        m = self.per_texel
        folded = p.reshape(-1, m, p.shape[1] // m, m).sum(axis=(0, 2))
        return float(self.wy[:m] @ folded**2 @ self.wx[:m])


def lag0_estimate_sd(texton: Texton, n: int, mni: float = 30.0) -> np.ndarray:
    """Standard deviation of ĉ_ab = (1/N) Σ_x (g_a − m_a)(g_b − m_b) over N pixels of a raster.

    Var ĉ_ab ≤ (1/N) Σ_τ [|C_aa(τ) C_bb(τ)| + |C_ab(τ) C_ab(−τ)| + κ_ab(τ)] where the shot
    noise's fourth cumulant κ_ab(τ) = (1/λ) ∫ p(y) p(y + τ) dy, p = h_a h_b (E ε⁴ = 1), sums to
    (1/λ) ∫_[0,1)² (Σ_n p(y + n))² dy. Edges of a finite raster only lower the variance.
    """
    cov = model_covariance(texton)
    nodes = NodeModel(texton, sub=1)
    lam = mni / texton.support_area
    c = texton.channels
    out = np.zeros((c, c))
    for a in range(c):
        for b in range(c):
            gauss = np.abs(cov[a, a] * cov[b, b]).sum() + np.abs(cov[a, b] * cov[a, b][::-1, ::-1]).sum()
            kappa = nodes.folded_square_integral(nodes.h[:, :, a] * nodes.h[:, :, b]) / lam
            out[a, b] = math.sqrt((gauss + kappa) / n)
    return out


def mean_estimate_sd(texton: Texton, n: int) -> np.ndarray:
    """sd of the mean of g_a over N pixels of a raster: √((1/N) Σ_τ |C_aa(τ)|), per channel."""
    cov = model_covariance(texton)
    return np.sqrt(np.array([np.abs(cov[a, a]).sum() for a in range(texton.channels)]) / n)


class ColumnModel:
    """Per-column moments of strip-mixed noise, and the sampling error of their estimates.

    With R strips of width W / R (scale 1, offset 0), an impact at x_j takes the texton of the
    strip its texton's centre falls in, r = clamp(floor((x_j + c) R / W)) with c = (s − 1)/2 for
    an r × s texton; pixel column j sits at x = j + ½. For a node at x-offset d from the impact
    the impact lies at x − d, so column j's vertical covariance is
        C_j(τ) = Σ_q w_q ∫ h_{r(x − d_q)}(d_q, y) h_{r(x − d_q)}(d_q, y + τ) dy,
    exact because the strip borders fall on cell edges (half-integers with sub = 2; x + c is a
    half-integer or an integer). The
    variance profile is C_j(0). For n pixels of column j (rows of independent rasters):
        Var(mean)          ≤ (1/n) Σ_τ |C_j|(τ)       (|C_j| built from |h||h_τ|),
        Var(mean of g'²)   ≤ (1/n) Σ_τ [2 C_j(τ)² + κ_j(τ)],  κ_j(τ) = (1/λ) Σ_q w_q ∫ h² h²_τ dy,
    the fourth cumulant of the shot noise; edges of finite columns only lower these.
    """

    def __init__(self, textons, width: int, mni: float = 30.0):
        nodes = [NodeModel(t) for t in textons]
        terms = np.stack([m.vertical_lag_terms() for m in nodes])  # (R, 3, Q, lags)
        d = nodes[0].x
        wx = nodes[0].wx
        lam = mni / textons[0].support_area  # synthesize_mixed takes λ from textons[0]
        R = len(textons)
        x = np.arange(width) + 0.5
        c = (textons[0].size[1] - 1) / 2  # the texton's centre, texels right of its impact
        labels = np.clip(np.floor((x[:, None] - d[None, :] + c) * R / width), 0, R - 1).astype(int)  # (W, Q)
        per = terms[labels, :, np.arange(len(d))[None, :], :]  # (W, Q, 3, lags)
        c, _, k4 = (np.einsum("q,jqt->jt", wx, per[:, :, i, :]) for i in (0, 1, 2))
        self.variance = c[:, c.shape[1] // 2]
        self._c = c
        self.var_var_unit = (2 * c**2).sum(axis=1) + k4.sum(axis=1) / lam  # × 1/n

    def mean_sd(self, rows: int, rasters: int) -> np.ndarray:
        lags = np.arange(self._c.shape[1]) - self._c.shape[1] // 2
        return np.sqrt(self._c @ np.clip(1 - np.abs(lags) / rows, 0, None) / (rows * rasters))


def column_moments(textons, weights, shape, seeds, mean_profile, *, device):
    """Per-column mean and mean square of (g − m(x)) over the rows of one raster per seed."""
    s1 = s2 = 0.0
    for seed in seeds:
        g = synthesize_mixed(textons, weights, shape, seed=seed, device=device)[:, :, 0].astype(np.float64)
        dev = g - mean_profile[None, :]
        s1 = s1 + dev.mean(axis=0)
        s2 = s2 + (dev**2).mean(axis=0)
    return s1 / len(seeds), s2 / len(seeds)


def noise_part(textons, weights, shape, *, device, **kw) -> np.ndarray:
    """Σ ε h / √λ: the mixed field minus the mean that synthesize_mixed adds.

    The same textons with equal means are used where this is called, so the mean is a constant.
    """
    g = synthesize_mixed(textons, weights, shape, device=device, **kw).astype(np.float64)
    return g - np.asarray(textons[0].mean, np.float64)


# --------------------------------------------------------------------------- #
# 1-4. mix_textons                                                            #
# --------------------------------------------------------------------------- #
class TestMixTextons:
    @pytest.mark.parametrize("channels", [1, 3])
    @pytest.mark.parametrize("order", [0, 1])
    def test_rho_0_and_1_reproduce_the_single_models(self, channels, order):
        u, v = pair(channels)
        kw = dict(size=8, order=order, iterations=ITER, seed=5)
        t0, t1 = mix_textons(u, v, [0.0, 1.0], **kw)
        a, b = analyze(u, **kw), analyze(v, **kw)
        # τ_0 is t_u times a unit phase per frequency, and the start (white noise projected
        # onto the target) does not see a phase factor shared by the channels: the same
        # texton up to the float32 arithmetic of the projections.
        assert rel_diff(t0, a) < 1e-5 and rel_diff(t1, b) < 1e-5, (rel_diff(t0, a), rel_diff(t1, b))
        np.testing.assert_allclose(t0.mean, a.mean, rtol=1e-6)
        np.testing.assert_allclose(t1.mean, b.mean, rtol=1e-6)
        np.testing.assert_allclose(t0.metadata["model_error"], a.metadata["model_error"], rtol=1e-5)
        assert (t0.channels, t0.order, t0.size) == (channels, order, (8, 8))
        assert (t0.metadata["rho"], t1.metadata["rho"]) == (0.0, 1.0)

    @pytest.mark.parametrize("channels", [1, 3])
    def test_barycentre_lies_on_the_ot_geodesic(self, channels):
        u, v = pair(channels)
        fu, fv = full_kernel_spectrum(u), full_kernel_spectrum(v)
        d2 = ot_distance(fu, fv)
        assert d2 > 1e-4  # two clearly different models
        for rho in (0.0, 0.1, 0.25, 0.5, 0.8, 1.0):
            tau = barycentre_spectrum(fu, fv, rho)
            # τ_ρ is the spectrum of a real kernel (the phase is Hermitian-symmetric)
            kernel = np.fft.ifft2(tau, axes=(0, 1))
            assert np.abs(kernel.imag).max() < 1e-12 * np.abs(kernel.real).max()
            # EUSIPCO eq. (1): d(t_u, τ_ρ) = ρ d, d(τ_ρ, t_v) = (1 − ρ) d. Both hold exactly in
            # exact arithmetic (|t̂_u* τ̂_ρ| = (1 − ρ)|t̂_u|² + ρ|t̂_u* t̂_v| per frequency); in float64
            # the squared distances agree to ~1e-15 d², so 1e-12 d² on squares (1e-9 relative on
            # distances, where an endpoint's distance is 0 and its sqrt is ~1e-8 d).
            assert abs(ot_distance(fu, tau) - rho**2 * d2) < 1e-12 * d2, rho
            assert abs(ot_distance(tau, fv) - (1 - rho) ** 2 * d2) < 1e-12 * d2, rho
            if 0.05 < rho < 0.95:
                assert math.sqrt(ot_distance(fu, tau)) / math.sqrt(d2) == pytest.approx(rho, rel=1e-9)
                assert math.sqrt(ot_distance(tau, fv)) / math.sqrt(d2) == pytest.approx(1 - rho, rel=1e-9)
        # the naive average (1 − ρ) t_u + ρ t_v is not on the geodesic: the test can tell
        naive = 0.5 * fu + 0.5 * fv
        assert abs(ot_distance(fu, naive) - 0.25 * d2) > 1e-3 * d2

    @pytest.mark.parametrize("channels", [1, 3])
    def test_textons_model_the_barycentres(self, channels):
        u, v = pair(channels)
        fu, fv = full_kernel_spectrum(u), full_kernel_spectrum(v)
        rhos = [0.0, 0.25, 0.5, 0.75, 1.0]
        textons = mix_textons(u, v, rhos, size=8, iterations=ITER)
        grid = u.shape[:2]
        for rho, t in zip(rhos, textons):
            tau = barycentre_spectrum(fu, fv, rho)
            rme = relative_model_error(tau, t.spectrum(grid))
            # the analysis' own RME is of the same target (half-plane sums of the same spectra)
            assert t.metadata["model_error"] == pytest.approx(rme, rel=1e-6)
            # an 8 × 8 texton of a 48 × 48 model: the usual range (0.3-0.7 for real textures)
            assert rme < 0.7, (rho, rme)
            # the colour correction gives the noise the lag-0 covariance of τ_ρ exactly:
            # Σ_x τ τᵀ = (1/|Θ|) Σ_ξ τ̂ τ̂* (Parseval) = ∫ h hᵀ. This fails for a naive average.
            target = np.einsum("ijc,ijd->cd", tau, np.conj(tau)).real / tau[:, :, 0].size
            np.testing.assert_allclose(t.covariance(), target, rtol=1e-5, atol=1e-7 * np.trace(target))
            # the texton of τ_ρ is closer to τ_ρ than to the far end of the path
            if rho in (0.25, 0.75):
                far = fv if rho < 0.5 else fu
                assert rme < relative_model_error(far, t.spectrum(grid))

    @pytest.mark.parametrize("channels", [1, 3])
    def test_textons_vary_continuously_with_rho(self, channels):
        u, v = pair(channels)
        rhos = np.linspace(0.0, 1.0, 21)
        # Another seed gives an unrelated texton: relative distance ≈ √2 (independent phases).
        # With one projection the texton is the common white-noise start projected onto τ_ρ,
        # so a step of 0.05 moves it little (measured ≤ 0.14 against ≥ 1.1 between seeds).
        path = mix_textons(u, v, rhos, size=8, iterations=1, seed=3)
        other = mix_textons(u, v, rhos, size=8, iterations=1, seed=4)
        steps = [rel_diff(b, a) for a, b in zip(path, path[1:])]
        apart = [rel_diff(b, a) for a, b in zip(path, other)]
        assert min(apart) > 0.8
        assert max(steps) < 0.2 * min(apart), (max(steps), min(apart))
        # More projections amplify the differences (the map ρ ↦ α is continuous but its slope
        # grows with the iterations: single 0.05 steps reach 0.5 after 20 iterations and ~1,
        # as far as another seed, after 50), yet along the path textons stay related ...
        path = mix_textons(u, v, rhos, size=8, iterations=ITER, seed=3)
        other = mix_textons(u, v, rhos, size=8, iterations=ITER, seed=4)
        steps = [rel_diff(b, a) for a, b in zip(path, path[1:])]
        apart = [rel_diff(b, a) for a, b in zip(path, other)]
        assert np.mean(steps) < 0.3 * np.mean(apart), (np.mean(steps), np.mean(apart))  # measured 0.15-0.16 vs 1.1-1.5
        # ... and the change vanishes with the step: continuity
        for rho in (0.15, 0.5, 0.85):
            a, b, c = mix_textons(u, v, [rho, rho + 1e-3, rho + 1e-4], size=8, iterations=ITER, seed=3)
            assert rel_diff(b, a) < 0.03, rho  # measured ≤ 0.011
            assert rel_diff(c, a) < 0.3 * rel_diff(b, a), rho  # measured ≈ 0.1×: linear in the step

    @pytest.mark.parametrize("channels", [1, 3])
    def test_means_interpolate(self, channels):
        u, v = pair(channels)
        mu = u.reshape(-1, channels).astype(np.float64).mean(axis=0)
        mv = v.reshape(-1, channels).astype(np.float64).mean(axis=0)
        rhos = np.linspace(0.0, 1.0, 7)
        for rho, t in zip(rhos, mix_textons(u, v, rhos, size=8, iterations=2)):
            np.testing.assert_allclose(t.mean, (1 - rho) * mu + rho * mv, rtol=1e-6)
            assert t.metadata["rho"] == pytest.approx(rho)

    def test_same_seed_same_textons(self):
        u, v = pair(1)
        a = mix_textons(u, v, [0.3, 0.6], size=8, iterations=5, seed=9)
        b = mix_textons(u, v, np.array([0.3, 0.6]), size=8, iterations=5, seed=9)
        for x, y in zip(a, b):
            np.testing.assert_array_equal(x.coeffs, y.coeffs)
        assert rel_diff(mix_textons(u, v, [0.3], size=8, iterations=5, seed=10)[0], a[0]) > 0.5

    def test_scalar_rho(self):
        u, v = pair(1)
        (t,) = mix_textons(u, v, 0.5, size=8, iterations=2)
        assert t.metadata["rho"] == 0.5

    def test_images_of_different_sizes_are_centre_cropped(self):
        u, _ = pair(1, shape=(64, 80))
        _, v = pair(1)
        (t,) = mix_textons(u, v, [0.0], size=8, iterations=ITER)
        crop = u[8:56, 16:64]  # the central 48 × 48
        a = analyze(crop, size=8, iterations=ITER)
        assert rel_diff(t, a) < 1e-5
        np.testing.assert_allclose(t.mean, a.mean, rtol=1e-6)

    def test_grey_and_rgb_mix_as_rgb(self):
        grey, _ = pair(1)
        _, rgb = pair(3)
        ts = mix_textons(grey, rgb, [0.0, 0.5, 1.0], size=8, iterations=ITER)
        assert all(t.channels == 3 for t in ts)
        # ρ = 0: the grey model as three equal channels
        a = analyze(np.repeat(grey[:, :, None] if grey.ndim == 2 else grey, 3, axis=2), size=8, iterations=ITER)
        assert rel_diff(ts[0], a) < 1e-5
        assert rel_diff(ts[2], analyze(rgb, size=8, iterations=ITER)) < 1e-5
        m = 0.5 * float(grey.astype(np.float64).mean()) + 0.5 * rgb.reshape(-1, 3).astype(np.float64).mean(axis=0)
        np.testing.assert_allclose(ts[1].mean, m, rtol=1e-6)
        # the same with the RGB texture first
        back = mix_textons(rgb, grey, [0.0], size=8, iterations=ITER)[0]
        assert back.channels == 3 and rel_diff(back, ts[2]) < 1e-5

    def test_texton_inputs_stand_for_their_model(self):
        _, v = pair(1)
        t = Texton(0.3 * ndi.gaussian_filter(np.random.default_rng(8).standard_normal((8, 8, 1)), 1.0), [0.4], 1)
        t0, t1 = mix_textons(t, v, [0.0, 1.0], size=8, iterations=50)
        # ρ = 0 is the texton's own model, sampled on v's 48 × 48 grid: the colour correction
        # gives exactly its variance (Parseval; the 17 × 17 covariance support does not wrap),
        # and the alternating projections find an 8 × 8 texton close to that model.
        np.testing.assert_allclose(t0.covariance(), t.covariance(), rtol=1e-5)
        np.testing.assert_allclose(t0.mean, t.mean, rtol=1e-6)
        assert relative_model_error(t.spectrum((48, 48)), t0.spectrum((48, 48))) < 0.2
        assert rel_diff(t1, analyze(v, size=8, iterations=50)) < 1e-5
        # the same with the texton as v
        u, _ = pair(1)
        s0, s1 = mix_textons(u, t, [0.0, 1.0], size=8, iterations=50)
        assert rel_diff(s1, t0) < 1e-5 and rel_diff(s0, analyze(u, size=8, iterations=50)) < 1e-5
        # two textons: a grid large enough for both
        w = Texton(t.coeffs[::-1, ::-1] * 2.0, [0.6], 3)
        a, b = mix_textons(t, w, [0.0, 1.0], size=8, iterations=ITER)
        np.testing.assert_allclose(a.covariance(), t.covariance(), rtol=1e-5)
        np.testing.assert_allclose(b.covariance(), w.covariance(), rtol=1e-5)
        np.testing.assert_allclose(b.mean, [0.6], rtol=1e-6)

    def test_texton_larger_than_the_image_grid(self):
        _, v = pair(1)  # 48 × 48
        big = random_texton((64, 64), seed=9, offset=0.0, gain=0.05)
        try:
            (t0,) = mix_textons(big, v, [0.0], size=8, iterations=5)
        except TextonError:
            return  # refusing is a valid answer
        # otherwise ρ = 0 must carry the texton's model: at least its variance
        np.testing.assert_allclose(t0.covariance(), big.covariance(), rtol=1e-3)

    def test_geodesic_when_v_has_spectral_zeros(self):
        # v constant along y (vertical stripes): t̂_v = 0 exactly off the row ξ_y = 0, where
        # u has most of its energy. Any unit phase there keeps τ_0 = t_u in modulus.
        u, _ = pair(1)
        v = np.tile(np.random.default_rng(3).random(48), (48, 1)).astype(np.float32)
        fu, fv = full_kernel_spectrum(u), full_kernel_spectrum(v)
        assert np.count_nonzero(fv[1:] == 0) > 0.9 * fv[1:].size
        (t0,) = mix_textons(u, v, [0.0], size=8, iterations=ITER)
        np.testing.assert_allclose(t0.covariance(), analyze(u, size=8, iterations=ITER).covariance(), rtol=1e-5)
        d2 = ot_distance(fu, fv)
        for rho in (0.0, 0.5):
            tau = barycentre_spectrum(fu, fv, rho)
            assert abs(ot_distance(fu, tau) - rho**2 * d2) < 1e-9 * d2, rho


# --------------------------------------------------------------------------- #
# 5-9. synthesize_mixed                                                       #
# --------------------------------------------------------------------------- #
L, GAP, PER_SIDE, BLOCK = 64, 14, 12, 4
RASTER = PER_SIDE * (L + GAP)  # 936: 144 independent 64 × 64 windows (gap 14 > support width 9)
STACK = (random_texton(seed=20, mean=0.2), anisotropic_texton((8, 8), seed=21, mean=0.35), random_texton(seed=22, mean=0.8))


class TestConstantMap:
    @pytest.mark.parametrize("r", [0, 1, 2])
    def test_stationary_noise_with_that_textons_spectrum(self, r, device):
        t = STACK[r]
        rho = r / (len(STACK) - 1)
        acc, k = np.zeros((L, L)), 0
        means = []
        for seed in (1, 2):
            g = synthesize_mixed(STACK, np.full((RASTER, RASTER), rho), (RASTER, RASTER), seed=seed, device=device)
            g = g[:, :, 0].astype(np.float64)
            means.append(g.mean())
            dev = g - float(t.mean[0])
            for y in range(0, RASTER - L + 1, L + GAP):
                for x in range(0, RASTER - L + 1, L + GAP):
                    acc += np.abs(np.fft.fft2(dev[y:y + L, x:x + L])) ** 2
                    k += 1
        measured = acc / (k * L * L)
        assert k == 288
        # random signs do not change the covariance: E ε² = 1
        model = expected_periodogram(model_covariance(t)[0, 0], L)
        rel, z, rel_sd = block_zscores(measured, model, k, BLOCK)
        # K = 288 windows, 16 frequencies per block: relative sd ≈ 1/√(288·16) ≈ 1.5 %;
        # 256 blocks, P(|z| > 5) = 6e-7 each.
        assert np.all(rel_sd < 0.03)
        assert np.abs(z).max() < 5.0, f"worst block z = {np.abs(z).max():.2f}"
        # 128 independent conjugate pairs: mean z² = 1 ± 0.125; 1.5 is 4σ
        assert np.mean(z**2) < 1.5, np.mean(z**2)
        # an overall gain error: the mean relative deviation has sd ≈ 1.5 % / √128 ≈ 0.13 %
        assert abs(rel.mean()) < 5 * np.sqrt(np.mean(rel_sd**2) / 128), rel.mean()
        # the test tells the textons apart: the others' models are rejected by far
        for other in STACK:
            if other is not t:
                _, z_other, _ = block_zscores(measured, expected_periodogram(model_covariance(other)[0, 0], L), k, BLOCK)
                assert np.abs(z_other).max() > 20.0
        # the mean is that texton's: sd of a raster mean ≤ √(Σ_τ |C(τ)| / N), N = 936²
        sd = math.sqrt(np.abs(model_covariance(t)[0, 0]).sum() / RASTER**2)
        assert abs(np.mean(means) - float(t.mean[0])) < 5 * sd / math.sqrt(2), (np.mean(means), t.mean)

    def test_rgb_lag0_covariance_and_mean(self, device):
        ts = [random_texton(channels=3, seed=30 + k, mean=[0.2 + 0.1 * k, 0.5, 0.6 - 0.1 * k]) for k in range(2)]
        t = ts[1]
        g = synthesize_mixed(ts, np.ones((512, 512)), (512, 512), seed=4, device=device).astype(np.float64)
        dev = (g - t.mean.astype(np.float64)).reshape(-1, 3)
        sd = lag0_estimate_sd(t, dev.shape[0])  # ≈ 0.5 % of the variances
        target = t.covariance()
        assert np.all(5 * sd < 0.15 * np.sqrt(np.outer(np.diag(target), np.diag(target))))
        z = (dev.T @ dev / dev.shape[0] - target) / sd
        assert np.abs(z).max() < 5.0, z
        # the mean colour is that texton's, not the other's (they differ by 0.1 in R and B)
        z_mean = (g.reshape(-1, 3).mean(axis=0) - t.mean) / mean_estimate_sd(t, dev.shape[0])
        assert np.abs(z_mean).max() < 5.0, z_mean
        assert np.all(mean_estimate_sd(t, dev.shape[0])[[0, 2]] < 0.01)

    def test_labels_round_rho_and_means_interpolate(self, device):
        # Textons c_r · t (c = 1, −1, 2) with means 0.2, 0.5, 0.6. For a constant map the
        # field is m(ρ) + c_{round(2ρ)} · N with N the one-texton mixed noise of t at that
        # seed (same impacts, same signs): an exact identity.
        t = random_texton(seed=40, mean=0.0)
        ts = [scaled(t, 1.0, [0.2]), scaled(t, -1.0, [0.5]), scaled(t, 2.0, [0.6])]
        base = synthesize_mixed([t], "strips", (40, 48), seed=6, device=device)[:, :, 0].astype(np.float64)
        assert base.std() > 0.05
        for rho, c in ((0.0, 1.0), (0.24, 1.0), (0.26, -1.0), (0.5, -1.0), (0.74, -1.0), (0.76, 2.0), (1.0, 2.0)):
            g = synthesize_mixed(ts, np.full((40, 48), rho), (40, 48), seed=6, device=device)[:, :, 0]
            m = np.interp(rho, [0.0, 0.5, 1.0], [0.2, 0.5, 0.6])
            np.testing.assert_allclose(g - m, c * base, atol=1e-5, err_msg=f"rho {rho}")

    def test_single_texton_strips_has_the_model_variance(self, device):
        t = anisotropic_texton((8, 8), seed=41, mean=0.25)
        g = synthesize_mixed([t], "strips", (512, 512), seed=7, device=device)[:, :, 0].astype(np.float64)
        c0 = t.covariance()[0, 0]
        np.testing.assert_allclose(ColumnModel([t], 512).variance, c0, rtol=1e-9)
        sd = lag0_estimate_sd(t, g.size)[0, 0]  # ≈ 0.7 % of C(0)
        assert 5 * sd < 0.1 * c0
        assert abs(np.mean((g - 0.25) ** 2) - c0) < 5 * sd, (np.mean((g - 0.25) ** 2) / c0, sd / c0)
        assert abs(g.mean() - 0.25) < 5 * mean_estimate_sd(t, g.size)[0]

    def test_random_signs_make_the_sum_zero_mean(self, device):
        # all-positive coefficients: ∫h = Σα ≈ 6.4 and λ = 30/81, so a sum without random signs
        # would be off by √λ ∫h ≈ 3.9, and one with signs that still subtracted λ∫h/√λ by −3.9.
        # The raster mean has sd ≤ √(Σ_τ C(τ) / N) = Σα / √N (Σ_τ C = (Σα)² Σb, Σb = 1).
        t = Texton(0.1 + 0.02 * np.random.default_rng(42).random((8, 8, 1)), [0.5], 1)
        assert t.integral[0] > 6.0
        for seed in (1, 2):
            g = synthesize_mixed([t], "strips", (256, 256), seed=seed, device=device)
            sd = t.integral[0] / 256
            assert abs(g.mean() - 0.5) < 5 * sd, (g.mean(), sd)
            # plain texton noise reaches the same mean by subtracting λ ∫h instead
            plain = synthesize(t, (256, 256), seed=seed, device=device)
            assert abs(plain.mean() - 0.5) < 5 * sd
            assert not np.allclose(g, plain)


class TestStripsAndMaps:
    def test_no_seams_variance_changes_over_the_support_width(self, device):
        # smooth coefficients spread the energy over the columns of the support
        a = 0.3 * ndi.gaussian_filter(np.random.default_rng(51).standard_normal((8, 8, 1)), 1.0) + 0.02
        t = Texton(a, [0.5], 1)
        ts = [t, scaled(t, 2.0)]  # variance ratio 4, equal means
        W, H, seeds = 64, 936, range(16)
        col = ColumnModel(ts, W)
        _, v = column_moments(ts, "strips", (H, W), seeds, np.full(W, 0.5), device=device)
        n = H * len(seeds)
        sd = np.sqrt(col.var_var_unit / n)  # 2.5-3 % of the local variance
        v0 = t.covariance()[0, 0]
        # plateaus of the model: an impact p is labelled by its texton's centre p + 3.5, and
        # reaches x in [p − 1, p + 8]; exactly C(0) where only left impacts reach (x + 1 + 3.5
        # ≤ 32), 4 C(0) where only right ones do (x − 8 + 3.5 ≥ 32): symmetric about the border
        np.testing.assert_allclose(col.variance[:28], v0, rtol=1e-9)
        np.testing.assert_allclose(col.variance[36:], 4 * v0, rtol=1e-9)
        assert col.variance[28] > v0 * (1 + 1e-6) and col.variance[35] < 4 * v0 * (1 - 1e-6)
        z = (v - col.variance) / sd
        assert np.abs(z).max() < 5.0, np.round(z, 1)  # 64 correlated columns: 5σ
        # a step at the border column (labelling pixels instead of impacts) is rejected
        step = np.where(np.arange(W) < W // 2, v0, 4 * v0)
        assert np.abs((v - step) / sd).max() > 10
        # no seam: the variance climbs over the support's width, not at one column. In the
        # model no adjacent-column jump exceeds 1/4 of the plateau difference; measured jumps
        # agree up to the sampling error of a difference (≤ 2 · 5 sd).
        model_jump = np.abs(np.diff(col.variance)).max()
        assert model_jump < 0.25 * 3 * v0, model_jump / (3 * v0)  # 0.19 here
        jumps = np.abs(np.diff(v))
        assert jumps.max() < model_jump + 10 * sd.max(), (jumps.max(), model_jump)
        # measured: at least 6 columns lie strictly between the plateaus, beyond 5σ of each,
        # all of them within the transition band centred on the border
        between = (v > v0 + 5 * sd) & (v < 4 * v0 - 5 * sd)
        idx = np.flatnonzero(between)
        assert between.sum() >= 6 and np.all((idx >= 28) & (idx < 36)), idx
        assert np.all(v[W // 2 - 4: W // 2 + 4] > v0 - 5 * sd[:28].max())
        assert np.all(v[W // 2 - 4: W // 2 + 4] < 4 * v0 + 5 * sd[36:].max())

    def test_strips_ramp_the_mean_and_keep_each_textons_variance(self, device):
        u, v = pair(1)
        ts = mix_textons(u, v, [0.0, 0.5, 1.0], size=8, iterations=ITER)
        W, H, seeds = 192, 936, range(12)
        x = (np.arange(W) + 0.5) / W
        m0, m1 = float(ts[0].mean[0]), float(ts[-1].mean[0])
        ramp = (1 - x) * m0 + x * m1
        col = ColumnModel(ts, W)
        mean, var = column_moments(ts, "strips", (H, W), seeds, ramp, device=device)
        n = H * len(seeds)
        # per-column means follow the linear ramp (192 correlated columns: 5σ)
        sd_mean = col.mean_sd(H, len(seeds))
        z_mean = mean / sd_mean
        assert np.abs(z_mean).max() < 5.0, np.abs(z_mean).max()
        # a per-strip constant mean would be off by (m1 − m0) / 6 at the strip edges: > 10σ
        assert abs(m1 - m0) / 6 > 10 * sd_mean.max()
        # the variance profile is the model's (5σ over 192 columns)
        z_var = (var - col.variance) / np.sqrt(col.var_var_unit / n)
        assert np.abs(z_var).max() < 5.0, np.abs(z_var).max()
        # far from the borders (≥ 4 columns from a border, either side: impacts are labelled
        # at their texton's centre) each strip has its texton's variance, which differ
        for r, t in enumerate(ts):
            plateau = np.arange(r * 64 + 4, (r + 1) * 64 - 4)
            np.testing.assert_allclose(col.variance[plateau], t.covariance()[0, 0], rtol=1e-9)
            # pooled over the plateau's pixels, which only see this texton's impacts
            pooled_sd = lag0_estimate_sd(t, n * len(plateau))[0, 0]
            assert abs(var[plateau].mean() - t.covariance()[0, 0]) < 5 * pooled_sd
        c = [t.covariance()[0, 0] for t in ts]
        assert c[2] > 2 * c[0]

    @pytest.mark.parametrize("kind", ["strips", "map-columns", "map-rows"])
    @pytest.mark.parametrize("geometry", [dict(), dict(offset=(-1234.5, 777.25)), dict(scale=2.0)])
    def test_impacts_take_the_texton_of_their_region(self, kind, geometry, device):
        # Given the labels the field is linear in the textons. With [t, t] it is L + R, with
        # [t, −t] it is L − R (L, R: the impacts labelled 0 and 1), with [t, 2t] L + 2R:
        # an exact identity. R vanishes where no impact of region 1 reaches, L where none of
        # region 0 does: in pixel units an impact at p reaches pixel centres in
        # p + [lo, hi]·scale, lo = −1, hi = 8 for an 8 × 8 bilinear texton, and is labelled by
        # its texton's centre p + 3.5·scale.
        t = random_texton(seed=60, mean=0.5)
        H, W = 48, 64
        s = geometry.get("scale", 1.0)
        if kind == "strips":
            weights = "strips"
        elif kind == "map-columns":
            weights = np.zeros((H, W))
            weights[:, W // 2:] = 1.0
        else:
            weights = np.zeros((H, W))
            weights[H // 2:] = 1.0
        kw = dict(seed=3, **geometry)
        both = noise_part([t, t], weights, (H, W), **kw, device=device)
        diff = noise_part([t, scaled(t, -1.0)], weights, (H, W), **kw, device=device)
        left, right = (both + diff) / 2, (both - diff) / 2
        np.testing.assert_allclose(noise_part([t, scaled(t, 2.0)], weights, (H, W), **kw, device=device),
                                   left + 2 * right, atol=1e-5)
        n_across = H if kind == "map-rows" else W
        centre = np.arange(n_across) + 0.5
        border = n_across / 2
        no_right = centre + 4.5 * s <= border  # impacts reaching it have p + 3.5 s ≤ centre + 4.5 s (h = 0 at equality)
        no_left = centre - 4.5 * s >= border  # ... and p + 3.5 s ≥ centre − 8 s + 3.5 s
        if kind == "map-rows":
            right, left = right.transpose(1, 0, 2), left.transpose(1, 0, 2)
        # zero up to the float32 rounding of the field (~3e-8 at a mean of 0.5)
        tol = 1e-5 * both.std()
        assert np.all(np.abs(right[:, no_right]) < tol)
        assert np.all(np.abs(left[:, no_left]) < tol)
        # and both are present where they should be: every column of each has signal
        assert np.all(np.abs(right[:, ~no_right]).max(axis=(0, 2)) > 100 * tol)
        assert np.all(np.abs(left[:, ~no_left]).max(axis=(0, 2)) > 100 * tol)

    def test_half_map_has_the_two_textons_statistics(self, device):
        ta, tb = random_texton(seed=70, mean=0.3), scaled(anisotropic_texton((8, 8), seed=71), 1.5, [0.7])
        H, W = 936, 128
        rho = np.zeros((H, W))
        rho[:, W // 2:] = 1.0
        g = synthesize_mixed([ta, tb], rho, (H, W), seed=8, device=device)
        # a map (H, W, 1) is the same map
        np.testing.assert_array_equal(synthesize_mixed([ta, tb], rho[:, :, None], (H, W), seed=8, device=device), g)
        # the noise is that of two strips (both label an impact by the column it lands in);
        # only the mean differs: a step here, a ramp there
        strips = synthesize_mixed([ta, tb], "strips", (H, W), seed=8, device=device)
        x = (np.arange(W) + 0.5) / W
        mean_map = np.where(np.arange(W) < W // 2, 0.3, 0.7)
        np.testing.assert_allclose(g[:, :, 0] - mean_map, strips[:, :, 0] - ((1 - x) * 0.3 + x * 0.7), atol=1e-5)
        # each half, away from the border (labelled at their centre, 3.5 columns right of the
        # impact, impacts reach 4.5 columns either side of it), has its texton's mean and
        # variance; these pixels only see that texton's impacts
        g = g[:, :, 0].astype(np.float64)
        for t, cols in ((ta, slice(0, W // 2 - 5)), (tb, slice(W // 2 + 5, W))):
            part = g[:, cols]
            c0 = t.covariance()[0, 0]
            assert abs(np.mean((part - float(t.mean[0])) ** 2) - c0) < 5 * lag0_estimate_sd(t, part.size)[0, 0]
            assert abs(part.mean() - float(t.mean[0])) < 5 * mean_estimate_sd(t, part.size)[0]
        assert tb.covariance()[0, 0] > 2 * ta.covariance()[0, 0]


class TestConsistency:
    def test_same_seed_same_output(self, device):
        ts = list(STACK)
        a = synthesize_mixed(ts, "strips", (40, 60), seed=11, device=device)
        np.testing.assert_array_equal(a, synthesize_mixed(ts, "strips", (40, 60), seed=11, device=device))
        b = synthesize_mixed(ts, "strips", (40, 60), seed=12, device=device)
        assert np.abs(a - b).mean() > 0.1 * a.std()
        assert a.dtype == np.float32 and a.shape == (40, 60, 1) and a.flags.c_contiguous

    @pytest.mark.parametrize("order", [0, 1, 3])
    @pytest.mark.parametrize("geometry", [dict(), dict(scale=2.5, offset=(-300.25, 41.5))])
    def test_gather_equals_splat(self, order, geometry, device):
        ts = [random_texton(channels=3, order=order, seed=80 + k, mean=[0.1 * k, 0.5, 0.3]) for k in range(3)]
        rho = np.random.default_rng(order).random((30, 26))
        std = math.sqrt(np.trace(ts[0].covariance()) / 3)
        for weights in ("strips", rho):
            kw = dict(seed=13, **geometry)
            a = synthesize_mixed(ts, weights, (30, 26), method="splat", device="cpu", **kw)
            b = synthesize_mixed(ts, weights, (30, 26), method="gather", device=device, **kw)
            bad = np.any(np.abs(a - b) > 1e-4 * std, axis=-1)
            # order 0 is discontinuous: a pixel within float rounding (~1e-5 texel) of a cell edge
            # of some impact may fall either side on the two paths (~0.2 % of pixels)
            assert bad.mean() <= (0.02 if order == 0 else 0.0), bad.mean()
            np.testing.assert_array_equal(a, synthesize_mixed(ts, weights, (30, 26), method="auto", **kw))

    @pytest.mark.parametrize("channels", [1, 3])
    def test_constant_map_tiles_like_synthesize(self, channels, device):
        # labels of a constant map do not depend on the position, so windows of the mixed
        # noise join as plain windows do (CGF §8), and a coarser scale samples the same noise
        ts = [random_texton(channels=channels, seed=90 + k, mean=0.4) for k in range(2)]
        H, W, o = 24, 30, (-77.5, 1000.25)
        whole = synthesize_mixed(ts, np.ones((H, 2 * W)), (H, 2 * W), seed=5, offset=o, device=device)
        left = synthesize_mixed(ts, np.ones((H, W)), (H, W), seed=5, offset=o, device=device)
        right = synthesize_mixed(ts, np.ones((H, W)), (H, W), seed=5, offset=(o[0] + W, o[1]), device=device)
        std = math.sqrt(np.trace(ts[1].covariance()) / channels)
        np.testing.assert_allclose(np.hstack([left, right]), whole, atol=1e-4 * std)
        small = synthesize_mixed(ts, np.ones((8, 10)), (8, 10), seed=5, scale=1 / 3, offset=o, device=device)
        np.testing.assert_allclose(small, whole[1::3, 1:30:3], atol=1e-4 * std)

    def test_zero_texton_in_the_list(self, device):
        t = random_texton(seed=95)
        zero = Texton(np.zeros((8, 8, 1)), [0.5], 1)
        try:
            g = synthesize_mixed([t, zero], "strips", (16, 32), device=device)
        except TextonError:
            return  # refusing it (with a TextonError) is acceptable
        assert np.isfinite(g).all()


# --------------------------------------------------------------------------- #
# 10. Bad input                                                               #
# --------------------------------------------------------------------------- #
T8 = random_texton(seed=110)
T8B = random_texton(seed=111, mean=0.7)


class TestErrors:
    @pytest.mark.parametrize(
        "weights, match",
        [
            (np.full((8, 16), 1.5), r"weights map values must lie in \[0, 1\]; found 1\.5 to 1\.5"),
            (np.full((8, 16), -0.25), r"must lie in \[0, 1\]; found -0\.25"),
            (np.where(np.eye(8, 16) > 0, np.nan, 0.5), "NaN or infinite"),
            (np.where(np.eye(8, 16) > 0, np.inf, 0.5), "NaN or infinite"),
            (np.zeros((16, 8)), r"weights map has shape \(16, 8\); it must match the raster shape \(8, 16\)"),
            (np.zeros((8, 16, 3)), r"weights map has shape \(8, 16, 3\)"),
            (np.zeros(16), r"weights map has shape \(16,\)"),
            (0.5, r"weights map has shape \(\)"),
            ("stripes", "weights must be 'strips' or an \\(H, W\\) map"),
            ("", "weights must be 'strips'"),
            ([[0.0, 1.0], [0.5]], "weights must be 'strips' or an"),
            (np.full((8, 16), "a"), "weights must be 'strips' or an"),
        ],
    )
    def test_weights(self, weights, match, device):
        with pytest.raises(TextonError, match=match):
            synthesize_mixed([T8, T8B], weights, (8, 16), device=device)

    @pytest.mark.parametrize(
        "textons, match",
        [
            ([T8, random_texton((6, 8), seed=1)], r"textons\[1\] is 8x6, order 1, 1 channels, but textons\[0\] is 8x8"),
            ([T8, T8B, random_texton(order=3, seed=1)], r"textons\[2\] is 8x8, order 3"),
            ([T8, random_texton(channels=3, seed=1)], r"textons\[1\] is 8x8, order 1, 3 channels"),
            ([], "textons must be a non-empty sequence of Texton"),
            ([T8, "grass.texton"], "textons must be a non-empty sequence of Texton"),
            ([T8.coeffs], "textons must be a non-empty sequence of Texton"),
            (None, "textons must be a sequence of Texton"),
            (5, "textons must be a sequence of Texton"),
        ],
    )
    def test_textons(self, textons, match, device):
        with pytest.raises(TextonError, match=match):
            synthesize_mixed(textons, "strips", (8, 16), device=device)

    def test_one_texton_may_be_given_alone(self, device):
        a = synthesize_mixed(T8, "strips", (8, 16), seed=2, device=device)
        np.testing.assert_array_equal(a, synthesize_mixed([T8], "strips", (8, 16), seed=2, device=device))
        np.testing.assert_array_equal(a, synthesize_mixed((T8,), np.zeros((8, 16)), (8, 16), seed=2, device=device))

    @pytest.mark.parametrize(
        "kw, match",
        [
            (dict(mni=0.0), "mni"),
            (dict(mni=float("nan")), "mni"),
            (dict(mni="30"), "mni"),
            (dict(shape=(0, 16)), r"shape\[0\] \(height\) must be at least 1"),
            (dict(shape=(8,)), "shape must be a pair"),
            (dict(shape=(8.5, 16)), "must be an integer"),
            (dict(seed=-1), "seed"),
            (dict(seed=2**32), "seed"),
            (dict(seed=1.5), "seed"),
            (dict(scale=0.0), "scale"),
            (dict(offset=(1.0,)), "offset"),
            (dict(offset=(0.0, float("nan"))), "offset"),
            (dict(method="bogus"), "method must be one of"),
            (dict(device="tpu"), "device"),
        ],
    )
    def test_placement_and_options(self, kw, match, device):
        kw = {"shape": (8, 16), "device": device, **kw}
        with pytest.raises(TextonError, match=match):
            synthesize_mixed([T8, T8B], "strips", **kw)

    @pytest.mark.parametrize(
        "rhos, match",
        [
            ([0.0, 1.5], r"rhos must lie in \[0, 1\]; got 1\.5"),
            ([-0.1], r"rhos must lie in \[0, 1\]; got -0\.1"),
            ([0.5, float("nan")], r"rhos must lie in \[0, 1\]; got nan"),
            ([float("inf")], r"rhos must lie in \[0, 1\]"),
            ([], "rhos must hold at least one value"),
            (np.zeros(0), "rhos must hold at least one value"),
            ("half", "rhos must be numbers in"),
            ([0.5, "a"], "rhos must be numbers in"),
            (None, "rhos must be numbers in|rhos must lie in"),
        ],
    )
    def test_rhos(self, rhos, match):
        u, v = pair(1)
        with pytest.raises(TextonError, match=match):
            mix_textons(u, v, rhos, size=8, iterations=1)

    @pytest.mark.parametrize(
        "kw, match",
        [
            (dict(size=49), r"u, v: the common grid of both images \(48x48\) is too small for size 49; .*size <= 48"),
            (dict(size=1), "size must be at least 2"),
            (dict(size=8.0), "size must be an integer"),
            (dict(order=2), "order must be one of 0, 1, 3, 5"),
            (dict(iterations=0), "iterations must be at least 1"),
            (dict(seed=-1), "seed"),
            (dict(support="hexagon"), "support must be one of square, disk"),
        ],
    )
    def test_mix_options(self, kw, match):
        u, v = pair(1)
        with pytest.raises(TextonError, match=match):
            mix_textons(u, v, [0.5], **{"size": 8, "iterations": 1, **kw})

    def test_too_small_after_cropping(self):
        # the common size is the smaller of each side: 48 rows × 20 columns here
        u, _ = pair(1, shape=(64, 20))
        _, v = pair(1)
        with pytest.raises(TextonError, match=r"common grid of both images \(20x48\) is too small for size 21"):
            mix_textons(u, v, [0.5], size=21, iterations=1)
        assert mix_textons(u, v, [0.5], size=20, iterations=1)[0].size == (20, 20)

    @pytest.mark.parametrize(
        "which, image, match",
        [
            ("u", np.full((48, 48), np.nan), "u: contains 2304 NaN or infinite values"),
            ("v", np.zeros((48, 48, 2)), "v: has 2 channels"),
            ("v", np.zeros((2, 48, 48, 1)), r"v: expected an image of shape \(H, W\) or \(H, W, C\)"),
            ("u", "grass.png", "u: expected a numeric image array"),
            ("u", np.full((48, 48), 0.5), "u: the image is constant"),
        ],
    )
    def test_bad_images(self, which, image, match):
        u, v = pair(1)
        args = (image, v) if which == "u" else (u, image)
        with pytest.raises(TextonError, match=match):
            mix_textons(*args, [0.5], size=8, iterations=1)

    def test_constant_v_is_refused(self):
        u, _ = pair(1)
        with pytest.raises(TextonError, match="the image is constant"):
            mix_textons(u, np.full((48, 48), 0.5), [0.5], size=8, iterations=1)

    def test_constant_v_error_names_v(self):
        u, _ = pair(1)
        with pytest.raises(TextonError, match=r"^v: the image is constant"):
            mix_textons(u, np.full((48, 48), 0.5), [0.5], size=8, iterations=1)

    def test_texton_error_is_a_value_error(self, device):
        with pytest.raises(ValueError):
            synthesize_mixed([T8], np.full((8, 16), 2.0), (8, 16), device=device)


# --------------------------------------------------------------------------- #
# 11. Command line                                                            #
# --------------------------------------------------------------------------- #
def write_png(path, img) -> Path:
    Image.fromarray(np.round(np.clip(img, 0, 1) * 255).astype(np.uint8).squeeze()).save(path)
    return path


@pytest.fixture
def textures(tmp_path):
    """A dark and a bright 32 × 32 grey texture (means ≈ 0.3 and 0.7, sd ≈ 0.05 and 0.1)."""
    rng = np.random.default_rng(7)
    k = ndi.gaussian_filter(rng.standard_normal((6, 6)), 1.0)
    a = adsn(0.05 * k / np.abs(k).max(), (32, 32), 0.3, seed=1)
    b = adsn(0.10 * k.T / np.abs(k).max(), (32, 32), 0.7, seed=2)
    return write_png(tmp_path / "a.png", a), write_png(tmp_path / "b.png", b)


FAST = ["--steps", 5, "--size", 8, "--iterations", 3, "-q", "--device", "cpu"]  # CLI behaviour, not a device property


@pytest.mark.usefixtures("restore_warning_format")
class TestCli:
    def test_strips(self, tmp_path, textures, capsys):
        out = tmp_path / "mix.png"
        status = run_cli(["mix", *textures, "-o", out, "--width", 64, "--height", 32, *FAST])
        captured = capsys.readouterr()
        assert status == 0, captured.err
        assert captured.out == "" and captured.err == ""
        img = read_image(out)
        assert img.shape == (32, 64, 1)
        # the ramp from A's mean (≈ 0.3) to B's (≈ 0.7): the outer 16-column bands' means differ
        # by ≈ 0.3, their sd is ≤ 0.1 (pixel sd) · √(81 / 512) ≈ 0.04 (impacts of 9 × 9 texels)
        left, right = img[:, :16].mean(), img[:, -16:].mean()
        assert right - left > 0.15, (left, right)
        assert sorted(p.name for p in tmp_path.iterdir()) == ["a.png", "b.png", "mix.png"]

    def test_exr_output_and_summary(self, tmp_path, textures, capsys, device):
        out = tmp_path / "mix.exr"
        args = ["mix", *textures, "-o", out, "--width", 40, "--height", 24, "--steps", 3, "--size", 8,
                "--iterations", 2, "--seed", 4, "--device", device]
        assert run_cli(args) == 0
        summary = capsys.readouterr().out
        assert f"{out}: 40x24 mix of 3 textons" in summary
        img = read_image(out)
        assert img.shape == (24, 40, 1) and img.dtype == np.float32
        # the same as the API with the same parameters
        a, b = (read_image(p) for p in textures)
        ts = mix_textons(a, b, np.linspace(0, 1, 3), size=8, iterations=2, seed=4)
        np.testing.assert_allclose(img, synthesize_mixed(ts, "strips", (24, 40), seed=4, device=device), atol=1e-6)

    def test_map(self, tmp_path, textures, capsys):
        rho = np.zeros((32, 64))
        rho[:, 32:] = 1.0
        mask = write_png(tmp_path / "mask.png", rho)
        out = tmp_path / "mix.png"
        # the raster takes the map's size by default
        assert run_cli(["mix", *textures, "-o", out, "--map", mask, *FAST]) == 0
        img = read_image(out)[:, :, 0]
        assert img.shape == (32, 64)
        # black = A (mean ≈ 0.3), white = B (≈ 0.7); half means have sd ≤ 0.1 · √(81 / 1024) ≈ 0.03
        assert abs(img[:, :30].mean() - 0.3) < 0.1 and abs(img[:, 40:].mean() - 0.7) < 0.1
        # an explicit size that matches the map is accepted
        assert run_cli(["mix", *textures, "-o", out, "--map", mask, "--width", 64, "--height", 32, *FAST]) == 0

    @pytest.mark.parametrize(
        "extra, match",
        [
            (["--steps", 1], r"--steps must be at least 2, got 1"),
            (["--steps", 0], r"--steps must be at least 2, got 0"),
            (["--map", "MASK", "--width", 50], r"--map is 64x32; --width/--height must match it \(got 50x32\)"),
            (["--map", "MASK", "--height", 33], r"--map is 64x32; .*\(got 64x33\)"),
            (["--size", 33], r"too small for --size 33"),
            (["--steps", "two"], r"argument --steps: invalid int value"),
        ],
    )
    def test_user_errors(self, tmp_path, textures, capsys, extra, match, device):
        mask = write_png(tmp_path / "mask.png", np.zeros((32, 64)))
        extra = [mask if x == "MASK" else x for x in extra]
        out = tmp_path / "mix.png"
        base = ["mix", *textures, "-o", out, "--size", 8, "--iterations", 2, "-q", "--device", device]
        self.assert_user_error(capsys, [*base, *extra], match, out)

    def test_missing_input(self, tmp_path, textures, capsys):
        out = tmp_path / "mix.png"
        missing = tmp_path / "none.png"
        self.assert_user_error(capsys, ["mix", textures[0], missing, "-o", out, *FAST], re.escape(f"{missing}: no such file"), out)

    def test_unsupported_output_extension(self, tmp_path, textures, capsys):
        out = tmp_path / "mix.bmp"
        self.assert_user_error(capsys, ["mix", *textures, "-o", out, *FAST], r"unsupported extension '\.bmp'", out)

    @staticmethod
    def assert_user_error(capsys, argv, match, out):
        """Exit 2, one 'warp-texton: error:' line on stderr, no traceback, no output nor partial file."""
        status = run_cli(argv)
        captured = capsys.readouterr()
        assert status == 2
        lines = captured.err.splitlines()
        assert len(lines) == 1, captured.err
        assert lines[0].startswith("warp-texton: error: "), lines[0]
        assert re.search(match, lines[0]), lines[0]
        assert "Traceback" not in captured.err + captured.out
        assert not Path(out).exists()
        assert not [p for p in Path(out).parent.iterdir() if p.name.endswith(".part")]


class TestMixArgumentsFirst:
    """`mix` checks every argument, and prices its steps, before reading or analysing a texture."""

    @pytest.mark.parametrize("extra, match", [
        (["--steps", "400000000", "--size", "8"], r"mixing 400000000 textons of 8x8 needs about .* use fewer --steps"),
        (["--width", "0"], r"--width must be at least 1"),
        (["--height", "-2"], r"--height must be at least 1"),
        (["--mni", "0"], r"--mni must be a finite number > 0"),
        (["--size", "1"], r"size must be at least 2"),
        (["--steps", "1"], r"--steps must be at least 2"),
    ])
    def test_refused_before_reading(self, tmp_path, monkeypatch, capsys, extra, match):
        import warp_texton.cli.image_commands as C

        read = []
        monkeypatch.setattr(C, "_load_texture", lambda path: read.append(path))
        code = run_cli(["mix", tmp_path / "a.png", tmp_path / "b.png", "-o", tmp_path / "m.png", *extra])
        err = capsys.readouterr().err
        assert code == 2 and re.search(match, err) and len(err.strip().splitlines()) == 1, err
        assert not read and not list(tmp_path.iterdir())

    def test_missing_output_folder_refused_first(self, tmp_path, monkeypatch, capsys):
        import warp_texton.cli.image_commands as C

        monkeypatch.setattr(C, "_load_texture", lambda path: pytest.fail("read before the output was checked"))
        assert run_cli(["mix", "a.png", "b.png", "-o", tmp_path / "no" / "m.png"]) == 2
        assert "the folder" in capsys.readouterr().err

    def test_rhos_priced_before_their_list(self):
        from warp_texton.core.limits import set_memory_budget
        from warp_texton.noise.mixing import mix_bytes

        set_memory_budget(mix_bytes(1000, 8) - 1)
        try:
            with pytest.raises(TextonError, match=r"mixing 1000 textons of 8x8 .* use fewer rhos") as info:
                mix_textons(np.zeros((4, 4)), np.zeros((4, 4)), np.linspace(0, 1, 1000), size=8)
        finally:
            set_memory_budget(None)
        assert info.value.param == "rhos"
