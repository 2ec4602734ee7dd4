"""Blocks of points sharing the impacts of their cubes: the device side of the
3-D block path (warp_texton/surface/blocks.py), for any evaluator of the cubic cells'
Poisson process (kernels/impacts.py) at many points.

Points are sorted by the block of cubes they lie in (``block_keys``,
``take_points``); each block's cubes then draw their impacts once
(``count_cubes``, a prefix sum, ``emit_cubes``) into a ``CubeBlocks``, which
the evaluator's gather reads in the order a lone point's walk would draw them.

Driven by: ``warp_texton.surface.blocks``.
"""

import warp as wp

from .impacts import Cells3, cell_state3, draw_count, next_impact3

wp.set_module_options({"enable_backward": False, "optimization_level": 3})


@wp.struct
class CubeBlocks:
    # block b owns the cubes origin[b] + [0, dims[b]) (x fastest), numbered from base[b];
    # cube g is cubes[g] and its impacts are (ux, uy, uz)[offsets[g]:offsets[g + 1]]
    cubes: wp.array(dtype=wp.vec3i)
    origin: wp.array(dtype=wp.vec3i)
    dims: wp.array(dtype=wp.vec3i)
    base: wp.array(dtype=wp.int32)
    offsets: wp.array(dtype=wp.int32)
    ux: wp.array(dtype=float)
    uy: wp.array(dtype=float)
    uz: wp.array(dtype=float)


@wp.func
def clamp_to_block(o: wp.vec3i, dm: wp.vec3i, x0: int, x1: int, y0: int, y1: int, z0: int, z1: int):
    # the cube range within the block's cubes o + [0, dm) (the host sizes each block to
    # hold its points' cubes; the clamps only guard memory)
    return (wp.max(x0, o[0]), wp.min(x1, o[0] + dm[0] - 1), wp.max(y0, o[1]), wp.min(y1, o[1] + dm[1] - 1),
            wp.max(z0, o[2]), wp.min(z1, o[2] + dm[2] - 1))


@wp.kernel
def block_keys(points: wp.array(dtype=wp.vec3d), scale: wp.float64, shift: wp.int64, o0: wp.int64, o1: wp.int64,
               o2: wp.int64, s0: wp.int64, s1: wp.int64, spread: wp.array(dtype=wp.int64),
               keys: wp.array(dtype=wp.int64)):
    """Each point's sort key: its block (of 2**shift eighths of a cube per side, the
    fine cell floor(y · scale) shifted right; numbered x fastest from (o0, o1, o2) in
    rows of s0 and planes of s1 blocks) above 15 bits of the Morton code of its eighth
    within the block (``spread`` spaces the bits of one axis)."""
    k = wp.tid()
    y = points[k]
    fx = wp.int64(wp.floor(y[0] * scale))
    fy = wp.int64(wp.floor(y[1] * scale))
    fz = wp.int64(wp.floor(y[2] * scale))
    mask = (wp.int64(1) << shift) - wp.int64(1)
    m = spread[int(fx & mask)] | (spread[int(fy & mask)] << wp.int64(1)) | (spread[int(fz & mask)] << wp.int64(2))
    block = (((fz >> shift) - o2) * s1 + ((fy >> shift) - o1)) * s0 + ((fx >> shift) - o0)
    keys[k] = (block << wp.int64(15)) | m


@wp.kernel
def take_points(order: wp.array(dtype=wp.int64), points: wp.array(dtype=wp.vec3d), normals: wp.array(dtype=wp.vec3),
                out_points: wp.array(dtype=wp.vec3d), out_normals: wp.array(dtype=wp.vec3)):
    """The points and normals in sorted order."""
    k = wp.tid()
    q = order[k]
    out_points[k] = points[q]
    out_normals[k] = normals[q]


@wp.kernel
def count_cubes(cells: Cells3, cubes: wp.array(dtype=wp.vec3i), counts: wp.array(dtype=wp.int32)):
    """Impact count of each listed cube."""
    g = wp.tid()
    c = cubes[g]
    n, s = draw_count(cell_state3(cells, c[0], c[1], c[2]), cells.mean_count, cells.exact_poisson)
    counts[g] = n


@wp.kernel
def emit_cubes(cells: Cells3, cubes: wp.array(dtype=wp.vec3i), offsets: wp.array(dtype=wp.int32),
               ux: wp.array(dtype=float), uy: wp.array(dtype=float), uz: wp.array(dtype=float)):
    """Each listed cube's impacts, in the order drawn, as positions in cell units
    (what ``next_impact3`` gives, one array per axis), so that a gather computes
    the offsets exactly as the per-point walk does."""
    g = wp.tid()
    c = cubes[g]
    n, s = draw_count(cell_state3(cells, c[0], c[1], c[2]), cells.mean_count, cells.exact_poisson)
    for k in range(offsets[g], wp.min(offsets[g] + n, offsets[g + 1])):
        u, s = next_impact3(s)
        ux[k] = u[0]
        uy[k] = u[1]
        uz[k] = u[2]


__all__ = ["CubeBlocks", "block_keys", "clamp_to_block", "count_cubes", "emit_cubes", "take_points"]
