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

The patch distance and its floor are the package's own (``warp_texton.model.tiling``,
which also uses them for ``structure_score``), re-exported here.
"""

from __future__ import annotations

import numpy as np
from scipy.ndimage import gaussian_laplace

from warp_texton.model.tiling import PATCH, SCALES, half_distance, patch_distance

__all__ = ["patch_distance", "half_distance", "blend_zone_energy", "hf_energy", "PATCH", "SCALES"]



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
