"""Blocks of points sharing their cubes' impacts: the 3-D block path.

An evaluator of the cubic cells' Poisson process (kernels/impacts.py) at many
points could let each point walk its cubes and draw their impacts itself (the
reference). Here the points are sorted into blocks of BLOCK_CUBES³ cubes
(:func:`sort_into_blocks`), each block's cubes draw their impacts once
(:func:`draw_cubes`, in rounds of about CUBES_PER_ROUND cubes:
:func:`block_rounds`), and every point of a block gathers them in the order its
own walk would draw them, so both give the same values (docs/model.md, "Blocks
of points"). These three functions know nothing of surfaces: a volume noise
uses them as they are.

Surface noise (CGF §6) gathers through cluster lists (:func:`gather_blocks`):
nearby points of a block list once the impacts that may reach any of them,
then each sums its cluster's list. On the CPU the two inner loops are native
(kernels/surface_native.py), with AVX-512 where the CPU has it (``SIMD``).

Package-internal (documented in docs/architecture.md): users call
:func:`warp_texton.surface_noise`.

Kernels driven here: ``warp_texton.kernels.impacts``, ``warp_texton.kernels.surface_blocks``,
``warp_texton.kernels.surface_points``, ``warp_texton.kernels.surface_clusters``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import warp as wp

from ..core.runtime import CHUNKS_PER_THREAD, cpu_threads, split_launch, vector_form
from ..kernels import surface_blocks
from ..kernels import surface_clusters, surface_points
from ..kernels.impacts import Cells3
from ..core.limits import check_memory

#: Points are grouped by blocks of BLOCK_CUBES = 2**BLOCK_SHIFT cubes per side.
BLOCK_SHIFT = 2
BLOCK_CUBES = 1 << BLOCK_SHIFT
#: Cubes drawn per round of the block path (bounds its impact buffer).
CUBES_PER_ROUND = 1 << 20
#: Points of a block that share a cell of side cube / 2**(3 − CLUSTER_LEVEL) (a half
#: cube: measured fastest on dense and sparse meshes, see docs/benchmarks.md) are
#: taken in clusters of at most CLUSTER_POINTS, which list the impacts that may
#: reach them once (in runs of one cube each); clusters of fewer than CLUSTER_MIN
#: points, or whose list would pass CLUSTER_CAP impacts or CLUSTER_RUNS cubes, walk
#: the block's cubes instead. At most
#: CLUSTERS_PER_ROUND lists exist at once.
CLUSTER_POINTS = 16
CLUSTER_MIN = 4
CLUSTER_RUNS = 128
CLUSTER_LEVEL = 2
CLUSTER_CAP = 1024
CLUSTERS_PER_ROUND = 1 << 12
#: Use the vector loops of kernels/surface_native.py where the CPU has AVX2, AVX-512
#: or NEON (the same values as their scalar form; tests switch it off to check that form).
SIMD = True

#: Bytes a drawn cube holds through its round: its coordinates (3 int32) and its
#: count and offset (an int32 each), rounded up for the host's index arrays.
BYTES_PER_CUBE = 24
#: Bytes per drawn impact: its position in the cube (3 float32).
BYTES_PER_IMPACT = 12
#: A cube of mean count μ is sized for μ + POISSON_SDS √μ + 1 impacts: the rounds'
#: counts are sums of many Poisson counts, so their total stays far below this.
POISSON_SDS = 10
#: Bytes per point at the peak of gather_blocks: its sorted float64 position (24) and
#: float32 normal (12), its frame u1, u2 (24) and cube span (24), its sort key, order
#: and destination (24), its value (12), and the sort's temporaries (about 40).
BYTES_PER_POINT = 160

#: x ↦ x with two zero bits after each of its 5 bits (Morton codes of 32 steps per axis)
_SPREAD = np.array([sum(((x >> b) & 1) << (3 * b) for b in range(5)) for x in range(8 * BLOCK_CUBES)], np.int64)


@dataclass(frozen=True)
class BlockedPoints:
    """Points sorted into blocks of BLOCK_CUBES³ cubes (see :func:`sort_into_blocks`).

    order : int64 (N,), the sorted points' original rows; pos : float64 (N, 3) and
    nrm : float32 (N, 3) or None, the sorted positions and normals; starts : the
    first point of each block; lo, hi : int64 (B, 3), the first and last cube per
    axis that the points of each block can reach; clusters : the first point of
    each cluster (sorted order; a block's first point starts a cluster).
    """

    order: np.ndarray
    pos: np.ndarray
    nrm: np.ndarray | None
    starts: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    clusters: np.ndarray


def sort_into_blocks(pos: np.ndarray, nrm: np.ndarray | None, cell: float, reach: float) -> BlockedPoints:
    """Sort (N ≥ 1) float64 positions (texel units) into blocks of BLOCK_CUBES³ cubes of
    side ``cell``, with their normals (None for points without one, as in a volume);
    each block reaches the cubes within ``reach`` of its points per axis (an upper
    bound on how far a point's walk goes)."""
    c = cell
    scale = 8.0 / c
    shift = 3 + BLOCK_SHIFT
    pos = np.ascontiguousarray(pos, dtype=np.float64)
    points: wp.array = wp.array(pos, dtype=wp.vec3d, device="cpu", copy=False)
    # the eighth of a cube each point lies in, floor(y · 8 / c) (any rounding will do:
    # a sort key); its block of BLOCK_CUBES = 2**BLOCK_SHIFT cubes of 8 eighths per side,
    # numbered from the blocks of the smallest coordinates (floor and the product are
    # monotone: the smallest eighth is that of the smallest coordinate); within a block
    # the Morton order of the eighths, so that consecutive points are neighbours
    lo_fine = [int(math.floor(float(pos[:, k].min()) * scale)) for k in range(3)]
    hi_fine = [int(math.floor(float(pos[:, k].max()) * scale)) for k in range(3)]
    own_min = [f >> shift for f in lo_fine]
    span = [(hi >> shift) - o + 1 for hi, o in zip(hi_fine, own_min)]
    if float(span[0]) * float(span[1]) * float(span[2]) < 2.0**46 and len(pos) < 2**31:
        # the keys in a CPU kernel (several times faster than NumPy on (N, 3) arrays)
        # Warp's radix sort takes buffers twice the length (its scratch space) and is stable, so the
        # order is np.argsort(key, kind="stable")'s, 2-3x faster on a million points
        n = len(pos)
        keys = wp.empty(2 * n, dtype=wp.int64, device="cpu")
        rows = wp.empty(2 * n, dtype=wp.int32, device="cpu")
        spread: wp.array = wp.array(_SPREAD, dtype=wp.int64, device="cpu")
        split_launch("cpu", surface_blocks, n, lambda a, b: wp.launch(
            surface_blocks.block_keys, dim=b - a, device="cpu",
            inputs=[points[a:b], wp.float64(scale), wp.int64(shift), *(wp.int64(o) for o in own_min),
                    wp.int64(span[0]), wp.int64(span[1]), spread, keys[a:b]]))
        rows.numpy()[:n] = np.arange(n, dtype=np.int32)
        wp.utils.radix_sort_pairs(keys, rows, n)
        key = keys.numpy()[:n]
        order = rows.numpy()[:n].astype(np.int64)
        block = key >> 15
    else:  # blocks spread over more than int64 keys hold
        fine = [np.floor(pos[:, k] * scale).astype(np.int64) for k in range(3)]
        own = [(f >> shift) - o for f, o in zip(fine, own_min)]
        morton = _SPREAD[fine[0] & (8 * BLOCK_CUBES - 1)] | (_SPREAD[fine[1] & (8 * BLOCK_CUBES - 1)] << 1) | \
            (_SPREAD[fine[2] & (8 * BLOCK_CUBES - 1)] << 2)
        order = np.lexsort((morton, own[0], own[1], own[2]))
        o = np.stack(own, axis=1)[order]
        block = np.cumsum(np.r_[0, np.any(o[1:] != o[:-1], axis=1)])
        key = (block << 15) | morton[order]
    new_block = np.r_[True, block[1:] != block[:-1]]
    starts = np.flatnonzero(new_block)
    if nrm is None:
        ps, ns = pos[order], None
    else:
        ps = np.empty_like(pos)
        ns = np.empty((len(pos), 3), np.float32)
        wp_order: wp.array = wp.array(order, dtype=wp.int64, device="cpu", copy=False)
        normals: wp.array = wp.array(np.ascontiguousarray(nrm, dtype=np.float32), dtype=wp.vec3, device="cpu", copy=False)
        wp_ps: wp.array = wp.array(ps, dtype=wp.vec3d, device="cpu", copy=False)
        wp_ns: wp.array = wp.array(ns, dtype=wp.vec3, device="cpu", copy=False)
        split_launch("cpu", surface_blocks, len(pos), lambda a, b: wp.launch(
            surface_blocks.take_points, dim=b - a, device="cpu", inputs=[wp_order[a:b], points, normals, wp_ps[a:b], wp_ns[a:b]]))
    # floor((min p − R)/c) = min floor((p − R)/c): floor and rounding are monotone
    lo = np.floor((np.minimum.reduceat(ps, starts, axis=0) - reach) / c).astype(np.int64)
    hi = np.floor((np.maximum.reduceat(ps, starts, axis=0) + reach) / c).astype(np.int64)
    # clusters: runs of points in the same cluster cell, cut every CLUSTER_POINTS
    cell_key = key >> (3 * CLUSTER_LEVEL)
    first = np.r_[True, cell_key[1:] != cell_key[:-1]] | new_block
    run = np.cumsum(first) - 1
    rank = np.arange(len(order)) - np.flatnonzero(first)[run]
    clusters = np.flatnonzero(first | (rank % CLUSTER_POINTS == 0))
    return BlockedPoints(order, ps, ns, starts, lo, hi, clusters)


def block_rounds(cubes: np.ndarray):
    """(b0, b1) ranges of consecutive blocks of about CUBES_PER_ROUND cubes together
    (at least one block each), given each block's number of cubes."""
    cum = np.cumsum(cubes)
    b0 = 0
    while b0 < len(cubes):
        before = cum[b0 - 1] if b0 else 0
        b1 = max(b0 + 1, int(np.searchsorted(cum, before + CUBES_PER_ROUND, side="right")))
        yield b0, b1
        b0 = b1


def draw_cubes(cells: Cells3, lo: np.ndarray, dims: np.ndarray, device) -> surface_blocks.CubeBlocks:
    """The impacts of every cube of blocks ``lo`` + [0, ``dims``) (int64 (B, 3) each), drawn
    once per cube in the order a walk draws them: cubes x fastest within each block."""
    cubes = np.prod(dims, axis=1)
    nb = len(cubes)
    base = np.zeros(nb, np.int64)
    base[1:] = np.cumsum(cubes)[:-1]
    total = int(cubes.sum())
    owner = np.repeat(np.arange(nb), cubes)
    local = np.arange(total, dtype=np.int64) - base[owner]
    d = dims[owner]
    coords = lo[owner] + np.stack([local % d[:, 0], (local // d[:, 0]) % d[:, 1], local // (d[:, 0] * d[:, 1])],
                                  axis=1)
    cube_arr: wp.array = wp.array(coords.astype(np.int32), dtype=wp.vec3i, device=device)
    counts = wp.empty(total + 1, dtype=wp.int32, device=device)
    split_launch(device, surface_blocks, total, lambda a, b: wp.launch(surface_blocks.count_cubes, dim=b - a,
                                                           inputs=[cells, cube_arr[a:b], counts[a:b]]))
    offsets = wp.empty(total + 1, dtype=wp.int32, device=device)
    wp.utils.array_scan(counts, offsets, inclusive=False)
    n_impacts = int(offsets[total:total + 1].numpy()[0])
    blocks = surface_blocks.CubeBlocks()
    blocks.cubes = cube_arr
    blocks.origin = wp.array(lo.astype(np.int32), dtype=wp.vec3i, device=device)
    blocks.dims = wp.array(dims.astype(np.int32), dtype=wp.vec3i, device=device)
    blocks.base = wp.array(base.astype(np.int32), dtype=wp.int32, device=device)
    blocks.offsets = offsets
    blocks.ux, blocks.uy, blocks.uz = (wp.empty(max(n_impacts, 1), dtype=wp.float32, device=device) for _ in range(3))
    if n_impacts:
        split_launch(device, surface_blocks, total, lambda a, b: wp.launch(
            surface_blocks.emit_cubes, dim=b - a, inputs=[cells, cube_arr[a:b], offsets[a:], blocks.ux, blocks.uy, blocks.uz]))
    return blocks


def gather_blocks(p: surface_points.SurfaceParams, coeffs, pos: np.ndarray, nrm: np.ndarray, tan, device, *, reach: float,
                  mean_count: float, sorted_points: BlockedPoints | None = None) -> np.ndarray:
    """Surface noise at (N ≥ 1) checked float64 texel positions with unit normals (and
    unit tangents, or None for the frame rule) through the block path: sort, draw each
    block's cubes once, list each cluster's impacts, gather (docs/model.md, "Blocks of
    points"). ``reach`` bounds how far a point's walk goes per axis; ``mean_count`` is
    the cubes' mean impact count (for the memory estimate). The values of
    ``kernels/surface_points.py:evaluate_surface``, bit for bit on the CPU. ``sorted_points``:
    the points already sorted (:func:`sort_into_blocks` with the same cell and reach)."""
    n = pos.shape[0]
    pts = sort_into_blocks(pos, nrm, p.cells.size, reach) if sorted_points is None else sorted_points
    dims = pts.hi - pts.lo + 1
    cubes = np.prod(dims, axis=1)
    # the peak: the sorted copies of the points and their frames, one round's cubes and
    # impacts (at most CUBES_PER_ROUND cubes, or one block), and the cluster lists
    round_cubes = min(float(cubes.sum()), max(float(CUBES_PER_ROUND), float(cubes.max())))
    # the CPU lists and gathers each cluster in turn (order-1 textons), in a one-slot
    # scratch per launch; otherwise the clusters of a round are listed at once
    on_cpu = wp.get_device(device).is_cpu
    by_cluster = on_cpu and p.order == 1
    slots = CHUNKS_PER_THREAD * cpu_threads() if by_cluster else min(len(pts.clusters), CLUSTERS_PER_ROUND)
    list_bytes = slots * (12.0 * CLUSTER_CAP + 8.0 * CLUSTER_RUNS + 12.0)
    per_cube = BYTES_PER_CUBE + BYTES_PER_IMPACT * (mean_count + POISSON_SDS * math.sqrt(mean_count) + 1)
    check_memory(round_cubes * per_cube + list_bytes + n * float(BYTES_PER_POINT),
                 f"surface noise at {n} points", "evaluate fewer points at once")
    ends = np.r_[pts.starts[1:], n]
    sorted_tan = np.take(tan, pts.order, axis=0).astype(np.float32) if tan is not None else None
    # values go straight to the points' own rows (dest = order), in place on the CPU
    # (one float a point for a one-channel texton's float coefficients, else three)
    lanes = 1 if coeffs.dtype == wp.float32 else 3
    out = np.empty((n, lanes), np.float32)
    res = wp.array(out.reshape(n) if lanes == 1 else out, dtype=coeffs.dtype, copy=False, device=device) if on_cpu \
        else wp.empty(n, dtype=coeffs.dtype, device=device)
    lists = None if by_cluster else ClusterLists(min(len(pts.clusters), CLUSTERS_PER_ROUND), device)
    for b0, b1 in block_rounds(cubes):
        blocks = draw_cubes(p.cells, pts.lo[b0:b1], dims[b0:b1], device)
        gather_round(p, coeffs, pts, sorted_tan, device, pts.starts[b0:b1], ends[b0:b1], blocks, lists, res,
                     by_cluster)
    return out if on_cpu else res.numpy().reshape(n, lanes)


class ClusterLists:
    """Room for the impact lists of ``size`` clusters (``surface_clusters.Clusters`` without ``first``),
    allocated once per call and reused by every round."""

    def __init__(self, size: int, device):
        cl = surface_clusters.Clusters()
        cl.cap = CLUSTER_CAP
        cl.cap_runs = CLUSTER_RUNS
        cl.first = wp.empty(1, dtype=wp.int32, device=device)  # set per round
        cl.runs = wp.empty(size, dtype=wp.int32, device=device)
        cl.run_cube = wp.empty(size * CLUSTER_RUNS, dtype=wp.int32, device=device)
        cl.run_end = wp.empty(size * CLUSTER_RUNS, dtype=wp.int32, device=device)
        cl.ux = wp.empty(size * CLUSTER_CAP, dtype=wp.float32, device=device)
        cl.uy = wp.empty(size * CLUSTER_CAP, dtype=wp.float32, device=device)
        cl.uz = wp.empty(size * CLUSTER_CAP, dtype=wp.float32, device=device)
        self.clusters = cl


def gather_round(p: surface_points.SurfaceParams, coeffs, sorted_points: BlockedPoints, tan, device, starts, ends, blocks: surface_blocks.CubeBlocks,
                 lists: ClusterLists | None, res, by_cluster: bool) -> None:
    """Surface noise at the points of the blocks ``starts``..``ends`` (sorted rows) of
    ``sorted_points``, whose cubes ``blocks`` holds, written to res[order]: one thread per
    cluster on the CPU (``by_cluster``), else each round's clusters listed in
    ``lists`` and gathered one thread per point."""
    pos, nrm, order, clusters = (sorted_points.pos, sorted_points.nrm, sorted_points.order,
                                 sorted_points.clusters)
    assert nrm is not None, "surface points carry normals"
    p0, p1 = int(starts[0]), int(ends[-1])
    block_of = np.repeat(np.arange(len(starts), dtype=np.int32), ends - starts)
    m = p1 - p0
    on_cpu = wp.get_device(device).is_cpu
    # the CPU reads the sorted copies in place (contiguous rows of float64 / float32)
    pts: wp.array = wp.array(pos[p0:p1], dtype=wp.vec3d, copy=not on_cpu, device=device)
    nrms: wp.array = wp.array(nrm[p0:p1], dtype=wp.vec3, copy=not on_cpu, device=device)
    tans = wp.array(tan[p0:p1], dtype=wp.vec3, copy=not on_cpu, device=device) if tan is not None else wp.zeros(1, dtype=wp.vec3, device=device)
    owners: wp.array = wp.array(block_of, dtype=wp.int32, device=device)
    frames = surface_points.PointFrames()
    frames.u1, frames.u2 = wp.empty(m, dtype=wp.vec3, device=device), wp.empty(m, dtype=wp.vec3, device=device)
    frames.lo, frames.hi = wp.empty(m, dtype=wp.vec3i, device=device), wp.empty(m, dtype=wp.vec3i, device=device)

    def frame(a, b):
        sub = surface_points.PointFrames()
        sub.u1, sub.u2, sub.lo, sub.hi = frames.u1[a:b], frames.u2[a:b], frames.lo[a:b], frames.hi[a:b]
        wp.launch(surface_points.frame_points, dim=b - a, inputs=[p, pts[a:b], nrms[a:b], tans[a:b] if tan is not None else tans,
                                                     int(tan is not None), sub])

    if not by_cluster:  # gather_cluster_lists frames its own points
        split_launch(device, surface_points, m, frame)
    dest: wp.array = wp.array(order[p0:p1], dtype=wp.int64, copy=not on_cpu, device=device)
    # one thread per cluster on the CPU (cluster_sums: SIMD over its points) for
    # order-1 textons; one per point elsewhere (the GPU, and other orders)
    simd = int(bool(SIMD))
    # the round's clusters (a cluster never straddles blocks: block starts are cluster starts)
    mine = clusters[(clusters >= p0) & (clusters < p1)]
    cfirst = np.r_[mine - p0, m].astype(np.int32)
    cluster_of: wp.array | None = None if by_cluster else wp.array(np.repeat(np.arange(len(mine), dtype=np.int32), np.diff(cfirst)),
                                                  dtype=wp.int32, device=device)
    if by_cluster:
        first: wp.array = wp.array(cfirst, dtype=wp.int32, device=device)

        def gather(a, b):
            wp.launch(surface_clusters.gather_cluster_lists, dim=b - a, inputs=[p, coeffs, pts, nrms, tans, int(tan is not None),
                                                                 frames, owners, blocks, first,
                                                                 ClusterLists(1, device).clusters, a, CLUSTER_MIN, simd, res,
                                                                 dest])

        split_launch(device, surface_clusters, len(mine), gather)
    else:
        assert lists is not None, "gather_blocks lists the clusters unless by_cluster"
        cl = lists.clusters
        for m0 in range(0, len(mine), CLUSTERS_PER_ROUND):
            m1 = min(m0 + CLUSTERS_PER_ROUND, len(mine))
            cl.first = wp.array(cfirst[m0:m1 + 1], dtype=wp.int32, device=device)
            split_launch(device, surface_clusters, m1 - m0, lambda a, b: wp.launch(
                surface_clusters.list_cluster_impacts, dim=b - a, inputs=[p, pts, nrms, frames, owners, blocks, cl, a, CLUSTER_MIN,
                                                           simd]))
            k0, k1 = int(cfirst[m0]), int(cfirst[m1])
            split_launch(device, surface_clusters, k1 - k0, lambda a, b, m0=m0, k0=k0: wp.launch(
                surface_clusters.gather_clustered, dim=b - a, inputs=[p, coeffs, pts, nrms, frames, owners, blocks, cluster_of, cl,
                                                       m0, a + k0, res, dest]))


def simd_loops(device="cpu") -> str:
    """The form of the block path's CPU loops (kernels/surface_native.py) that runs:
    "avx512", "avx2" or "neon" where their vector form was compiled for that
    instruction set, "scalar" otherwise (other CPUs, CUDA, or ``SIMD`` off): all
    give the same values; benchmarks report which ran."""
    return vector_form(device, SIMD)
