"""Measures of structure for by-example textures: patch distance and blend-zone energy.

* :func:`patch_distance` — the multi-scale 7 × 7 patch sliced-Wasserstein
  distance between two images: at each scale (the image, then box-halved twice)
  a sample of 7 × 7 patches (all channels) of each image is projected on the same
  random unit directions, and the 1-D Wasserstein-1 distance of the projected
  samples (quantiles compared) is averaged over directions and scales. It sees
  shapes — edges, corners, mortar lines — that the spectrum and the histogram do
  not (Heitz et al., "A Sliced Wasserstein Loss for Neural Texture Synthesis",
  CVPR 2021, use the same statistic on features).
* :func:`half_distance` — the floor: the same distance between the example's own
  two halves (left/right, or top/bottom for a tall example), so that a ratio of
  about 1 means "as close to the example as the example is to itself".
* :func:`blend_zone_energy` — ln of the high-frequency energy (a Laplacian of
  Gaussian, σ = 1 pixel) of an output inside its blend zones (where no patch has
  a weight above 0.8) over the example's mean: 0 when the blend adds no speckle and
  removes no detail, > 0 for speckle, < 0 for ghosting/blur.
* :func:`lattice_kept` — how regular an output is on the example's lattice: the
  output's normalised autocorrelation at the lattice's peaks (its vectors and small
  integer combinations of them, read bilinearly at sub-texel lags) over the
  example's own at the same lags. 1: as regular as the example; 0: the lattice is
  lost (brick courses that jog at every blend).
* :func:`residual_repetition` — ``bench_quality.repetition`` of the output after
  its lattice-periodic mean is removed (the output's own mean over the example's
  lattice translations, ``warp_texton.model.lattice.lattice_mean``): the repeats that
  are not the lattice (the same stain every few tiles). Without a lattice, plain
  repetition.

The patch distance and its floor are the package's own (``warp_texton.model.tiling``,
which also uses them for ``structure_score``), re-exported here.
"""

from __future__ import annotations

import numpy as np
from scipy.ndimage import gaussian_laplace

from warp_texton.model.structure import PATCH, SCALES, half_distance, patch_distance

try:
    from .bench_quality import autocorrelation, repetition
except ImportError:  # imported as a script's sibling (benchmarks/ on sys.path)
    from bench_quality import autocorrelation, repetition

__all__ = ["patch_distance", "half_distance", "blend_zone_energy", "hf_energy", "PATCH", "SCALES",
           "lattice_lags", "lattice_kept", "residual_repetition", "as_lattice", "MIN_PEAK", "REACH"]

#: Lattice peaks of the example's autocorrelation below this are left out of :func:`lattice_kept`
#: (a lag where the example itself is not correlated says nothing about the output).
MIN_PEAK = 0.05
#: Integer combinations m₁ v₁ + m₂ v₂ with |mᵢ| ≤ REACH (2-D), or m v with 1 ≤ m ≤ REACH + 1 (courses).
REACH = 2


def _channels(u) -> np.ndarray:
    u = np.asarray(u, np.float64)
    return u[:, :, None] if u.ndim == 2 else u


def hf_energy(u) -> np.ndarray:
    """Per-pixel high-frequency energy: the squared Laplacian of Gaussian (σ = 1), summed over channels."""
    a = _channels(u)
    return sum(gaussian_laplace(a[..., k], 1.0, mode="reflect") ** 2 for k in range(a.shape[2]))


def blend_zone_energy(example, out, max_weight: np.ndarray | None, *, threshold: float = 0.8) -> float:
    """ln(mean HF energy of ``out`` where ``max_weight`` < threshold / mean HF energy of ``example``).

    ``max_weight`` (H, W): the largest blend weight at each output pixel; None
    measures the whole output.
    """
    e = hf_energy(out)
    if max_weight is not None:
        zone = np.asarray(max_weight) < threshold
        if zone.any():
            e = e[zone]
    return float(np.log(np.mean(e) / np.mean(hf_energy(example))))


def as_lattice(lattice, shape):
    """``lattice`` as a :class:`warp_texton.model.lattice.Lattice`: None, a Lattice, or one or two vectors
    (dy, dx) (made for an example of ``shape`` that does not wrap)."""
    from warp_texton.model.lattice import Lattice

    if lattice is None or isinstance(lattice, Lattice):
        return lattice
    return Lattice.from_vectors(lattice, shape, (False, False))


def _vectors(lattice) -> np.ndarray:
    if hasattr(lattice, "vectors"):
        return np.array(lattice.vectors, np.float64).reshape(-1, 2)
    return np.array(lattice, np.float64).reshape(-1, 2)


def lattice_lags(lattice, limit: float) -> np.ndarray:
    """(n, 2) lags (dy, dx) of a lattice's peaks, one of each ± pair, at most ``limit`` texels long: the
    combinations m₁ v₁ + m₂ v₂ (|mᵢ| ≤ :data:`REACH`, not both 0) of a 2-D lattice, the multiples m v
    (1 ≤ m ≤ REACH + 1) of a course vector. ``lattice``: a Lattice or one or two vectors (dy, dx)."""
    v = _vectors(lattice)
    if len(v) == 1:
        lags = np.arange(1, REACH + 2)[:, None] * v[0][None, :]
    else:
        m = np.array([(a, b) for a in range(REACH + 1) for b in range(-REACH, REACH + 1) if a > 0 or b > 0],
                     np.float64)
        lags = m @ v
    return lags[np.hypot(lags[:, 0], lags[:, 1]) <= limit]


def _at(corr: np.ndarray, lags: np.ndarray) -> np.ndarray:
    """Bilinear values of a centred autocorrelation (``bench_quality.autocorrelation``) at lags (dy, dx)."""
    from scipy.ndimage import map_coordinates

    cy, cx = corr.shape[0] // 2, corr.shape[1] // 2
    return map_coordinates(corr, [cy + lags[:, 0], cx + lags[:, 1]], order=1, mode="nearest")


def lattice_kept(output, example, lattice) -> float | None:
    """The output's normalised autocorrelation at the example's lattice peaks over the example's own.

    Both autocorrelations are ``bench_quality.autocorrelation`` (mean removed, channels summed, not
    circular: each lag over the pixel pairs it overlaps), read bilinearly at the lags of
    :func:`lattice_lags` within half the example's smaller side (the reach of lattice detection) where the example's is at least :data:`MIN_PEAK`; the ratio of the sums over those lags.
    1: as regular as the example; 0: the lattice is lost. None without a lattice or a peak.
    """
    if lattice is None:
        return None
    e = np.asarray(example)
    lags = lattice_lags(lattice, min(e.shape[:2]) / 2.0)
    if not len(lags):
        return None
    ref = _at(autocorrelation(e), lags)
    keep = ref >= MIN_PEAK
    if not keep.any():
        return None
    out = _at(autocorrelation(output), lags[keep])
    return float(out.sum() / ref[keep].sum())


def residual_repetition(output, example=None, lattice=None, wrap=(False, False)) -> float:
    """``bench_quality.repetition`` of ``output`` less its own lattice-periodic mean on ``lattice`` (the
    example's lattice: a Lattice or one or two vectors (dy, dx)); plain repetition without a lattice.

    The mean is :func:`warp_texton.model.lattice.lattice_mean` of the output (``wrap``: whether the output
    itself tiles, False for a synthesised raster) with the example's lattice vectors: the output's own
    mean at each phase of the lattice, wherever its tiles lie. ``example`` is not read (the signature
    matches :func:`lattice_kept`); pass the example as ``output`` for the example's own value, with its
    ``wrap``.
    """
    from warp_texton.model.lattice import lattice_mean

    out = np.asarray(output, np.float64)
    out = out[:, :, None] if out.ndim == 2 else out
    lat = as_lattice(lattice, out.shape)
    if lat is None:
        return repetition(out)
    return repetition(out - lattice_mean(out, lat, wrap))
