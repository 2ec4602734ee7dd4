"""Texton noise in the plane: the evaluation kernels of the hashed-cell process.

Impacts come from the cells of kernels/impacts.py (one stream, one order, for
every path). Rasters draw a block of cells' impacts once (``count_impacts``,
a prefix sum, ``emit_impacts``) and then splat each impact's texton (CPU) or
gather the impacts near each pixel (CUDA); points walk their neighbouring cells.

Texton convention: an impact at p adds h(x − p) with h(y) = Σ_k α(k) ψ(y − k),
coefficient (row i, column j) at y = (j, i). Coefficients are stored with a
zero margin of PAD texels so that every tap of every order reads in bounds.
"""

import warp as wp

from .impacts import GOLDEN, Cells, avalanche, cell_state, cell_walk, draw_count, next_impact

# Forward evaluation only: no adjoints, which halves compile time.
wp.set_module_options({"enable_backward": False, "optimization_level": 3})

#: Zero margin around stored coefficients: the widest order (5) reaches 5 past an edge.
PAD = 5


@wp.struct
class NoiseParams:
    cells: Cells  # the Poisson process of impacts
    order: int  # 0, 1, 3 or 5
    lo: wp.vec2  # support of h relative to the impact: [lo, hi] per axis
    hi: wp.vec2
    lam: float  # λ, impacts per texel²
    mean: wp.vec3  # m
    integral: wp.vec3  # ∫h = Σα


@wp.func
def bspline_weight(t: float, order: int):
    # centred B-spline ψ of the given order at t
    a = wp.abs(t)
    if order == 0:
        if t >= -0.5 and t < 0.5:
            return 1.0
        return 0.0
    if order == 1:
        return wp.max(1.0 - a, 0.0)
    if order == 3:
        if a < 1.0:
            return (4.0 - 6.0 * a * a + 3.0 * a * a * a) / 6.0
        if a < 2.0:
            b = 2.0 - a
            return b * b * b / 6.0
        return 0.0
    # order 5: sum of truncated powers, (1/120) Σ_j (-1)^j C(6, j) (a + 3 - j)_+^5
    s = 0.0
    c = wp.vec4(1.0, -6.0, 15.0, -20.0)
    for j in range(4):
        u = 3.0 - a - float(j)
        if u > 0.0:
            s = s + c[j] * u * u * u * u * u
    return s / 120.0


@wp.func
def texton_value(coeffs: wp.array2d(dtype=wp.vec3), row0: int, rows: int, y: wp.vec2, order: int):
    # h(y) for y inside the support, for the texton stored in rows [row0, row0 + rows)
    # of a stack; taps outside the coefficients read the zero margin
    cols = coeffs.shape[1]
    acc = wp.vec3(0.0)
    if order == 1:
        fx = wp.floor(y[0])
        fy = wp.floor(y[1])
        tx = y[0] - fx
        ty = y[1] - fy
        j = wp.clamp(int(fx) + PAD, 0, cols - 2)
        i = row0 + wp.clamp(int(fy) + PAD, 0, rows - 2)
        top = coeffs[i, j] * (1.0 - tx) + coeffs[i, j + 1] * tx
        bottom = coeffs[i + 1, j] * (1.0 - tx) + coeffs[i + 1, j + 1] * tx
        return top * (1.0 - ty) + bottom * ty
    if order == 0:
        j = wp.clamp(int(wp.floor(y[0] + 0.5)) + PAD, 0, cols - 1)
        i = row0 + wp.clamp(int(wp.floor(y[1] + 0.5)) + PAD, 0, rows - 1)
        return coeffs[i, j]
    # orders 3 and 5: (order + 1) taps per axis around y
    half = (order + 1) // 2
    j0 = int(wp.floor(y[0])) - half + 1
    i0 = int(wp.floor(y[1])) - half + 1
    for a in range(order + 1):
        i = i0 + a
        wy = bspline_weight(y[1] - float(i), order)
        ii = row0 + wp.clamp(i + PAD, 0, rows - 1)
        row = wp.vec3(0.0)
        for b in range(order + 1):
            j = j0 + b
            wx = bspline_weight(y[0] - float(j), order)
            row = row + coeffs[ii, wp.clamp(j + PAD, 0, cols - 1)] * wx
        acc = acc + row * wy
    return acc


@wp.func
def inside(d: wp.vec2, p: NoiseParams):
    return d[0] >= p.lo[0] and d[0] <= p.hi[0] and d[1] >= p.lo[1] and d[1] <= p.hi[1]


@wp.func
def normalize(acc: wp.vec3, p: NoiseParams):
    return p.mean + (acc - p.integral * p.lam) / wp.sqrt(p.lam)


# ----------------------------------------------------------------- impacts
@wp.kernel
def count_impacts(p: NoiseParams, cell0: wp.vec2i, ncx: int, counts: wp.array(dtype=wp.int32)):
    """Impact count of every cell of a rectangular block of cells."""
    t = wp.tid()
    cx = cell0[0] + t % ncx
    cy = cell0[1] + t / ncx
    n, s = draw_count(cell_state(p.cells, cx, cy), p.cells.mean_count, p.cells.exact_poisson)
    counts[t] = n


@wp.kernel
def emit_impacts(
    p: NoiseParams,
    cell0: wp.vec2i,
    ncx: int,
    offsets: wp.array(dtype=wp.int32),
    impacts: wp.array(dtype=wp.vec2),
):
    """Positions of every cell's impacts, relative to the block corner (cell0's corner)."""
    t = wp.tid()
    lx = t % ncx
    ly = t / ncx
    n, s = draw_count(cell_state(p.cells, cell0[0] + lx, cell0[1] + ly), p.cells.mean_count, p.cells.exact_poisson)
    start = offsets[t]
    stop = wp.min(start + n, offsets[t + 1])
    size = p.cells.size
    for k in range(start, stop):
        u, s = next_impact(s)
        impacts[k] = wp.vec2((float(lx) + u[0]) * size[0], (float(ly) + u[1]) * size[1])


@wp.kernel
def emit_signs(p: NoiseParams, cell0: wp.vec2i, ncx: int, offsets: wp.array(dtype=wp.int32),
               signs: wp.array(dtype=float)):
    """Random signs ε = ±1 of every impact (mixed noise, CGF §7).

    Hashed from the cell's seed and the impact's rank in its cell, apart from
    the position stream, so plain and mixed noise place the same impacts.
    """
    t = wp.tid()
    h = cell_state(p.cells, cell0[0] + t % ncx, cell0[1] + t / ncx)
    for k in range(offsets[t], offsets[t + 1]):
        bit = avalanche(h ^ (wp.uint32(k - offsets[t] + 1) * GOLDEN)) >> wp.uint32(31)
        signs[k] = 1.0 - 2.0 * float(bit)


# ------------------------------------------------------------------ rasters
@wp.struct
class Raster:
    # pixel (i, j) sits at noise position base + (j + 0.5) * step_x + (i + 0.5) * step_y
    base: wp.vec2  # relative to the impact origin
    step_x: wp.vec2
    step_y: wp.vec2
    width: int
    height: int


@wp.func
def pixel_position(r: Raster, i: int, j: int):
    return r.base + r.step_x * (float(j) + 0.5) + r.step_y * (float(i) + 0.5)


@wp.struct
class Marks:
    # Mixed noise: impact k adds signs[k] · h_{labels[k]}; textons are stacked
    # in the coefficient array, `rows` rows each. Plain noise: marked = 0.
    marked: int
    rows: int
    labels: wp.array(dtype=wp.int32)
    signs: wp.array(dtype=float)


@wp.func
def mark_of(m: Marks, k: int):
    # (first coefficient row of the impact's texton, its sign)
    if m.marked == 0:
        return 0, 1.0
    return m.labels[k] * m.rows, m.signs[k]


@wp.kernel
def label_impacts(
    impacts: wp.array(dtype=wp.vec2),
    r: Raster,
    inv: wp.mat22,
    centre: wp.vec2,
    strips: int,
    regions: int,
    rho: wp.array2d(dtype=float),
    labels: wp.array(dtype=wp.int32),
):
    """The texton of each impact: the region of the raster that the centre of its
    texton falls in (CGF §7: 1{x_j ∈ D_r} for a kernel centred on x_j). Textons
    are stored from coefficient (0, 0) at the impact, so the centre of the
    support box, ``centre`` texels from the impact, stands for x_j: a texture
    then covers its region of the map, half a texton past it on every side.

    ``strips`` = 1: ``regions`` vertical strips across the raster's width;
    otherwise the nearest pixel of the ρ map (clamped at the border) picks
    texton round(ρ (regions − 1)).
    """
    k = wp.tid()
    pix = inv * (impacts[k] + centre - r.base)  # (column, row) + ½
    if strips != 0:
        lab = int(wp.floor(pix[0] / float(r.width) * float(regions)))
    else:
        j = wp.clamp(int(wp.floor(pix[0])), 0, rho.shape[1] - 1)
        i = wp.clamp(int(wp.floor(pix[1])), 0, rho.shape[0] - 1)
        lab = int(wp.floor(rho[i, j] * float(regions - 1) + 0.5))
    labels[k] = wp.clamp(lab, 0, regions - 1)


@wp.kernel
def splat_impacts(
    p: NoiseParams,
    r: Raster,
    inv: wp.mat22,
    coeffs: wp.array2d(dtype=wp.vec3),
    impacts: wp.array(dtype=wp.vec2),
    marks: Marks,
    row0: int,
    row1: int,
    acc: wp.array2d(dtype=wp.vec3),
):
    """Add each impact's texton to the rows [row0, row1) of ``acc`` (no atomics).

    ``acc`` holds raw sums; ``normalize_raster`` turns them into noise values.

    For the CPU: one launch runs its threads one after another on one core,
    and concurrent launches own disjoint row bands, so plain writes are safe.
    ``inv`` maps a noise-space offset to (column, row) pixel offsets.
    """
    k = wp.tid()
    q = impacts[k]
    t0, sign = mark_of(marks, k)
    # pixel-space bounding box of the support [lo, hi] placed at q
    c = q - r.base
    b00 = inv * (c + wp.vec2(p.lo[0], p.lo[1]))
    b01 = inv * (c + wp.vec2(p.hi[0], p.lo[1]))
    b10 = inv * (c + wp.vec2(p.lo[0], p.hi[1]))
    b11 = inv * (c + wp.vec2(p.hi[0], p.hi[1]))
    jmin = wp.min(wp.min(b00[0], b01[0]), wp.min(b10[0], b11[0]))
    jmax = wp.max(wp.max(b00[0], b01[0]), wp.max(b10[0], b11[0]))
    imin = wp.min(wp.min(b00[1], b01[1]), wp.min(b10[1], b11[1]))
    imax = wp.max(wp.max(b00[1], b01[1]), wp.max(b10[1], b11[1]))
    j_lo = wp.max(int(wp.ceil(jmin - 0.5)), 0)
    j_hi = wp.min(int(wp.floor(jmax - 0.5)), r.width - 1)
    i_lo = wp.max(int(wp.ceil(imin - 0.5)), row0)
    i_hi = wp.min(int(wp.floor(imax - 0.5)), row1 - 1)
    for i in range(i_lo, i_hi + 1):
        for j in range(j_lo, j_hi + 1):
            d = pixel_position(r, i, j) - q
            if inside(d, p):
                acc[i, j] = acc[i, j] + texton_value(coeffs, t0, marks.rows, d, p.order) * sign


# One footprint row of a grid splat, as a flat unit-stride loop over the 3·count
# floats of the row: with restrict pointers the compiler vectorises it, which
# Warp's strided array indexing does not allow. Rows of `acc` and `coeffs`
# must be contiguous (the host allocates them so).
_SPLAT_ROW = """
float* __restrict dst = (float*)((char*)acc.data + (size_t)i * acc.strides[0]) + 3 * j;
const float* __restrict top = (const float*)((const char*)coeffs.data + (size_t)a * coeffs.strides[0]) + 3 * b;
const float* __restrict bot = (const float*)((const char*)coeffs.data + (size_t)(a + 1) * coeffs.strides[0]) + 3 * b;
const int n = 3 * count;
for (int t = 0; t < n; ++t) {
    const float left = gy * top[t] + fy * bot[t];
    const float right = gy * top[t + 3] + fy * bot[t + 3];
    dst[t] += gx * left + fx * right;
}
"""


@wp.func_native(_SPLAT_ROW)
def splat_row(
    acc: wp.array2d(dtype=wp.vec3),
    i: int,
    j: int,
    coeffs: wp.array2d(dtype=wp.vec3),
    a: int,
    b: int,
    count: int,
    gy: float,
    fy: float,
    gx: float,
    fx: float,
): ...


@wp.kernel
def splat_impacts_grid(
    base: wp.vec2,
    coeffs: wp.array2d(dtype=wp.vec3),
    impacts: wp.array(dtype=wp.vec2),
    marks: Marks,
    width: int,
    row0: int,
    row1: int,
    acc: wp.array2d(dtype=wp.vec3),
):
    """``splat_impacts`` for a bilinear texton on an unrotated raster at scale 1.

    Pixel (i, j) sits at base + (j + ½, i + ½), so an impact's offset to every
    pixel has the same fractional part: its texton is the coefficient array
    blended with four fixed weights. The zero margin of ``coeffs`` makes taps
    past the support vanish, so no support test is needed.
    """
    k = wp.tid()
    q = impacts[k]
    t0, sign = mark_of(marks, k)
    # d(i, j) = (j + B + fx, i + A + fy): the integer and fractional parts of the offset
    ox = base[0] + 0.5 - q[0]
    oy = base[1] + 0.5 - q[1]
    fbx = wp.floor(ox)
    fby = wp.floor(oy)
    fx = ox - fbx
    fy = oy - fby
    bx = int(fbx) + PAD
    ay = int(fby) + PAD
    rows = marks.rows
    cols = coeffs.shape[1]
    # pixels whose top-left tap (ay + i, bx + j) lies in [0, rows-1) x [0, cols-1)
    i_lo = wp.max(-ay, row0)
    i_hi = wp.min(rows - 2 - ay, row1 - 1)
    j_lo = wp.max(-bx, 0)
    j_hi = wp.min(cols - 2 - bx, width - 1)
    count = j_hi - j_lo + 1
    if count > 0:
        for i in range(i_lo, i_hi + 1):
            splat_row(acc, i, j_lo, coeffs, t0 + ay + i, bx + j_lo, count,
                      (1.0 - fy) * sign, fy * sign, 1.0 - fx, fx)


@wp.kernel
def normalize_raster(p: NoiseParams, row0: int, acc: wp.array2d(dtype=wp.vec3)):
    i, j = wp.tid()
    acc[row0 + i, j] = normalize(acc[row0 + i, j], p)


@wp.kernel
def gather_raster(
    p: NoiseParams,
    r: Raster,
    coeffs: wp.array2d(dtype=wp.vec3),
    impacts: wp.array(dtype=wp.vec2),
    offsets: wp.array(dtype=wp.int32),
    marks: Marks,
    ncx: int,
    ncy: int,
    row0: int,
    out: wp.array2d(dtype=wp.vec3),
):
    """One thread per pixel of rows row0…: sum the textons of the impacts of nearby cells."""
    i, j = wp.tid()
    i = i + row0
    x = pixel_position(r, i, j)  # relative to the block origin, i.e. cell0's corner
    size = p.cells.size
    cx_lo = wp.max(int(wp.floor((x[0] - p.hi[0]) / size[0])), 0)
    cx_hi = wp.min(int(wp.floor((x[0] - p.lo[0]) / size[0])), ncx - 1)
    cy_lo = wp.max(int(wp.floor((x[1] - p.hi[1]) / size[1])), 0)
    cy_hi = wp.min(int(wp.floor((x[1] - p.lo[1]) / size[1])), ncy - 1)
    acc = wp.vec3(0.0)
    for cy in range(cy_lo, cy_hi + 1):
        for cx in range(cx_lo, cx_hi + 1):
            c = cy * ncx + cx
            for k in range(offsets[c], offsets[c + 1]):
                d = x - impacts[k]
                if inside(d, p):
                    t0, sign = mark_of(marks, k)
                    acc = acc + texton_value(coeffs, t0, marks.rows, d, p.order) * sign
    out[i, j] = normalize(acc, p)


# ------------------------------------------------------------------- points
@wp.struct
class TextonLookup:
    # one padded texton: the rows [row0, row0 + rows) of a coefficient stack
    coeffs: wp.array2d(dtype=wp.vec3)
    row0: int
    rows: int
    order: int


@wp.func
def add_texton(t: TextonLookup, d: wp.vec2, acc: wp.vec3):
    return acc + texton_value(t.coeffs, t.row0, t.rows, d, t.order)


#: Σ h(x − q) over the impacts q with x − q in [lo, hi] (see impacts.cell_walk).
sum_textons = cell_walk(add_texton, "sum_textons")


@wp.kernel
def evaluate_points(
    p: NoiseParams,
    coeffs: wp.array2d(dtype=wp.vec3),
    points: wp.array(dtype=wp.vec2d),
    out: wp.array(dtype=wp.vec3),
):
    """Noise at arbitrary points (texel units), drawing each nearby cell's impacts."""
    t = wp.tid()
    look = TextonLookup()
    look.coeffs = coeffs
    look.row0 = 0
    look.rows = coeffs.shape[0]
    look.order = p.order
    out[t] = normalize(sum_textons(points[t], p.lo, p.hi, p.cells, look), p)
