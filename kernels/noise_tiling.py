"""Tiling and blending by example: the evaluation of a :class:`warp_texton.model.tiling.TilingModel`.

The plane is cut into equilateral triangles of side ``side`` (noise units). Each
vertex (a, b) of the triangle lattice, at p(a, b) = side · (a + b/2, b √3/2),
shows the example translated so that a random texel centre c(a, b) of the
example (a hash of the vertex and the seed, kept at least ``margin`` from the
example's border) lies on the vertex, rounded to whole texels. A point x sees
the three vertices of its triangle; their patches are blended with weights
w_k ∝ β_k^sharpness · exp(guide_weight · (g_k − max g)), β_k the barycentric
coordinates and g_k the guide (the example's standardised luminance) read
from each patch at x. docs/tiling.md is the exact specification; GLSL, OSL and
users' Warp kernels reproduce it from ``tiling_value``. The vertex draw (the hash,
the centre texel, the rounded position, the periodic lattice's vertex, the example's
addressing) and its constants are ``kernels/tiling_draw.py``'s, which every other
evaluator's code is generated from; ``vertex_centre``, ``vertex_position`` and
``lattice_vertex`` here apply it to the ``Tiling`` and ``Lattice`` structs.

``tiling_value`` is the reference, called by the points kernel ``tiling_points`` and by
``tiling_raster``. The raster kernel ``tiling_runs`` computes the same values bit for bit
faster: a thread takes a run of pixels along a row, keeps the centres of the last
vertices it met (pixels of one triangle share them, so a vertex is hashed once per
run instead of once per pixel), skips weights that the cutoff would drop before
raising them to the sharpness (they would underflow to slow subnormals), and reads
and writes one float a texel for a grey example.

Driven by: ``warp_texton.noise.tiling``.
"""

import warp as wp

from typing import Any

from . import tiling_draw
from .noise_tiling_native import tiling_run_native
from .tiling_draw import CUTOFF, SQRT3_2, texel_address

wp.set_module_options({"enable_backward": False, "optimization_level": 3})


@wp.struct
class Tiling:
    example: wp.array2d(dtype=wp.vec3)  # (rows, columns) texels; grey examples in channel 0
    guide: wp.array2d(dtype=float)  # the standardised luminance, same shape
    side: float  # the triangles' side, noise units
    margin: int  # c(a, b) ∈ [margin, size − 1 − margin] per axis, texel indices
    squarings: int  # the weights' exponent is 2^squarings (sharpness 1, 2, 4, ... 64)
    guide_weight: float  # β of the guide term; 0 = barycentric only
    variance_preserving: int  # 1: (Σ k (v − mean)) / √(Σ k²) + mean; 0: Σ k v
    mean: wp.vec3  # the example's mean colour (float32)
    seed: wp.uint32
    lo: wp.vec2i  # the centres' first texel (column, row): TilingModel.centre_box
    count: wp.vec2i  # and how many texels from it centres range over, per axis
    wrap: wp.vec2i  # 1 on an axis the example is read wrapped on (x, y), else 0 (clamped)
    rank: int  # the lattice's: 0 (none), 1 (courses) or 2
    modulus: int  # its N (1 without a lattice)
    k1: wp.vec2i  # its dual vectors in (x, y) order
    k2: wp.vec2i
    mean_image: wp.array2d(dtype=wp.vec3)  # the lattice-periodic mean (rank ≠ 0), same shape; (1, 1) otherwise


@wp.func
def vertex_centre(t: Tiling, a: int, b: int):
    # the example texel (column, row) that vertex (a, b) draws (kernels/tiling_draw.py): centres range over
    # the texels of the model's centre box (at least `margin` from a clamped border; anywhere on a wrapped axis)
    return tiling_draw.vertex_centre(tiling_draw.seed_state(t.seed), a, b, t.lo, t.count)


@wp.func
def snapped(t: Tiling, c: wp.vec2i, p: wp.vec2d):
    # the centre c of a vertex at the rounded position p, snapped to the model's lattice (c without one)
    if t.rank == 0:
        return c
    return tiling_draw.lattice_snap(c, tiling_draw.position_mod(p[0], t.modulus),
                                    tiling_draw.position_mod(p[1], t.modulus), t.rank, t.modulus, t.k1, t.k2)


@wp.func
def vertex_position(t: Tiling, a: int, b: int):
    # p(a, b) rounded to whole texels (float64, so far points are exact)
    return tiling_draw.rounded_position(wp.float64(t.side), a, b)


@wp.func
def floor_int(x: float):
    # ⌊x⌋ as an int for |x| < 2³¹ without a call to floorf (CPU builds target baseline x86-64, where floorf
    # is a library call): truncate, then step down below negative non-integers. float(⌊x⌋) is wp.floor(x).
    i = int(x)
    if float(i) > x:
        i = i - 1
    return i


@wp.func
def bilinear(img: wp.array2d(dtype=Any), q: wp.vec2, wrap: wp.vec2i):
    # the example (or the guide, the mean image) at q = (x, y) in texel units (texel (i, j) centred at
    # (j + ½, i + ½)), clamped to its edge or wrapped per axis (wrap: x, y), for either texel type
    rows = img.shape[0]
    cols = img.shape[1]
    fx = q[0] - 0.5
    fy = q[1] - 0.5
    ix = floor_int(fx)
    iy = floor_int(fy)
    tx = fx - float(ix)
    ty = fy - float(iy)
    j0 = texel_address(ix, cols, wrap[0])
    i0 = texel_address(iy, rows, wrap[1])
    if tx == 0.0 and ty == 0.0:
        return img[i0, j0]
    j1 = texel_address(ix + 1, cols, wrap[0])
    i1 = texel_address(iy + 1, rows, wrap[1])
    top = img[i0, j0] * (1.0 - tx) + img[i0, j1] * tx
    bottom = img[i1, j0] * (1.0 - tx) + img[i1, j1] * tx
    return top * (1.0 - ty) + bottom * ty


#: 0.2's names of the example's (three channels) and the guide's (one) lookup.
bilinear3 = bilinear1 = bilinear


@wp.func
def patch_point(t: Tiling, x: wp.vec2d, a: int, b: int):
    # where vertex (a, b)'s patch reads the example for the point x: c + (x − round(p))
    p = vertex_position(t, a, b)
    c = snapped(t, vertex_centre(t, a, b), p)
    return wp.vec2(float(c[0]) + float(x[0] - p[0]), float(c[1]) + float(x[1] - p[1]))


@wp.func
def triangle_of(t: Tiling, x: wp.vec2d):
    # (a, b, upper) of the lower-left vertex cell and barycentric coordinates (float32) of x
    s = wp.float64(t.side)
    qx = x[0] / s
    qy = x[1] / s
    sy = qy / SQRT3_2  # skewed coordinates: the lattice's vertices on Z²
    sx = qx - sy * wp.float64(0.5)
    fa = wp.floor(sx)
    fb = wp.floor(sy)
    u = float(sx - fa)
    v = float(sy - fb)
    return int(fa), int(fb), u, v


@wp.func
def power(w: float, squarings: int):
    # w^(2^squarings) by repeated squaring: the same float32 products in every runtime
    r = w
    for i in range(squarings):
        r = r * r
    return r


@wp.func
def sharpened(w: float, squarings: int, guide_weight: float, dg: float):
    # the unnormalised weight w^(2^squarings) · exp(guide_weight · dg); 0 for w ≤ 0
    if w <= 0.0:
        return 0.0
    k = power(w, squarings)
    if guide_weight != 0.0:
        k = k * wp.exp(guide_weight * dg)
    return k


@wp.func
def guided_weights(t: Tiling, w0: float, w1: float, w2: float, g0: float, g1: float, g2: float):
    # the three unnormalised weights of a blend: barycentric w sharpened, times exp(guide_weight (g − max g))
    gm = wp.max(g0, wp.max(g1, g2))
    k0 = sharpened(w0, t.squarings, t.guide_weight, g0 - gm)
    k1 = sharpened(w1, t.squarings, t.guide_weight, g1 - gm)
    k2 = sharpened(w2, t.squarings, t.guide_weight, g2 - gm)
    return k0, k1, k2


@wp.func
def cut_weights(k0: float, k1: float, k2: float):
    # the cutoff: weights below CUTOFF × the largest become 0 (their patches are not read)
    km = wp.max(k0, wp.max(k1, k2)) * CUTOFF
    if k0 < km:
        k0 = 0.0
    if k1 < km:
        k1 = 0.0
    if k2 < km:
        k2 = 0.0
    return k0, k1, k2


@wp.func
def kept_normalised(k0: float, k1: float, k2: float):
    # the cutoff, then k / Σ k: every blend's weights
    k0, k1, k2 = cut_weights(k0, k1, k2)
    total = k0 + k1 + k2
    return k0 / total, k1 / total, k2 / total


@wp.func
def patch_term3(t: Tiling, q: wp.vec2, k: float, acc: wp.vec3, macc: wp.vec3):
    # one kept patch's part of the blend: (e − mean) k without a lattice; with one, the residual around the
    # lattice-periodic mean, (e − m) k, and the mean's part m k (the blend keeps Σ m k: docs/tiling.md, "Lattices")
    e = bilinear(t.example, q, t.wrap)
    if t.rank == 0:
        return acc + (e - t.mean) * k, macc
    m = bilinear(t.mean_image, q, t.wrap)
    return acc + (e - m) * k, macc + m * k


@wp.func
def triangle_weights(a: int, b: int, u: float, v: float):
    # (a0, b0, w0, w1, w2): the first vertex of the triangle of x (lower-left cell (a, b), barycentric (u, v)),
    # (a, b) in a lower triangle, (a + 1, b + 1) in an upper one (u + v > 1), and the weights of it, of
    # (a + 1, b) and of (a, b + 1): the fixed order of every evaluator's blend
    if u + v > 1.0:
        return a + 1, b + 1, u + v - 1.0, 1.0 - v, 1.0 - u
    return a, b, 1.0 - u - v, u, v


@wp.func
def tiling_value(t: Tiling, x: wp.vec2d):
    # the tiling's value at x (noise units): the patches of the three vertices of x's triangle, blended
    a, b, u, v = triangle_of(t, x)
    a0, b0, w0, w1, w2 = triangle_weights(a, b, u, v)
    q0 = wp.vec2(0.0)
    q1 = wp.vec2(0.0)
    q2 = wp.vec2(0.0)
    g0 = 0.0
    g1 = 0.0
    g2 = 0.0
    if t.guide_weight != 0.0:
        q0 = patch_point(t, x, a0, b0)
        q1 = patch_point(t, x, a + 1, b)
        q2 = patch_point(t, x, a, b + 1)
        g0 = bilinear(t.guide, q0, t.wrap)
        g1 = bilinear(t.guide, q1, t.wrap)
        g2 = bilinear(t.guide, q2, t.wrap)
    k0, k1, k2 = guided_weights(t, w0, w1, w2, g0, g1, g2)
    # weights below CUTOFF × the largest are dropped (their patches are not read)
    k0, k1, k2 = kept_normalised(k0, k1, k2)
    acc = wp.vec3(0.0)
    macc = wp.vec3(0.0)
    if k0 > 0.0:
        if t.guide_weight == 0.0:
            q0 = patch_point(t, x, a0, b0)
        acc, macc = patch_term3(t, q0, k0, acc, macc)
    if k1 > 0.0:
        if t.guide_weight == 0.0:
            q1 = patch_point(t, x, a + 1, b)
        acc, macc = patch_term3(t, q1, k1, acc, macc)
    if k2 > 0.0:
        if t.guide_weight == 0.0:
            q2 = patch_point(t, x, a, b + 1)
        acc, macc = patch_term3(t, q2, k2, acc, macc)
    if t.variance_preserving != 0:
        acc = acc / wp.sqrt(k0 * k0 + k1 * k1 + k2 * k2)
    if t.rank != 0:
        return macc + acc
    return t.mean + acc


@wp.kernel
def tiling_raster(t: Tiling, origin: wp.vec2d, step_x: wp.vec2d, step_y: wp.vec2d, first: wp.vec2i,
                  out: wp.array2d(dtype=wp.vec3)):
    # pixel (i, j) of a window whose pixel (0, 0) is (first[0], first[1]) of the global raster
    i, j = wp.tid()
    I = wp.float64(first[0] + i) + wp.float64(0.5)
    J = wp.float64(first[1] + j) + wp.float64(0.5)
    x = origin + step_x * J + step_y * I
    out[i, j] = tiling_value(t, x)


@wp.kernel
def tiling_points(t: Tiling, points: wp.array(dtype=wp.vec2d), out: wp.array(dtype=wp.vec3)):
    k = wp.tid()
    out[k] = tiling_value(t, points[k])


# ------------------------------------------------------------------ the fast raster: runs of pixels
#: Slots of a run's vertex cache: a triangle's three vertices and one of its neighbour's.
SLOTS = 4
#: The lattice index of an empty slot.
NO_VERTEX = wp.constant(-2147483647)


@wp.struct
class Lattice:
    # the triangle lattice of a periodic tiling (periodic = 1): `cols` vertices across the period px and
    # `rows` (even) rows of height dy = py / rows; dx = px / cols. periodic = 0: the plain lattice of side t.side.
    periodic: int
    cols: int
    rows: int
    dx: wp.float64
    dy: wp.float64
    px: wp.float64
    py: wp.float64


@wp.struct
class VertexCache:
    # the last SLOTS vertices a run met: lattice indices, centre texels and (rounded) positions
    a: wp.vec4i
    b: wp.vec4i
    cx: wp.vec4i
    cy: wp.vec4i
    px: wp.vec4d
    py: wp.vec4d
    next: int  # the slot replaced next (round robin)


@wp.func
def empty_cache():
    c = VertexCache()
    c.a = wp.vec4i(NO_VERTEX)  # no vertex has this index (positions stay within ±2³⁰ texels)
    c.b = wp.vec4i(NO_VERTEX)
    c.cx = wp.vec4i(0)
    c.cy = wp.vec4i(0)
    c.px = wp.vec4d(wp.float64(0.0))
    c.py = wp.vec4d(wp.float64(0.0))
    c.next = 0
    return c


@wp.func
def lattice_triangle(t: Tiling, lat: Lattice, x: wp.vec2d):
    # triangle_of on the plain lattice; on a periodic one the skewed coordinates of its (dx, dy) grid
    if lat.periodic == 0:
        return triangle_of(t, x)
    sy = x[1] / lat.dy
    sx = x[0] / lat.dx - sy * wp.float64(0.5)
    fa = wp.floor(sx)
    fb = wp.floor(sy)
    return int(fa), int(fb), float(sx - fa), float(sy - fb)


@wp.func
def lattice_vertex(t: Tiling, lat: Lattice, a: int, b: int):
    # (centre texel, rounded position) of vertex (a, b). Periodic: the vertex is the period's own vertex
    # (a', b') — b' = b mod rows, a' = (a + (b − b') / 2) mod cols — hashed as such, placed at
    # round(p(a', b')) shifted by the whole periods that separate them, so every period shows the same patches
    if lat.periodic == 0:
        p = vertex_position(t, a, b)
        return snapped(t, vertex_centre(t, a, b), p), p
    v = tiling_draw.period_vertex(a, b, lat.cols, lat.rows)
    cen = vertex_centre(t, v[0], v[1])
    if t.rank != 0:  # snapped where the period's own vertex lies: every period shows the same patches
        own = tiling_draw.period_position(lat.dx, lat.dy, lat.px, lat.py, wp.vec4i(v[0], v[1], 0, 0))
        cen = snapped(t, cen, own)
    return cen, tiling_draw.period_position(lat.dx, lat.dy, lat.px, lat.py, v)


@wp.func
def lattice_point(t: Tiling, lat: Lattice, x: wp.vec2d, a: int, b: int):
    # where vertex (a, b)'s patch reads the example for x: patch_point through lattice_vertex
    c, p = lattice_vertex(t, lat, a, b)
    return wp.vec2(float(c[0]) + float(x[0] - p[0]), float(c[1]) + float(x[1] - p[1]))


@wp.func
def cached_slot(t: Tiling, lat: Lattice, c: VertexCache, a: int, b: int):
    # the slot of vertex (a, b) in the cache, hashing it into a slot when absent
    for k in range(SLOTS):
        if c.a[k] == a and c.b[k] == b:
            return c, k
    k = c.next
    cen, p = lattice_vertex(t, lat, a, b)
    c.a[k] = a
    c.b[k] = b
    c.cx[k] = cen[0]
    c.cy[k] = cen[1]
    c.px[k] = p[0]
    c.py[k] = p[1]
    c.next = k + 1
    if c.next == SLOTS:
        c.next = 0
    return c, k


@wp.func
def slot_point(c: VertexCache, k: int, x: wp.vec2d):
    # patch_point from a cached vertex: the same float64 difference, float32 rounding and sum
    return wp.vec2(float(c.cx[k]) + float(x[0] - c.px[k]), float(c.cy[k]) + float(x[1] - c.py[k]))


@wp.func
def floor_int64(x: wp.float64):
    # floor_int for float64
    i = int(x)
    if wp.float64(i) > x:
        i = i - 1
    return i


@wp.func
def patch_term(t: Tiling, example: wp.array2d(dtype=Any), mean_img: wp.array2d(dtype=Any), mean: Any, q: wp.vec2,
               k: float, acc: Any, macc: Any):
    # patch_term3 for either texel type (mean_img: the lattice-periodic mean in the example's texel type)
    e = bilinear(example, q, t.wrap)
    if t.rank == 0:
        return acc + (e - mean) * k, macc
    m = bilinear(mean_img, q, t.wrap)
    return acc + (e - m) * k, macc + m * k


@wp.func
def quick_weight(w: float, squarings: int, skip: float):
    # sharpened(w, squarings, 0, 0), or 0 where w < skip: there w^(2^squarings) is below the cutoff
    # (skip = 0.3 · CUTOFF^(1/2^squarings) < (max weight ≥ 1/3) · CUTOFF^(...)), so the blend drops it anyway.
    # power's squarings written out (squarings ≤ 6): the same products without a loop
    if w <= 0.0 or w < skip:
        return 0.0
    r = w
    if squarings > 0:
        r = r * r
    if squarings > 1:
        r = r * r
    if squarings > 2:
        r = r * r
    if squarings > 3:
        r = r * r
    if squarings > 4:
        r = r * r
    if squarings > 5:
        r = r * r
    return r


@wp.func
def guide_weights(t: Tiling, lat: Lattice, c: VertexCache, x: wp.vec2d, a0: int, b0: int, a: int, b: int,
                  w0: float, w1: float, w2: float):
    # the guided weights of blend_at (each slot read as soon as it is found: the next lookup may replace it)
    c, s0 = cached_slot(t, lat, c, a0, b0)
    g0 = bilinear(t.guide, slot_point(c, s0, x), t.wrap)
    c, s1 = cached_slot(t, lat, c, a + 1, b)
    g1 = bilinear(t.guide, slot_point(c, s1, x), t.wrap)
    c, s2 = cached_slot(t, lat, c, a, b + 1)
    g2 = bilinear(t.guide, slot_point(c, s2, x), t.wrap)
    k0, k1, k2 = guided_weights(t, w0, w1, w2, g0, g1, g2)
    return c, k0, k1, k2


@wp.func
def cached_weights(t: Tiling, lat: Lattice, c: VertexCache, x: wp.vec2d, a0: int, b0: int, a: int, b: int,
                   w0: float, w1: float, w2: float, skip: float):
    # (cache, k0, k1, k2): the unnormalised weights of the run kernels' blend, guided (guide_weights) or not
    # (quick_weight, which skips the powers of weights that the cutoff drops)
    if t.guide_weight != 0.0:
        return guide_weights(t, lat, c, x, a0, b0, a, b, w0, w1, w2)
    return c, quick_weight(w0, t.squarings, skip), quick_weight(w1, t.squarings, skip), quick_weight(w2, t.squarings, skip)


@wp.func
def blend_at(t: Tiling, lat: Lattice, example: wp.array2d(dtype=Any), mean_img: wp.array2d(dtype=Any), mean: Any,
             skip: float, c: VertexCache, x: wp.vec2d):
    # tiling_value(t, x) bit for bit on the plain lattice (any texel type), its vertices through the cache c
    a, b, u, v = lattice_triangle(t, lat, x)
    a0, b0, w0, w1, w2 = triangle_weights(a, b, u, v)
    s0 = int(0)
    s1 = int(0)
    s2 = int(0)
    c, k0, k1, k2 = cached_weights(t, lat, c, x, a0, b0, a, b, w0, w1, w2, skip)
    k0, k1, k2 = kept_normalised(k0, k1, k2)
    acc = mean - mean
    macc = mean - mean
    if k0 > 0.0:
        c, s0 = cached_slot(t, lat, c, a0, b0)
        acc, macc = patch_term(t, example, mean_img, mean, slot_point(c, s0, x), k0, acc, macc)
    if k1 > 0.0:
        c, s1 = cached_slot(t, lat, c, a + 1, b)
        acc, macc = patch_term(t, example, mean_img, mean, slot_point(c, s1, x), k1, acc, macc)
    if k2 > 0.0:
        c, s2 = cached_slot(t, lat, c, a, b + 1)
        acc, macc = patch_term(t, example, mean_img, mean, slot_point(c, s2, x), k2, acc, macc)
    if t.variance_preserving != 0:
        acc = acc / wp.sqrt(k0 * k0 + k1 * k1 + k2 * k2)
    if t.rank != 0:
        return c, macc + acc
    return c, mean + acc


@wp.func
def kept_weights(k0: float, k1: float, k2: float):
    # the cutoff and the normalisation of tiling_value; with one vertex kept (most pixels at high
    # sharpness) its weight k/k is 1 and √(1²) = 1: returned without the divisions, with one = True
    k0, k1, k2 = cut_weights(k0, k1, k2)
    n = int(k0 > 0.0) + int(k1 > 0.0) + int(k2 > 0.0)
    if n == 1:
        return wp.float32(k0 > 0.0), wp.float32(k1 > 0.0), wp.float32(k2 > 0.0), True
    total = k0 + k1 + k2
    return k0 / total, k1 / total, k2 / total, False


@wp.kernel
def lattice_points(t: Tiling, lat: Lattice, example: wp.array2d(dtype=Any), mean_img: wp.array2d(dtype=Any),
                   mean: Any, skip: float, points: wp.array(dtype=wp.vec2d), out: wp.array(dtype=Any)):
    # blend_at at each point (the periodic tiling's points; tiling_points is the plain one)
    k = wp.tid()
    c, value = blend_at(t, lat, example, mean_img, mean, skip, empty_cache(), points[k])
    out[k] = value


for _T in (wp.vec3, float):
    wp.overload(lattice_points, {"example": wp.array2d(dtype=_T), "mean_img": wp.array2d(dtype=_T), "mean": _T,
                                 "out": wp.array(dtype=_T)})


@wp.kernel
def tiling_runs(t: Tiling, lat: Lattice, example: wp.array2d(dtype=Any),  # noqa: C901
                mean_img: wp.array2d(dtype=Any), mean: Any, skip: float, origin: wp.vec2d, step_x: wp.vec2d, step_y: wp.vec2d, first: wp.vec2i, run: int,
                out: wp.array2d(dtype=Any)):
    # pixels (i, j0 … j0 + run − 1) of the window: blend_at's steps written out in the loop, tiling_value bit
    # for bit on the plain lattice. The run's vertex cache lives in local vectors (ca, cb: lattice indices;
    # ccx, ccy: centre texels; cpx, cpy: rounded positions; round robin) so that the compiler keeps it in
    # registers; each vertex role first tries the slot where it was found for the last pixel (h0, h1, h2).
    # The skewed row coordinate depends on x's y only: computed again only when y changes (never, without
    # rotation).
    i, r = wp.tid()
    cols = out.shape[1]
    j0 = r * run
    j1 = wp.min(j0 + run, cols)
    I = wp.float64(first[0] + i) + wp.float64(0.5)
    ca = wp.vec4i(NO_VERTEX)
    cb = wp.vec4i(NO_VERTEX)
    ccx = wp.vec4i(0)
    ccy = wp.vec4i(0)
    cpx = wp.vec4d(wp.float64(0.0))
    cpy = wp.vec4d(wp.float64(0.0))
    nxt = int(0)
    c = empty_cache()  # the guide's lookups (guide_weight ≠ 0) use the struct cache
    s = wp.float64(t.side)
    if lat.periodic != 0:
        s = lat.dx
    last_y = wp.float64(0.0)
    h0 = int(0)
    h1 = int(0)
    h2 = int(0)
    sy = wp.float64(0.0)
    fb = wp.float64(0.0)
    b = int(0)
    for j in range(j0, j1):
        J = wp.float64(first[1] + j) + wp.float64(0.5)
        x = origin + step_x * J + step_y * I
        if j == j0 or x[1] != last_y:
            last_y = x[1]
            if lat.periodic == 0:
                sy = (x[1] / s) / SQRT3_2
            else:
                sy = x[1] / lat.dy
            b = floor_int64(sy)
            fb = wp.float64(b)
        sx = x[0] / s - sy * wp.float64(0.5)
        a = floor_int64(sx)
        u = float(sx - wp.float64(a))
        v = float(sy - fb)
        a0, b0, w0, w1, w2 = triangle_weights(a, b, u, v)
        c, k0, k1, k2 = cached_weights(t, lat, c, x, a0, b0, a, b, w0, w1, w2, skip)
        k0, k1, k2, one = kept_weights(k0, k1, k2)
        acc = mean - mean
        macc = mean - mean
        if k0 > 0.0:
            if ca[h0] != a0 or cb[h0] != b0:
                h0 = -1
                for k in range(SLOTS):
                    if ca[k] == a0 and cb[k] == b0:
                        h0 = k
                if h0 < 0:
                    h0 = nxt
                    nxt = (nxt + 1) & 3
                    cen, p = lattice_vertex(t, lat, a0, b0)
                    ca[h0] = a0
                    cb[h0] = b0
                    ccx[h0] = cen[0]
                    ccy[h0] = cen[1]
                    cpx[h0] = p[0]
                    cpy[h0] = p[1]
            q = wp.vec2(float(ccx[h0]) + float(x[0] - cpx[h0]), float(ccy[h0]) + float(x[1] - cpy[h0]))
            acc, macc = patch_term(t, example, mean_img, mean, q, k0, acc, macc)
        if k1 > 0.0:
            if ca[h1] != a + 1 or cb[h1] != b:
                h1 = -1
                for k in range(SLOTS):
                    if ca[k] == a + 1 and cb[k] == b:
                        h1 = k
                if h1 < 0:
                    h1 = nxt
                    nxt = (nxt + 1) & 3
                    cen, p = lattice_vertex(t, lat, a + 1, b)
                    ca[h1] = a + 1
                    cb[h1] = b
                    ccx[h1] = cen[0]
                    ccy[h1] = cen[1]
                    cpx[h1] = p[0]
                    cpy[h1] = p[1]
            q = wp.vec2(float(ccx[h1]) + float(x[0] - cpx[h1]), float(ccy[h1]) + float(x[1] - cpy[h1]))
            acc, macc = patch_term(t, example, mean_img, mean, q, k1, acc, macc)
        if k2 > 0.0:
            if ca[h2] != a or cb[h2] != b + 1:
                h2 = -1
                for k in range(SLOTS):
                    if ca[k] == a and cb[k] == b + 1:
                        h2 = k
                if h2 < 0:
                    h2 = nxt
                    nxt = (nxt + 1) & 3
                    cen, p = lattice_vertex(t, lat, a, b + 1)
                    ca[h2] = a
                    cb[h2] = b + 1
                    ccx[h2] = cen[0]
                    ccy[h2] = cen[1]
                    cpx[h2] = p[0]
                    cpy[h2] = p[1]
            q = wp.vec2(float(ccx[h2]) + float(x[0] - cpx[h2]), float(ccy[h2]) + float(x[1] - cpy[h2]))
            acc, macc = patch_term(t, example, mean_img, mean, q, k2, acc, macc)
        if t.variance_preserving != 0 and not one:
            acc = acc / wp.sqrt(k0 * k0 + k1 * k1 + k2 * k2)
        if t.rank != 0:
            out[i, j] = macc + acc
        else:
            out[i, j] = mean + acc


for _T in (wp.vec3, float):
    wp.overload(tiling_runs, {"example": wp.array2d(dtype=_T), "mean_img": wp.array2d(dtype=_T), "mean": _T,
                              "out": wp.array2d(dtype=_T)})


# ------------------------------------------------------------------ the run loop in native C++ (CPU)
@wp.func
def tiling_run(t: Tiling, lat: Lattice, example: wp.array2d(dtype=Any), mean_img: wp.array2d(dtype=Any), mean: Any,
               skip: float, origin: wp.vec2d, step_x: wp.vec2d, step_y: wp.vec2d, first: wp.vec2i, i: int, j0: int,
               j1: int, simd: int, out: wp.array2d(dtype=Any)):
    # the native run loop of the texel type (noise_tiling_native.tiling_run_native's overloads), the structs unpacked
    tiling_run_native(example, mean, mean_img, out, i, j0, j1, first[0], first[1], origin, step_x, step_y, t.side,
                      t.lo, t.count, t.wrap, t.rank, t.modulus, t.k1, t.k2, t.squarings, skip, t.variance_preserving,
                      t.seed, lat.periodic, lat.cols, lat.rows, lat.dx, lat.dy, lat.px, lat.py, simd)


@wp.kernel
def tiling_runs_native(t: Tiling, lat: Lattice, example: wp.array2d(dtype=Any), mean_img: wp.array2d(dtype=Any),
                       mean: Any, skip: float, origin: wp.vec2d, step_x: wp.vec2d, step_y: wp.vec2d, first: wp.vec2i,
                       run: int, simd: int, out: wp.array2d(dtype=Any)):
    # tiling_runs' pixels (i, j0 … j0 + run − 1) through the native run loop (kernels/noise_tiling_native.py:
    # 16 pixels at a time where simd ≠ 0 and the CPU has vector registers); guide_weight = 0 only
    i, r = wp.tid()
    j0 = r * run
    tiling_run(t, lat, example, mean_img, mean, skip, origin, step_x, step_y, first, i, j0,
               wp.min(j0 + run, out.shape[1]), simd, out)


for _T in (wp.vec3, float):
    wp.overload(tiling_runs_native, {"example": wp.array2d(dtype=_T), "mean_img": wp.array2d(dtype=_T), "mean": _T,
                                     "out": wp.array2d(dtype=_T)})
