"""The tiling model filtered for the viewing distance: "mip" and "anisotropic" footprints (docs/tiling.md).

The example's MIP pyramid (``TilingPyramid``, built on the host by warp_texton/noise/tiling.py) is read
at the footprint's level, each patch's deviation from the mean scaled by the level's contrast; the
blend's weights, vertices and lattice are kernels/noise_tiling.py's, so a footprint of one texel is the
unfiltered model.

Driven by: ``warp_texton.noise.tiling``.
"""

import warp as wp

from .noise_filter import Filter, footprint_lookups
from .noise_tiling import (Lattice, Tiling, bilinear, guided_weights, kept_normalised, lattice_point, lattice_triangle,
                           triangle_weights)
from .tiling_draw import texel_address

wp.set_module_options({"enable_backward": False, "optimization_level": 3})


@wp.struct
class TilingPyramid:
    # the example's MIP levels (2 × 2 box means, edge texels repeated on odd sides), stacked by rows:
    # level ℓ in rows [row0[ℓ], row0[ℓ] + rows[ℓ]) and columns [0, cols[ℓ]) of `texels`; its texel (i, j) is
    # centred at 2^ℓ (j + ½, i + ½) in level-0 texels. contrast[ℓ] scales a patch's deviation from the mean
    # read at level ℓ down to what a footprint of 2^ℓ texels keeps of the blend of independent patches.
    texels: wp.array2d(dtype=wp.vec3)
    means: wp.array2d(dtype=wp.vec3)  # the lattice-periodic mean's levels, the same layout (rank ≠ 0); (1, 1) else
    row0: wp.array(dtype=int)
    rows: wp.array(dtype=int)
    cols: wp.array(dtype=int)
    contrast: wp.array(dtype=float)
    levels: int


@wp.func
def level_lookup(pyr: TilingPyramid, texels: wp.array2d(dtype=wp.vec3), lvl: int, q: wp.vec2, wrap: wp.vec2i):
    # bilinear lookup of level lvl of `texels` (the pyramid's texels or means) at q (level-0 texel units),
    # clamped to the level or wrapped per axis; at level 0 the same values as noise_tiling.bilinear (q · 1 is q)
    inv = 1.0 / float(1 << lvl)
    fx = q[0] * inv - 0.5
    fy = q[1] * inv - 0.5
    r0 = pyr.row0[lvl]
    rows = pyr.rows[lvl]
    cols = pyr.cols[lvl]
    x0 = wp.floor(fx)
    y0 = wp.floor(fy)
    tx = fx - x0
    ty = fy - y0
    j0 = texel_address(int(x0), cols, wrap[0])
    i0 = texel_address(int(y0), rows, wrap[1]) + r0
    if tx == 0.0 and ty == 0.0:
        return texels[i0, j0]
    j1 = texel_address(int(x0) + 1, cols, wrap[0])
    i1 = texel_address(int(y0) + 1, rows, wrap[1]) + r0
    top = texels[i0, j0] * (1.0 - tx) + texels[i0, j1] * tx
    bottom = texels[i1, j0] * (1.0 - tx) + texels[i1, j1] * tx
    return top * (1.0 - ty) + bottom * ty


@wp.func
def patch_deviation(t: Tiling, pyr: TilingPyramid, q: wp.vec2, l0: int, l1: int, w1: float):
    # (deviation, mean): a patch's deviation from the mean at q, read between levels l0 and l1 (weight w1 on
    # l1), times the levels' contrast (trilinear filtering of the patch); the mean is the example's, or with a
    # lattice the lattice-periodic mean read between the same levels, and the deviation the residual around it
    e = level_lookup(pyr, pyr.texels, l0, q, t.wrap)
    c = pyr.contrast[l0]
    if w1 > 0.0:
        e = e * (1.0 - w1) + level_lookup(pyr, pyr.texels, l1, q, t.wrap) * w1
        c = c * (1.0 - w1) + pyr.contrast[l1] * w1
    if t.rank == 0:
        return (e - t.mean) * c, t.mean
    m = level_lookup(pyr, pyr.means, l0, q, t.wrap)
    if w1 > 0.0:
        m = m * (1.0 - w1) + level_lookup(pyr, pyr.means, l1, q, t.wrap) * w1
    return (e - m) * c, m


@wp.func
def blend_levels(t: Tiling, lat: Lattice, pyr: TilingPyramid, x: wp.vec2d, l0: int, l1: int, w1: float):
    # the blend at x (tiling_value's weights) of the three patches, each read filtered between levels l0, l1
    a, b, u, v = lattice_triangle(t, lat, x)
    a0, b0, w0, wa, wb = triangle_weights(a, b, u, v)
    q0 = lattice_point(t, lat, x, a0, b0)
    q1 = lattice_point(t, lat, x, a + 1, b)
    q2 = lattice_point(t, lat, x, a, b + 1)
    g0 = float(0.0)
    g1 = float(0.0)
    g2 = float(0.0)
    if t.guide_weight != 0.0:
        g0 = bilinear(t.guide, q0, t.wrap)
        g1 = bilinear(t.guide, q1, t.wrap)
        g2 = bilinear(t.guide, q2, t.wrap)
    k0, k1, k2 = guided_weights(t, w0, wa, wb, g0, g1, g2)
    k0, k1, k2 = kept_normalised(k0, k1, k2)
    acc = wp.vec3(0.0)
    macc = wp.vec3(0.0)
    if k0 > 0.0:
        d, m = patch_deviation(t, pyr, q0, l0, l1, w1)
        acc = acc + d * k0
        macc = macc + m * k0
    if k1 > 0.0:
        d, m = patch_deviation(t, pyr, q1, l0, l1, w1)
        acc = acc + d * k1
        macc = macc + m * k1
    if k2 > 0.0:
        d, m = patch_deviation(t, pyr, q2, l0, l1, w1)
        acc = acc + d * k2
        macc = macc + m * k2
    if t.variance_preserving != 0:
        acc = acc / wp.sqrt(k0 * k0 + k1 * k1 + k2 * k2)
    if t.rank != 0:
        return macc + acc
    return t.mean + acc


@wp.func
def tiling_filtered(t: Tiling, lat: Lattice, pyr: TilingPyramid, f: Filter, x: wp.vec2d, J: wp.mat22):
    # the tiling averaged over the footprint x + J [−½, ½]² ("mip": one probe; "anisotropic": n probes along
    # the major axis), each probe a blend of patches read at the footprint's level; the mean past the last level
    major, axis, n, lod = footprint_lookups(f, J)
    if wp.isnan(lod) or lod >= float(pyr.levels - 1):
        return t.mean
    l0 = int(wp.floor(lod))
    w1 = lod - float(l0)
    l1 = wp.min(l0 + 1, pyr.levels - 1)
    spread = axis * (major * (0.5 - 0.5 / float(n)))
    stride = wp.vec2(0.0)
    if n > 1:
        stride = spread * (2.0 / float(n - 1))
    acc = wp.vec3(0.0)
    for k in range(n):
        d = stride * float(k) - spread
        acc = acc + blend_levels(t, lat, pyr, x + wp.vec2d(wp.float64(d[0]), wp.float64(d[1])), l0, l1, w1)
    return acc / float(n)


@wp.kernel
def tiling_filtered_raster(t: Tiling, lat: Lattice, pyr: TilingPyramid, f: Filter, origin: wp.vec2d,
                           step_x: wp.vec2d, step_y: wp.vec2d, first: wp.vec2i, jac: wp.array2d(dtype=wp.mat22),
                           per_pixel: int, out: wp.array2d(dtype=wp.vec3)):
    # pixel (i, j) of a window (positions as tiling_runs places them), footprint jac[i, j] or jac[0, 0]
    i, j = wp.tid()
    I = wp.float64(first[0] + i) + wp.float64(0.5)
    J = wp.float64(first[1] + j) + wp.float64(0.5)
    x = origin + step_x * J + step_y * I
    F = jac[0, 0]
    if per_pixel != 0:
        F = jac[i, j]
    out[i, j] = tiling_filtered(t, lat, pyr, f, x, F)


@wp.kernel
def tiling_filtered_points(t: Tiling, lat: Lattice, pyr: TilingPyramid, f: Filter,
                           points: wp.array(dtype=wp.vec2d), jac: wp.array(dtype=wp.mat22), per_point: int,
                           out: wp.array(dtype=wp.vec3)):
    k = wp.tid()
    out[k] = tiling_filtered(t, lat, pyr, f, points[k], jac[k * per_point])


__all__ = ["TilingPyramid", "level_lookup", "patch_deviation", "blend_levels", "tiling_filtered",
           "tiling_filtered_raster", "tiling_filtered_points"]
