"""The translation process: the Gaussian covariance that lands on an example's after its tables.

A histogram-preserving texton's outputs are T_c(G_c): a pointwise non-decreasing map T_c (the
lookup table of channel c, :class:`~warp_texton.model.histogram.HistogramTransform`) applied to
a stationary field G of standard Gaussian channels. With the normalised probabilists' Hermite
polynomials h_k = He_k / √k! and b_{c,k} = E[T_c(X) h_k(X)] (X standard normal), Mehler's formula
gives the covariance of the outputs from the correlation ρ_cd(τ) of G_c(x) and G_d(x + τ):

    Cov(T_c(G_c(x)), T_d(G_d(x + τ))) = Σ_{k ≥ 1} b_{c,k} b_{d,k} ρ_cd(τ)^k  (= Σ c_k c'_k ρ^k / k!),

non-decreasing in ρ on [−1, 1] for non-decreasing maps (Price's theorem: its derivative is
E[T_c'(X) T_d'(Y)] ≥ 0). Inverting it lag by lag gives the correlation G needs so that the
outputs have the example's covariance (Grigoriu 1984; Deodatis & Micaloff 2001). Where the
example's correlation lies outside the series' range [f(−1), f(1)] no Gaussian correlation maps
onto it: it is clamped to the range; where the inverted correlations are not a covariance (a
cross-spectral matrix with negative eigenvalues), the nearest one is taken by clipping those
eigenvalues. Both changes are recorded. Derivation and choices: docs/histogram.md, "The
translation process".
"""

from __future__ import annotations

import numpy as np

from .bspline import bspline
from .histogram import CDF_OVERSAMPLING, CDF_POINTS, CDF_SPAN

#: Terms of the Hermite series (past them the rest of each variance is lumped into ρ^(K+1)).
HERMITE_TERMS = 24
#: The quadrature of the Hermite coefficients: points over [−QUAD_RANGE, QUAD_RANGE].
QUAD_POINTS = 4097
QUAD_RANGE = 9.0
#: Points of the tabulated series over ρ ∈ [−1, 1], inverted by interpolation and one Newton step.
RHO_POINTS = 2049


def hermite_functions(x: np.ndarray, terms: int) -> np.ndarray:
    """(terms + 1, len(x)): h_k(x) = He_k(x) / √k!, k = 0..terms, by the stable recurrence
    h_{k+1} = (x h_k − √k h_{k−1}) / √(k + 1)."""
    h = np.empty((terms + 1, len(x)))
    h[0] = 1.0
    if terms:
        h[1] = x
    for k in range(1, terms):
        h[k + 1] = (x * h[k] - np.sqrt(k) * h[k - 1]) / np.sqrt(k + 1.0)
    return h


def _quadrature() -> tuple[np.ndarray, np.ndarray]:
    x = np.linspace(-QUAD_RANGE, QUAD_RANGE, QUAD_POINTS)
    w = np.exp(-0.5 * x * x)
    w[[0, -1]] *= 0.5  # trapezoid
    return x, w / w.sum()


def hermite_coefficients(tables: np.ndarray, grid: np.ndarray, terms: int = HERMITE_TERMS
                         ) -> tuple[np.ndarray, np.ndarray]:
    """(b, second): b (C, terms + 1), b[c, k] = E[T_c(X) h_k(X)] for the tables (C, K) sampled at the
    Gaussian positions ``grid`` (K; clamped to their end values beyond it), and ``second`` (C, C), the
    covariances E[T_c(X) T_d(X)] − E[T_c] E[T_d] of the maps of one Gaussian (the series at ρ = 1)."""
    x, w = _quadrature()
    tables = np.atleast_2d(np.asarray(tables, np.float64))
    # each table less its median: the same covariances, without the rounding of a far offset
    tx = np.array([np.interp(x, grid, t - t[len(t) // 2]) for t in tables])
    b = (tx * w) @ hermite_functions(x, terms).T
    mean = tx @ w
    second = (tx * w) @ tx.T - np.outer(mean, mean)
    return b, second


class TranslationSeries:
    """The normalised covariance series f_cd(ρ) of a set of tables (C channels): the correlation of
    T_c(G_c(x)), T_d(G_d(y)) when G_c(x), G_d(y) are standard Gaussians of correlation ρ,

        f_cd(ρ) = (Σ_{k=1..K} b_ck b_dk ρ^k + e_cd ρ^(K+1)) / √(V_c V_d),

    e_cd the part of the covariance at ρ = 1 the K terms miss (so that f_cc(1) = 1 exactly),
    V_c the variance of T_c(X). :meth:`inverse` solves f_cd(ρ) = κ for arrays of κ."""

    def __init__(self, tables: np.ndarray, grid: np.ndarray, terms: int = HERMITE_TERMS):
        b, second = hermite_coefficients(tables, grid, terms)
        self.channels = b.shape[0]
        var = np.maximum(np.diag(second), 1e-300)
        self.scale = np.sqrt(np.outer(var, var))
        b1 = b[:, 1:]
        # coefficients of ρ^1 .. ρ^(K+1) for every pair, normalised
        coef = np.einsum("ck,dk->cdk", b1, b1)
        rest = second - coef.sum(axis=2)
        self.coef = np.concatenate([coef, rest[..., None]], axis=2) / self.scale[..., None]
        self.constant = var <= 1e-300  # a constant table: no correlation to speak of
        self.rho = np.linspace(-1.0, 1.0, RHO_POINTS)
        # the tabulated series, made non-decreasing (the truncation may wiggle where T is steep)
        self.table = np.maximum.accumulate(self(self.rho[None, None, :]), axis=-1)

    def __call__(self, rho: np.ndarray, derivative: bool = False) -> np.ndarray:
        """f_cd(ρ) (or its derivative) for ρ broadcast against (C, C, ...)."""
        rho = np.asarray(rho, np.float64)
        k = self.coef.shape[2]
        out = np.zeros(np.broadcast_shapes(rho.shape, (self.channels, self.channels) + (1,) * (rho.ndim - 2)))
        extra = (None,) * (rho.ndim - 2)
        for j in range(k, 0, -1):  # Horner: Σ a_j ρ^j = ρ (a_1 + ρ (a_2 + ...))
            a = self.coef[:, :, j - 1][(...,) + extra]
            out = (out * rho + (j * a if derivative else a))
        return out if derivative else out * rho

    def range(self) -> tuple[np.ndarray, np.ndarray]:
        """(f(−1), f(1)), (C, C) each: the correlations Gaussian fields can make."""
        return self.table[..., 0], self.table[..., -1]

    def inverse(self, kappa: np.ndarray) -> tuple[np.ndarray, float]:
        """(ρ, clamped): the Gaussian correlations (C, C, L) whose series give the correlations ``kappa``
        (C, C, L), each clamped to its pair's range first; ``clamped`` is the share of values that were
        outside it. Tabulated inverse, then one Newton step on the series."""
        kappa = np.asarray(kappa, np.float64)
        lo, hi = self.range()
        inside = (kappa >= lo[..., None]) & (kappa <= hi[..., None])
        k = np.clip(kappa, lo[..., None], hi[..., None])
        rho = np.empty_like(k)
        for c in range(self.channels):
            for d in range(self.channels):
                f = self.table[c, d]
                rho[c, d] = np.interp(k[c, d], f, self.rho) if f[-1] > f[0] else 0.0
        slope = self(rho, derivative=True)
        step = np.divide(self(rho) - k, slope, out=np.zeros_like(rho), where=slope > 1e-6)
        rho = np.clip(rho - step, -1.0, 1.0)
        for c in np.nonzero(self.constant)[0].tolist():
            rho[c, :] = 0.0
            rho[:, c] = 0.0
        return rho, float(1.0 - inside.mean())


def _lag_block(window: int, shape: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
    """The rows and columns (periodic indices) of the lags |τ| < window on an M × N grid."""
    m, n = shape
    ry = np.r_[0:min(window, m // 2 + 1), max(m - window + 1, m // 2 + 1):m]
    rx = np.r_[0:min(window, n // 2 + 1), max(n - window + 1, n // 2 + 1):n]
    return ry, rx


def _cross_correlations(f_hat: np.ndarray, shape: tuple[int, int], ry, rx) -> np.ndarray:
    """(C, C, len(ry), len(rx)): r_cd(τ) = Σ_x t_c(x) t_d(x + τ) at the block's lags, from the kernels'
    rfft half-planes (M, N//2 + 1, C)."""
    c = f_hat.shape[2]
    out = np.empty((c, c, len(ry), len(rx)))
    for a in range(c):
        for b in range(a, c):
            r = np.fft.irfft2(np.conj(f_hat[..., a]) * f_hat[..., b], s=shape)
            out[a, b] = r[np.ix_(ry, rx)]
            if b != a:  # r_dc(τ) = r_cd(−τ)
                out[b, a] = r[np.ix_((-ry) % shape[0], (-rx) % shape[1])]
    return out


def _spectra(corr: np.ndarray, shape: tuple[int, int], ry, rx, window: np.ndarray) -> np.ndarray:
    """(M, N//2 + 1, C, C): the cross-spectral matrices S[c, d] = Σ_τ w(τ) r_dc(τ) e^{−i ξ τ} of the
    windowed block correlations (S = E[v v^H] for v the kernels' transforms at ξ)."""
    c = corr.shape[0]
    m, n = shape
    out = np.empty((m, n // 2 + 1, c, c), np.complex128)
    full = np.zeros(shape)
    for a in range(c):
        for b in range(c):
            full[np.ix_(ry, rx)] = corr[b, a] * window
            out[..., a, b] = np.fft.rfft2(full)
    return out


def _psd(s: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """(eigenvalues clipped at 0, eigenvectors, share of the spectrum's weight removed) of Hermitian
    matrices (..., C, C)."""
    w, v = np.linalg.eigh(s)
    removed = float(np.sum(np.clip(-w, 0.0, None)) / max(np.sum(np.abs(w)), 1e-300))
    return np.clip(w, 0.0, None), v, removed


def translated_kernel(t: np.ndarray, tz: np.ndarray, tables: np.ndarray, grid: np.ndarray, window: int
                      ) -> tuple[np.ndarray, dict]:
    """(t̂, metadata): the rfft half-plane (M, N//2 + 1, C) of the kernel whose Gaussian noise the tables
    map onto the example's covariance, and what the inverse changed.

    ``t`` (M, N, C) is the normalised kernel of the Gaussianised example, ``tz`` that of the example
    (its channels in the tables' units), ``tables`` (C, K) the maps T_c at the Gaussian positions
    ``grid``. The example's correlations κ_cd(τ) at the lags |τ| < ``window`` (the texton's side: it
    cannot make longer ones) are inverted through :class:`TranslationSeries`; the Gaussian
    correlations and the Gaussianised example's, under the same separable triangular lag window
    (a non-negative Fejér kernel), give cross-spectral matrices S_G(ξ) (projected onto the positive
    semi-definite ones) and S_t(ξ); t̂ is t's transform filtered by S_G^{1/2} S_t^{-1/2} per frequency,
    so that its windowed cross-spectra are S_G while it keeps the example's phases.

    ``metadata``: ``translation_clamped`` (the share of the correlations outside the series' range),
    ``translation_psd_removed`` (the share of the spectral weight in negative eigenvalues, set to 0).
    """
    m, n, c = t.shape
    shape = (m, n)
    ry, rx = _lag_block(window, shape)
    dy = np.minimum(ry, m - ry)
    dx = np.minimum(rx, n - rx)
    win = np.outer(np.clip(1.0 - dy / window, 0.0, None), np.clip(1.0 - dx / window, 0.0, None))
    tz_hat = np.fft.rfft2(np.asarray(tz, np.float64), axes=(0, 1))
    t_hat = np.fft.rfft2(np.asarray(t, np.float64), axes=(0, 1))
    rz = _cross_correlations(tz_hat, shape, ry, rx)
    var = np.maximum(np.array([rz[a, a, 0, 0] for a in range(c)]), 1e-300)
    kappa = rz / np.sqrt(np.outer(var, var))[..., None, None]
    series = TranslationSeries(tables, grid)
    rho, clamped = series.inverse(kappa.reshape(c, c, -1))
    rho = rho.reshape(kappa.shape)
    for a in range(c):
        rho[a, a, 0, 0] = 1.0
    s_gauss = _spectra(rho, shape, ry, rx, win)
    w_g, v_g, removed = _psd(s_gauss)
    w_t, v_t, _ = _psd(_spectra(_cross_correlations(t_hat, shape, ry, rx), shape, ry, rx, win))
    floor = 1e-6 * max(float(w_t.mean()), 1e-300)
    root_g = (v_g * np.sqrt(w_g)[..., None, :]) @ np.conj(np.swapaxes(v_g, -1, -2))
    inv_root_t = (v_t / np.sqrt(np.maximum(w_t, floor))[..., None, :]) @ np.conj(np.swapaxes(v_t, -1, -2))
    out = np.einsum("...cd,...d->...c", root_g @ inv_root_t, t_hat)
    # the Gaussian field's unit variances: the filtered kernel keeps each channel's lag-0 variance at 1
    return out, {"translation_clamped": round(clamped, 6), "translation_psd_removed": round(removed, 6)}


def half_plane_covariance(t_hat: np.ndarray, n: int) -> np.ndarray:
    """(C, C): Σ_x t_c(x) t_d(x) of the real kernel whose rfft half-plane (M, n//2 + 1, C) is ``t_hat``
    (Parseval, the columns other than 0 and n/2 counted twice)."""
    m = t_hat.shape[0]
    weight = np.full(t_hat.shape[1], 2.0)
    weight[0] = 1.0
    if n % 2 == 0:
        weight[-1] = 1.0
    flat = (t_hat * np.sqrt(weight)[None, :, None]).reshape(-1, t_hat.shape[2])
    return (flat.T @ np.conj(flat)).real / (m * n)


# ---------------------------------------------------------------- the noise's marginal
def texton_values(coeffs: np.ndarray, order: int, oversampling: int) -> np.ndarray:
    """h(y) = Σ α(j) ψ(y − j) on ``oversampling``² midpoints per texel of its
    bounding box, (N, C) float64; each sample stands for 1 / oversampling² texels²."""
    r, s, c = coeffs.shape
    reach = 0.5 if order == 0 else (order + 1) / 2.0

    def weights(n: int) -> np.ndarray:
        y = np.arange(-reach, n - 1 + reach - 1e-9, 1.0 / oversampling) + 0.5 / oversampling
        return bspline(y[:, None] - np.arange(n)[None, :], order)

    h = np.einsum("ir,rsc,js->ijc", weights(r), np.asarray(coeffs, np.float64), weights(s), optimize=True)
    return h.reshape(-1, c)


def noise_cdf(texton, mni: float, grid: np.ndarray) -> np.ndarray:
    """(C, len(grid)): the CDF of texton noise at MNI ``mni``, standardised by its
    exact moments (g = (v − m) / σ, as the outputs standardise it), at ``grid``.

    Texton noise sums h(x − x_j) over a Poisson process of intensity λ = MNI /
    support_area: a compound Poisson variable of characteristic function
    exp(λ ∫ (e^{i t h(y)} − 1) dy) (CGF §3.3). h is sampled on a fine grid
    (:func:`texton_values`), its values spread linearly over a lattice of
    CDF_POINTS steps spanning CDF_SPAN standard deviations, and the lattice
    distribution of the sum is the inverse FFT of that function (exact up to the
    lattice and the sampling of h). Channels without variance get Φ.
    """
    from scipy.special import ndtr  # imported here: the command line starts without SciPy

    grid = np.asarray(grid, np.float64)
    size = max(texton.size)
    q = int(np.clip(1024 // max(size, 1), 1, CDF_OVERSAMPLING))
    h = texton_values(texton.coeffs, texton.order, q)
    lam = mni / texton.support_area
    var = np.diag(np.atleast_2d(texton.covariance()))
    integral = texton.integral
    n, delta = CDF_POINTS, CDF_SPAN / CDF_POINTS
    out = np.empty((h.shape[1], len(grid)))
    for c in range(h.shape[1]):
        sigma = np.sqrt(lam * var[c])
        if not sigma > 0:
            out[c] = ndtr(grid)
            continue
        x = h[:, c] / (sigma * delta)  # the values of one impact, in lattice steps
        lo = np.floor(x)
        t = x - lo
        i = lo.astype(np.int64) % n
        rate = lam / (q * q)  # impacts per sample of h
        w = np.bincount(i, (1.0 - t) * rate, n) + np.bincount((i + 1) % n, t * rate, n)
        pmf = np.fft.ifft(np.exp(np.fft.fft(w) - w.sum())).real
        # the sum's lattice point j is the value j δ (mod the span); centred: j δ − λ∫h / σ
        centred = (np.arange(n) - lam * integral[c] / (sigma * delta) + n / 2) % n - n / 2
        order = np.argsort(centred)
        cdf = np.cumsum(np.maximum(pmf[order], 0.0))
        out[c] = np.interp(grid, (centred[order] + 0.5) * delta, cdf / cdf[-1])
    return out
