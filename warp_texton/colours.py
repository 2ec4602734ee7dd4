"""The colours of the outputs: a texton's histogram transform applied to its noise.

A texton analysed with ``histogram="preserve"`` synthesises Gaussian values;
:func:`to_colours` standardises them with the noise's own mean and standard
deviation (the texton's ``mean`` and the diagonal of its ``covariance()``)
and maps them through the texton's
:class:`~warp_texton.histogram.HistogramTransform`. Every output hands its
values over through it once: :class:`~warp_texton.canvas.Canvas` (rasters,
points, plane views, batches, and so Dask chunks and the viewer) and the
surface evaluation (surface noise, meshes, bakes, renders).

Filtered values keep a share v of the noise's variance: :func:`footprint_shares`
models it for a pixel's footprint as a Gaussian filter of the footprint's
second moments, v = Σ_ξ P(ξ) exp(−4π² ξᵀ J Jᵀ ξ / 12) / Σ_ξ P(ξ) with P the
noise's power spectrum (summed over channels), and the transform uses tables
prefiltered for v (docs/histogram.md).
"""

from __future__ import annotations

import functools

import numpy as np

from .filter_options import FilterOptions
from .limits import check_memory
from .texton import Texton

#: The shares' table: footprint extents 2^LOG_EXTENTS texels along the two axes of
#: J Jᵀ, and ANGLES directions of its major axis over [0, π).
LOG_EXTENTS = np.arange(-3.0, 13.01, 0.5)
ANGLES = 16
#: Values mapped at a time: the float64 temporaries of a lookup stay near 100 MB.
CHUNK = 1 << 20
#: The spectrum's grid side, at least (and at least the texton's size).
SPECTRUM_SIDE = 64


@functools.lru_cache(maxsize=16)
def noise_moments(texton: Texton) -> tuple[np.ndarray, np.ndarray]:
    """(mean, standard deviation) per channel of the texton's noise (CGF §3.3)."""
    var = np.diag(np.atleast_2d(texton.covariance()))
    return texton.mean.astype(np.float64), np.sqrt(np.maximum(var, 1e-30))


def to_colours(values: np.ndarray, texton: Texton | None, share=None) -> None:
    """Map ``values`` (N, ≥ C) float32, in place, from the noise of ``texton`` to its
    example's colours; nothing for a texton without a histogram transform.

    ``share``: None (unfiltered values) or the share of the variance each value
    kept, a number or (N,) (:func:`footprint_shares`).
    """
    if texton is None or texton.histogram is None or not len(values):
        return
    c = texton.channels
    mean, std = noise_moments(texton)
    shares = None if share is None else np.broadcast_to(np.asarray(share, np.float64), (len(values),))
    for start in range(0, len(values), CHUNK):  # float64 temporaries of a bounded size
        part = values[start:start + CHUNK]
        g = (part[:, :c].astype(np.float64) - mean) / std
        part[:, :c] = texton.histogram.to_colours(g, None if shares is None else shares[start:start + CHUNK])


def mean_colour(texton: Texton) -> np.ndarray:
    """(C,) float32: the colour of the noise's mean, the limit of far views (its
    mean, mapped with the table prefiltered for a share 0 of the variance)."""
    value = np.zeros((1, 3), np.float32)
    value[0, :texton.channels] = texton.mean
    to_colours(value, texton, 0.0)
    return value[0, :texton.channels]


@functools.lru_cache(maxsize=16)
def share_table(texton: Texton) -> np.ndarray:
    """(E, E, ANGLES) shares of the variance kept by Gaussian footprints of extents
    2^LOG_EXTENTS (major, minor) and major-axis angle k π / ANGLES."""
    side = max(SPECTRUM_SIDE, *texton.size)
    check_memory(80.0 * side * side * texton.channels, "the share table of a histogram-preserving texton",
                 "use a smaller texton")
    power = (np.abs(texton.spectrum((side, side))) ** 2).sum(axis=2).ravel()
    total = power.sum()
    fy, fx = (a.ravel() for a in np.meshgrid(np.fft.fftfreq(side), np.fft.fftfreq(side), indexing="ij"))
    lam = (2.0 ** LOG_EXTENTS) ** 2 / 12.0  # a pixel of extent a is a box of variance a² / 12
    out = np.empty((len(LOG_EXTENTS), len(LOG_EXTENTS), ANGLES))
    for k in range(ANGLES):
        th = np.pi * k / ANGLES
        u = fx * np.cos(th) + fy * np.sin(th)
        v = -fx * np.sin(th) + fy * np.cos(th)
        # separable: exp(−4π² (λ1 u² + λ2 v²)) = exp(−4π² λ1 u²) exp(−4π² λ2 v²)
        e1 = np.exp(-4.0 * np.pi ** 2 * lam[:, None] * u[None] ** 2)
        e2 = np.exp(-4.0 * np.pi ** 2 * lam[:, None] * v[None] ** 2)
        out[:, :, k] = (e1 * power) @ e2.T / total if total > 0 else 1.0
    return out


def footprint_shares(texton: Texton, J: np.ndarray, options: FilterOptions) -> np.ndarray:
    """The share of the noise's variance kept by pixels of footprints J (..., 2, 2)
    filtered as ``options`` say: 1 for unfiltered pixels; J's leading shape."""
    J = np.asarray(J, np.float64)
    if not (options.spec.footprint or options.spec.supersamples):
        return np.ones(J.shape[:-2])
    m = np.einsum("...ij,...kj->...ik", J, J)
    half = 0.5 * (m[..., 0, 0] + m[..., 1, 1])
    disc = np.sqrt(0.25 * (m[..., 0, 0] - m[..., 1, 1]) ** 2 + m[..., 0, 1] ** 2)
    major, minor = np.sqrt(half + disc), np.sqrt(np.maximum(half - disc, 0.0))
    angle = 0.5 * np.arctan2(2.0 * m[..., 0, 1], m[..., 0, 0] - m[..., 1, 1])  # of the major axis
    table = share_table(texton)
    step = LOG_EXTENTS[1] - LOG_EXTENTS[0]
    n = len(LOG_EXTENTS)

    def axis(extent):
        with np.errstate(divide="ignore"):
            pos = np.clip((np.log2(extent) - LOG_EXTENTS[0]) / step, 0.0, n - 1)
        i = np.minimum(pos.astype(np.int64), n - 2)
        return i, pos - i

    (i, ti), (j, tj) = axis(major), axis(minor)
    pk = np.mod(angle, np.pi) / np.pi * ANGLES
    k = np.minimum(pk.astype(np.int64), ANGLES - 1)
    tk = pk - k
    k1 = (k + 1) % ANGLES
    out = 0.0
    for di, wi in ((0, 1.0 - ti), (1, ti)):
        for dj, wj in ((0, 1.0 - tj), (1, tj)):
            out = out + wi * wj * (table[i + di, j + dj, k] * (1.0 - tk) + table[i + di, j + dj, k1] * tk)
    return np.clip(out, 0.0, 1.0)
