"""Tiling models filtered for the viewing distance: the example's MIP pyramid and the drivers of the
filtered tiling kernels ("mip", "anisotropic"), the supersampled reference and the filters' options and
work (docs/tiling.md, "Filtering"). Unfiltered tilings are :mod:`warp_texton.noise.tiling`'s; texton
noise's filters are :mod:`warp_texton.noise.filtering`'s.

Kernels driven here: ``warp_texton.kernels.noise_tiling_filter``.
"""

from __future__ import annotations

import dataclasses
import math
import weakref

import numpy as np

from ..core.errors import TextonError
from ..core.runtime import init_warp, resolve_device, split_launch
from ..kernels import noise_tiling_filter
from ..model.tiling import TilingModel
from .filter_options import FADE_ENERGY
from .filtering import jittered_means
from .tiling import lattice_struct, refuse_filtered_tables, tiling_at, tiling_struct

__all__ = ["example_pyramid", "level_contrast", "tiling_pyramid_struct", "tiling_filter", "TILING_LOD_BIAS",
           "tiling_filtered_raster", "tiling_filtered_at", "tiling_supersampled", "tiling_options", "BLEND_WORK",
           "tiling_filter_work"]


def example_pyramid(example: np.ndarray, wrap=(False, False)) -> list[np.ndarray]:
    """The MIP levels of an example (H, W, C): level 0 is the example, level ℓ + 1 the 2 × 2 block means
    of level ℓ (an odd side repeats its last row or column, or its first on an axis the example wraps
    on), down to one texel; float64."""
    levels = [np.asarray(example, np.float64)]
    while max(levels[-1].shape[:2]) > 1:
        a = levels[-1]
        r, s = a.shape[:2]
        a = np.pad(a, ((0, r % 2), (0, 0), (0, 0)), mode="wrap" if wrap[1] else "edge")
        a = np.pad(a, ((0, 0), (0, s % 2), (0, 0)), mode="wrap" if wrap[0] else "edge")
        levels.append(a.reshape(a.shape[0] // 2, 2, a.shape[1] // 2, 2, -1).mean(axis=(1, 3)))
    return levels


def level_contrast(model: TilingModel, levels: list[np.ndarray]) -> np.ndarray:
    """Per level ℓ, the factor on a patch's deviation from the mean read at level ℓ (the prefiltering of
    the blend).

    A footprint of 2^ℓ texels larger than a triangle covers about (2^ℓ / side)² independent patches: the
    blend averaged over it keeps the variance v(side) of one patch's footprint of ``side`` texels divided by
    their number, while one patch read at level ℓ keeps v(ℓ), the variance of level ℓ (with the large-scale
    variation of the example that the tiling does not show). The factor is √(min(1, v(side) 4^(ℓs − ℓ) / v(ℓ))),
    ℓs = log2 side, v(side) interpolated between levels in log2; 1 up to the side's level."""
    mean = levels[0].mean(axis=(0, 1))
    var = np.array([float(((lv - mean) ** 2).sum(axis=2).mean()) for lv in levels])
    ls = math.log2(model.side)
    i0 = min(int(math.floor(ls)), len(levels) - 1)
    i1 = min(i0 + 1, len(levels) - 1)
    f = ls - math.floor(ls)
    vs = math.exp((1 - f) * math.log(max(var[i0], 1e-30)) + f * math.log(max(var[i1], 1e-30)))
    ell = np.arange(len(levels), dtype=np.float64)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(var > 0, vs * 4.0 ** (ls - ell) / np.maximum(var, 1e-30), 1.0)
    return np.where(ell <= ls, 1.0, np.sqrt(np.clip(ratio, 0.0, 1.0))).astype(np.float32)


#: The pyramids of each model, per device (models are immutable).
_PYRAMIDS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def tiling_pyramid_struct(model: TilingModel, device: str):
    """The kernels' ``TilingPyramid`` of a model on ``device``: its arrays computed once per model and
    device, the struct made anew for each call (each launch packs its own)."""
    wp = init_warp()
    per_device = _PYRAMIDS.setdefault(model, {})
    if device not in per_device:
        levels = example_pyramid(model.example, model.wrap)
        w = levels[0].shape[1]
        rows = np.array([lv.shape[0] for lv in levels], np.int32)
        cols = np.array([lv.shape[1] for lv in levels], np.int32)
        row0 = np.concatenate([[0], np.cumsum(rows)[:-1]]).astype(np.int32)

        def stacked(levels):
            stack = np.zeros((int(rows.sum()), w, 3), np.float32)
            for lv, r0 in zip(levels, row0):
                stack[r0:r0 + lv.shape[0], :lv.shape[1], :model.channels] = lv
            return wp.array(stack, dtype=wp.vec3, device=device)

        mean_image = model.mean_image
        means = stacked(example_pyramid(mean_image, model.wrap)) if mean_image is not None else \
            wp.zeros((1, 1), dtype=wp.vec3, device=device)
        per_device[device] = (stacked(levels), means,
                              wp.array(row0, dtype=int, device=device), wp.array(rows, dtype=int, device=device),
                              wp.array(cols, dtype=int, device=device),
                              wp.array(level_contrast(model, levels), dtype=float, device=device), len(levels))
    pyr = noise_tiling_filter.TilingPyramid()
    pyr.texels, pyr.means, pyr.row0, pyr.rows, pyr.cols, pyr.contrast, pyr.levels = per_device[device]
    return pyr


def tiling_filter(options) -> object:
    """The kernels' ``Filter`` of a footprint kind, with the tiling's level bias (:data:`TILING_LOD_BIAS`
    unless ``options.lod_bias`` is given)."""
    from ..kernels import noise_filter

    f = noise_filter.Filter()
    f.mode = noise_filter.ANISOTROPIC if options.spec.axis_lookups else noise_filter.MIP
    f.max_aniso = options.max_aniso
    f.lod_bias = float(TILING_LOD_BIAS[options.kind] if options.lod_bias is None else options.lod_bias)
    return f


#: The level bias of a tiling's footprint filters: added to log2 of a probe's width (measured on
#: benchmarks/bench_structure.py's plane, docs/tiling.md "Filtering").
TILING_LOD_BIAS = {"mip": -1.0, "anisotropic": -0.7}


def _channels(model: TilingModel, values: np.ndarray) -> np.ndarray:
    return values if model.channels == 3 else np.ascontiguousarray(values[..., :model.channels])


def tiling_filtered_raster(model: TilingModel, shape, origin, step, first, J: np.ndarray, options, seed: int,
                           device, period=None) -> np.ndarray:
    """The (H, W, C) raster of :func:`tiling_pixels` filtered for footprints ``J`` ((2, 2) or (H, W, 2, 2))
    with a footprint kind ("mip" or "anisotropic")."""
    refuse_filtered_tables(model)
    wp = init_warp()
    device = resolve_device(device)
    h, w = shape
    tiling_struct(model, seed, device)  # the model's arrays on the device
    per_pixel = int(J.ndim == 4)
    jac_host = np.ascontiguousarray(J.astype(np.float32).reshape((h, w, 2, 2) if per_pixel else (1, 1, 2, 2)))
    jac = wp.array(jac_host, dtype=wp.mat22, device=device)
    out = wp.empty((h, w), dtype=wp.vec3, device=device)
    o = wp.vec2d(float(origin[0]), float(origin[1]))
    sx = wp.vec2d(float(step[0, 0]), float(step[1, 0]))
    sy = wp.vec2d(float(step[0, 1]), float(step[1, 1]))

    def launch(r0, r1):
        t = tiling_struct(model, seed, device)  # structs of its own per launch (launched from several threads)
        lat = lattice_struct(model, period)
        pyr = tiling_pyramid_struct(model, device)
        f = tiling_filter(options)
        at = wp.vec2i(int(first[0]) + r0, int(first[1]))
        wp.launch(noise_tiling_filter.tiling_filtered_raster, dim=(r1 - r0, w),
                  inputs=[t, lat, pyr, f, o, sx, sy, at, jac[r0:r1] if per_pixel else jac, per_pixel, out[r0:r1]],
                  device=device)

    split_launch(device, noise_tiling_filter, h, launch)
    return _channels(model, out.numpy())


def tiling_filtered_at(model: TilingModel, points: np.ndarray, J: np.ndarray, options, seed: int, device,
                       period=None) -> np.ndarray:
    """(N, C) values of the model at points (N, 2) filtered for footprints J ((N, 2, 2) or (1, 2, 2)) with a
    footprint kind: the same function as :func:`tiling_filtered_raster`'s pixels."""
    refuse_filtered_tables(model)
    wp = init_warp()
    device = resolve_device(device)
    n = points.shape[0]
    if not n:
        return np.zeros((0, model.channels), np.float32)
    tiling_struct(model, seed, device)  # the model's arrays on the device
    per = int(J.shape[0] > 1)
    pts = wp.array(np.ascontiguousarray(points, np.float64), dtype=wp.vec2d, device=device)
    jac = wp.array(np.ascontiguousarray(J.reshape(-1, 2, 2).astype(np.float32)), dtype=wp.mat22, device=device)
    out = wp.empty(n, dtype=wp.vec3, device=device)

    def launch(k0, k1):
        t = tiling_struct(model, seed, device)  # structs of its own per launch (launched from several threads)
        lat = lattice_struct(model, period)
        pyr = tiling_pyramid_struct(model, device)
        f = tiling_filter(options)
        wp.launch(noise_tiling_filter.tiling_filtered_points, dim=k1 - k0,
                  inputs=[t, lat, pyr, f, pts[k0:k1], jac[k0:k1] if per else jac, per, out[k0:k1]], device=device)

    split_launch(device, noise_tiling_filter, n, launch)
    return _channels(model, out.numpy())


def tiling_supersampled(model: TilingModel, pixels, n: int, seed: int, device, period=None,
                        reach: float = float(1 << 30)) -> np.ndarray:
    """(pixels.count, C) means of n × n stratified jittered evaluations per pixel (a
    :class:`~warp_texton.noise.filtering.PixelSet`), the reference of the footprint filters; sub-pixels
    that see no plane or lie beyond ``reach`` count as the mean."""
    return jittered_means(pixels, n, seed, reach, model.mean3[:model.channels],
                          lambda pts: tiling_at(model, pts, seed, device, period))


def tiling_options(options):
    """``options`` with the tiling's level bias where it has none (:data:`TILING_LOD_BIAS`), so that
    :func:`~warp_texton.noise.filtering.footprint_levels` and ``needs_filtering`` see the kernels' choice."""
    if options.fade_energy != FADE_ENERGY:
        raise TextonError("fade_energy does not apply to a tiling model: its MIP pyramid keeps every level of the "
                          "example (footprints past the last one see the mean)", param="fade_energy")
    if options.spec.footprint and options.lod_bias is None:
        return dataclasses.replace(options, lod_bias=TILING_LOD_BIAS[options.kind])
    return options


#: Operations of one blend (a triangle, three hashed vertices, three lookups), for the work budget.
BLEND_WORK = 64


def tiling_filter_work(options, count: int) -> float:
    """Operations of filtering ``count`` pixels of a tiling model with ``options``: a blend per probe
    (two levels per lookup) or per sub-pixel."""
    if options.spec.supersamples:
        return float(count) * BLEND_WORK * options.supersample ** 2
    if options.spec.axis_lookups:
        return float(count) * BLEND_WORK * 2 * options.max_aniso
    return float(count) * BLEND_WORK * 2
