"""Surface texton noise (CGF §6): a 3-D hashed-cell Poisson process projected on
tangent planes, evaluated at points (each point walking its cubes, or blocks of
points sharing the cubes' impacts drawn by kernels/surface_blocks.py).

Units are texels: the host divides world positions by the texel size. The
impacts are those of the cubic cells of kernels/impacts.py (the plane's hash
with a third coordinate and a domain tag, so the two processes are
independent). At a point y with frame (u1, u2, n)
an impact x adds (1 − 2|⟨y − x, n⟩|/r)⁺ h_c(⟨y − x, u1⟩, ⟨y − x, u2⟩), where
h_c is the texton centred on its support and r the slab thickness (the
support's larger side).

Driven by: ``warp_texton.runtimes.warp_api``, ``warp_texton.surface.blocks``,
``warp_texton.surface.points``.
"""

from typing import Any

import warp as wp

from .surface_blocks import CubeBlocks, clamp_to_block
from .impacts import Cells3, cell_walk3, cube_offset, cube_span, impact_offset3
from .noise_raster import PAD, texton_value
from .native_simd import vector_form_probe
from .surface_native import cluster_sums, scan_cube

wp.set_module_options({"enable_backward": False, "optimization_level": 3})

#: √3: an impact that reaches a point lies within R = (r/2)√3 of it (the half-diagonal
#: of the cube of side r around the point, in its frame).
SQRT3 = wp.constant(1.7320508)
#: R is taken 0.1 % larger, far above float32 rounding (a few 1e-7), so that no impact
#: within R of a point is left off its cluster's list.
REACH_ROUNDING = wp.constant(1.001)


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


@wp.struct
class SlabLookup1:
    # the same, one channel (a grey texton: float coefficients)
    coeffs: wp.array2d(dtype=float)
    u1: wp.vec3
    u2: wp.vec3
    n: wp.vec3
    half: float
    centre: wp.vec2
    lo: wp.vec2
    hi: wp.vec2
    order: int


@wp.func
def slab_term(coeffs: wp.array2d(dtype=Any), u1: wp.vec3, u2: wp.vec3, t: float, half: float, centre: wp.vec2,
              lo: wp.vec2, hi: wp.vec2, order: int, d: wp.vec3, acc: Any):
    # One channel (float coefficients) or three (vec3): the same operations on each
    # channel, so a grey texton's float sum is the first component of its vec3 sum.
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


@wp.func
def add_slab(c: SlabLookup1, d: wp.vec3, acc: float):  # noqa: F811 (a Warp overload)
    t = wp.dot(d, c.n)
    if wp.abs(t) < c.half:
        acc = slab_term(c.coeffs, c.u1, c.u2, t, c.half, c.centre, c.lo, c.hi, c.order, d, acc)
    return acc


#: Σ of the slab contributions over the impacts of the cubes near a point (see impacts.cell_walk3),
#: three channels and one.
sum_slab = cell_walk3(add_slab, "sum_slab")
sum_slab1 = cell_walk3(add_slab, "sum_slab1", zero=wp.float32)


@wp.func
def new_lookup(coeffs: wp.array2d(dtype=wp.vec3)):
    look = SlabLookup()
    look.coeffs = coeffs
    return look


@wp.func
def new_lookup(coeffs: wp.array2d(dtype=float)):  # noqa: F811 (a Warp overload)
    look = SlabLookup1()
    look.coeffs = coeffs
    return look


@wp.func
def slab_lookup(p: SurfaceParams, coeffs: wp.array2d(dtype=Any), u1: wp.vec3, u2: wp.vec3, n: wp.vec3):
    look = new_lookup(coeffs)
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
def normalize_surface(p: SurfaceParams, acc: float):  # noqa: F811 (a Warp overload)
    # one channel: the vec3 form's operations on its first component
    return p.mean[0] + (acc - p.shift[0]) * p.inv_scale


@wp.func
def frame_value(p: SurfaceParams, coeffs: wp.array2d(dtype=wp.vec3), y: wp.vec3d, u1: wp.vec3, u2: wp.vec3,
                n: wp.vec3):
    # the noise at texel-space y with the frame (u1, u2, n): each point walking its cubes
    look = slab_lookup(p, coeffs, u1, u2, n)
    acc = sum_slab(y, frame_extent(p.half, u1, u2, n), p.cells, look)
    return normalize_surface(p, acc)


@wp.func
def frame_value(p: SurfaceParams, coeffs: wp.array2d(dtype=float), y: wp.vec3d, u1: wp.vec3,  # noqa: F811
                u2: wp.vec3, n: wp.vec3):  # (a Warp overload: one channel)
    look = slab_lookup(p, coeffs, u1, u2, n)
    acc = sum_slab1(y, frame_extent(p.half, u1, u2, n), p.cells, look)
    return normalize_surface(p, acc)


@wp.func
def normal_length(n: wp.vec3d):
    # |n| in float64, summed in NumPy's order (x² + y²) + z²
    xx = n[0] * n[0]
    yy = n[1] * n[1]
    zz = n[2] * n[2]
    s = xx + yy
    s = s + zz
    return wp.sqrt(s)


@wp.func
def unit_normal(n: wp.vec3d, length: wp.float64):
    # n / |n| in float64, rounded to float32: NumPy's unit_rows, then the float32 copy
    return wp.vec3(wp.float32(n[0] / length), wp.float32(n[1] / length), wp.float32(n[2] / length))


@wp.struct
class SurfaceNoise:
    """Surface texton noise, as a kernel evaluates it (the device API).

    Filled on the host by :func:`warp_texton.runtimes.warp_api.pack_surface`; its array
    lives on the device it was packed for.

    Attributes
    ----------
    params : SurfaceParams
        The 3-D Poisson process of impacts (cube side, mean count, seed,
        Poisson mode), the slab half-thickness r/2, the texton's support box
        and order, the normalisation of CGF Prop. 3 and the frame rule's
        directions ``up`` and ``side``.
    coeffs : wp.array2d(dtype=wp.vec3)
        The texton's coefficients with a zero margin of ``PAD`` texels.
    texel_size : wp.float64
        World units per texel.
    """

    params: SurfaceParams
    coeffs: wp.array2d(dtype=wp.vec3)
    texel_size: wp.float64


@wp.struct
class SurfaceNoise1:
    """Surface texton noise of a one-channel (grey) texton (the device API).

    Filled on the host by :func:`warp_texton.runtimes.warp_api.pack_surface` with
    ``channels=1``; ``surface_value`` and ``surface_frame_value`` of it return a
    float, and read one float a texel where ``SurfaceNoise`` reads three.

    Attributes
    ----------
    params : SurfaceParams
        As in ``SurfaceNoise`` (the mean and shift in the first component).
    coeffs : wp.array2d(dtype=float)
        The texton's coefficients with a zero margin of ``PAD`` texels.
    texel_size : wp.float64
        World units per texel.
    """

    params: SurfaceParams
    coeffs: wp.array2d(dtype=float)
    texel_size: wp.float64


@wp.func
def surface_frame_value(noise: SurfaceNoise, y: wp.vec3d, n: wp.vec3, u1: wp.vec3) -> wp.vec3:
    """Surface texton noise at the texel-space point ``y`` with the frame (``u1``, n × ``u1``, ``n``).

    ``y`` is in texels (world / ``texel_size``), ``n`` a unit normal and
    ``u1`` a unit tangent orthogonal to it: the direction of the texton's x
    axis. The value of :func:`warp_texton.surface_noise` with ``tangents``
    for the same point, normal and tangent after its own normalisation
    (float64, then float32), bit for bit on the same device.
    """
    return frame_value(noise.params, noise.coeffs, y, u1, wp.cross(n, u1), n)


@wp.func
def surface_frame_value(noise: SurfaceNoise1, y: wp.vec3d, n: wp.vec3, u1: wp.vec3) -> float:  # noqa: F811
    """One channel: the first component of the ``SurfaceNoise`` form's value, bit for bit."""
    return frame_value(noise.params, noise.coeffs, y, u1, wp.cross(n, u1), n)


@wp.func
def surface_value(noise: SurfaceNoise, x: wp.vec3d, normal: wp.vec3d) -> wp.vec3:
    """Surface texton noise at the world point ``x`` with the normal ``normal`` (CGF §6).

    ``normal`` may have any non-zero length (a zero normal gives NaN). The
    tangent frame follows the rule of :func:`warp_texton.tangent_frames`
    with the packed ``up`` and ``side``. The value of
    :func:`warp_texton.surface_noise` at the same float64 point and normal
    without ``tangents``, bit for bit on the same device: the point is
    divided by the texel size in float64 and the normal normalised in
    float64, then rounded to float32, as ``surface_noise`` does.
    """
    length = normal_length(normal)
    n = unit_normal(normal, length)
    u1, u2 = tangent_frame(n, noise.params.up, noise.params.side)
    return surface_frame_value(noise, x / noise.texel_size, n, u1)


@wp.func
def surface_value(noise: SurfaceNoise1, x: wp.vec3d, normal: wp.vec3d) -> float:  # noqa: F811 (a Warp overload)
    """One channel: the first component of the ``SurfaceNoise`` form's value, bit for bit."""
    length = normal_length(normal)
    n = unit_normal(normal, length)
    u1, u2 = tangent_frame(n, noise.params.up, noise.params.side)
    return surface_frame_value(noise, x / noise.texel_size, n, u1)


@wp.func
def new_noise(coeffs: wp.array2d(dtype=wp.vec3)):
    noise = SurfaceNoise()
    noise.coeffs = coeffs
    return noise


@wp.func
def new_noise(coeffs: wp.array2d(dtype=float)):  # noqa: F811 (a Warp overload)
    noise = SurfaceNoise1()
    noise.coeffs = coeffs
    return noise


@wp.kernel
def evaluate_surface(
    p: SurfaceParams,
    coeffs: wp.array2d(dtype=Any),
    points: wp.array(dtype=wp.vec3d),
    normals: wp.array(dtype=wp.vec3),
    tangents: wp.array(dtype=wp.vec3),
    use_tangents: int,
    out: wp.array(dtype=Any),
):
    """Surface noise at points (texel units, float64) with unit normals, each point
    walking its own cubes; frames from the rule, or from given tangents (already
    orthogonal to the normals, unit): ``surface_frame_value``, the device API's
    function, at each point. The reference for the block path."""
    k = wp.tid()
    noise = new_noise(coeffs)
    noise.params = p
    noise.texel_size = wp.float64(1.0)
    n = normals[k]
    u1, u2 = point_frame(p, n, tangents, k, use_tangents)
    out[k] = surface_frame_value(noise, points[k], n, u1)


@wp.kernel
def prepare_points(points: wp.array(dtype=wp.vec3d), normals: wp.array(dtype=wp.vec3d), texel: wp.float64,
                   pos: wp.array(dtype=wp.vec3d), unit: wp.array(dtype=wp.vec3), length: wp.array(dtype=wp.float64)):
    """Positions in texel units (y / texel) and unit normals n / |n| rounded to
    float32, in float64 with the operations (and so the values) of NumPy's
    ``points / texel`` and ``n / sqrt(x·x + y·y + z·z)``; |n| for the host's check.
    ``surface_value`` makes the same two steps."""
    k = wp.tid()
    pos[k] = points[k] / texel
    n = normals[k]
    r = normal_length(n)
    length[k] = r
    unit[k] = unit_normal(n, r)


# ------------------------------------------------------- blocks of points
@wp.func
def range_meets(rel: wp.vec3, a: wp.vec3, size: float, lo: float, hi: float):
    # does ⟨rel − u size, a⟩ over u ∈ [0, 1]³ meet [lo, hi]?
    x = wp.dot(rel, a)
    x_lo = x - size * (wp.max(a[0], 0.0) + wp.max(a[1], 0.0) + wp.max(a[2], 0.0))
    x_hi = x - size * (wp.min(a[0], 0.0) + wp.min(a[1], 0.0) + wp.min(a[2], 0.0))
    return x_lo <= hi and x_hi >= lo


@wp.func
def cube_may_count(c: Any, rel: wp.vec3, size: float):
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
def sum_block(p: SurfaceParams, coeffs: wp.array2d(dtype=Any), look: Any, y: wp.vec3d, n: wp.vec3,
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
    acc = coeffs.dtype(0.0)
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


#: The point kernels for one channel (float) and three (vec3): a grey texton's
#: surface noise reads and writes one float a texel, not three.
for _lanes in (float, wp.vec3):
    wp.overload(evaluate_surface, {"coeffs": wp.array2d(dtype=_lanes), "out": wp.array(dtype=_lanes)})
    wp.overload(gather_clustered, {"coeffs": wp.array2d(dtype=_lanes), "out": wp.array(dtype=_lanes)})
    wp.overload(gather_cluster_lists, {"coeffs": wp.array2d(dtype=_lanes), "out": wp.array(dtype=_lanes)})


#: 0.2's name of the probe of the native loops' form (kernels/native_simd.py).
simd_probe = vector_form_probe


__all__ = ["PAD", "SurfaceParams", "PointFrames", "Clusters", "evaluate_surface", "prepare_points", "frame_points",
           "list_cluster_impacts", "gather_clustered", "gather_cluster_lists", "simd_probe", "tangent_frame",
           "SurfaceNoise", "SurfaceNoise1", "surface_value", "surface_frame_value"]
