"""How structured an example is, and what its tiling analysis costs.

The structure score (:func:`structure_score`) compares an example with its Gaussian version (its
Fourier phases randomised) by a multi-scale patch distance (:func:`patch_distance`), in units of the
example's own half-to-half distance: texton noise keeps a Gaussian texture, the tiling model
(model/tiling.py) the shapes of a structured one. The tiling analysis (model/tiling_fit.py) is priced
here from the example's shape alone, before any of its work (:func:`tiling_analysis_cost`).
"""

from __future__ import annotations

import math

import numpy as np

from ..core.checks import as_image
from ..core.errors import TextonError
from ..core.limits import check_memory, check_work

__all__ = ["MAX_EXAMPLE_SIDE", "PATCH", "SCALES", "SAMPLES", "DIRECTIONS", "patch_distance", "half_distance",
           "phase_randomised", "scorable", "structure_score", "structure_parts", "tiling_analysis_cost",
           "check_tiling_analysis", "tiling_affordable"]

#: Largest example side read from a file or accepted.
MAX_EXAMPLE_SIDE = 8192
#: Patch side and scales of :func:`patch_distance`.
PATCH = 7
SCALES = 3
SAMPLES = 16384
DIRECTIONS = 64
#: The price of the tiling analysis (:func:`tiling_analysis_cost`), per value (pixel × channel)
#: and per pixel, measured on the 2-core CPU of docs/limits.md (tracemalloc peaks; 256² to
#: 8192²): bytes at the peak of the structure score (the example in float64, its spectrum, the
#: white noise's phases and the phase-randomised copy in complex128), of the Gaussianised example
#: (``histogram="preserve"``: sorts, ranks, tables) and of the model (its float64 check and
#: float32 copy). Work, per value and log2(pixels): the score's NumPy FFTs (complex128, one
#: core) and the Gaussianised example's sorts, counted as the NumPy FFT path of
#: ``gaussian_texture`` runs (1.3 × 10⁹ operations a second there): measured 1.0–1.2 × 10⁻⁸ s
#: and 2.3–3.1 × 10⁻⁸ s a unit.
SCORE_BYTES = (56.0, 16.0)
PRESERVE_BYTES = (24.0, 64.0)
MODEL_BYTES = 12.0
SCORE_WORK = 15.0
PRESERVE_WORK = 40.0
MODEL_WORK = 12.0
#: The fit's steps (model/tiling_fit.py): the lattice detections' bytes and work per pixel, the probes'
#: bytes per probe pixel and per probe value (its index arrays, weights and sums in float64 and int64),
#: their work per probe pixel, the probes of a fit at most (three lattices, two more sides, two seeds)
#: and the probe's largest side.
DETECT_BYTES = 96.0
DETECT_WORK = 40.0
PROBE_BYTES = (320.0, 48.0)
PROBE_WORK = 120.0
PROBES = 10
PROBE_LIMIT = 512



def _patches(u: np.ndarray, rng: np.random.Generator, n: int) -> np.ndarray:
    h, w, _ = u.shape
    ys = rng.integers(0, h - PATCH + 1, n)
    xs = rng.integers(0, w - PATCH + 1, n)
    dy, dx = np.meshgrid(np.arange(PATCH), np.arange(PATCH), indexing="ij")
    return u[ys[:, None, None] + dy, xs[:, None, None] + dx].reshape(n, -1)


def _halve(u: np.ndarray) -> np.ndarray:
    h, w = (u.shape[0] // 2) * 2, (u.shape[1] // 2) * 2
    u = u[:h, :w]
    return 0.25 * (u[0::2, 0::2] + u[1::2, 0::2] + u[0::2, 1::2] + u[1::2, 1::2])


def patch_distance(u, v, *, seed: int = 0, scales: int = SCALES, samples: int = SAMPLES,
                   directions: int = DIRECTIONS) -> float:
    """The multi-scale 7 × 7 patch sliced-Wasserstein distance between images u and v.

    At each scale (the images, then halved by 2 × 2 box averages) 16384 patches
    of each image (all channels) are projected on the same 64 random unit
    directions; the mean |difference| of the sorted projections (the 1-D
    Wasserstein-1 distance) is averaged over directions and scales. Both images
    (H, W) or (H, W, C) with the same C and sides ≥ 7 · 2^(scales − 1).
    Deterministic for a given ``seed``; ``samples`` and ``directions`` trade its precision for time
    (the tiling fit's probes use fewer).
    """
    a = np.asarray(u, np.float64)
    b = np.asarray(v, np.float64)
    a = a[:, :, None] if a.ndim == 2 else a
    b = b[:, :, None] if b.ndim == 2 else b
    if a.shape[2] != b.shape[2]:
        raise TextonError(f"channels differ: {a.shape[2]} and {b.shape[2]}", param="v")
    if min(*a.shape[:2], *b.shape[:2]) < PATCH * 2 ** (scales - 1):
        raise TextonError(f"images must be at least {PATCH * 2 ** (scales - 1)} pixels on each side", param="u")
    rng = np.random.default_rng(seed)
    total = 0.0
    for _ in range(scales):
        pa, pb = _patches(a, rng, samples), _patches(b, rng, samples)
        d = rng.normal(size=(pa.shape[1], directions))
        d /= np.linalg.norm(d, axis=0)
        total += float(np.mean(np.abs(np.sort(pa @ d, axis=0) - np.sort(pb @ d, axis=0))))
        a, b = _halve(a), _halve(b)
    return total / scales


def half_distance(u, *, seed: int = 0) -> float:
    """:func:`patch_distance` between the two halves of u cut across its longer side: the floor."""
    a = np.asarray(u, np.float64)
    a = a[:, :, None] if a.ndim == 2 else a
    h, w = a.shape[:2]
    if w >= h:
        return patch_distance(a[:, :w // 2], a[:, w // 2:], seed=seed)
    return patch_distance(a[:h // 2], a[h // 2:], seed=seed)


def phase_randomised(u: np.ndarray, seed: int = 0) -> np.ndarray:
    """u with its Fourier phases replaced by those of white noise: the Gaussian model's version of u."""
    a = np.asarray(u, np.float64)
    a = a[:, :, None] if a.ndim == 2 else a
    mean = a.mean(axis=(0, 1))
    rng = np.random.default_rng(seed)
    phase = np.fft.fft2(rng.normal(size=a.shape[:2]))
    phase /= np.maximum(np.abs(phase), 1e-30)
    f = np.fft.fft2(a - mean, axes=(0, 1)) * phase[..., None]
    return np.real(np.fft.ifft2(f, axes=(0, 1))) + mean


def scorable(shape) -> bool:
    """True when an image of ``shape`` (H, W[, C]) is large enough for :func:`structure_score`."""
    h, w = shape[:2]
    need = PATCH * 2 ** (SCALES - 1)
    return min(h, w) >= need and max(h, w) >= 2 * need


def tiling_analysis_cost(shape, *, score: bool = True, histogram: str = "gaussian",
                         model: bool = True) -> tuple[float, float]:
    """(bytes, operations): the peak memory and the work of :func:`fit_tiling` on an example of
    ``shape`` (H, W) or (H, W, C), from the shape alone (docs/limits.md). The one place the tiling
    analysis is priced: a step it gains (lattice detection, more FFTs) adds its term here, and
    ``analyze``, the command line (from an image file's header) and the viewer follow.

    ``score``: with the structure score (``fit_tiling``'s default, for :func:`scorable` shapes);
    ``histogram``: as ``fit_tiling``'s; ``model=False``: the structure score alone
    (:func:`structure_score`). The steps run one after the other: the peak is the largest
    step's, beside the example in float32."""
    h, w = int(shape[0]), int(shape[1])
    c = int(shape[2]) if len(shape) > 2 else 1
    pixels = float(h) * w
    values, log = pixels * c, math.log2(max(pixels, 2.0))
    peaks, work = [0.0], 0.0
    if score and scorable(shape):
        # the patch distances: 16384 patches of each image at each scale, twice, on 64 directions
        projections = 2 * 2 * SCALES * SAMPLES * PATCH ** 2 * c * DIRECTIONS
        peaks.append(SCORE_BYTES[0] * values + SCORE_BYTES[1] * pixels + 8.0 * SAMPLES * (4 * PATCH ** 2 * c
                                                                                           + 2 * DIRECTIONS))
        work += SCORE_WORK * values * log + projections
    if model:
        peaks.append(MODEL_BYTES * values)
        work += MODEL_WORK * values
        # the fit (tiling_fit.py): two lattice detections (FFTs of the luminance), then the probes, each
        # a NumPy raster of the probe's side and its patch distance
        peaks.append(DETECT_BYTES * pixels)
        work += DETECT_WORK * pixels * log
        if score and scorable(shape):
            probe = float(min(PROBE_LIMIT, 2 * max(h, w))) ** 2
            peaks.append(PROBE_BYTES[0] * probe + PROBE_BYTES[1] * probe * c + 4.0 * values)
            work += PROBES * probe * (PROBE_WORK + 2 * 2 * SCALES * 4096 * PATCH ** 2 * c * 32 / probe)
        if histogram == "preserve":
            peaks.append(PRESERVE_BYTES[0] * values + PRESERVE_BYTES[1] * pixels)
            work += PRESERVE_WORK * values * log
    return 4.0 * values + max(peaks), work


def check_tiling_analysis(shape, *, score: bool = True, histogram: str = "gaussian", model: bool = True) -> None:
    """Refuse a tiling analysis (:func:`tiling_analysis_cost`'s arguments) of an example larger than a
    model holds or over the memory or work budget, before any of its work."""
    h, w = int(shape[0]), int(shape[1])
    if model and max(h, w) > MAX_EXAMPLE_SIDE:
        raise TextonError(f"example: {h}x{w}; at most {MAX_EXAMPLE_SIDE} per side", param="example")
    what = f"the {'tiling analysis' if model else 'structure score'} of a {w}x{h} example"
    nbytes, operations = tiling_analysis_cost(shape, score=score, histogram=histogram, model=model)
    check_memory(nbytes, what, "use a smaller example", param="u")
    check_work(operations, what, "use a smaller example", param="u")


def tiling_affordable(shape, histogram: str = "gaussian") -> bool:
    """Whether :func:`check_tiling_analysis` lets the tiling analysis of an example of ``shape`` through:
    ``method="auto"`` takes a texton where it would not."""
    try:
        check_tiling_analysis(shape, histogram=histogram)
    except TextonError:
        return False
    return True


def structure_score(u, *, seed: int = 0) -> float:
    """How far a Gaussian model of u is from u, in units of u's own half-to-half patch distance.

    About 1 for a Gaussian-like texture (grass, gravel, marble); 2 to 5 for
    textures with shapes (bricks, tiles, leaves), which texton noise turns into
    mush. Above :data:`STRUCTURE_THRESHOLD` the tiling model fits better.
    Priced before its FFTs (:func:`tiling_analysis_cost`).
    """
    a = as_image(u, "u")
    if not scorable(a.shape):
        need = PATCH * 2 ** (SCALES - 1)
        raise TextonError(f"the structure score needs an image of at least {need}x{2 * need} pixels, got "
                          f"{a.shape[1]}x{a.shape[0]}", param="u")
    check_tiling_analysis(a.shape, model=False)
    return _structure(a, seed)


def _structure(a: np.ndarray, seed: int) -> float:
    """:func:`structure_score` of an image (H, W, C) already checked and priced."""
    d, floor = structure_parts(a, seed)
    return float(d / max(floor, 1e-12))


def structure_parts(a: np.ndarray, seed: int) -> tuple[float, float]:
    """(the phase-randomised example's patch distance to the example, the half-to-half distance): the
    two parts of :func:`structure_score` of an image (H, W, C) already checked and priced."""
    floor = half_distance(a, seed=seed)
    return float(patch_distance(phase_randomised(a, seed), a, seed=seed)), float(floor)
