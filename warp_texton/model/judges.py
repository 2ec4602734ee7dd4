"""The judges of a texton: its model error against an example, and samples of its noise in NumPy.

:func:`model_error` compares a texton's model spectrum with an example's (EUSIPCO §3.2).
:func:`judged_texton` picks a histogram-preserving texton among refits by what their noise makes
through the tables: samples of texton noise (:func:`noise_sample`, Poisson impacts splatted and
convolved in NumPy; not the kernels' impact stream), their spectrum and marginal distances to the
example (docs/histogram.md, "Judged refits").
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import scipy.fft as sfft

from ..core.checks import as_image, check_bool
from ..core.errors import TextonError
from ..core.limits import check_memory
from .analysis_options import ANALYSIS_BYTES_PER_VALUE
from .bspline import bhat, bspline
from .gaussian import FFT_WORKERS, normalized_kernel, relative_model_error_half
from .histogram import (MARGINAL_SAMPLES, NOISE_MNI, REFINE_MAX_PIXELS, REFINE_ROUNDS, REFINE_SAMPLES, ZERO_SUM_SPECTRUM_MARGIN,
                        ZERO_SUM_SPECTRUM_SLACK, HistogramTransform, gauss_grid, ring_spectrum_error)
from .texton import Texton
from .translation import half_plane_covariance, noise_cdf, translated_kernel

@dataclass(frozen=True)
class Candidate:
    """A texton judged on samples of its noise (``judged_texton``)."""

    texton: Texton
    transform: HistogramTransform  # tables fitted to this texton's noise
    spectrum: float  # mean spectrum distance of its mapped samples to the example


def judged_texton(u, texton: Texton, transform: HistogramTransform, t, t_hat, tz, n, mean, size, order,
                  iterations, seed, covariance, support, fit, rounds: int = REFINE_ROUNDS
                  ) -> tuple[Texton, HistogramTransform, dict]:
    """(texton, transform, metadata): the texton ``analyze(..., histogram="preserve")``
    keeps for a grey or colour example of at most REFINE_MAX_PIXELS pixels, the
    transform fitted to its noise, and the judges' figures for its metadata.

    Two families of candidates, each a first texton and ``rounds`` (REFINE_ROUNDS) refits:
    the plain fit (``texton``) and the zero-sum fit (``fit``, the analysis's
    ``texton_from_spectrum``, with ``zero_sum``: no power at frequency 0). Each refit filters the Gaussian kernel
    t by the gain between the example's spectrum and the one the last texton's
    noise makes through the tables, as the translation process predicts it
    (``HistogramTransform.refined_kernel``). Every candidate is judged on what it
    makes: REFINE_SAMPLES samples of its texton noise (``noise_sample``, MNI
    NOISE_MNI, the same impacts for every candidate) on the example's grid,
    mapped through tables fitted to its noise, by their spectrum distance to the
    example (``HistogramTransform.spectrum_error``); each family keeps its
    candidate of least distance. The zero-sum one is admissible when its
    distance is within ZERO_SUM_SPECTRUM_SLACK × that of the example's Gaussian
    texton (judged on the same impacts) + ZERO_SUM_SPECTRUM_MARGIN, and then kept
    if MARGINAL_SAMPLES samples of it are closer to the example's marginals (mean
    W1 of the channels) than the plain one's (docs/histogram.md, "Colour: one
    output's large scales")."""
    m = t.shape[0]
    target = np.abs(np.fft.fft2(tz, axes=(0, 1))) ** 2
    bins = max(2, min(32, min(m, n) // 4))
    grid = gauss_grid(transform.lut.shape[1])
    c = u.shape[2]
    ordered = np.sort(transform.decorrelate(u).reshape(-1, c), axis=0)  # the tables' channels, sorted
    quarter = np.sort(np.asarray(u, np.float64)[::2, ::2].reshape(-1, c), axis=0)  # every other row and column
    impacts: dict[int, np.ndarray] = {}  # sample i's impacts (seed + i), made once, shared by every candidate

    def samples(tx: Texton, count: int = REFINE_SAMPLES) -> list[np.ndarray]:
        for i in range(count):
            if i not in impacts:
                impacts[i] = impact_spectrum(texton.support_area, order, NOISE_MNI, (m, n), seed + i)
        return [noise_sample(tx, NOISE_MNI, (m, n), seed + i, impacts[i]) for i in range(count)]

    def marginal(k: Candidate) -> float:
        # mean W1 of the channels over MARGINAL_SAMPLES samples (a sample's W1 is mostly its
        # mean's shift, heavy-tailed over samples: two would not tell the families apart), on
        # every other row and column (the shift is the same; the sorts a quarter)
        return float(np.mean([np.mean(np.abs(np.sort(k.transform.to_colours(g[::2, ::2].reshape(-1, c)), axis=0)
                                             - quarter)) for g in samples(k.texton, MARGINAL_SAMPLES)]))

    def judged(tx: Texton) -> Candidate:
        tr = transform.for_noise(u, noise_cdf(tx, NOISE_MNI, grid), ordered=ordered)
        return Candidate(tx, tr, float(np.mean([tr.spectrum_error(g, target, bins) for g in samples(tx)])))

    def family(first: Texton, zero_sum: bool) -> list[Candidate]:
        kernel, current = t, first  # t: the kernel the refits filter (unused without refits)
        out = [judged(first)]
        for _ in range(rounds):
            kernel = transform.refined_kernel(kernel, np.abs(current.spectrum((m, n))) ** 2, target, size)
            current = fit(sfft.rfft2(kernel, axes=(0, 1), workers=FFT_WORKERS), n, mean, size,
                                           order, iterations, seed, covariance=covariance, support=support,
                                           zero_sum=zero_sum)
            out.append(judged(current))  # the next gain corrects this one's output
        return out

    plain = family(texton, False)
    free = family(fit(t_hat, n, mean, size, order, iterations, seed, covariance=covariance,
                                       support=support, zero_sum=True), True)
    # the reference: the example's own Gaussian texton (histogram="gaussian"), its colours m + σ g
    flat = tz.reshape(-1, c)
    gaussian = fit(sfft.rfft2(tz, axes=(0, 1), workers=FFT_WORKERS), n, mean, size, order,
                                    iterations, seed, covariance=None if covariance is None else flat.T @ flat,
                                    support=support)
    sigma = np.sqrt(np.maximum(np.diag(np.atleast_2d(gaussian.covariance())), 0.0))
    reference = float(np.mean([ring_spectrum_error(g * sigma, target, bins) for g in samples(gaussian)]))
    best, best_free = min(plain, key=lambda k: k.spectrum), min(free, key=lambda k: k.spectrum)
    limit = ZERO_SUM_SPECTRUM_SLACK * reference + ZERO_SUM_SPECTRUM_MARGIN
    # the marginals are judged only where the zero-sum family is admissible (else the plain one stays)
    marginals = [marginal(best), marginal(best_free)] if best_free.spectrum <= limit else None
    metadata = {
        "histogram_spectrum_errors": [round(k.spectrum, 4) for k in plain],
        "histogram_zero_sum_spectrum_errors": [round(k.spectrum, 4) for k in free],
        "histogram_reference_spectrum_error": round(reference, 4),
    }
    if marginals is not None:
        metadata["histogram_marginal_errors"] = [round(w, 6) for w in marginals]
        if marginals[1] < marginals[0]:
            best = best_free
    metadata["zero_sum"] = best is best_free
    return best.texton, best.transform, metadata


def preserve_steps(progress: bool):
    """The bar of ``histogram="preserve"`` (``analyze(..., progress=True)``): its stages (tables,
    texton, judges) on one bar, redrawn while a stage runs, shown once the analysis has run for
    PROGRESS_DELAY (a second); a stand-in that shows nothing without ``progress``."""
    from ..core.progress import NamedSteps
    from ..core.runtime import progress_bar

    names = ["tables", "texton", "judges"]
    return NamedSteps(progress_bar(progress, len(names), f"analyze: {names[0]}", "step"), names, "analyze",
                      tick=progress)


def translated_texton(u, transform: HistogramTransform, t, tz, mean, size, order, iterations, seed, periodic,
                      color_correction, support, fit, steps) -> Texton:
    """``histogram="preserve"`` by the translation process (``analysis.PRESERVE_FIT == "translation"``):
    the Gaussian field's cross-covariances that the tables map onto the example's, inverted lag by lag
    (``translation.translated_kernel``), one texton fitted to them (``fit``, the analysis's
    ``texton_from_spectrum``), and it or its zero-sum variant kept by :func:`judged_texton` without
    refits (docs/histogram.md, "The translation fit"). ``steps``: :func:`preserve_steps`."""
    m, n, c = t.shape
    grid = gauss_grid(transform.lut.shape[1])
    g_hat, meta = translated_kernel(np.asarray(t, np.float64), np.asarray(tz, np.float64), transform.lut, grid,
                                    size)
    cov = half_plane_covariance(g_hat, n) if color_correction else None
    g_hat = g_hat.astype(np.complex64)
    steps.step()
    texton = fit(g_hat, n, mean, size, order, iterations, seed, covariance=cov, support=support)
    steps.step()
    texton.metadata.update(periodic=bool(periodic))
    if m * n <= REFINE_MAX_PIXELS:
        # the plain texton or the zero-sum one (no power at frequency 0), judged as the refits
        # are but without refits: both start from the translation's kernel
        texton, transform, judges = judged_texton(u, texton, transform, t, g_hat, tz, n, mean, size, order,
                                                  iterations, seed, cov, support, fit, rounds=0)
        texton.metadata.update(periodic=bool(periodic), **judges)
    else:
        transform = transform.for_noise(u, noise_cdf(texton, NOISE_MNI, grid))
    steps.step()
    steps.close()
    texton.metadata.update(histogram="preserve", histogram_mni=NOISE_MNI, histogram_fit="translation", **meta)
    return replace(texton, histogram=transform)


def texton_half_spectrum(texton: Texton, shape: tuple[int, int]) -> np.ndarray:
    """α̂ √b̂ on the rfft half-plane of an M × N grid, (M, N//2 + 1, C)."""
    m, n = shape
    a_hat = sfft.rfft2(texton.coeffs.astype(np.float64), s=shape, axes=(0, 1), workers=FFT_WORKERS)
    return a_hat * np.sqrt(bhat(shape, texton.order))[:, : n // 2 + 1, None]


def relative_texton_error(tu_half: np.ndarray, texton: Texton, n: int) -> float:
    """The RME (:func:`model_error`) from u's half-plane spectrum (M, N//2 + 1, C) on an M × n grid."""
    shape = (tu_half.shape[0], n)
    if texton.size[0] > shape[0] or texton.size[1] > shape[1]:
        raise TextonError(f"a {texton.size[1]}x{texton.size[0]} texton does not fit on a {shape[1]}x{shape[0]} grid")
    return relative_model_error_half(tu_half, texton_half_spectrum(texton, shape), n)


def model_error(u, texton: Texton, *, periodic: bool | None = None) -> float:
    """Relative model error (RME) between the Gaussian model of u and a texton's.

    RME² = Σ_{ξ≠0} (|t̂_u|² + |t̂|² − 2|t̂_u* t̂|) / Σ_{ξ≠0} |t̂_u|² on u's grid,
    where |t̂|² = |α̂|² b̂ is the sampled spectrum the texton implies (CGF eq. (4)).
    0 is a perfect model; real textures with a 64² texton score 0.3–0.7.

    Even the exact model of a texture scores about 0.46–0.48 against a single
    sample of it (docs/model.md §3, "why a perfect model scores about
    0.46–0.48 against one sample"), so compare the RMEs of textons of the same
    image rather than reading one alone.

    Parameters
    ----------
    u : array (H, W) or (H, W, C)
    texton : Texton
        With as many channels as u and no larger than u.
    periodic : bool, optional
        Model the periodic component of u; by default (``None``) as the
        texton was analysed.

    Returns
    -------
    float
        The RME, ≥ 0.

    Raises
    ------
    TextonError
        For a ``texton`` that is not a :class:`Texton`, an image it cannot be
        compared with (another channel count, smaller than the texton, not a
        finite numeric array) and a computation over the memory budget.

    References
    ----------
    EUSIPCO §3.2 (with the factor 2 of eq. (1) in the numerator).

    Examples
    --------
    Larger textons fit better:

    >>> from warp_texton import read_image, analyze, model_error
    >>> from warp_texton.demo import demo_texture_path
    >>> u = read_image(demo_texture_path())
    >>> for size in (16, 32, 64):
    ...     t = analyze(u, size=size, iterations=30)
    ...     print(size, round(model_error(u, t), 3))
    16 0.485
    32 0.477
    64 0.453
    """
    if not isinstance(texton, Texton):
        raise TextonError(f"texton must be a Texton, got {type(texton).__name__}")
    if periodic is None:
        periodic = bool(texton.metadata.get("periodic", True))
    periodic = check_bool(periodic, "periodic")
    u = as_image(u)
    check_memory(ANALYSIS_BYTES_PER_VALUE * float(u.size), f"the model error of a {u.shape[1]}x{u.shape[0]} image",
                 "use a smaller image")
    _, t = normalized_kernel(u, periodic=periodic)
    if t.shape[2] != texton.channels:
        raise TextonError(
            f"u has {t.shape[2]} channels but the texton has {texton.channels}; they must match"
        )
    return relative_texton_error(sfft.rfft2(t, axes=(0, 1), workers=FFT_WORKERS), texton, t.shape[1])


def noise_sample(texton, mni: float, shape: tuple[int, int], seed: int,
                 impacts: np.ndarray | None = None) -> np.ndarray:
    """(M, N, C) float64: texton noise at MNI ``mni`` on a periodic M × N grid of
    texels, standardised by its exact moments, in NumPy: Poisson impacts (their
    count and uniform positions from ``seed``) splatted on the grid with the
    weights ψ(x − x_j) of the texton's order, convolved with its coefficients
    (Σ_j h(x − x_j) = (α ∗ Σ_j ψ(· − x_j))(x)). ``impacts``, when given, is
    :func:`impact_spectrum` of the same texton area, order, MNI, grid and seed
    (shared by textons that differ only in their coefficients). Not the kernels'
    impact stream: the analysis measures candidate textons with it."""
    m, n = shape
    if impacts is None:
        impacts = impact_spectrum(texton.support_area, texton.order, mni, shape, seed)
    lam = mni / texton.support_area
    coeffs = np.asarray(texton.coeffs, np.float64)
    field = np.fft.ifft2(impacts[..., None] * np.fft.fft2(coeffs, s=(m, n), axes=(0, 1)), axes=(0, 1)).real
    var = np.diag(np.atleast_2d(texton.covariance()))
    return (field - lam * texton.integral) / np.sqrt(np.maximum(lam * var, 1e-300))


def impact_spectrum(area: float, order: int, mni: float, shape: tuple[int, int], seed: int) -> np.ndarray:
    """(M, N) complex: the DFT of the Poisson impacts of :func:`noise_sample` (intensity
    MNI / ``area``), splatted with the B-spline weights of ``order``."""
    m, n = shape
    rng = np.random.default_rng(seed)
    lam = mni / area
    count = rng.poisson(lam * m * n)
    py, px = rng.uniform(0, m, count), rng.uniform(0, n, count)
    half = (order + 1) / 2.0
    y0, x0 = np.floor(py - half), np.floor(px - half)
    splat = np.zeros(m * n)
    for a in range(order + 2):
        wy = bspline(y0 + a - py, order)
        for b in range(order + 2):
            w = wy * bspline(x0 + b - px, order)
            idx = ((y0 + a).astype(np.int64) % m) * n + (x0 + b).astype(np.int64) % n
            splat += np.bincount(idx, w, m * n)
    return np.fft.fft2(splat.reshape(m, n))
