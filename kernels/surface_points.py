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
    up: wp.vec3  # the frame rule's directions a and b (``side`` a direction, the public ``side`` of surfaces;
    side: wp.vec3  # a tiling model's ``side`` is its triangles' length, in kernels/noise_tiling.Tiling)


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


#: The point kernels for one channel (float) and three (vec3): a grey texton's
#: surface noise reads and writes one float a texel, not three.
for _lanes in (float, wp.vec3):
    wp.overload(evaluate_surface, {"coeffs": wp.array2d(dtype=_lanes), "out": wp.array(dtype=_lanes)})


#: 0.2's name of the probe of the native loops' form (kernels/native_simd.py).
simd_probe = vector_form_probe


__all__ = ["PAD", "SurfaceParams", "PointFrames", "evaluate_surface", "prepare_points", "frame_points", "simd_probe",
           "tangent_frame", "sum_block",
           "SurfaceNoise", "SurfaceNoise1", "surface_value", "surface_frame_value"]
