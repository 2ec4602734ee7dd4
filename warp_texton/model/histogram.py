"""Histogram transforms: an example's colours mapped to a Gaussian and back.

Texton noise is Gaussian; a photograph's colour histogram is not. A
:class:`HistogramTransform` (Heitz & Neyret 2018, §1.4 "histogram-preserving
blending"; Deliot & Heitz 2019) rotates the colours onto their axes,
z = (u − centre) Mᵀ (a principal component analysis, or for ``analyze``'s
colour transforms the RGB channels themselves: M = I, centre = 0), maps each channel
through its empirical CDF to a standard Gaussian, and keeps the inverse map as
a lookup table: ``lut[c, k]`` is the quantile of channel c at the Gaussian
quantile Φ(g_k) of the grid g_k = −GAUSS_RANGE … GAUSS_RANGE (LUT_SIZE points).
The noise is analysed and synthesised in the Gaussian space; the transform
maps its values back (:meth:`HistogramTransform.to_colours`).

A filtered value keeps a share v ≤ 1 of the noise's variance. Its expected
colour is the lookup table averaged over the variance 1 − v it lost: the
table convolved with a Gaussian of that variance (Deliot & Heitz 2019,
"LUT prefiltering"). :meth:`HistogramTransform.prefiltered` holds those tables
for SHARE_STEPS shares, and far views (v → 0) tend to the example's mean
colour. Derivations and choices: docs/histogram.md.
"""

from __future__ import annotations

import functools
import json
from dataclasses import dataclass

import numpy as np

from ..core.errors import TextonError

#: The lookup tables' Gaussian grid: LUT_SIZE points over [−GAUSS_RANGE, GAUSS_RANGE].
#: Φ(−5) ≈ 3·10⁻⁷: past the grid every example of fewer than 3 million pixels
#: holds its extreme values.
GAUSS_RANGE = 5.0
LUT_SIZE = 1024
#: Shares of the variance at which prefiltered tables are kept (linear in between).
SHARE_STEPS = 33
#: Quadrature nodes and correlation steps of :meth:`HistogramTransform.correlation_map`.
CORRELATION_NODES = 96
CORRELATION_STEPS = 401
#: The MNI whose noise ``analyze`` fits the tables to (``synthesize``'s default and
#: every runtime's): ``analysis.noise_cdf``.
NOISE_MNI = 30.0
#: ``analysis.noise_cdf``'s lattice: points, and its span in standard deviations (±SPAN / 2).
CDF_POINTS = 1 << 16
CDF_SPAN = 40.0
#: Samples of the texton per texel and axis for ``analysis.noise_cdf`` (fewer for large textons).
CDF_OVERSAMPLING = 8
#: Refits of a histogram-preserving texton against the spectrum its noise makes through the tables.
REFINE_ROUNDS = 2
#: Noise samples (on the example's grid) that judge each candidate texton's spectrum.
REFINE_SAMPLES = 2
#: Noise samples that judge the marginals of each family's best candidate (the first
#: REFINE_SAMPLES shared with the spectrum's judges).
MARGINAL_SAMPLES = 8
#: An example's zero-sum texton is admissible while its spectrum distance is at most
#: SLACK × that of the example's Gaussian texton + MARGIN, both judged on the same samples;
#: then kept if its marginals are closer (``analysis.judged_texton``).
ZERO_SUM_SPECTRUM_SLACK = 1.15
ZERO_SUM_SPECTRUM_MARGIN = 0.02
#: Examples larger than this (pixels) get no refits: their samples and fits would
#: cost seconds to minutes; their tables are still fitted to the noise.
REFINE_MAX_PIXELS = 1 << 20
#: Accepted values of ``analyze(..., histogram=...)``.
HISTOGRAMS = ("gaussian", "preserve")
#: Bound of a stored transform's JSON (3 channels of LUT_SIZE numbers take about 70 kB; two tables 140 kB).
MAX_HISTOGRAM_CHARS = 1 << 20
#: Largest magnitude of a transform's centre (an example's mean colour): the bound of
#: image values, ``_checks.MAX_VALUE``.
MAX_CENTRE = 1.0e10
#: Largest magnitude of a table entry: a decorrelated colour of an example whose values
#: lie within ±MAX_CENTRE is at most √3 · 2 · 10¹⁰ from 0. Beyond it the colours, mapped
#: back in float32 by the kernels and shaders, could overflow to infinity.
MAX_TABLE_VALUE = 4.0e10


def gauss_grid(size: int = LUT_SIZE) -> np.ndarray:
    """The Gaussian positions g_k of a table of ``size`` entries."""
    return np.linspace(-GAUSS_RANGE, GAUSS_RANGE, size)


def mean_ranks(x: np.ndarray) -> np.ndarray:
    """Ranks 1..n of the values of a 1-D array, ties sharing their mean rank (float64):
    ``scipy.stats.rankdata``'s default, whose import takes a second."""
    order = np.argsort(x, kind="mergesort")
    xs = x[order]
    new = np.r_[True, xs[1:] != xs[:-1]]
    group = np.cumsum(new)  # 1-based group of each sorted value
    starts = np.r_[np.nonzero(new)[0], len(xs)]  # first sorted position of each group, then n
    ranks = np.empty(len(x), np.float64)
    ranks[order] = 0.5 * (starts[group] + starts[group - 1] + 1)
    return ranks


@dataclass(frozen=True, eq=False)
class HistogramTransform:
    """Colour decorrelation and per-channel inverse CDFs of an example.

    Attributes
    ----------
    matrix : float64 array (C, C)
        Orthonormal rows: the colour axes of the tables, the principal axes
        of the example's colours or the identity (``fit(..., axes="rgb")``)
        (largest variance first); ``[[1]]`` for grey.
    centre : float64 array (C,)
        The example's mean colour (0 for the RGB axes of ``fit(..., axes="rgb")``).
    lut : float64 array (C, K)
        Non-decreasing quantiles of each decorrelated channel at the
        probabilities F(g_k), g_k = :func:`gauss_grid` (K), F the CDF of the
        standardised noise the table is applied to: Φ for a Gaussian input
        (:meth:`fit`), the texton noise's own compound-Poisson CDF for the
        tables of ``analyze`` (:meth:`for_noise`, ``analysis.noise_cdf``).
    gaussian_lut : float64 array (C, K) or None
        The tables at the Gaussian quantiles Φ(g_k) when :attr:`lut` is fitted
        to a non-Gaussian noise (:meth:`for_noise`); the prefiltered tables
        fade from :attr:`lut` to it as a filter averages the noise towards a
        Gaussian (:attr:`prefiltered`). None: :attr:`lut` is the Gaussian one.

    Raises
    ------
    TextonError
        For shapes other than (C, C), (C,), (C, K) with C in {1, 3} and
        K ≥ 2, values that are not finite, a matrix whose rows are not
        orthonormal, and tables that decrease somewhere.

    Examples
    --------
    >>> import numpy as np
    >>> u = np.random.default_rng(0).gamma(2.0, 0.1, size=(64, 64, 3))
    >>> tr = HistogramTransform.fit(u)
    >>> g = tr.to_gaussian(u)
    >>> [round(float(v), 2) for v in g.std(axis=(0, 1))]
    [1.0, 1.0, 1.0]
    >>> back = tr.to_colours(g.reshape(-1, 3)).reshape(u.shape)  # the table's resolution
    >>> round(float(np.median(np.abs(back - u))), 4)
    0.0001
    """

    matrix: np.ndarray
    centre: np.ndarray
    lut: np.ndarray
    gaussian_lut: np.ndarray | None = None

    def __post_init__(self):
        m = _finite(self.matrix, "matrix")
        c = m.shape[0] if m.ndim == 2 else 0
        if m.ndim != 2 or m.shape != (c, c) or c not in (1, 3):
            raise TextonError(f"histogram transform: matrix must be (C, C) with C 1 or 3, got {m.shape}",
                              param="histogram")
        if np.abs(m).max() > 1.0 + 1e-6 or not np.allclose(m @ m.T, np.eye(c), atol=1e-6):
            raise TextonError("histogram transform: the matrix rows must be orthonormal (principal axes)",
                              param="histogram")
        centre = _bounded(_finite(self.centre, "centre").ravel(), "centre", MAX_CENTRE)
        if centre.shape != (c,):
            raise TextonError(f"histogram transform: centre must hold {c} values, got {centre.shape}",
                              param="histogram")
        lut = _finite(self.lut, "lut")
        if lut.ndim != 2 or lut.shape[0] != c or lut.shape[1] < 2:
            raise TextonError(f"histogram transform: lut must be ({c}, K) with K >= 2, got {lut.shape}",
                              param="histogram")
        _bounded(lut, "lut", MAX_TABLE_VALUE)
        if np.any(np.diff(lut, axis=1) < 0):
            raise TextonError("histogram transform: a lookup table decreases somewhere; the inverse CDFs "
                              "must be non-decreasing", param="histogram")
        arrays = [("matrix", m), ("centre", centre), ("lut", lut)]
        if self.gaussian_lut is not None:
            glut = _bounded(_finite(self.gaussian_lut, "gaussian_lut"), "gaussian_lut", MAX_TABLE_VALUE)
            if glut.shape != lut.shape:
                raise TextonError(f"histogram transform: gaussian_lut must have the shape of lut {lut.shape}, "
                                  f"got {glut.shape}", param="histogram")
            if np.any(np.diff(glut, axis=1) < 0):
                raise TextonError("histogram transform: gaussian_lut decreases somewhere; the inverse CDFs "
                                  "must be non-decreasing", param="histogram")
            arrays.append(("gaussian_lut", glut))
        for name, a in arrays:
            a.setflags(write=False)
            object.__setattr__(self, name, a)

    @property
    def channels(self) -> int:
        return self.matrix.shape[0]

    # ------------------------------------------------------------------ fitting
    @classmethod
    def fit(cls, u: np.ndarray, size: int = LUT_SIZE, axes: str = "pca") -> HistogramTransform:
        """The transform of an (H, W, C) example (checked by the caller).

        ``axes``: ``"pca"``, the principal axes of the colours (tiling and
        blending's choice), or ``"rgb"``, the colour channels themselves (the
        identity matrix): every table then bounds and keeps the marginal of one
        RGB channel, which is what ``analyze`` uses for colour (docs/histogram.md);
        its ``centre`` is 0 and its tables hold the colours themselves.
        """
        flat = np.asarray(u, np.float64).reshape(-1, u.shape[-1])
        if axes == "pca":
            centre = flat.mean(axis=0)
            matrix = principal_axes(flat - centre)
        else:
            # centre 0: the tables hold the colours themselves, so that their ends are the
            # example's extreme values exactly, in float32 too (no rounding past 0 or 1)
            centre = np.zeros(flat.shape[1])
            matrix = np.eye(flat.shape[1])
        z = (flat - centre) @ matrix.T
        from scipy.special import ndtr  # imported here: the command line starts without SciPy

        q = ndtr(gauss_grid(size))
        lut = np.quantile(z, q, axis=0).T  # linear interpolation between order statistics
        return cls(matrix, centre, np.maximum.accumulate(lut, axis=1))

    def for_noise(self, u: np.ndarray, cdf: np.ndarray, *, ordered: np.ndarray | None = None) -> HistogramTransform:
        """The transform whose tables map the standardised noise of CDF ``cdf`` (C, K),
        sampled at :func:`gauss_grid`, to the example u's channels: ``lut`` holds their
        quantiles at the probabilities ``cdf`` (F_u⁻¹ ∘ F_noise: each output channel
        then has u's marginal exactly, whatever the noise's skewness), and
        ``gaussian_lut`` this transform's tables at Φ(g_k). ``ordered``, when
        given, is u's decorrelated colours sorted per channel ((H W, C)): the
        quantiles are then interpolated in it (no partition per call)."""
        cdf = np.clip(np.asarray(cdf, np.float64), 0.0, 1.0)
        if ordered is None:
            z = self.decorrelate(u).reshape(-1, self.channels)
            lut = np.array([np.quantile(z[:, c], cdf[c]) for c in range(self.channels)])
        else:
            at = np.arange(ordered.shape[0], dtype=np.float64)
            lut = np.array([np.interp(cdf[c] * (ordered.shape[0] - 1), at, ordered[:, c])
                            for c in range(self.channels)])
        base = self.lut if self.gaussian_lut is None else self.gaussian_lut
        return HistogramTransform(self.matrix, self.centre, np.maximum.accumulate(lut, axis=1), base)

    def mixed(self, other: HistogramTransform, rho: float) -> HistogramTransform:
        """The displacement interpolation (1 − ρ) self + ρ other of two transforms on the
        same colour axes: tables and centres interpolated linearly (both the applied
        and the Gaussian tables, each transform's ``lut`` standing for a missing one)."""
        glut = None
        if self.gaussian_lut is not None or other.gaussian_lut is not None:
            a = self.lut if self.gaussian_lut is None else self.gaussian_lut
            b = other.lut if other.gaussian_lut is None else other.gaussian_lut
            glut = (1.0 - rho) * a + rho * b
        return HistogramTransform(self.matrix, (1.0 - rho) * self.centre + rho * other.centre,
                                  (1.0 - rho) * self.lut + rho * other.lut, glut)

    def to_gaussian(self, u: np.ndarray) -> np.ndarray:
        """The example u (H, W, C) Gaussianised: decorrelated, each channel through its
        empirical CDF to a standard Gaussian (ties share their mean rank), float64."""
        flat = np.asarray(u, np.float64).reshape(-1, self.channels)
        z = (flat - self.centre) @ self.matrix.T
        from scipy.special import ndtri

        n = z.shape[0]
        g = np.empty_like(z)
        for c in range(self.channels):
            g[:, c] = ndtri((mean_ranks(z[:, c]) - 0.5) / n)
        g /= np.maximum(g.std(axis=0), 1e-12)  # ties shrink the variance a little; the noise is standardised
        return g.reshape(np.shape(u)[:2] + (self.channels,))

    def decorrelate(self, u: np.ndarray) -> np.ndarray:
        """The decorrelated colours z = (u − centre) Mᵀ of an (H, W, C) image, float64."""
        flat = np.asarray(u, np.float64).reshape(-1, self.channels)
        return ((flat - self.centre) @ self.matrix.T).reshape(np.shape(u)[:2] + (self.channels,))

    def correlation_map(self, c: int, centred: bool = False) -> tuple[np.ndarray, np.ndarray]:
        """(ρ, R(ρ)): the correlation R of T_c(X), T_c(Y) for standard Gaussians X, Y of
        correlation ρ, T_c the lookup table of channel c; non-decreasing, R(1) = 1.

        By Gauss–Hermite quadrature over X and the part of Y independent of X.
        ``centred``: the table less its median first (the same R in exact
        arithmetic); a table far from 0 against its spread, as the RGB tables of
        colours are, would otherwise lose R to the quadrature's rounding.
        """
        x, w = np.polynomial.hermite_e.hermegauss(CORRELATION_NODES)
        w = w / w.sum()
        grid = gauss_grid(self.lut.shape[1])
        lut = self.lut if self.gaussian_lut is None else self.gaussian_lut  # a map of Gaussian values
        table = lut[c] - lut[c, lut.shape[1] // 2] if centred else lut[c]
        tx = np.interp(x, grid, table)
        m = tx @ w
        var = tx ** 2 @ w - m * m
        rho = np.linspace(-1.0, 1.0, CORRELATION_STEPS)
        if var <= 0:
            return rho, rho
        ww = w[:, None] * w[None, :]
        r = np.array([np.sum(tx[:, None] * np.interp(q * x[:, None] + np.sqrt(max(1.0 - q * q, 0.0)) * x[None, :],
                                                      grid, table) * ww) for q in rho])
        return rho, np.maximum.accumulate((r - m * m) / var)

    def gaussian_kernel(self, t: np.ndarray, tz: np.ndarray, window: int | None = None) -> np.ndarray:
        """The kernel (H, W, C) the Gaussian noise needs so that its colours have the
        example's spectrum: a translation process (Grigoriu 1995).

        ``t`` is the normalised kernel of the Gaussianised example and ``tz`` that
        of the decorrelated example (:func:`~warp_texton.model.gaussian.normalized_kernel`).
        Per channel, the example's autocorrelation r_z(τ) (from |t̂_z|²) would come
        out of the table from a Gaussian correlation R⁻¹(r_z(τ))
        (:meth:`correlation_map`); its spectrum (negative values, which no
        Gaussian field has, set to 0) scaled to the variance of t gives the new
        modulus, and t's phases keep the cross-channel structure.

        ``window`` (colour): instead, each channel of t is filtered by the gain
        √(S_target / S_t) between the two spectra estimated from their
        autocorrelations under a separable triangular window of half-width
        ``window`` (non-negative estimates, smooth at the scale of 1/window):
        the correction is then a compact filter per channel, and t's channels
        keep their relation to each other beyond the phases. Replacing each
        channel's modulus by its own noisy estimate decorrelates the channels
        frequency by frequency, which a texton of support ``window`` cannot
        follow (docs/histogram.md, "Spectrum correction").
        """
        th = np.fft.fft2(t, axes=(0, 1))
        tzh = np.fft.fft2(tz, axes=(0, 1))
        if window is not None:
            return self._windowed_kernel(th, tzh, window)
        out = th.copy()
        for c in range(self.channels):
            pz = np.abs(tzh[..., c]) ** 2
            pg = np.abs(th[..., c]) ** 2
            if pz.sum() <= 0 or pg.sum() <= 0:
                continue
            rz = np.fft.ifft2(pz).real
            rho, r = self.correlation_map(c)
            rg = np.interp(rz / rz[0, 0], r, rho)
            sg = np.maximum(np.fft.fft2(rg).real, 0.0)
            sg *= pg.sum() / sg.sum()
            phase = np.divide(th[..., c], np.abs(th[..., c]), out=np.ones_like(th[..., c]),
                              where=np.abs(th[..., c]) > 0)
            out[..., c] = np.sqrt(sg) * phase
        return np.fft.ifft2(out, axes=(0, 1)).real.astype(np.float32)

    def _windowed_kernel(self, th: np.ndarray, tzh: np.ndarray, window: int) -> np.ndarray:
        h, w = th.shape[:2]
        dy = np.minimum(np.arange(h), h - np.arange(h))
        dx = np.minimum(np.arange(w), w - np.arange(w))
        # a triangle's Fourier transform (Fejér) is non-negative: so are the windowed spectra
        win = np.outer(np.clip(1.0 - dy / window, 0.0, None), np.clip(1.0 - dx / window, 0.0, None))
        out = th.copy()
        for c in range(self.channels):
            pg = np.abs(th[..., c]) ** 2
            pz = np.abs(tzh[..., c]) ** 2
            if pz.sum() <= 0 or pg.sum() <= 0:
                continue
            rz = np.fft.ifft2(pz).real
            rg = np.fft.ifft2(pg).real
            rho, r = self.correlation_map(c, centred=True)
            target = np.interp(rz / rz[0, 0], r, rho) * rg[0, 0]
            s_target = np.maximum(np.fft.fft2(target * win).real, 0.0)
            s_t = np.maximum(np.fft.fft2(rg * win).real, 1e-12 * rg[0, 0])
            col = th[..., c] * np.sqrt(s_target / s_t)
            power = np.sum(np.abs(col) ** 2)
            out[..., c] = col * np.sqrt(pg.sum() / power) if power > 0 else th[..., c]
        return np.fft.ifft2(out, axes=(0, 1)).real.astype(np.float32)

    def output_spectra(self, spectrum: np.ndarray) -> np.ndarray:
        """(M, N, C): the spectra, each normalised to unit variance, of the colours this
        transform makes of Gaussian noise of power spectrum ``spectrum`` (M, N, C)
        (a texton's |α̂|² b̂ on that grid): per channel the noise's correlation ρ(τ)
        becomes R(ρ(τ)) (:meth:`correlation_map`), whose transform is the output's
        spectrum (the translation process's, exact for a Gaussian input)."""
        out = np.zeros(spectrum.shape)
        for c in range(self.channels):
            rho = np.fft.ifft2(spectrum[..., c]).real
            if not rho[0, 0] > 0:
                continue
            q, r = self.correlation_map(c, centred=True)
            out[..., c] = np.fft.fft2(np.interp(rho / rho[0, 0], q, r)).real
        return out

    def refined_kernel(self, t: np.ndarray, spectrum: np.ndarray, target: np.ndarray, window: int) -> np.ndarray:
        """``t`` (M, N, C) filtered per channel by √(S_target / S_out), both windowed by a
        Gaussian lag window of width ``window`` / 2 (smooth estimates without a
        triangle's sidelobes): S_out from :meth:`output_spectra` of ``spectrum`` (the
        texton fitted to t), S_target the normalised periodogram ``target`` (M, N, C)
        of the example's channels. Gains are kept within [1/2, 2] per round; colour
        channels share one (the geometric mean of theirs); each channel keeps its
        variance."""
        m, n = t.shape[:2]
        dy = np.minimum(np.arange(m), m - np.arange(m))
        dx = np.minimum(np.arange(n), n - np.arange(n))
        win = np.exp(-(dy[:, None] ** 2 + dx[None, :] ** 2) / (2.0 * (window / 2.0) ** 2))
        s_out = self.output_spectra(spectrum)
        th = np.fft.fft2(t, axes=(0, 1))
        gains: list[np.ndarray | None] = []
        for c in range(self.channels):
            r_t = np.fft.ifft2(target[..., c]).real
            if not (r_t[0, 0] > 0 and s_out[..., c].any()):
                gains.append(None)
                continue
            a = np.fft.fft2(r_t / r_t[0, 0] * win).real
            b = np.fft.fft2(np.fft.ifft2(s_out[..., c]).real * win).real
            eps = 1e-2 * max(float(a.mean()), 1e-30)  # the windowed estimates' floor (rounding)
            gains.append(np.sqrt(np.clip((np.maximum(a, 0.0) + eps) / (np.maximum(b, 0.0) + eps), 0.25, 4.0)))
        known = [g for g in gains if g is not None]
        if self.channels > 1 and len(known) == self.channels:
            # colour: one gain for every channel, the geometric mean of theirs. Each channel's
            # own gain changes the channels' cross-spectra, which the colour correction then
            # mixes back into every channel: such refits moved away from the example (sand's
            # spectrum distance 0.06 → 0.12; with one gain 0.065, and its zero-sum fit 0.10 → 0.076)
            shared = np.exp(np.mean([np.log(g) for g in known], axis=0))
            gains = [shared] * self.channels
        for c, gain in enumerate(gains):
            if gain is None:
                continue
            power = np.sum(np.abs(th[..., c]) ** 2)
            th[..., c] *= gain
            th[..., c] *= np.sqrt(power / max(np.sum(np.abs(th[..., c]) ** 2), 1e-300))
        return np.fft.ifft2(th, axes=(0, 1)).real.astype(np.float32)

    def spectrum_error(self, noise: np.ndarray, target: np.ndarray, bins: int = 32) -> float:
        """Mean |Δ ln P| between ring averages (``bins`` rings of radius up to ½ cycle per
        texel, the DC left out) of the periodograms of ``noise`` (M, N, C,
        standardised noise, e.g. ``analysis.noise_sample``) mapped through the tables
        and of the example (``target``, its channels' periodogram |t̂_z|² on the
        same grid, t_z its normalised kernel): the benchmark's spectrum distance."""
        z = ((self.to_colours(noise.reshape(-1, self.channels)) - self.centre) @ self.matrix.T).reshape(noise.shape)
        return ring_spectrum_error(z, target, bins)

    # ------------------------------------------------------------------ applying
    @functools.cached_property
    def prefiltered(self) -> np.ndarray:
        """(SHARE_STEPS, C, K) tables: row i is a table convolved with a Gaussian of
        variance 1 − v_i, v_i = i / (SHARE_STEPS − 1); the last row is :attr:`lut`.

        Without :attr:`gaussian_lut` the table is :attr:`lut`. With it, the table
        is G + √v (lut − G), G = :attr:`gaussian_lut`: a filtered value averages
        the noise over about 1/v independent parts, so its skewness falls as √v
        and its table moves towards the Gaussian one; at v = 0 the row is G
        averaged over a standard Gaussian, the example's mean."""
        from scipy.ndimage import gaussian_filter1d

        step = 2.0 * GAUSS_RANGE / (self.lut.shape[1] - 1)
        out = np.empty((SHARE_STEPS,) + self.lut.shape)
        base = self.lut if self.gaussian_lut is None else self.gaussian_lut
        for i, v in enumerate(np.linspace(0.0, 1.0, SHARE_STEPS)):
            sigma = np.sqrt(max(1.0 - v, 0.0)) / step
            table = base + np.sqrt(v) * (self.lut - base) if self.gaussian_lut is not None else self.lut
            # "nearest" extends each table by its end values: the clamp that to_colours applies
            out[i] = gaussian_filter1d(table, sigma, axis=1, mode="nearest", truncate=6.0) if sigma > 0 else table
        out[-1] = self.lut
        out.setflags(write=False)
        return out

    def to_colours(self, g: np.ndarray, share=None) -> np.ndarray:
        """Colours (N, C) of standardised Gaussian values g (N, C).

        ``share`` (None, a number or (N,) per value) is the share of the
        variance each value kept after filtering: the tables prefiltered for
        it are used (None and 1: :attr:`lut` itself).
        """
        g = np.asarray(g, np.float64)
        k = self.lut.shape[1]
        pos = np.clip((g + GAUSS_RANGE) * ((k - 1) / (2.0 * GAUSS_RANGE)), 0.0, k - 1)
        i0 = np.minimum(pos.astype(np.int64), k - 2)
        t = pos - i0
        ch = np.arange(self.channels)[None, :]
        if share is None:
            z = self.lut[ch, i0] * (1.0 - t) + self.lut[ch, i0 + 1] * t
        else:
            tables = self.prefiltered
            s = np.clip(np.broadcast_to(np.asarray(share, np.float64), g.shape[:1]), 0.0, 1.0)
            sp = s * (SHARE_STEPS - 1)
            j0 = np.minimum(sp.astype(np.int64), SHARE_STEPS - 2)[:, None]
            ts = (sp - j0[:, 0])[:, None]

            def at(j):
                return tables[j, ch, i0] * (1.0 - t) + tables[j, ch, i0 + 1] * t

            z = at(j0) * (1.0 - ts) + at(j0 + 1) * ts
        return z @ self.matrix + self.centre

    # ------------------------------------------------------------------ files
    def to_json(self) -> str:
        """The transform as JSON; float64 values round-trip exactly."""
        d = {"version": 1, "gauss_range": GAUSS_RANGE, "matrix": self.matrix.tolist(),
             "centre": self.centre.tolist(), "lut": self.lut.tolist()}
        if self.gaussian_lut is not None:
            d["gaussian_lut"] = self.gaussian_lut.tolist()
        return json.dumps(d, allow_nan=False)

    @classmethod
    def from_json(cls, raw: str, where: str) -> HistogramTransform:
        """The transform of :meth:`to_json`; anything else is a TextonError naming ``where``."""
        def bad(what):
            return TextonError(f"{where}: malformed histogram transform: {what}")

        if not isinstance(raw, str) or len(raw) > MAX_HISTOGRAM_CHARS:
            raise bad(f"not a JSON text of at most {MAX_HISTOGRAM_CHARS} characters")
        try:
            d = json.loads(raw)
        except (json.JSONDecodeError, RecursionError):
            raise bad("not JSON") from None
        if not isinstance(d, dict) or d.get("version") != 1 or d.get("gauss_range") != GAUSS_RANGE:
            raise bad(f"expected version 1 over the Gaussian range ±{GAUSS_RANGE:g}")
        try:
            glut = d.get("gaussian_lut")
            return cls(np.array(d["matrix"], np.float64), np.array(d["centre"], np.float64),
                       np.array(d["lut"], np.float64), None if glut is None else np.array(glut, np.float64))
        except TextonError as exc:  # a ValueError too: first
            raise bad(str(exc).removeprefix("histogram transform: ")) from None
        except (KeyError, TypeError, ValueError):
            raise bad("matrix, centre, lut (and gaussian_lut) must be arrays of numbers") from None


def _finite(a, name: str) -> np.ndarray:
    try:
        arr = np.array(a, np.float64)
    except (TypeError, ValueError):
        raise TextonError(f"histogram transform: {name} must be an array of numbers", param="histogram") from None
    if not np.isfinite(arr).all():
        raise TextonError(f"histogram transform: {name} holds NaN or infinite values", param="histogram")
    return arr


def _bounded(arr: np.ndarray, name: str, bound: float) -> np.ndarray:
    """``arr`` when its entries lie within ±``bound``; else one TextonError naming ``name``."""
    if arr.size and float(np.abs(arr).max()) > bound:
        raise TextonError(f"histogram transform: {name} holds values up to {float(np.abs(arr).max()):.3g}; "
                          f"accepted: within ±{bound:.3g}", param="histogram")
    return arr


def ring_spectrum_error(z: np.ndarray, target: np.ndarray, bins: int = 32) -> float:
    """Mean |Δ ln P| over the channels and ``bins`` rings (radius up to ½ cycle per
    texel, the DC left out) between the periodogram of ``z`` (M, N, C, colours in
    the example's units, any mean) and ``target`` (M, N, C, the example's |t̂|² on
    the same grid): the benchmark's spectrum distance."""
    m, n = target.shape[:2]
    out = np.abs(np.fft.fft2(z - z.mean(axis=(0, 1)), axes=(0, 1))) ** 2 / (m * n)
    ring = np.ceil(np.hypot(*np.meshgrid(np.fft.fftfreq(m), np.fft.fftfreq(n), indexing="ij")) / 0.5
                   * bins).astype(np.int64) - 1
    keep = (ring >= 0) & (ring < bins)
    counts = np.maximum(np.bincount(ring[keep], minlength=bins), 1)
    errs = []
    for c in range(z.shape[2]):
        a = np.bincount(ring[keep], target[..., c][keep], bins) / counts
        b = np.bincount(ring[keep], out[..., c][keep], bins) / counts
        ok = (a > 0) & (b > 0)
        errs.append(np.mean(np.abs(np.log(a[ok]) - np.log(b[ok]))) if ok.any() else 0.0)
    return float(np.mean(errs))


def principal_axes(x: np.ndarray) -> np.ndarray:
    """Orthonormal rows, largest variance first, of centred samples x (N, C); each
    row's sign makes its largest entry positive, so the axes are deterministic."""
    w, v = np.linalg.eigh(x.T @ x)
    axes = v[:, ::-1].T
    signs = np.where(axes[np.arange(len(axes)), np.abs(axes).argmax(axis=1)] < 0, -1.0, 1.0)
    return axes * signs[:, None]


def check_histogram(histogram) -> str:
    """``"gaussian"`` or ``"preserve"``."""
    if not isinstance(histogram, str) or histogram not in HISTOGRAMS:
        raise TextonError(f"histogram must be one of {', '.join(HISTOGRAMS)}, got {histogram!r:.60}",
                          param="histogram")
    return histogram


def refuse_transform(texton, target: str, instead: str) -> None:
    """Refuse a texton with a histogram transform in ``target``, an output that does not
    apply it: it would show the noise's Gaussian values where every other output shows
    the example's colours. ``instead`` says what to use."""
    if getattr(texton, "histogram", None) is not None:
        raise TextonError(f"texton has a histogram transform (analyze(..., histogram='preserve')), which {target} "
                          f"does not apply: it would show Gaussian values, not the example's colours; {instead}",
                          param="texton")
