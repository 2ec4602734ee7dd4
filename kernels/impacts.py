"""The hashed-cell Poisson process: one stream of impacts shared by every kernel.

Space is cut into cells (rectangles in the plane, cubes in 3-D). Cell c draws
its impacts from a PCG stream seeded by an avalanche hash of its integer
coordinates and the user seed: first the count (Poisson with the cell's mean),
then, for each impact, two uniforms (three in 3-D) giving its position in the
cell. Every path that needs a cell's impacts (raster blocks, points, filters,
surfaces) draws them through the functions here, in this one order, so all
paths and devices see the same impacts.

A kernel that sums something over the impacts near a point builds its walk
with :func:`cell_walk` (plane) or :func:`cell_walk3` (space) from a
*contribution* function ``contribution(ctx, d, acc) -> acc``, where ``d`` is
the point minus the impact and ``ctx`` any struct the kernel fills. The walk
visits the cells, draws the impacts and calls the contribution for those in
the box [lo, hi] (plane) or the given extent (space); the loop exists once.

Driven by: ``warp_texton.surface.blocks``, ``warp_texton.surface.points``.
"""

from typing import Any

import warp as wp

wp.set_module_options({"enable_backward": False, "optimization_level": 3})

#: The avalanche finaliser's multipliers.
AVALANCHE_M1 = wp.constant(wp.uint32(0x7FEB352D))
AVALANCHE_M2 = wp.constant(wp.uint32(0x846CA68B))
GOLDEN = wp.constant(wp.uint32(0x9E3779B9))
#: Warp's PCG step (warp/native/rand.h ``rand_pcg``), which ``wp.randf`` and the other draws take: the
#: kernels call Warp's functions; ports that reproduce the stream (kernels/tiling_draw.py) write these.
PCG_MUL = wp.constant(wp.uint32(747796405))
PCG_INC = wp.constant(wp.uint32(2891336453))
PCG_OUT = wp.constant(wp.uint32(277803737))
#: Mixed into the seed of 3-D cells, so that the plane's and space's processes are independent.
_SPACE_TAG = wp.constant(wp.uint32(0x5BD1E995))


@wp.struct
class Cells:
    # the plane's process
    size: wp.vec2  # cell width and height, texels
    period: wp.vec2i  # cells per period along x and y; 0 = no period
    mean_count: float  # mean impact count per cell, λ cw ch
    seed: wp.uint32
    exact_poisson: int  # 1: exact Poisson counts; 0: rounded Gaussian approximation


@wp.struct
class Cells3:
    # space's process (cubic cells, never periodic)
    size: float  # cube side, texels
    mean_count: float  # λ c³
    seed: wp.uint32
    exact_poisson: int


@wp.func
def avalanche(x: wp.uint32):
    # "lowbias32" integer finaliser: every input bit flips each output bit with p ≈ 1/2
    x = x ^ (x >> wp.uint32(16))
    x = x * AVALANCHE_M1
    x = x ^ (x >> wp.uint32(15))
    x = x * AVALANCHE_M2
    x = x ^ (x >> wp.uint32(16))
    return x


@wp.func
def wrap(i: int, n: int):
    # index i modulo n (n > 0) with a non-negative result; n == 0 leaves i alone
    if n <= 0:
        return i
    r = i % n
    if r < 0:
        r = r + n
    return r


@wp.func
def cell_state(cells: Cells, cx: int, cy: int):
    # the PCG state of plane cell (cx, cy); a period wraps the seed indices only
    sx = wrap(cx, cells.period[0])
    sy = wrap(cy, cells.period[1])
    h = avalanche(cells.seed + GOLDEN)
    h = avalanche(h ^ wp.uint32(sx))
    h = avalanche(h ^ wp.uint32(sy))
    return h


@wp.func
def cell_state3(cells: Cells3, cx: int, cy: int, cz: int):
    h = avalanche((cells.seed ^ _SPACE_TAG) + GOLDEN)
    h = avalanche(h ^ wp.uint32(cx))
    h = avalanche(h ^ wp.uint32(cy))
    h = avalanche(h ^ wp.uint32(cz))
    return h


@wp.func
def draw_count(state: wp.uint32, mean_count: float, exact_poisson: int):
    # the cell's impact count, drawn first from its stream: (count, advanced state)
    s = state
    n = int(0)
    if exact_poisson != 0:
        n = int(wp.poisson(s, mean_count))
    else:
        g = wp.randn(s)
        n = int(wp.floor(mean_count + 0.5 + wp.sqrt(mean_count) * g))
        if n < 0:
            n = 0
    return n, s


@wp.func
def uniform(state: wp.uint32):
    # one uniform in [0, 1) of the stream (Warp's PCG, wp.randf): (u, advanced state). Every uniform of the
    # impact stream and of the tiling's vertex draw (kernels/tiling_draw.py) is drawn here.
    s = state
    u = wp.randf(s)
    return u, s


@wp.func
def next_impact(state: wp.uint32):
    # the next impact's position in its plane cell, in cell units [0, 1)²: (u, advanced state), x first
    ux, s = uniform(state)
    uy, s = uniform(s)
    return wp.vec2(ux, uy), s


@wp.func
def next_impact3(state: wp.uint32):
    # the next impact's position in its cube, in cell units [0, 1)³: (u, advanced state), x, y, then z
    u, s = next_impact(state)
    uz, s = uniform(s)
    return wp.vec3(u[0], u[1], uz), s


@wp.func
def cell_span(x: wp.vec2d, lo: wp.vec2, hi: wp.vec2, size: wp.vec2):
    # the cells (cx_lo, cx_hi, cy_lo, cy_hi) that hold the impacts q with x − q in
    # [lo, hi], found in float64 so that points far from the origin land right
    cw = wp.float64(size[0])
    ch = wp.float64(size[1])
    return (int(wp.floor((x[0] - wp.float64(hi[0])) / cw)), int(wp.floor((x[0] - wp.float64(lo[0])) / cw)),
            int(wp.floor((x[1] - wp.float64(hi[1])) / ch)), int(wp.floor((x[1] - wp.float64(lo[1])) / ch)))


def cell_walk(contribution, name: str, zero=wp.vec3):
    """A ``@wp.func walk(x: vec2d, lo: vec2, hi: vec2, cells: Cells, ctx) -> vec3``
    summing ``contribution(ctx, d, acc)`` over the impacts q with d = x − q in
    [lo, hi], from ``zero(0.0)`` (``wp.float32`` for a one-channel sum).

    Cell indices come from float64 positions, so that points far from the
    origin land in the right cell; offsets inside a cell are small and float32.
    The walk is registered under ``name`` in the contribution's module.
    """

    def walk(x: wp.vec2d, lo: wp.vec2, hi: wp.vec2, cells: Cells, ctx: Any):
        cw = wp.float64(cells.size[0])
        ch = wp.float64(cells.size[1])
        cx_lo, cx_hi, cy_lo, cy_hi = cell_span(x, lo, hi, cells.size)
        acc = zero(0.0)
        for cy in range(cy_lo, cy_hi + 1):
            for cx in range(cx_lo, cx_hi + 1):
                # x relative to this cell's corner
                rel = wp.vec2(float(x[0] - wp.float64(cx) * cw), float(x[1] - wp.float64(cy) * ch))
                n, s = draw_count(cell_state(cells, cx, cy), cells.mean_count, cells.exact_poisson)
                for k in range(n):
                    u, s = next_impact(s)
                    d = rel - wp.vec2(u[0] * cells.size[0], u[1] * cells.size[1])
                    if d[0] >= lo[0] and d[0] <= hi[0] and d[1] >= lo[1] and d[1] <= hi[1]:
                        acc = contribution(ctx, d, acc)
        return acc

    return wp.func(walk, name=name, module=contribution.module)


@wp.func
def cube_span(y: wp.vec3d, ext: wp.vec3, size: float):
    # the cubes (x0, x1, y0, y1, z0, z1) that meet the box y ± ext, found in float64
    # so that points far from the origin land in the right cube
    c = wp.float64(size)
    return (int(wp.floor((y[0] - wp.float64(ext[0])) / c)), int(wp.floor((y[0] + wp.float64(ext[0])) / c)),
            int(wp.floor((y[1] - wp.float64(ext[1])) / c)), int(wp.floor((y[1] + wp.float64(ext[1])) / c)),
            int(wp.floor((y[2] - wp.float64(ext[2])) / c)), int(wp.floor((y[2] + wp.float64(ext[2])) / c)))


@wp.func
def cube_offset(y: wp.vec3d, cx: int, cy: int, cz: int, size: float):
    # y relative to the corner of cube (cx, cy, cz): float64 before rounding, so the
    # offset is as exact far from the origin as near it
    c = wp.float64(size)
    return wp.vec3(float(y[0] - wp.float64(cx) * c), float(y[1] - wp.float64(cy) * c),
                   float(y[2] - wp.float64(cz) * c))


@wp.func
def impact_offset3(rel: wp.vec3, u: wp.vec3, size: float):
    # point minus impact, from the point's offset to the cube corner and the impact's
    # position u in cell units: the one expression every 3-D path uses
    return rel - u * size


def cell_walk3(contribution, name: str, zero=wp.vec3):
    """A ``@wp.func walk(y: vec3d, ext: vec3, cells: Cells3, ctx) -> vec3`` summing
    ``contribution(ctx, d, acc)`` over the impacts q of the cubes that meet the
    box y ± ext, with d = y − q (the contribution tests its own support), from
    ``zero(0.0)`` (``wp.float32`` for a one-channel sum).

    Cubes are visited in z, y, x order and the impacts of a cube in the order
    they are drawn; a path that shares impacts between points (``kernels/surface_points.py``,
    the block gather) keeps this order, so the two sum the same terms in the same order.
    """

    def walk(y: wp.vec3d, ext: wp.vec3, cells: Cells3, ctx: Any):
        c = cells.size
        x0, x1, y0, y1, z0, z1 = cube_span(y, ext, c)
        acc = zero(0.0)
        for cz in range(z0, z1 + 1):
            for cy in range(y0, y1 + 1):
                for cx in range(x0, x1 + 1):
                    count, s = draw_count(cell_state3(cells, cx, cy, cz), cells.mean_count, cells.exact_poisson)
                    rel = cube_offset(y, cx, cy, cz, c)
                    for k in range(count):
                        u, s = next_impact3(s)
                        acc = contribution(ctx, impact_offset3(rel, u, c), acc)
        return acc

    return wp.func(walk, name=name, module=contribution.module)
