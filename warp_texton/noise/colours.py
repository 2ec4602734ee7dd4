"""The colours of the outputs: a texton's histogram transform applied to its noise.

A texton analysed with ``histogram="preserve"`` synthesises Gaussian values;
:func:`to_colours` standardises them with the noise's own mean and standard
deviation (the texton's ``mean`` and the diagonal of its ``covariance()``)
and maps them through the texton's
:class:`~warp_texton.model.histogram.HistogramTransform`. Every output hands its
values over through it once: :class:`~warp_texton.noise.canvas.Canvas` (rasters,
points, plane views, batches, and so Dask chunks and the viewer) and the
surface evaluation (surface noise, meshes, bakes, renders).

Filtered values keep a share v of the noise's variance: :func:`footprint_shares`
models it for a pixel's footprint as a Gaussian filter of the footprint's
second moments, v = Σ_ξ P(ξ) exp(−4π² ξᵀ J Jᵀ ξ / 12) / Σ_ξ P(ξ) with P the
noise's power spectrum (summed over channels), and the transform uses tables
prefiltered for v (docs/histogram.md).

Kernels driven here: ``warp_texton.kernels.noise_colours``, ``warp_texton.kernels.noise_filter``.
"""

from __future__ import annotations

import functools

import numpy as np

from ..core.runtime import init_warp
from .filter_options import FilterOptions
from ..model.histogram import GAUSS_RANGE
from ..kernels import noise_colours
from ..kernels.noise_filter import Filter
from ..core.limits import check_memory
from ..model.texton import Texton
from ..model.tiling import TilingModel

#: The shares' table: footprint extents 2^LOG_EXTENTS texels along the two axes of
#: J Jᵀ, and ANGLES directions of its major axis over [0, π).
LOG_EXTENTS = np.arange(-3.0, 13.01, 0.5)
ANGLES = 16
#: Values mapped at a time: the float64 temporaries of a lookup stay near 100 MB.
CHUNK = 1 << 20
#: The spectrum's grid side, at least (and at least the texton's size).
SPECTRUM_SIDE = 64


@functools.lru_cache(maxsize=16)
def noise_moments(texton: Texton | TilingModel) -> tuple[np.ndarray, np.ndarray]:
    """(mean, standard deviation) per channel of the texton's noise (CGF §3.3), or of a
    tiling model's blend (its Gaussianised example's, which the variance-preserving blend keeps)."""
    var = np.diag(np.atleast_2d(texton.covariance()))
    return texton.mean.astype(np.float64), np.sqrt(np.maximum(var, 1e-30))


def make_colour_map(texton: Texton | TilingModel, device: str = "cpu", shares: bool = False) -> noise_colours.ColourMap:
    """The kernels' ``ColourMap`` of ``texton`` on ``device`` (float32 copies of its
    transform and noise moments; ``enabled`` 0 without a transform), with its table
    of footprint shares when ``shares`` (:func:`share_table`)."""
    wp = init_warp()
    cmap = noise_colours.ColourMap()
    tr = texton.histogram
    c = texton.channels
    cmap.channels = c
    cmap.enabled = int(tr is not None)
    cmap.gauss_range = GAUSS_RANGE
    matrix = np.eye(3)
    mean, std = noise_moments(texton)
    if tr is not None:
        matrix[:c, :c] = tr.matrix
        cmap.centre = wp.vec3(*np.pad(tr.centre, (0, 3 - c)))
        cmap.tables = wp.array(tr.prefiltered.astype(np.float32), dtype=float, device=device)
    cmap.matrix = wp.mat33(*matrix.ravel())
    cmap.mean = wp.vec3(*np.pad(mean, (0, 3 - c)))
    cmap.std = wp.vec3(*np.pad(std, (0, 3 - c), constant_values=1.0))
    if shares:
        cmap.shares = wp.array(share_table(texton).astype(np.float32), dtype=float, device=device)
        cmap.log_first = float(LOG_EXTENTS[0])
        cmap.log_step = float(LOG_EXTENTS[1] - LOG_EXTENTS[0])
    return cmap


#: The host's maps, one per texton (shared by its outputs' threads; never changed).
colour_map = functools.lru_cache(maxsize=16)(make_colour_map)


def to_colours(values: np.ndarray, texton: Texton | TilingModel | None, share=None) -> None:
    """Map ``values`` (N, ≥ C) float32, in place, from the noise of ``texton`` to its
    example's colours; nothing for a texton without a histogram transform.

    ``share``: None (unfiltered values) or the share of the variance each value
    kept, a number or (N,) (:func:`footprint_shares`). The values are mapped by
    the device API's functions (``colour_value``, ``colour_share``) on the CPU.
    """
    if texton is None or texton.histogram is None or not len(values):
        return
    wp = init_warp()
    c = texton.channels
    cmap = colour_map(texton)
    shares = None if share is None else np.broadcast_to(np.asarray(share, np.float32), (len(values),))
    for start in range(0, len(values), CHUNK):  # copies of a bounded size
        part = values[start:start + CHUNK]
        v = np.zeros((len(part), 3), np.float32)
        v[:, :c] = part[:, :c]
        arr = wp.array(v, dtype=wp.vec3, device="cpu")
        if shares is None:
            wp.launch(noise_colours.map_values, dim=len(v), inputs=[cmap, arr], device="cpu")
        else:
            s = wp.array(np.ascontiguousarray(shares[start:start + CHUNK]), dtype=float, device="cpu")
            wp.launch(noise_colours.map_shared_values, dim=len(v), inputs=[cmap, arr, s], device="cpu")
        part[:, :c] = arr.numpy()[:, :c]


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
    filtered as ``options`` say: 1 for unfiltered pixels; J's leading shape.
    Computed by the device API's ``footprint_share`` on the CPU (J in float32)."""
    J = np.asarray(J)
    if not (options.spec.footprint or options.spec.supersamples):
        return np.ones(J.shape[:-2])
    return shares_of(texton, J)


def shares_of(texton: Texton, J: np.ndarray, flt: Filter | None = None, levels: int = 0) -> np.ndarray:
    """float32 shares of footprints J (..., 2, 2): the footprints' own, or faded as the
    MIP filter ``flt`` with ``levels`` kept levels fades the noise (``filtered_share``)."""
    wp = init_warp()
    J = np.asarray(J, np.float32)
    flat = np.ascontiguousarray(J.reshape(-1, 2, 2))
    out = wp.zeros(len(flat), dtype=float, device="cpu")
    if len(flat):
        wp.launch(noise_colours.pixel_shares, dim=len(flat), device="cpu",
                  inputs=[colour_map(texton, "cpu", True), wp.array(flat, dtype=wp.mat22, device="cpu"),
                          int(flt is not None), Filter() if flt is None else flt, int(levels), out])
    return out.numpy().reshape(J.shape[:-2])
