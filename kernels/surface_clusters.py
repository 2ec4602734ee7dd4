"""Surface texton noise at clusters of nearby points (the block path's CPU and CUDA gathers).

The points of a block (kernels/surface_blocks.py) are grouped in clusters; each cluster lists once
the impacts that may reach any of its points (``list_cluster_impacts``, or on the CPU the native
``scan_cube`` of kernels/surface_native.py), then each point sums its cluster's list
(``gather_clustered``; on the CPU the native ``cluster_sums``), in the order of the per-point walk
of kernels/surface_points.py, so every path gives the walk's values bit for bit.

Driven by: ``warp_texton.surface.blocks``.
"""

from typing import Any

import warp as wp

from .impacts import cube_offset, impact_offset3
from .surface_blocks import CubeBlocks, clamp_to_block
from .surface_native import cluster_sums, scan_cube
from .surface_points import (REACH_ROUNDING, SQRT3, PointFrames, SurfaceParams, frame_point, normalize_surface, range_meets,
                             slab_lookup, slab_term, sum_block)

wp.set_module_options({"enable_backward": False, "optimization_level": 3})


@wp.struct
class Clusters:
    # cluster m holds the points first[m] .. first[m + 1] − 1 (all of one block); the
    # impacts that may reach them are listed in the walk's order as runs of one cube
    # each: run k < runs[m] is cube run_cube[cap_runs·m + k], its impacts (positions in
    # cell units, as drawn) are (ux, uy, uz)[cap·m + run_end[cap_runs·m + k − 1] ..
    # cap·m + run_end[cap_runs·m + k] − 1]; runs −1: no list (too few points, or it
    # overflowed). The CPU's one-cluster scratch uses slot 0 only (m = 0; first and
    # runs unused).
    first: wp.array(dtype=wp.int32)
    cap: int
    cap_runs: int
    runs: wp.array(dtype=wp.int32)
    run_cube: wp.array(dtype=wp.int32)
    run_end: wp.array(dtype=wp.int32)
    ux: wp.array(dtype=float)
    uy: wp.array(dtype=float)
    uz: wp.array(dtype=float)


@wp.func
def cluster_means(points: wp.array(dtype=wp.vec3d), normals: wp.array(dtype=wp.vec3), frames: PointFrames,
                  k0: int, k1: int):
    """The mean position y_c and mean frame (n̄, ū1, ū2) of the points k0 .. k1 − 1, and the
    box of the cubes their walks visit (x0, x1, y0, y1, z0, z1, from their frames' lo and hi)."""
    # means of the positions (relative to the first point) and of the frames
    y0 = points[k0]
    mean_off = wp.vec3(0.0)
    nbar = wp.vec3(0.0)
    ubar = wp.vec3(0.0)
    vbar = wp.vec3(0.0)
    x0 = int(2147483647)
    x1 = int(-2147483647)
    yy0 = int(2147483647)
    yy1 = int(-2147483647)
    z0 = int(2147483647)
    z1 = int(-2147483647)
    for k in range(k0, k1):
        y = points[k]
        mean_off = mean_off + wp.vec3(float(y[0] - y0[0]), float(y[1] - y0[1]), float(y[2] - y0[2]))
        nbar = nbar + normals[k]
        ubar = ubar + frames.u1[k]
        vbar = vbar + frames.u2[k]
        lo = frames.lo[k]
        hi = frames.hi[k]
        x0 = wp.min(x0, lo[0])
        x1 = wp.max(x1, hi[0])
        yy0 = wp.min(yy0, lo[1])
        yy1 = wp.max(yy1, hi[1])
        z0 = wp.min(z0, lo[2])
        z1 = wp.max(z1, hi[2])
    inv = 1.0 / float(k1 - k0)
    mean_off = mean_off * inv
    nbar = nbar * inv
    ubar = ubar * inv
    vbar = vbar * inv
    yc = wp.vec3d(y0[0] + wp.float64(mean_off[0]), y0[1] + wp.float64(mean_off[1]), y0[2] + wp.float64(mean_off[2]))
    return yc, nbar, ubar, vbar, x0, x1, yy0, yy1, z0, z1


@wp.func
def cluster_ranges(p: SurfaceParams, points: wp.array(dtype=wp.vec3d), normals: wp.array(dtype=wp.vec3),
                   frames: PointFrames, k0: int, k1: int, yc: wp.vec3d, nbar: wp.vec3, ubar: wp.vec3, vbar: wp.vec3):
    """The ranges of ⟨y_c − q, n̄⟩ (±t_lim), ⟨y_c − q, ū1⟩ (a_lo .. a_hi) and ⟨y_c − q, ū2⟩
    (b_lo .. b_hi) within which an impact q may reach a point of the cluster (see
    ``list_cluster``), from the points' spread about the means."""
    c = p.cells.size
    rho = float(0.0)  # the cluster's radius, and its extents along n̄, ū1, ū2
    rho_n = float(0.0)
    rho_u = float(0.0)
    rho_v = float(0.0)
    nu = float(0.0)
    mu1 = float(0.0)
    mu2 = float(0.0)
    for k in range(k0, k1):
        y = points[k]
        off = wp.vec3(float(y[0] - yc[0]), float(y[1] - yc[1]), float(y[2] - yc[2]))
        rho = wp.max(rho, wp.length(off))
        rho_n = wp.max(rho_n, wp.abs(wp.dot(off, nbar)))
        rho_u = wp.max(rho_u, wp.abs(wp.dot(off, ubar)))
        rho_v = wp.max(rho_v, wp.abs(wp.dot(off, vbar)))
        nu = wp.max(nu, wp.length(normals[k] - nbar))
        mu1 = wp.max(mu1, wp.length(frames.u1[k] - ubar))
        mu2 = wp.max(mu2, wp.length(frames.u2[k] - vbar))
    big_r = p.half * SQRT3 * REACH_ROUNDING
    margin = 1.0e-3 * (p.half + c) + 1.0e-5 * (rho + big_r)
    t_lim = p.half + rho_n + big_r * nu + margin
    a_lo = p.lo[0] - p.centre[0] - rho_u - big_r * mu1 - margin
    a_hi = p.hi[0] - p.centre[0] + rho_u + big_r * mu1 + margin
    b_lo = p.lo[1] - p.centre[1] - rho_v - big_r * mu2 - margin
    b_hi = p.hi[1] - p.centre[1] + rho_v + big_r * mu2 + margin
    return t_lim, a_lo, a_hi, b_lo, b_hi


@wp.func
def list_cluster(p: SurfaceParams, points: wp.array(dtype=wp.vec3d), normals: wp.array(dtype=wp.vec3),
                 frames: PointFrames, block_of: wp.array(dtype=wp.int32), blocks: CubeBlocks, k0: int, k1: int,
                 lists: Clusters, slot: int, min_points: int, simd: int):
    """List, in slot ``slot`` of ``lists``, the impacts that may reach some point
    k0 .. k1 − 1 of a cluster, in the walk's order; returns the number of runs, or
    −1 for no list (fewer than ``min_points`` points, or it does not fit).

    For a point y_i with frame (u1_i, u2_i, n_i) an impact q counts only if
    |⟨y_i − q, n_i⟩| < r/2 and its frame coordinates lie in the support, so
    |y_i − q| ≤ R = (r/2)√3. With y_c, n̄, ū1, ū2 the cluster's means, ν, μ1, μ2
    the largest distances of n_i, u1_i, u2_i from their means and ρ_n, ρ1, ρ2 the
    largest |⟨y_i − y_c, ·⟩| along n̄, ū1, ū2, ⟨y_c − q, n̄⟩ = ⟨y_i − q, n_i⟩ +
    ⟨y_i − q, n̄ − n_i⟩ − ⟨y_i − y_c, n̄⟩ lies within r/2 + Rν + ρ_n of 0, and
    ⟨y_c − q, ū1⟩, ⟨y_c − q, ū2⟩ within Rμ + ρ of the support's range (a cluster
    on a surface is thin along n̄: ρ_n is far below its radius). Impacts outside those
    ranges are left off the list: none of them can reach a point. Each cube's
    impacts are tested by ``scan_cube`` (16 at a time in its vector form)."""
    if k1 - k0 < min_points:
        return -1
    c = p.cells.size
    yc, nbar, ubar, vbar, x0, x1, yy0, yy1, z0, z1 = cluster_means(points, normals, frames, k0, k1)
    t_lim, a_lo, a_hi, b_lo, b_hi = cluster_ranges(p, points, normals, frames, k0, k1, yc, nbar, ubar, vbar)
    b = block_of[k0]
    o = blocks.origin[b]
    dm = blocks.dims[b]
    base = blocks.base[b]
    x0, x1, yy0, yy1, z0, z1 = clamp_to_block(o, dm, x0, x1, yy0, yy1, z0, z1)
    count = int(0)
    runs = int(0)
    out0 = slot * lists.cap
    run0 = slot * lists.cap_runs
    for cz in range(z0, z1 + 1):
        for cy in range(yy0, yy1 + 1):
            row = base + ((cz - o[2]) * dm[1] + (cy - o[1])) * dm[0] - o[0]
            for cx in range(x0, x1 + 1):
                rel = cube_offset(yc, cx, cy, cz, c)
                if runs >= 0 and range_meets(rel, nbar, c, -t_lim, t_lim) and range_meets(rel, ubar, c, a_lo, a_hi) \
                        and range_meets(rel, vbar, c, b_lo, b_hi):
                    g = row + cx
                    found = scan_cube(blocks.ux, blocks.uy, blocks.uz, blocks.offsets[g], blocks.offsets[g + 1], rel,
                                      nbar, ubar, vbar, c, t_lim, a_lo, a_hi, b_lo, b_hi, lists.ux, lists.uy, lists.uz,
                                      out0 + count, lists.cap - count, simd)
                    if found > 0:
                        count += found
                        if count > lists.cap or runs >= lists.cap_runs:
                            runs = -1  # the list does not fit: the cluster walks its block
                        else:
                            lists.run_cube[run0 + runs] = g
                            lists.run_end[run0 + runs] = count
                            runs += 1
    return runs


@wp.kernel
def list_cluster_impacts(
    p: SurfaceParams,
    points: wp.array(dtype=wp.vec3d),
    normals: wp.array(dtype=wp.vec3),
    frames: PointFrames,
    block_of: wp.array(dtype=wp.int32),
    blocks: CubeBlocks,
    clusters: Clusters,
    first_cluster: int,
    min_points: int,
    simd: int,
):
    """Each cluster's list (``list_cluster``) in its own slot, for ``gather_clustered``."""
    m = wp.tid() + first_cluster
    clusters.runs[m] = list_cluster(p, points, normals, frames, block_of, blocks, clusters.first[m],
                                    clusters.first[m + 1], clusters, m, min_points, simd)


@wp.func
def cluster_point(p: SurfaceParams, coeffs: wp.array2d(dtype=Any), points: wp.array(dtype=wp.vec3d),
                  normals: wp.array(dtype=wp.vec3), frames: PointFrames, block_of: wp.array(dtype=wp.int32),
                  blocks: CubeBlocks, lists: Clusters, slot: int, runs: int, k: int):
    # point k of a cluster: the raw sum over its list of ``runs`` runs in slot ``slot``
    # of ``lists``, or over its block's cubes if it has none (runs < 0)
    n = normals[k]
    u1 = frames.u1[k]
    u2 = frames.u2[k]
    lo3 = frames.lo[k]
    hi3 = frames.hi[k]
    y = points[k]
    if runs < 0:
        return sum_block(p, coeffs, slab_lookup(p, coeffs, u1, u2, n), y, n, u1, u2, lo3[0], hi3[0], lo3[1], hi3[1],
                         lo3[2], hi3[2], block_of[k], blocks)
    half = p.half
    c = p.cells.size
    u0 = slot * lists.cap
    r0 = slot * lists.cap_runs
    acc = coeffs.dtype(0.0)
    start = int(0)
    for r in range(runs):
        end = lists.run_end[r0 + r]
        cc = blocks.cubes[lists.run_cube[r0 + r]]
        if cc[0] >= lo3[0] and cc[0] <= hi3[0] and cc[1] >= lo3[1] and cc[1] <= hi3[1] and cc[2] >= lo3[2] and \
                cc[2] <= hi3[2]:
            rel = cube_offset(y, cc[0], cc[1], cc[2], c)
            for e in range(u0 + start, u0 + end):
                d = impact_offset3(rel, wp.vec3(lists.ux[e], lists.uy[e], lists.uz[e]), c)
                t = wp.dot(d, n)
                if wp.abs(t) < half:
                    acc = slab_term(coeffs, u1, u2, t, half, p.centre, p.lo, p.hi, p.order, d, acc)
        start = end
    return acc


@wp.kernel
def gather_clustered(
    p: SurfaceParams,
    coeffs: wp.array2d(dtype=Any),
    points: wp.array(dtype=wp.vec3d),
    normals: wp.array(dtype=wp.vec3),
    frames: PointFrames,
    block_of: wp.array(dtype=wp.int32),
    blocks: CubeBlocks,
    cluster_of: wp.array(dtype=wp.int32),
    clusters: Clusters,
    first_cluster: int,
    first: int,
    out: wp.array(dtype=Any),
    dest: wp.array(dtype=wp.int64),
):
    """The walk's sum at each point k (written to out[dest[k]]) (one thread per point: the GPU's gather, and any
    texton order) through its cluster's list: the list keeps the walk's order and
    holds every impact that can reach the point, and impacts of cubes outside the
    point's own walk are skipped, so the terms and their order are the walk's."""
    k = wp.tid() + first
    m = cluster_of[k] - first_cluster
    acc = cluster_point(p, coeffs, points, normals, frames, block_of, blocks, clusters, m, clusters.runs[m], k)
    out[dest[k]] = normalize_surface(p, acc)


@wp.kernel
def gather_cluster_lists(
    p: SurfaceParams,
    coeffs: wp.array2d(dtype=Any),
    points: wp.array(dtype=wp.vec3d),
    normals: wp.array(dtype=wp.vec3),
    tangents: wp.array(dtype=wp.vec3),
    use_tangents: int,
    frames: PointFrames,
    block_of: wp.array(dtype=wp.int32),
    blocks: CubeBlocks,
    first: wp.array(dtype=wp.int32),
    scratch: Clusters,
    first_cluster: int,
    min_points: int,
    simd: int,
    out: wp.array(dtype=Any),
    dest: wp.array(dtype=wp.int64),
):
    """Frame, list and gather one cluster per thread (the CPU's path, order-1
    textons): the frames of its points (``frame_point``), then the list, in slot 0 of ``scratch`` (one per launch: a CPU launch runs its
    threads one after another) and is summed while it is in cache, by
    ``cluster_sums``, whose 16 lanes are the cluster's points; the same terms in the
    same order as ``gather_clustered``. Point k's value goes to out[dest[k]]."""
    m = wp.tid() + first_cluster
    k0 = first[m]
    k1 = first[m + 1]
    for k in range(k0, k1):
        frame_point(p, points, normals, tangents, use_tangents, frames, k)
    runs = list_cluster(p, points, normals, frames, block_of, blocks, k0, k1, scratch, 0, min_points, simd)
    if runs < 0 or k1 - k0 > 16:
        for k in range(k0, k1):
            out[dest[k]] = normalize_surface(p, cluster_point(p, coeffs, points, normals, frames, block_of, blocks,
                                                              scratch, 0, runs, k))
        return
    cluster_sums(coeffs, points, normals, frames.u1, frames.u2, frames.lo, frames.hi, k0, k1, blocks.cubes,
                 scratch.run_cube, scratch.run_end, 0, runs, scratch.ux, scratch.uy, scratch.uz, 0, p.cells.size,
                 p.half, p.centre[0], p.centre[1], p.lo[0], p.lo[1], p.hi[0], p.hi[1], out, dest, simd)
    for k in range(k0, k1):
        d = dest[k]
        out[d] = normalize_surface(p, out[d])


#: The cluster kernels for one channel (float) and three (vec3): a grey texton's
#: surface noise reads and writes one float a texel, not three.
for _lanes in (float, wp.vec3):
    wp.overload(gather_clustered, {"coeffs": wp.array2d(dtype=_lanes), "out": wp.array(dtype=_lanes)})
    wp.overload(gather_cluster_lists, {"coeffs": wp.array2d(dtype=_lanes), "out": wp.array(dtype=_lanes)})


__all__ = ["Clusters", "list_cluster_impacts", "gather_clustered", "gather_cluster_lists"]
