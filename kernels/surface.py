"""Surface texton noise (CGF §6): a 3-D hashed-cell Poisson process projected on
tangent planes, evaluated at points (each point walking its cubes, or blocks of
points sharing the cubes' impacts) and ray-cast for renders.

Units are texels: the host divides world positions by the texel size. The
impacts are those of the cubic cells of kernels/impacts.py (the plane's hash
with a third coordinate and a domain tag, so the two processes are
independent). At a point y with frame (u1, u2, n)
an impact x adds (1 − 2|⟨y − x, n⟩|/r)⁺ h_c(⟨y − x, u1⟩, ⟨y − x, u2⟩), where
h_c is the texton centred on its support and r the slab thickness (the
support's larger side).
"""

import warp as wp

from .impacts import Cells3, cell_state3, cell_walk3, cube_offset, cube_span, draw_count, impact_offset3, next_impact3
from .noise2d import PAD, texton_value
from .surface_native import cluster_sums, scan_cube, vector_loops

wp.set_module_options({"enable_backward": False, "optimization_level": 3})


@wp.struct
class SurfaceParams:
    cells: Cells3  # the 3-D Poisson process of impacts
    order: int
    half: float  # r / 2
    centre: wp.vec2  # centre of the texton support in texton coordinates
    lo: wp.vec2  # texton support, texton coordinates
    hi: wp.vec2
    shift: wp.vec3  # λ (r/2) ∫h: the mean of the raw sum (CGF Prop. 3)
    inv_scale: float  # 1 / √(λ r / 3)
    mean: wp.vec3
    up: wp.vec3  # the frame rule's directions a and b
    side: wp.vec3


@wp.func
def tangent_frame(n: wp.vec3, a: wp.vec3, b: wp.vec3):
    """u1 from the rule v = P_n(a) + ⟨a, n⟩⁴ P_n(b), P_n the tangent projection.

    v is continuous in n and vanishes only at isolated normals (a closed
    surface must have such points); where it does, b's projection (or any
    direction) stands in. Returns (u1, u2 = n × u1).
    """
    ca = wp.dot(a, n)
    c4 = ca * ca * ca * ca
    v = (a - n * ca) + (b - n * wp.dot(b, n)) * c4
    length = wp.length(v)
    if length < 1.0e-6:
        v = b - n * wp.dot(b, n)
        length = wp.length(v)
        if length < 1.0e-6:
            v = wp.cross(n, a)
            length = wp.length(v)
    u1 = v / length
    return u1, wp.cross(n, u1)


@wp.struct
class SlabLookup:
    # the point's frame and the texton, centred on its support
    coeffs: wp.array2d(dtype=wp.vec3)
    u1: wp.vec3
    u2: wp.vec3
    n: wp.vec3
    half: float
    centre: wp.vec2
    lo: wp.vec2
    hi: wp.vec2
    order: int


@wp.func
def slab_term(coeffs: wp.array2d(dtype=wp.vec3), u1: wp.vec3, u2: wp.vec3, t: float, half: float, centre: wp.vec2,
              lo: wp.vec2, hi: wp.vec2, order: int, d: wp.vec3, acc: wp.vec3):
    # an impact at t = ⟨d, n⟩ within r/2 of the tangent plane adds (1 − 2|t|/r) h_c(⟨d, u1⟩, ⟨d, u2⟩)
    z = wp.vec2(wp.dot(d, u1), wp.dot(d, u2)) + centre
    if z[0] >= lo[0] and z[0] <= hi[0] and z[1] >= lo[1] and z[1] <= hi[1]:
        w = 1.0 - wp.abs(t) / half
        if order == 1:
            # texton_value's order-1 branch for one texton (row0 = 0), inline: the same
            # operations in the same order (the same values, bit for bit) without the call and
            # the order dispatch, for the lookup each point makes about MNI times. z is in the
            # support [−1, s]², so PAD − 1 ≤ j, i and j + 1, i + 1 ≤ s + PAD + 1 < s + 2 PAD:
            # texton_value's clamps never act and are left out.
            fx = wp.floor(z[0])
            fy = wp.floor(z[1])
            tx = z[0] - fx
            ty = z[1] - fy
            j = int(fx) + PAD
            i = int(fy) + PAD
            top = coeffs[i, j] * (1.0 - tx) + coeffs[i, j + 1] * tx
            bottom = coeffs[i + 1, j] * (1.0 - tx) + coeffs[i + 1, j + 1] * tx
            acc = acc + (top * (1.0 - ty) + bottom * ty) * w
        else:
            acc = acc + texton_value(coeffs, 0, coeffs.shape[0], z, order) * w
    return acc


@wp.func
def add_slab(c: SlabLookup, d: wp.vec3, acc: wp.vec3):
    t = wp.dot(d, c.n)
    if wp.abs(t) < c.half:
        acc = slab_term(c.coeffs, c.u1, c.u2, t, c.half, c.centre, c.lo, c.hi, c.order, d, acc)
    return acc


#: Σ of the slab contributions over the impacts of the cubes near a point (see impacts.cell_walk3).
sum_slab = cell_walk3(add_slab, "sum_slab")


@wp.func
def slab_lookup(p: SurfaceParams, coeffs: wp.array2d(dtype=wp.vec3), u1: wp.vec3, u2: wp.vec3, n: wp.vec3):
    look = SlabLookup()
    look.coeffs = coeffs
    look.u1 = u1
    look.u2 = u2
    look.n = n
    look.half = p.half
    look.centre = p.centre
    look.lo = p.lo
    look.hi = p.hi
    look.order = p.order
    return look


@wp.func
def frame_extent(half: float, u1: wp.vec3, u2: wp.vec3, n: wp.vec3):
    # the rotated cube of side r around y (axes u1, u2, n) lies in the box y ± this
    return wp.vec3(
        half * (wp.abs(u1[0]) + wp.abs(u2[0]) + wp.abs(n[0])),
        half * (wp.abs(u1[1]) + wp.abs(u2[1]) + wp.abs(n[1])),
        half * (wp.abs(u1[2]) + wp.abs(u2[2]) + wp.abs(n[2])),
    )


@wp.func
def point_frame(p: SurfaceParams, n: wp.vec3, tangents: wp.array(dtype=wp.vec3), k: int, use_tangents: int):
    # (u1, u2): the given tangent, or the frame rule
    if use_tangents != 0:
        u1 = tangents[k]
        return u1, wp.cross(n, u1)
    return tangent_frame(n, p.up, p.side)


@wp.func
def normalize_surface(p: SurfaceParams, acc: wp.vec3):
    return p.mean + (acc - p.shift) * p.inv_scale


@wp.func
def surface_value(p: SurfaceParams, coeffs: wp.array2d(dtype=wp.vec3), y: wp.vec3d, u1: wp.vec3, u2: wp.vec3,
                  n: wp.vec3):
    look = slab_lookup(p, coeffs, u1, u2, n)
    acc = sum_slab(y, frame_extent(p.half, u1, u2, n), p.cells, look)
    return normalize_surface(p, acc)


@wp.kernel
def evaluate_surface(
    p: SurfaceParams,
    coeffs: wp.array2d(dtype=wp.vec3),
    points: wp.array(dtype=wp.vec3d),
    normals: wp.array(dtype=wp.vec3),
    tangents: wp.array(dtype=wp.vec3),
    use_tangents: int,
    out: wp.array(dtype=wp.vec3),
):
    """Surface noise at points (texel units, float64) with unit normals, each point
    walking its own cubes; frames from the rule, or from given tangents (already
    orthogonal to the normals, unit). The reference for the block path."""
    k = wp.tid()
    n = normals[k]
    u1, u2 = point_frame(p, n, tangents, k, use_tangents)
    out[k] = surface_value(p, coeffs, points[k], u1, u2, n)


# ------------------------------------------------------- blocks of points
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
def prepare_points(points: wp.array(dtype=wp.vec3d), normals: wp.array(dtype=wp.vec3d), texel: wp.float64,
                   pos: wp.array(dtype=wp.vec3d), unit: wp.array(dtype=wp.vec3), length: wp.array(dtype=wp.float64)):
    """Positions in texel units (y / texel) and unit normals n / |n| rounded to
    float32, in float64 with the operations (and so the values) of NumPy's
    ``points / texel`` and ``n / sqrt(x·x + y·y + z·z)``; |n| for the host's check."""
    k = wp.tid()
    pos[k] = points[k] / texel
    n = normals[k]
    xx = n[0] * n[0]
    yy = n[1] * n[1]
    zz = n[2] * n[2]
    s = xx + yy
    s = s + zz
    r = wp.sqrt(s)
    length[k] = r
    unit[k] = wp.vec3(wp.float32(n[0] / r), wp.float32(n[1] / r), wp.float32(n[2] / r))


@wp.kernel
def count_cubes(p: SurfaceParams, cubes: wp.array(dtype=wp.vec3i), counts: wp.array(dtype=wp.int32)):
    """Impact count of each listed cube."""
    g = wp.tid()
    c = cubes[g]
    n, s = draw_count(cell_state3(p.cells, c[0], c[1], c[2]), p.cells.mean_count, p.cells.exact_poisson)
    counts[g] = n


@wp.kernel
def emit_cubes(p: SurfaceParams, cubes: wp.array(dtype=wp.vec3i), offsets: wp.array(dtype=wp.int32),
               ux: wp.array(dtype=float), uy: wp.array(dtype=float), uz: wp.array(dtype=float)):
    """Each listed cube's impacts, in the order drawn, as positions in cell units
    (what ``next_impact3`` gives, one array per axis), so that a gather computes
    the offsets exactly as the per-point walk does."""
    g = wp.tid()
    c = cubes[g]
    n, s = draw_count(cell_state3(p.cells, c[0], c[1], c[2]), p.cells.mean_count, p.cells.exact_poisson)
    for k in range(offsets[g], wp.min(offsets[g] + n, offsets[g + 1])):
        u, s = next_impact3(s)
        ux[k] = u[0]
        uy[k] = u[1]
        uz[k] = u[2]


@wp.func
def range_meets(rel: wp.vec3, a: wp.vec3, size: float, lo: float, hi: float):
    # does ⟨rel − u size, a⟩ over u ∈ [0, 1]³ meet [lo, hi]?
    x = wp.dot(rel, a)
    x_lo = x - size * (wp.max(a[0], 0.0) + wp.max(a[1], 0.0) + wp.max(a[2], 0.0))
    x_hi = x - size * (wp.min(a[0], 0.0) + wp.min(a[1], 0.0) + wp.min(a[2], 0.0))
    return x_lo <= hi and x_hi >= lo


@wp.func
def cube_may_count(c: SlabLookup, rel: wp.vec3, size: float):
    """Whether an impact of the cube whose corner is at y − rel can pass add_slab's
    tests: the ranges of ⟨d, n⟩, ⟨d, u1⟩, ⟨d, u2⟩ over d = rel − [0, size]³ against
    the slab and the support, with a margin far above float rounding. A cube
    refused here holds no impact that adds anything, so skipping it leaves the
    sum unchanged, bit for bit."""
    margin = 1.0e-4 * (c.half + size)
    return (range_meets(rel, c.n, size, -c.half - margin, c.half + margin)
            and range_meets(rel, c.u1, size, c.lo[0] - c.centre[0] - margin, c.hi[0] - c.centre[0] + margin)
            and range_meets(rel, c.u2, size, c.lo[1] - c.centre[1] - margin, c.hi[1] - c.centre[1] + margin))


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


@wp.struct
class PointFrames:
    # each point's frame (u1, u2) and the cubes [lo, hi] its walk visits
    u1: wp.array(dtype=wp.vec3)
    u2: wp.array(dtype=wp.vec3)
    lo: wp.array(dtype=wp.vec3i)
    hi: wp.array(dtype=wp.vec3i)


@wp.func
def frame_point(p: SurfaceParams, points: wp.array(dtype=wp.vec3d), normals: wp.array(dtype=wp.vec3),
                tangents: wp.array(dtype=wp.vec3), use_tangents: int, frames: PointFrames, k: int):
    # point k's frame (the rule, or its tangent) and the span of cubes of its walk
    n = normals[k]
    u1, u2 = point_frame(p, n, tangents, k, use_tangents)
    frames.u1[k] = u1
    frames.u2[k] = u2
    x0, x1, y0, y1, z0, z1 = cube_span(points[k], frame_extent(p.half, u1, u2, n), p.cells.size)
    frames.lo[k] = wp.vec3i(x0, y0, z0)
    frames.hi[k] = wp.vec3i(x1, y1, z1)


@wp.kernel
def frame_points(p: SurfaceParams, points: wp.array(dtype=wp.vec3d), normals: wp.array(dtype=wp.vec3),
                 tangents: wp.array(dtype=wp.vec3), use_tangents: int, frames: PointFrames):
    """Each point's frame (the rule, or its tangent) and the span of cubes of its
    walk (``cube_span`` of ``frame_extent``), computed once for listing and gathering."""
    frame_point(p, points, normals, tangents, use_tangents, frames, wp.tid())


@wp.func
def clamp_to_block(o: wp.vec3i, dm: wp.vec3i, x0: int, x1: int, y0: int, y1: int, z0: int, z1: int):
    # the cube range within the block's cubes o + [0, dm) (the host sizes each block to
    # hold its points' cubes; the clamps only guard memory)
    return (wp.max(x0, o[0]), wp.min(x1, o[0] + dm[0] - 1), wp.max(y0, o[1]), wp.min(y1, o[1] + dm[1] - 1),
            wp.max(z0, o[2]), wp.min(z1, o[2] + dm[2] - 1))


@wp.func
def sum_block(p: SurfaceParams, coeffs: wp.array2d(dtype=wp.vec3), look: SlabLookup, y: wp.vec3d, n: wp.vec3,
              u1: wp.vec3, u2: wp.vec3, x0: int, x1: int, y0: int, y1: int, z0: int, z1: int, b: int,
              blocks: CubeBlocks):
    # the walk's sum over the cubes [x0, x1] × [y0, y1] × [z0, z1], from block b's drawn
    # impacts: the same cubes and impacts in the same order; cubes that cannot reach
    # the point are skipped
    o = blocks.origin[b]
    dm = blocks.dims[b]
    base = blocks.base[b]
    x0, x1, y0, y1, z0, z1 = clamp_to_block(o, dm, x0, x1, y0, y1, z0, z1)
    half = p.half
    centre = p.centre
    lo = p.lo
    hi = p.hi
    order = p.order
    c = p.cells.size
    acc = wp.vec3(0.0)
    for cz in range(z0, z1 + 1):
        for cy in range(y0, y1 + 1):
            row = base + ((cz - o[2]) * dm[1] + (cy - o[1])) * dm[0] - o[0]
            for cx in range(x0, x1 + 1):
                rel = cube_offset(y, cx, cy, cz, c)
                if cube_may_count(look, rel, c):
                    g = row + cx
                    for j in range(blocks.offsets[g], blocks.offsets[g + 1]):
                        # add_slab, with its fields held in registers
                        d = impact_offset3(rel, wp.vec3(blocks.ux[j], blocks.uy[j], blocks.uz[j]), c)
                        t = wp.dot(d, n)
                        if wp.abs(t) < half:
                            acc = slab_term(coeffs, u1, u2, t, half, centre, lo, hi, order, d, acc)
    return acc


# ------------------------------------------------ clusters of nearby points
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
    big_r = p.half * 1.7320508 * 1.001
    margin = 1.0e-3 * (p.half + c) + 1.0e-5 * (rho + big_r)
    t_lim = p.half + rho_n + big_r * nu + margin
    a_lo = p.lo[0] - p.centre[0] - rho_u - big_r * mu1 - margin
    a_hi = p.hi[0] - p.centre[0] + rho_u + big_r * mu1 + margin
    b_lo = p.lo[1] - p.centre[1] - rho_v - big_r * mu2 - margin
    b_hi = p.hi[1] - p.centre[1] + rho_v + big_r * mu2 + margin
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
def cluster_point(p: SurfaceParams, coeffs: wp.array2d(dtype=wp.vec3), points: wp.array(dtype=wp.vec3d),
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
    acc = wp.vec3(0.0)
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
    coeffs: wp.array2d(dtype=wp.vec3),
    points: wp.array(dtype=wp.vec3d),
    normals: wp.array(dtype=wp.vec3),
    frames: PointFrames,
    block_of: wp.array(dtype=wp.int32),
    blocks: CubeBlocks,
    cluster_of: wp.array(dtype=wp.int32),
    clusters: Clusters,
    first_cluster: int,
    first: int,
    out: wp.array(dtype=wp.vec3),
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
    coeffs: wp.array2d(dtype=wp.vec3),
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
    out: wp.array(dtype=wp.vec3),
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


@wp.kernel
def hit_points(pixels: wp.array(dtype=wp.int32), face: wp.array(dtype=wp.int32), bary: wp.array(dtype=wp.vec2),
               normal: wp.array(dtype=wp.vec3), vertices: wp.array(dtype=wp.vec3d), faces: wp.array(dtype=wp.int32),
               texel: wp.float64, points: wp.array(dtype=wp.vec3d), normals: wp.array(dtype=wp.vec3)):
    """The hit of pixel pixels[k] (flat index into the ray cast's arrays) in float64
    texel units, from its face's vertices and weights (u, v, 1 − u − v), and its
    shading normal."""
    k = wp.tid()
    q = pixels[k]
    f = face[q]
    uv = bary[q]
    u = wp.float64(uv[0])
    v = wp.float64(uv[1])
    w = wp.float64(1.0) - u - v
    y = vertices[faces[3 * f]] * u + vertices[faces[3 * f + 1]] * v + vertices[faces[3 * f + 2]] * w
    points[k] = y / texel
    normals[k] = normal[q]


@wp.kernel
def fill_image(img: wp.array2d(dtype=wp.vec3), background: wp.vec3):
    i, j = wp.tid()
    img[i, j] = background


@wp.kernel
def shade_hits(pixels: wp.array(dtype=wp.int32), values: wp.array(dtype=wp.vec3), shade: wp.array(dtype=float),
               box_width: int, row0: int, col0: int, grey: int, img: wp.array2d(dtype=wp.vec3)):
    """Pixel pixels[k] (flat index into the ray cast's box) of the render: its noise
    value clipped to [0, 1] times its shade (grey noise, in channel 0, spread to RGB)."""
    k = wp.tid()
    q = pixels[k]
    g = values[k]
    if grey != 0:
        g = wp.vec3(g[0], g[0], g[0])
    s = shade[q]
    img[row0 + q / box_width, col0 + q % box_width] = wp.vec3(wp.clamp(g[0], 0.0, 1.0) * s,
                                                              wp.clamp(g[1], 0.0, 1.0) * s,
                                                              wp.clamp(g[2], 0.0, 1.0) * s)


@wp.kernel
def simd_probe(out: wp.array(dtype=wp.int32)):
    """Which form of the loops of kernels/surface_native.py this build holds (vector_loops)."""
    out[0] = vector_loops()


@wp.struct
class Camera:
    origin: wp.vec3  # world units, relative to the mesh's local origin
    right: wp.vec3
    up: wp.vec3
    forward: wp.vec3
    tan_half_fov: float  # vertical
    aspect: float  # width / height
    light: wp.vec3  # unit direction towards the light


@wp.kernel
def cast_rays(
    mesh: wp.uint64,
    vertex_normals: wp.array(dtype=wp.vec3),
    indices: wp.array(dtype=wp.int32),
    cam: Camera,
    height: int,
    width: int,
    row0: int,
    col0: int,
    faces: wp.array2d(dtype=wp.int32),
    bary: wp.array2d(dtype=wp.vec2),
    normals: wp.array2d(dtype=wp.vec3),
    shade: wp.array2d(dtype=float),
):
    """Ray-cast one pixel (row0 + i, col0 + j) of a height × width image into
    element (i, j) of the outputs: the face hit (−1 for none), the barycentric
    weights of its first two vertices, the shading normal and the diffuse shade
    (zeros where nothing is hit). The mesh and the camera are in world units
    relative to a local origin (the host adds it back in float64)."""
    i, j = wp.tid()
    sx = (2.0 * (float(j + col0) + 0.5) / float(width) - 1.0) * cam.tan_half_fov * cam.aspect
    sy = (1.0 - 2.0 * (float(i + row0) + 0.5) / float(height)) * cam.tan_half_fov
    d = wp.normalize(cam.forward + cam.right * sx + cam.up * sy)
    q = wp.mesh_query_ray(mesh, cam.origin, d, 1.0e30)
    if not q.result:
        faces[i, j] = -1
        bary[i, j] = wp.vec2(0.0)
        normals[i, j] = wp.vec3(0.0)
        shade[i, j] = 0.0
        return
    f = q.face
    n = (vertex_normals[indices[3 * f]] * q.u + vertex_normals[indices[3 * f + 1]] * q.v
         + vertex_normals[indices[3 * f + 2]] * (1.0 - q.u - q.v))
    # smooth normals, except across creases: where the interpolated normal leaves
    # the face's by more than 30°, the face normal keeps flat faces flat
    if wp.length(n) < 1.0e-6:
        n = q.normal
    n = wp.normalize(n)
    if wp.dot(n, q.normal) < 0.866:
        n = q.normal
    faces[i, j] = f
    bary[i, j] = wp.vec2(q.u, q.v)
    normals[i, j] = n
    shade[i, j] = 0.3 + 0.7 * wp.abs(wp.dot(n, cam.light))


__all__ = ["PAD", "SurfaceParams", "Camera", "CubeBlocks", "PointFrames", "evaluate_surface", "block_keys",
           "take_points", "prepare_points", "count_cubes",
           "emit_cubes", "frame_points", "Clusters", "list_cluster_impacts", "gather_clustered",
           "gather_cluster_lists", "hit_points", "fill_image", "shade_hits",
           "simd_probe", "cast_rays", "tangent_frame"]
