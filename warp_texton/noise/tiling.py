"""Tiling and blending on rasters and points: the drivers of the tiling kernels.

The model, its files and its measures live in :mod:`warp_texton.model.tiling` (NumPy only);
this module packs a :class:`~warp_texton.model.tiling.TilingModel` into the kernels' struct and
launches them (docs/tiling.md).

Kernels driven here: ``warp_texton.kernels.noise_tiling``.
"""

from __future__ import annotations

import weakref

import numpy as np

from ..core.runtime import init_warp, is_cpu, resolve_device, split_launch
from ..kernels import noise_tiling
from ..model.tiling import TilingModel
from .colours import to_colours

#: The device arrays of each model, per device (models are immutable).
_ARRAYS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def tiling_struct(model: TilingModel, seed: int, device: str):
    """The kernels' ``Tiling`` struct of a model and a seed, its arrays on ``device``."""
    wp = init_warp()
    per_device = _ARRAYS.setdefault(model, {})
    if device not in per_device:
        ex = model.example
        rgb = ex if ex.shape[2] == 3 else np.concatenate([ex, np.zeros(ex.shape[:2] + (2,), np.float32)], axis=2)
        guide = model.guide if model.guide_weight != 0.0 else np.zeros((1, 1), np.float32)
        per_device[device] = (wp.array(np.ascontiguousarray(rgb), dtype=wp.vec3, device=device),
                              wp.array(guide, dtype=float, device=device))
    t = noise_tiling.Tiling()
    t.example, t.guide = per_device[device]
    t.side = float(model.side)
    t.margin = int(model.margin)
    t.squarings = int(model.sharpness).bit_length() - 1
    t.guide_weight = float(model.guide_weight)
    t.variance_preserving = int(model.blend == "variance")
    t.mean = wp.vec3(*model.mean3.tolist())
    t.seed = wp.uint32(seed & 0xFFFFFFFF)
    return t


def tiling_colours(model: TilingModel, values: np.ndarray) -> None:
    """Map a tiling model's blended values (..., lanes ≥ C) float32, in place, through its histogram
    tables (a histogram-preserving model), exactly as texton noise maps its noise
    (:func:`~warp_texton.noise.colours.to_colours`); nothing for a model without tables.
    Every output of a tiling model passes its values through here once, after the blend."""
    if model.histogram is not None:
        flat = values.reshape(-1, values.shape[-1])
        to_colours(flat, model)
        if not np.shares_memory(flat, values):  # a copy (a strided view): write it back
            values[...] = flat.reshape(values.shape)


def tiling_pixels(model: TilingModel, shape, origin, step, first, seed: int, device) -> np.ndarray:
    """The (H, W, C) float32 raster whose pixel (i, j) is the model at
    origin + step · (first[1] + j + ½, first[0] + i + ½) (``raster_geometry``'s layout)."""
    wp = init_warp()
    device = resolve_device(device)
    h, w = shape
    t = tiling_struct(model, seed, device)
    host = np.empty((h, w, 3), np.float32) if is_cpu(device) else None
    out = wp.array(host, dtype=wp.vec3, copy=False, device=device) if host is not None else wp.empty((h, w), dtype=wp.vec3,
                                                                                         device=device)
    o = wp.vec2d(float(origin[0]), float(origin[1]))
    sx = wp.vec2d(float(step[0, 0]), float(step[1, 0]))
    sy = wp.vec2d(float(step[0, 1]), float(step[1, 1]))

    def launch(r0, r1):
        if r1 > r0:
            at = wp.vec2i(int(first[0]) + r0, int(first[1]))
            wp.launch(noise_tiling.tiling_raster, dim=(r1 - r0, w), inputs=[t, o, sx, sy, at, out[r0:r1]], device=device)

    split_launch(device, noise_tiling, h, launch)
    values = host if host is not None else out.numpy()
    tiling_colours(model, values)
    return values if model.channels == 3 else np.ascontiguousarray(values[..., :model.channels])


def tiling_at(model: TilingModel, points: np.ndarray, seed: int, device) -> np.ndarray:
    """The (N, C) float32 values of the model at points (N, 2) (x, y), float64."""
    wp = init_warp()
    device = resolve_device(device)
    n = points.shape[0]
    t = tiling_struct(model, seed, device)
    pts = wp.array(np.ascontiguousarray(points, np.float64), dtype=wp.vec2d, device=device)
    out = wp.empty(n, dtype=wp.vec3, device=device)

    def launch(k0, k1):
        wp.launch(noise_tiling.tiling_points, dim=k1 - k0, inputs=[t, pts[k0:k1], out[k0:k1]], device=device)

    split_launch(device, noise_tiling, n, launch)
    if not n:
        return np.zeros((0, model.channels), np.float32)
    values = out.numpy()
    tiling_colours(model, values)
    return np.ascontiguousarray(values[:, :model.channels])
