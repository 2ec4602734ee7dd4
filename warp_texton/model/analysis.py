"""Texton analysis: alternating projections from an example image.

One algorithm serves every order: EUSIPCO Algorithm 2 (order 0, the discrete
synthesis-oriented texton) is CGF Algorithm 1 with b̂ = 1. From a random-phase
start it alternates the projection onto the target spectrum |t̂_u|/√b̂
(EUSIPCO eq. (2), with the colour phase of CGF §4.3) and the restriction to
the support S. A 3 × 3 colour correction then restores the input's colour
covariance (CGF §4.3, EUSIPCO §4).

Speed: α lives on S (size × size) while the spectral projection needs the
whole M × N grid. The forward transform therefore runs real FFTs over the
``size`` non-zero rows only before the column FFTs, and the inverse keeps only
the ``size`` rows it needs before the last real FFTs; everything is float32.
See ``benchmarks/bench_analysis.py`` for the comparison with the plain
complex128 full-grid version.
"""

from __future__ import annotations

import math
from typing import Literal, overload
from dataclasses import replace

import numpy as np
import scipy.fft as sfft

from ..core.checks import as_image, check_bool, check_int, check_seed
from .structure import patch_distance, scorable, tiling_affordable
from .tiling import MIN_SIDE, TILING_KIND, TilingModel
from .spot_noise import dsn
from .tiling_fit import LATTICE_AUTO, PROBE_SAMPLES, PROBE_DIRECTIONS, PROBE_SEEDS, PROBE_SIDE, fit_tiling
from .bspline import bhat
from .analysis_options import (ANALYSIS_BYTES_PER_VALUE, SUPPORTS, AnalysisOptions,  # noqa: F401 - its names too
                               check_support)
from ..core.errors import TextonError
from .example_checks import warn_large, warn_unsuited
from ..core.limits import check_memory, check_work
from .histogram import NOISE_MNI, REFINE_MAX_PIXELS, REFINE_ROUNDS, HistogramTransform, check_histogram, gauss_grid
from .gaussian import FFT_WORKERS, normalized_kernel
from .judges import (impact_spectrum, judged_texton, model_error, noise_sample, preserve_steps, translated_texton,  # noqa: F401 - its names too
                     relative_texton_error, texton_half_spectrum)
from .texton import Texton, lag0_covariance
from .translation import noise_cdf, texton_values  # noqa: F401 - this module's names too

#: The methods of `analyze`: the Gaussian texton model (the default), tiling and blending.
METHODS = ("texton", TILING_KIND, "auto")
#: ``method="auto"`` picks the tiling model where its probe's patch distance to the example is below
#: this fraction of the texton's noise's (``texton_probe_distance``; with histogram tables, the
#: phase-randomised example's): the labelled set of benchmarks/bench_advice.py, docs/tiling.md.
AUTO_TILING_FRACTION = 1.0
#: The MNI of the texton's probe (the outputs' default).
AUTO_MNI = 30.0
#: The fits of ``histogram="preserve"`` (the first is the default): the translation process's
#: inverse (``translation.translated_kernel``) or the judged refits (``judges.judged_texton``).
PRESERVE_FITS = ("judges", "translation")
#: The fit ``analyze(..., histogram="preserve")`` uses (benchmarks/bench_colour.py sets it).
PRESERVE_FIT = PRESERVE_FITS[0]

#: A histogram-preserving analysis (``histogram="preserve"``) beyond the projections: bytes per
#: value (pixel × channel) and per pixel at its peak, and operations per value and log2(pixels).
#: HISTOGRAM: the tables, the Gaussianised and decorrelated example, the translation process's
#: kernel (NumPy's complex128 FFTs, on one core) and the tables fitted to the noise. JUDGES, for
#: examples of at most REFINE_MAX_PIXELS (``judged_texton``): their noise samples, the impacts'
#: spectra they share (MARGINAL_SAMPLES complex128 grids), the refits' kernels and each
#: candidate's tables, beside the projections of JUDGED_TEXTONS more textons. Measured on the
#: 2-core CPU of docs/limits.md (tracemalloc peaks; 512² to 2048², grey and RGB), the work
#: counted as the NumPy FFT path of ``gaussian_texture`` runs (1.3 × 10⁹ operations a second
#: there): 3.8–5.3 × 10⁻⁸ s and 2.2–2.9 × 10⁻⁷ s a unit.
HISTOGRAM_BYTES = (120.0, 48.0)
JUDGES_BYTES = (144.0, 136.0)
HISTOGRAM_WORK = 70.0
JUDGES_WORK = 360.0
#: The textons the judges fit besides the first: the plain one's refits, the zero-sum one and its
#: refits, and the example's Gaussian texton they are measured against.
JUDGED_TEXTONS = 2 * REFINE_ROUNDS + 2


def check_size_fits(size: int, grid, name: str, what: str = "the image") -> None:
    """The support must lie inside the image (CGF Algorithm 1: S ⊂ Ω)."""
    m, n = grid
    if size > min(m, n):
        raise TextonError(
            f"{name}: {what} ({n}x{m}) is too small for size {size}; the texton's support must lie inside "
            f"the image (choose size <= {min(m, n)})", param=name, mentions=("size",)
        )


def analysis_work(grid, channels: int, iterations: int) -> float:
    """Operations of the alternating projections on an M × N grid: per iteration
    and channel, a forward and an inverse 2-D FFT (M N log2(M N) each)."""
    m, n = grid
    return 2.0 * iterations * channels * m * n * math.log2(max(m * n, 2))


def analysis_cost(grid, channels: int, iterations: int, *, textons: int = 1, size: int = 0,
                  histogram: str = "gaussian") -> tuple[float, float]:
    """(bytes, operations): the peak memory and the work of an analysis (``textons`` of them,
    ``size`` × ``size``, on one M × N grid; ``histogram="preserve"``: its tables and, for at most
    REFINE_MAX_PIXELS pixels, its judges) from the shape alone (docs/limits.md)."""
    m, n = grid
    pixels = float(m) * n
    values = pixels * channels
    nbytes = ANALYSIS_BYTES_PER_VALUE * values + 8.0 * textons * size * size * channels
    work = textons * analysis_work(grid, channels, iterations)
    if histogram == "preserve":
        judged = pixels <= REFINE_MAX_PIXELS
        per_value, per_pixel = JUDGES_BYTES if judged else HISTOGRAM_BYTES
        nbytes = max(nbytes, per_value * values + per_pixel * pixels)
        log = math.log2(max(pixels, 2.0))
        work += HISTOGRAM_WORK * values * log
        if judged:
            work += JUDGES_WORK * values * log + JUDGED_TEXTONS * analysis_work(grid, channels, iterations)
    return nbytes, work


def check_analysis_cost(grid, channels: int, iterations: int, what: str, textons: int = 1, size: int = 0,
                        histogram: str = "gaussian") -> None:
    """Refuse an analysis (:func:`analysis_cost`'s arguments) beyond the memory or work budget."""
    nbytes, work = analysis_cost(grid, channels, iterations, textons=textons, size=size, histogram=histogram)
    if histogram == "preserve":
        what += " (histogram preserved)"
    check_memory(nbytes, what, "use a smaller image" + (" or fewer rhos" if textons > 1 else ""), mentions=("rhos",))
    check_work(work, what + f" with {iterations} iterations",
               "use fewer iterations or a smaller image" + (" or fewer rhos" if textons > 1 else ""),
               mentions=("iterations", "rhos"))


def support_mask(size: int, support: str = "square") -> np.ndarray:
    """Boolean (size, size) mask of the texton support S.

    "square" is the full square; "disk" keeps the coefficients whose centre is
    within size/2 of the square's centre (the circular supports of EUSIPCO Fig. 5).
    """
    if support == "square":
        return np.ones((size, size), dtype=bool)
    if support == "disk":
        c = (size - 1) / 2.0
        i, j = np.mgrid[:size, :size]
        return (i - c) ** 2 + (j - c) ** 2 <= (size / 2.0) ** 2
    raise TextonError(f"support must be one of {', '.join(SUPPORTS)}, got {support!r}")


def initial_phase(shape: tuple[int, int], seed: int) -> np.ndarray:
    """Random phase e^{iψ} on the rfft half-plane of an M × N grid.

    ψ is the phase of the DFT of a standard white noise drawn from ``seed``:
    uniform and Hermitian-symmetric. The alternating projections start by
    projecting this noise (the same in every channel) onto the target, as
    CGF Algorithm 1 does; its result is the target modulus with a uniform
    random phase, EUSIPCO Algorithm 2's start. Same (shape, seed), same start.
    """
    w = np.random.default_rng(seed).standard_normal(shape)
    w_hat = sfft.rfft2(w, workers=FFT_WORKERS)
    mag = np.abs(w_hat)
    return np.divide(w_hat, mag, out=np.zeros_like(w_hat), where=mag > 0)


def unit_phase(z: np.ndarray) -> np.ndarray:
    """z / |z|, and 0 where z = 0 (the indicator of EUSIPCO eq. (2))."""
    mag = np.abs(z)
    return np.divide(z, mag, out=np.zeros_like(z), where=mag > 0)


def _spectral_projection(a_hat: np.ndarray, target: np.ndarray, target_conj: np.ndarray) -> np.ndarray:
    """EUSIPCO eq. (2) per frequency: rotate the target onto a_hat's phase.

    Arrays are channel-first (C, M, Nc). The phase is that of the Hermitian
    product t̂*·â over channels, so colour channels keep their relative phases.
    """
    cross = a_hat[0] * target_conj[0]
    for c in range(1, a_hat.shape[0]):
        cross += a_hat[c] * target_conj[c]
    return target * unit_phase(cross)[None]


def correct_colors(alpha: np.ndarray, order: int, covariance: np.ndarray) -> np.ndarray:
    """Apply the 3 × 3 (or 1 × 1) map C = B^{1/2} A^{-1/2} to the coefficients.

    A = ∫ h hᵀ is the noise's lag-0 covariance for ``alpha`` and B the target,
    so that the corrected texton has ∫ h hᵀ = B (CGF §4.3). Directions where A
    vanishes are left at zero instead of being inverted.
    """
    a_cov = lag0_covariance(alpha.astype(np.float64), order)

    def sqrt_psd(m, inverse=False):
        w, v = np.linalg.eigh(0.5 * (m + m.T))
        tol = max(w.max(), 0.0) * 1e-10
        if inverse:
            d = np.where(w > tol, 1.0 / np.sqrt(np.maximum(w, tol)), 0.0)
        else:
            d = np.sqrt(np.clip(w, 0.0, None))
        return (v * d) @ v.T

    c = sqrt_psd(covariance) @ sqrt_psd(a_cov, inverse=True)
    return (alpha.astype(np.float64) @ c.T).astype(np.float32)


@overload
def analyze(
    u,
    *,
    size: int = 64,
    order: int = 1,
    iterations: int = 50,
    seed: int = 0,
    periodic: bool | str | None = None,
    color_correction: bool = True,
    support: str = "square",
    histogram: str = "gaussian",
    progress: bool = False,
    options: AnalysisOptions | None = None,
    method: Literal["texton"] = "texton",
    side: int | None = None,
    lattice=LATTICE_AUTO,
) -> Texton: ...


@overload
def analyze(
    u,
    *,
    size: int = 64,
    order: int = 1,
    iterations: int = 50,
    seed: int = 0,
    periodic: bool | str | None = None,
    color_correction: bool = True,
    support: str = "square",
    histogram: str = "gaussian",
    progress: bool = False,
    options: AnalysisOptions | None = None,
    method: Literal["tiling"],
    side: int | None = None,
    lattice=LATTICE_AUTO,
) -> TilingModel: ...


@overload
def analyze(
    u,
    *,
    size: int = 64,
    order: int = 1,
    iterations: int = 50,
    seed: int = 0,
    periodic: bool | str | None = None,
    color_correction: bool = True,
    support: str = "square",
    histogram: str = "gaussian",
    progress: bool = False,
    options: AnalysisOptions | None = None,
    method: str = "texton",
    side: int | None = None,
    lattice=LATTICE_AUTO,
) -> Texton | TilingModel: ...


def analyze(
    u,
    *,
    size: int = 64,
    order: int = 1,
    iterations: int = 50,
    seed: int = 0,
    periodic: bool | str | None = None,
    color_correction: bool = True,
    support: str = "square",
    histogram: str = "gaussian",
    progress: bool = False,
    options: AnalysisOptions | None = None,
    method: str = "texton",
    side: int | None = None,
    lattice=LATTICE_AUTO,
) -> Texton | TilingModel:
    """Compute the texton of a Gaussian texture example (or, with ``method``, the tiling model of a
    structured one).

    Parameters
    ----------
    u : array (H, W) or (H, W, C), C in {1, 3}
        Example texture. An integer array is scaled by its dtype's range
        (``uint8`` / 255...), as image files are; values must lie within
        ±1e10 (docs/limits.md).
    size : int
        Side of the square support, or diameter of the disk support: from 2
        to the image's smaller side (the support must lie inside the image,
        CGF Algorithm 1) and at most 4096. Textons larger than about half the
        image (past ``(min(H, W) + 1) // 2``, where the covariance support
        S − S no longer fits in the image, the assumption of EUSIPCO §3) model
        the image's own periodogram: its estimation noise and its large
        features, which the noise then repeats (see docs/limits.md).
    order : {0, 1, 3, 5}
        Interpolation order: 0 gives the discrete synthesis-oriented texton of
        EUSIPCO Algorithm 2, 1 the bilinear texton of CGF Algorithm 1, 3 and 5
        B-spline textons (CGF §10). The target modulus is |t̂_u| / √b̂.
    iterations : int
        Number of alternating projections (≥ 1; 50 suffice, EUSIPCO Fig. 2).
    seed : int
        Seed of the random initial phase; the texton is a deterministic
        function of (u, parameters, seed).
    periodic : bool or "auto", optional
        Texton: analyse the periodic component of u (CGF §4.2) rather than u
        itself (True, the default; "auto" is True). Tiling: read the example
        wrapped across its borders (True), or not (False), or where it is
        seamless ("auto", the default: its seam ratio per axis,
        :func:`~warp_texton.model.lattice.seam_ratios`).
    color_correction : bool
        Apply the linear colour map that makes the noise's lag-0 colour
        covariance equal to the input's (for grey: its variance).
    support : {"square", "disk"}
        Shape of the support S.
    histogram : {"gaussian", "preserve"}
        ``"gaussian"``: the noise's values are Gaussian (the papers' model).
        ``"preserve"``: each channel of the example (grey, or R, G and B) is
        mapped through its CDF to a Gaussian, that Gaussianised
        example is analysed, and the texton keeps the inverse map
        (:class:`~warp_texton.model.histogram.HistogramTransform`), which every
        output applies after the noise, so that outputs have the example's
        colour histogram (docs/histogram.md). For examples of at most 2²⁰
        pixels the texton is chosen by judges, on samples of its noise, among
        refits of the plain fit and of a zero-sum fit (whose outputs keep the
        example's mean; ``metadata["zero_sum"]``). With ``method="tiling"`` the
        model blends the Gaussianised example and maps the blend back through
        the same tables (docs/tiling.md, "Histogram-preserving blend").
    progress : bool
        Show a progress bar over the iterations.
    options : AnalysisOptions, optional
        ``size``, ``order``, ``iterations``, ``seed``, ``periodic``,
        ``color_correction``, ``support`` and ``histogram`` as one value
        (:class:`~warp_texton.AnalysisOptions`), in place of those keywords,
        which must then keep their defaults.

    Warns
    -----
    ExampleWarning
        When the example suits a texton badly (docs/photographs.md): larger
        than 1024² pixels (``LargeExampleWarning``), most of its variance at
        wavelengths longer than half the texton (``SmoothExampleWarning``), a
        local mean or contrast that varies across it
        (``NonStationaryWarning``), a ``size`` past half of it
        (``LargeTextonWarning``); the classes are in
        :mod:`warp_texton.model.example_checks`. The analysis goes on.
    method : {"texton", "tiling", "auto"}
        ``"texton"`` (the default): the Gaussian texton model, for textures
        without shapes (docs/model.md). ``"tiling"``: tiling and blending of
        the example itself (:class:`~warp_texton.model.tiling.TilingModel`,
        docs/tiling.md), for structured textures (bricks, tiles, paving);
        ``seed`` is then that of the structure score, and the
        texton-only options (``size``, ``order``, ``iterations``,
        ``color_correction``, ``support``) must keep their
        defaults. Its ``metadata["structure"]`` is the measured structure
        score (:func:`~warp_texton.model.structure.structure_score`) and
        ``metadata["fit"]`` what the fit found (seams, lattices, the
        candidates' distances). ``"auto"``: the tiling model where its probe
        is closer to the example, by the patch distance, than the
        phase-randomised example (what texton noise makes of it), else the
        texton (``metadata["method_choice"]`` holds both distances); a
        texton option given (``size``, ``order``, ``iterations``,
        ``color_correction``, ``support``, ``options``) makes it the texton,
        a tiling option (``side``, ``lattice``) the tiling model.
    side : int, optional
        With ``method="tiling"``: the side of the blend triangles in texels
        (default: chosen by the fit's probes among a quarter, a third and a
        half of the example's smaller side when it wraps, a quarter and a
        sixth otherwise).
    lattice : "auto", None, or one or two vectors (dy, dx)
        With ``method="tiling"``: the example's lattice, detected
        (``"auto"``, kept where the probes say it helps), none (None), or
        given in texels (:class:`~warp_texton.model.lattice.Lattice`).


    Returns
    -------
    Texton or TilingModel
        ``coeffs`` (size, size, C), ``mean`` of u, ``order``; ``metadata`` holds
        the parameters and ``metadata["model_error"]``, the relative model
        error of the texton against u (:func:`model_error`).

    Raises
    ------
    TextonError
        For an image that is not a numeric (H, W[, C]) array with C in
        {1, 3, 4} (an alpha channel is dropped with a warning), holds NaN or
        infinite values or is constant; a ``size`` outside [2, min(H, W)] or
        above 4096; an ``order`` other than 0, 1, 3, 5; ``iterations`` < 1; a
        ``seed`` outside [0, 2**32); an unknown ``support`` or ``histogram``;
        and an analysis over the memory or work budget (docs/limits.md).

    Notes
    -----
    The algorithm, with the derivation of the target modulus and the colour
    correction, is in docs/model.md §5–§7. 50 iterations are plenty.

    References
    ----------
    EUSIPCO Algorithm 2 and eq. (2); CGF §4.2 Algorithm 1, §4.3, §10.

    Examples
    --------
    >>> from warp_texton import read_image, analyze
    >>> from warp_texton.demo import demo_texture_path
    >>> u = read_image(demo_texture_path())
    >>> t = analyze(u, size=64, order=1, seed=0)
    >>> t
    Texton(64x64, channels=1, order=1, mean=[0.4664])
    >>> round(t.metadata["model_error"], 3)
    0.449
    """
    if not isinstance(method, str) or method not in METHODS:
        raise TextonError(f"method must be one of {', '.join(METHODS)}, got {method!r:.60}", param="method")
    if periodic is not None and not (isinstance(periodic, bool) or periodic == "auto"):
        raise TextonError(f"periodic must be True, False or 'auto', got {periodic!r:.60}", param="periodic")
    if method in (TILING_KIND, "auto"):
        return _by_method(u, method, dict(size=size, order=order, iterations=iterations, seed=seed,
                                          periodic=periodic, color_correction=color_correction, support=support,
                                          histogram=histogram, progress=progress, options=options), side, lattice)
    if side is not None:
        raise TextonError("side applies to method 'tiling' only", param="side")
    if lattice is not LATTICE_AUTO:
        raise TextonError("lattice applies to method 'tiling' only", param="lattice")
    if periodic is None or periodic == "auto":
        periodic = True
    return _texton_analysis(u, size, order, iterations, seed, periodic, color_correction, support, histogram,
                            progress, options)


def _texton_analysis(u, size, order, iterations, seed, periodic, color_correction, support, histogram, progress,
                     options) -> Texton:
    """``analyze`` with method "texton", its options checked for the method."""
    u = as_image(u)
    o = AnalysisOptions.given(options, size=size, order=order, iterations=iterations, seed=seed, periodic=periodic,
                              color_correction=color_correction, support=support, histogram=histogram)
    progress = check_bool(progress, "progress")
    size, order, iterations, seed = o.size, o.order, o.iterations, o.seed
    periodic, color_correction, support, histogram = o.periodic, o.color_correction, o.support, o.histogram
    m, n, c = u.shape
    check_size_fits(size, (m, n), "u")
    check_analysis_cost((m, n), c, iterations, f"analysing a {n}x{m} image", histogram=histogram)
    warn_large((m, n), size)
    transform = None
    if histogram == "preserve":
        # colour: one table per RGB channel, and a correction that keeps the channels
        # coherent (docs/histogram.md); grey keeps the per-frequency correction. Both are
        # then refitted and judged on samples of their noise (judged_texton)
        colour = c > 1
        steps = preserve_steps(progress)  # one bar over the stages, not the projections' own
        progress = False
        transform = HistogramTransform.fit(u, axes="rgb" if colour else "pca")
        z = transform.decorrelate(u).astype(np.float32)
        mean, t = normalized_kernel(transform.to_gaussian(u).astype(np.float32), periodic=periodic)
        tz = normalized_kernel(z, periodic=periodic)[1]
        if PRESERVE_FIT == "translation":
            return translated_texton(u, transform, t, tz, mean, size, order, iterations, seed, periodic,
                                     color_correction, support, texton_from_spectrum, steps)
        t = transform.gaussian_kernel(t, tz, size if colour else None)
        steps.step()
    else:
        mean, t = normalized_kernel(u, periodic=periodic)
    t_hat = sfft.rfft2(t, axes=(0, 1), workers=FFT_WORKERS)
    warn_unsuited(u, t_hat, size)
    flat = t.reshape(-1, c)
    texton = texton_from_spectrum(
        t_hat, n, mean, size, order, iterations, seed,
        covariance=flat.T @ flat if color_correction else None, support=support, progress=progress,
    )
    texton.metadata.update(periodic=bool(periodic))
    if transform is None:
        return texton
    steps.step()
    if m * n <= REFINE_MAX_PIXELS:
        texton, transform, judges = judged_texton(u, texton, transform, t, t_hat, tz, n, mean, size, order,
                                                  iterations, seed, flat.T @ flat if color_correction else None,
                                                  support, texton_from_spectrum)
        texton.metadata.update(periodic=bool(periodic), **judges)
    else:
        # the tables take the noise's own marginal (compound Poisson, skewed at MNI 30) to
        # the example's, not a Gaussian's (docs/histogram.md, "The noise's own marginal")
        transform = transform.for_noise(u, noise_cdf(texton, NOISE_MNI, gauss_grid(transform.lut.shape[1])))
    steps.step()
    steps.close()
    texton.metadata.update(histogram=histogram, histogram_mni=NOISE_MNI)
    return replace(texton, histogram=transform)



def _by_method(u, method: str, texton_options: dict, side, lattice) -> Texton | TilingModel:
    """``analyze`` with ``method`` "tiling" or "auto" (``texton_options``: its texton keywords)."""
    o = texton_options
    size, order, iterations, seed, periodic = o["size"], o["order"], o["iterations"], o["seed"], o["periodic"]
    color_correction, support, histogram, options = o["color_correction"], o["support"], o["histogram"], o["options"]
    choice: dict | None = None
    changed = [name for name, value, default in (
        ("size", size, 64), ("order", order, 1), ("iterations", iterations, 50),
        ("color_correction", color_correction, True), ("support", support, "square"))
        if not (type(value) is type(default) and value == default)]
    if options is not None:
        changed.insert(0, "options")
    if changed and method == TILING_KIND:
        verb = "applies" if len(changed) == 1 else "apply"
        raise TextonError(f"{', '.join(changed)} {verb} to method 'texton' only, not to method 'tiling'",
                          param=changed[0])
    side = None if side is None else check_int(side, "side", minimum=2)
    a = as_image(u)
    if method == "auto" and (side is not None or lattice is not LATTICE_AUTO):
        if changed:
            raise TextonError(f"{changed[0]} (a texton option) and {'side' if side is not None else 'lattice'} "
                              "(a tiling option) disagree for method 'auto'; give method", param="method")
        method = TILING_KIND  # a tiling option given: the user asks for the tiling model
    if method == TILING_KIND or (not changed and scorable(a.shape) and min(a.shape[:2]) >= MIN_SIDE
                                 and tiling_affordable(a.shape, check_histogram(histogram))):
        model = fit_tiling(a, side=side, seed=check_seed(seed), histogram=check_histogram(histogram),
                           periodic="auto" if periodic is None else periodic,
                           lattice="auto" if lattice is LATTICE_AUTO else lattice)
        if method == TILING_KIND:
            return model
        d_tiling = model.metadata.get("tiling_distance")
        d_texton = model.metadata.get("texton_distance_blended", model.metadata.get("texton_distance"))
        choice = {"tiling": d_tiling, "texton": d_texton}
    texton = _texton_analysis(a, size, order, iterations, seed, True if periodic in (None, "auto") else periodic,
                              color_correction, support, histogram, o["progress"], options)
    if choice is None:
        return texton
    if texton.histogram is None:  # the texton's own output, as the tiling's probe is the tiling's
        choice["texton"] = texton_probe_distance(texton, a, check_seed(seed))
        choice["texton_measure"] = "texton noise (discrete spot noise, MNI 30)"
    else:
        choice["texton_measure"] = "the phase-randomised example (Gaussianised)"
    structure = model.metadata.get("structure")
    if choice["tiling"] is not None and choice["texton"] is not None \
            and choice["tiling"] < AUTO_TILING_FRACTION * choice["texton"]:
        model.metadata["method_choice"] = choice
        return model
    texton.metadata["method_choice"] = choice
    texton.metadata["structure"] = structure
    return texton


def texton_probe_distance(texton: Texton, u: np.ndarray, seed: int = 0) -> float:
    """The patch distance to the example u of the texton's noise, drawn as discrete spot noise at MNI 30
    (:func:`~warp_texton.model.spot_noise.dsn`) on the tiling fit's probe raster, with its seeds, samples
    and directions: what ``method="auto"`` weighs against the tiling model's probe."""
    side = min(PROBE_SIDE, 2 * max(u.shape[:2]))
    return float(np.mean([patch_distance(dsn(texton, (side, side), mni=AUTO_MNI, seed=s), u, seed=seed,
                                         samples=PROBE_SAMPLES, directions=PROBE_DIRECTIONS)
                          for s in PROBE_SEEDS]))


def texton_from_spectrum(
    t_hat: np.ndarray,
    n: int,
    mean,
    size: int,
    order: int,
    iterations: int,
    seed: int,
    covariance: np.ndarray | None = None,
    support: str = "square",
    progress: bool = False,
    zero_sum: bool = False,
) -> Texton:
    """The alternating projections for a model given by its kernel spectrum.

    ``t_hat`` is the rfft half-plane (M, n//2 + 1, C) of a real kernel t on an
    M × n grid (for an image, t_u); the texton's model |α̂|² b̂ approaches |t̂|²
    on that grid. ``covariance`` (C × C), when given, is the lag-0 colour
    covariance the colour correction enforces. With ``zero_sum`` the spatial
    projection is onto the textons supported by S whose coefficients sum to 0
    (each channel's mean over S subtracted): the noise then has no power at
    frequency 0, as the model (t̂_u(0) = 0) has none. Arguments are trusted: the
    public entry points check them.
    """
    m = t_hat.shape[0]
    mask = support_mask(size, support)
    nc = n // 2 + 1
    t_cf = np.ascontiguousarray(t_hat.transpose(2, 0, 1))  # channel-first (C, M, Nc)
    target = (t_cf / np.sqrt(bhat((m, n), order))[None, :, :nc]).astype(np.complex64)
    target_conj = np.conj(target)
    mask_f = mask.astype(np.float32)
    mask_count = float(mask_f.sum())

    def restrict(a_hat: np.ndarray) -> np.ndarray:
        # inverse transform, keeping only the `size` rows and columns of S
        rows = sfft.ifft(a_hat, axis=-2, workers=FFT_WORKERS, overwrite_x=True)[:, :size]
        alpha = sfft.irfft(rows, n=n, axis=-1, workers=FFT_WORKERS)[:, :, :size] * mask_f
        if zero_sum:
            alpha -= alpha.sum(axis=(1, 2), keepdims=True) / mask_count * mask_f
        return alpha

    bar = None
    if progress:
        from ..core.progress import bar as progress_bar

        bar = progress_bar(total=iterations, desc="analyze", unit="it")
    # CGF Algorithm 1 starts from white noise and projects it: the first iterate
    # is the target with a random phase relative to the target's own phase, so
    # targets that differ by a phase factor (e.g. τ_0 in mixing) give one texton.
    noise = np.broadcast_to(initial_phase((m, n), seed).astype(np.complex64)[None], target.shape)
    alpha = restrict(_spectral_projection(noise, target, target_conj))
    if bar is not None:
        bar.update()
    for _ in range(iterations - 1):
        rows = sfft.rfft(alpha, n=n, axis=-1, workers=FFT_WORKERS)
        a_hat = sfft.fft(rows, n=m, axis=-2, workers=FFT_WORKERS, overwrite_x=True)
        alpha = restrict(_spectral_projection(a_hat, target, target_conj))
        if bar is not None:
            bar.update()
    if bar is not None:
        bar.close()

    alpha = np.ascontiguousarray(alpha.transpose(1, 2, 0), dtype=np.float32)
    if covariance is not None:
        alpha = correct_colors(alpha, order, covariance) * mask[:, :, None]
    metadata = {
        "source_shape": [m, n],
        "size": size,
        "order": order,
        "iterations": iterations,
        "seed": seed,
        "color_correction": covariance is not None,
        "support": support,
    }
    if zero_sum:
        metadata["zero_sum"] = True
    texton = Texton(alpha, np.asarray(mean, dtype=np.float32), order, metadata)
    texton.metadata["model_error"] = relative_texton_error(t_hat, texton, n)
    return texton
