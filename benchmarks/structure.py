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

Everything here is deterministic for a given ``seed``.
"""

from __future__ import annotations

import numpy as np
from scipy.ndimage import gaussian_laplace

__all__ = ["patch_distance", "half_distance", "blend_zone_energy", "hf_energy", "PATCH", "SCALES"]

#: Side of the patches compared.
PATCH = 7
#: Number of scales (the image, then halved by 2 × 2 box averages, each time).
SCALES = 3
#: Patches drawn per image and scale, and random directions per scale.
SAMPLES = 16384
DIRECTIONS = 64


def _channels(u) -> np.ndarray:
    u = np.asarray(u, np.float64)
    return u[:, :, None] if u.ndim == 2 else u


def _halve(u: np.ndarray) -> np.ndarray:
    h, w = (u.shape[0] // 2) * 2, (u.shape[1] // 2) * 2
    u = u[:h, :w]
    return 0.25 * (u[0::2, 0::2] + u[1::2, 0::2] + u[0::2, 1::2] + u[1::2, 1::2])


def _patches(u: np.ndarray, rng: np.random.Generator, n: int) -> np.ndarray:
    """n patches of u (drawn uniformly, with replacement), flattened: (n, PATCH² C)."""
    h, w, c = u.shape
    ys = rng.integers(0, h - PATCH + 1, n)
    xs = rng.integers(0, w - PATCH + 1, n)
    dy, dx = np.meshgrid(np.arange(PATCH), np.arange(PATCH), indexing="ij")
    return u[ys[:, None, None] + dy, xs[:, None, None] + dx].reshape(n, -1)


def _sliced_w1(a: np.ndarray, b: np.ndarray, rng: np.random.Generator) -> float:
    d = rng.normal(size=(a.shape[1], DIRECTIONS))
    d /= np.linalg.norm(d, axis=0)
    pa, pb = np.sort(a @ d, axis=0), np.sort(b @ d, axis=0)
    if pa.shape[0] != pb.shape[0]:  # compare quantiles
        q = (np.arange(SAMPLES) + 0.5) / SAMPLES
        pa, pb = np.quantile(pa, q, axis=0), np.quantile(pb, q, axis=0)
    return float(np.mean(np.abs(pa - pb)))


def patch_distance(u, v, *, seed: int = 0, scales: int = SCALES) -> float:
    """The multi-scale 7 × 7 patch sliced-Wasserstein distance between images u and v.

    Both (H, W) or (H, W, C) with the same C, each side at least 7 · 2^(scales − 1).
    """
    a, b = _channels(u), _channels(v)
    if a.shape[2] != b.shape[2]:
        raise ValueError(f"channels differ: {a.shape[2]} and {b.shape[2]}")
    rng = np.random.default_rng(seed)
    total = 0.0
    for _ in range(scales):
        total += _sliced_w1(_patches(a, rng, SAMPLES), _patches(b, rng, SAMPLES), rng)
        a, b = _halve(a), _halve(b)
    return total / scales


def half_distance(u, *, seed: int = 0) -> float:
    """:func:`patch_distance` between the two halves of u, cut across its longer side."""
    a = _channels(u)
    h, w = a.shape[:2]
    if w >= h:
        return patch_distance(a[:, :w // 2], a[:, w // 2:], seed=seed)
    return patch_distance(a[:h // 2], a[h // 2:], seed=seed)


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
