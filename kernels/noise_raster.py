"""Texton noise in the plane: the evaluation kernels of the hashed-cell process.

Impacts come from the cells of kernels/impacts.py (one stream, one order, for
every path). Rasters draw a block of cells' impacts once (``count_impacts``,
a prefix sum, ``emit_impacts``) and then splat each impact's texton (CPU) or
gather the impacts near each pixel (CUDA); points walk their neighbouring cells.

Texton convention: an impact at p adds h(x − p) with h(y) = Σ_k α(k) ψ(y − k),
coefficient (row i, column j) at y = (j, i). Coefficients are stored with a
zero margin of PAD texels so that every tap of every order reads in bounds.

Driven by: ``warp_texton.noise.canvas``, ``warp_texton.noise.engine``,
``warp_texton.noise.filtering``, ``warp_texton.noise.raster``, ``warp_texton.runtimes.glsl``,
``warp_texton.runtimes.osl``, ``warp_texton.runtimes.warp_api``.
"""

from typing import Any

import warp as wp

from .impacts import GOLDEN, Cells, avalanche, cell_span, cell_state, cell_walk, draw_count, next_impact
from .noise_raster_native import GROUP_ROWS, WIDTH, normalize_row1, normalize_row3, splat_rows1, splat_rows3  # noqa: F401 (WIDTH, GROUP_ROWS: 0.2 names)

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
def texton_value(coeffs: wp.array2d(dtype=Any), row0: int, rows: int, y: wp.vec2, order: int):
    # h(y) for y inside the support, for the texton stored in rows [row0, row0 + rows)
    # of a stack; taps outside the coefficients read the zero margin. One channel
    # (float coefficients) or three (vec3): the same operations on each channel.
    cols = coeffs.shape[1]
    acc = coeffs.dtype(0.0)
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
        row = coeffs.dtype(0.0)
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


@wp.func
def normalize(acc: float, p: NoiseParams):  # noqa: F811 (a Warp overload)
    # one channel: the vec3 form's operations on its first component
    return p.mean[0] + (acc - p.integral[0] * p.lam) / wp.sqrt(p.lam)


# ------------------------------------------------------------------ windows
@wp.struct
class Window:
    # One raster of a batch (a single raster is a batch of one). Pixel (I, J) of
    # the *global* raster sits at origin + step_x (J + ½) + step_y (I + ½), in
    # float64; the window holds its pixels (first[0] + i, first[1] + j) and
    # stores them in the output rows out_row + i. Its impacts are those of the
    # ncx × ncy cells from cell0 (global cell indices), numbered first_cell… in
    # the batch's cell arrays. Its texton is rows [texton_row, texton_row +
    # texton_rows) and columns [0, texton_cols) of the coefficient stack
    # (mixed noise stacks its textons there, texton_rows apart).
    p: NoiseParams
    origin: wp.vec2d
    step_x: wp.vec2d
    step_y: wp.vec2d
    inv: wp.mat22d  # noise-space offset -> (column, row) offset
    fstep_x: wp.vec2  # the steps in float32, for offsets between nearby pixels
    fstep_y: wp.vec2
    first: wp.vec2i  # (row, column) of the window's pixel (0, 0) in the global raster
    out_row: int
    width: int
    cell0: wp.vec2i
    ncx: int
    ncy: int
    first_cell: int
    texton_row: int
    texton_rows: int
    texton_cols: int
    grid: int  # 1: order 1 at scale 1 without rotation (splat_grid applies)


@wp.func
def block_cell(w: Window, c: int):
    # global (cx, cy) of cell c of the batch, which lies in w's block
    l = c - w.first_cell
    return w.cell0[0] + l % w.ncx, w.cell0[1] + l / w.ncx


@wp.func
def impact_from_origin(w: Window, c: int, q: wp.vec2):
    # the impact at offset q in cell c, relative to the raster's origin, in float64:
    # a function of the global cell and the offset alone, whichever window asks
    cx, cy = block_cell(w, c)
    size = w.p.cells.size
    return wp.vec2d(wp.float64(cx) * wp.float64(size[0]) + wp.float64(q[0]) - w.origin[0],
                    wp.float64(cy) * wp.float64(size[1]) + wp.float64(q[1]) - w.origin[1])


# ----------------------------------------------------------------- impacts
@wp.kernel
def count_impacts(windows: wp.array(dtype=Window), cell_window: wp.array(dtype=wp.int32),
                  counts: wp.array(dtype=wp.int32)):
    """Impact count of every cell of every window's block."""
    c = wp.tid()
    w = windows[cell_window[c]]
    cx, cy = block_cell(w, c)
    n, s = draw_count(cell_state(w.p.cells, cx, cy), w.p.cells.mean_count, w.p.cells.exact_poisson)
    counts[c] = n


@wp.kernel
def emit_impacts(
    windows: wp.array(dtype=Window),
    cell_window: wp.array(dtype=wp.int32),
    offsets: wp.array(dtype=wp.int32),
    impacts: wp.array(dtype=wp.vec2),
    impact_cell: wp.array(dtype=wp.int32),
):
    """Every cell's impacts as (its cell, its float32 offset from the cell's corner).

    Offsets are u · cell size, as the point walks compute them: an impact
    is stored the same way whichever block it is drawn in.
    """
    c = wp.tid()
    w = windows[cell_window[c]]
    cx, cy = block_cell(w, c)
    n, s = draw_count(cell_state(w.p.cells, cx, cy), w.p.cells.mean_count, w.p.cells.exact_poisson)
    start = offsets[c]
    stop = wp.min(start + n, offsets[c + 1])
    size = w.p.cells.size
    for k in range(start, stop):
        u, s = next_impact(s)
        impacts[k] = wp.vec2(u[0] * size[0], u[1] * size[1])
        impact_cell[k] = c


@wp.kernel
def emit_signs(windows: wp.array(dtype=Window), cell_window: wp.array(dtype=wp.int32),
               offsets: wp.array(dtype=wp.int32), signs: wp.array(dtype=float)):
    """Random signs ε = ±1 of every impact (mixed noise, CGF §7).

    Hashed from the cell's seed and the impact's rank in its cell, apart from
    the position stream, so plain and mixed noise place the same impacts.
    """
    c = wp.tid()
    w = windows[cell_window[c]]
    cx, cy = block_cell(w, c)
    h = cell_state(w.p.cells, cx, cy)
    for k in range(offsets[c], offsets[c + 1]):
        bit = avalanche(h ^ (wp.uint32(k - offsets[c] + 1) * GOLDEN)) >> wp.uint32(31)
        signs[k] = 1.0 - 2.0 * float(bit)


# ------------------------------------------------------------------ rasters
@wp.struct
class Marks:
    # Mixed noise: impact k adds signs[k] · h_{labels[k]}, the textons stacked
    # texton_rows apart in the window's coefficient rows. Plain noise: marked = 0.
    marked: int
    labels: wp.array(dtype=wp.int32)
    signs: wp.array(dtype=float)


@wp.func
def mark_of(m: Marks, k: int):
    # (the impact's texton in the window's stack, its sign)
    if m.marked == 0:
        return 0, 1.0
    return m.labels[k], m.signs[k]


@wp.kernel
def label_impacts(
    windows: wp.array(dtype=Window),
    cell_window: wp.array(dtype=wp.int32),
    impacts: wp.array(dtype=wp.vec2),
    impact_cell: wp.array(dtype=wp.int32),
    centre: wp.vec2,
    strips: int,
    regions: int,
    rho: wp.array2d(dtype=float),
    rho_first: wp.vec2i,
    labels: wp.array(dtype=wp.int32),
):
    """The texton of each impact: the region of the raster that the centre of its
    texton falls in (CGF §7: 1{x_j ∈ D_r} for a kernel centred on x_j). Textons
    are stored from coefficient (0, 0) at the impact, so the centre of the
    support box, ``centre`` texels from the impact, stands for x_j: a texture
    then covers its region of the map, half a texton past it on every side.

    ``strips`` = 1: ``regions`` vertical strips across the window's width;
    otherwise the nearest pixel of the ρ map (clamped at the border) picks
    texton round(ρ (regions − 1)). The map starts at the global (row, column)
    ``rho_first``, so a raster computed in strips of rows (windows of their
    own ``first``) labels its impacts as in one pass.
    """
    k = wp.tid()
    c = impact_cell[k]
    w = windows[cell_window[c]]
    at = impact_from_origin(w, c, impacts[k]) + wp.vec2d(wp.float64(centre[0]), wp.float64(centre[1]))
    q = w.inv * at  # global (column, row) + ½ of the texton's centre
    px = float(q[0] - wp.float64(rho_first[1]))
    py = float(q[1] - wp.float64(rho_first[0]))
    if strips != 0:
        lab = int(wp.floor(px / float(w.width) * float(regions)))
    else:
        j = wp.clamp(int(wp.floor(px)), 0, rho.shape[1] - 1)
        i = wp.clamp(int(wp.floor(py)), 0, rho.shape[0] - 1)
        lab = int(wp.floor(rho[i, j] * float(regions - 1) + 0.5))
    labels[k] = wp.clamp(lab, 0, regions - 1)


@wp.func
def splat_rows(acc: wp.array2d(dtype=wp.vec3), i0: int, i1: int, j: int, coeffs: wp.array2d(dtype=wp.vec3),
               a0: int, b: int, count: int, gy: float, fy: float, gx: float, fx: float):
    splat_rows3(acc, i0, i1, j, coeffs, a0, b, count, gy, fy, gx, fx)


@wp.func
def splat_rows(acc: wp.array2d(dtype=float), i0: int, i1: int, j: int, coeffs: wp.array2d(dtype=float),  # noqa: F811
               a0: int, b: int, count: int, gy: float, fy: float, gx: float, fx: float):  # (a Warp overload)
    splat_rows1(acc, i0, i1, j, coeffs, a0, b, count, gy, fy, gx, fx)


@wp.func
def splat_grid(w: Window, P: wp.vec2d, coeffs: wp.array2d(dtype=Any), t0: int, sign: float,
               di: int, r_lo: int, r_hi: int, acc: wp.array2d(dtype=Any)):
    # A bilinear texton on an unrotated raster at scale 1: the offset from the
    # impact to global pixel (I, J) is (J + tx, I + ty) with t = ½ − P, so every
    # pixel sees the same fraction and the texton is the coefficient array
    # blended with four fixed weights. The zero margin of the coefficients makes
    # taps past the support vanish, so no support test is needed.
    tx = wp.float64(0.5) - P[0]
    ty = wp.float64(0.5) - P[1]
    fbx = wp.floor(tx)
    fby = wp.floor(ty)
    fx = float(tx - fbx)
    fy = float(ty - fby)
    # padded tap (row, column) of output pixel (i, j): (i + ay, j + bx)
    bx = int(fbx) + w.first[1] + PAD
    ay = int(fby) + di + PAD
    i_lo = wp.max(-ay, r_lo)
    i_hi = wp.min(w.texton_rows - 2 - ay, r_hi)
    j_lo = wp.max(-bx, 0)
    j_hi = wp.min(w.texton_cols - 2 - bx, w.width - 1)
    count = j_hi - j_lo + 1
    if count > 0:
        # output rows i_lo..i_hi from texton rows t0 + ay + i (and the next)
        splat_rows(acc, i_lo, i_hi, j_lo, coeffs, t0 + ay, bx + j_lo, count, (1.0 - fy) * sign, fy * sign,
                   1.0 - fx, fx)


@wp.func
def splat_general(w: Window, P: wp.vec2d, coeffs: wp.array2d(dtype=Any), t0: int, sign: float,
                  di: int, r_lo: int, r_hi: int, acc: wp.array2d(dtype=Any)):
    # The pixels whose offset can fall in the support box: the box of its
    # corners in pixel units, in float64 from global indices, so that every
    # window tests the same pixels.
    p = w.p
    lo = wp.vec2d(wp.float64(p.lo[0]), wp.float64(p.lo[1]))
    hi = wp.vec2d(wp.float64(p.hi[0]), wp.float64(p.hi[1]))
    b00 = w.inv * (P + lo)
    b11 = w.inv * (P + hi)
    b01 = w.inv * (P + wp.vec2d(hi[0], lo[1]))
    b10 = w.inv * (P + wp.vec2d(lo[0], hi[1]))
    half = wp.float64(0.5)
    jmin = wp.min(wp.min(b00[0], b01[0]), wp.min(b10[0], b11[0]))
    jmax = wp.max(wp.max(b00[0], b01[0]), wp.max(b10[0], b11[0]))
    imin = wp.min(wp.min(b00[1], b01[1]), wp.min(b10[1], b11[1]))
    imax = wp.max(wp.max(b00[1], b01[1]), wp.max(b10[1], b11[1]))
    big_j0 = int(wp.ceil(jmin - half))
    big_i0 = int(wp.ceil(imin - half))
    big_j1 = int(wp.floor(jmax - half))
    big_i1 = int(wp.floor(imax - half))
    # offsets are taken from the anchor pixel (big_i0, big_j0), which depends on
    # the impact alone: every window computes the same float32 offsets
    da = w.step_x * (wp.float64(big_j0) + half) + w.step_y * (wp.float64(big_i0) + half) - P
    anchor = wp.vec2(float(da[0]), float(da[1]))
    dj = w.first[1]
    i_lo = wp.max(big_i0 - di, r_lo)
    i_hi = wp.min(big_i1 - di, r_hi)
    j_lo = wp.max(big_j0 - dj, 0)
    j_hi = wp.min(big_j1 - dj, w.width - 1)
    for i in range(i_lo, i_hi + 1):
        row = anchor + w.fstep_y * float(i + di - big_i0)
        for j in range(j_lo, j_hi + 1):
            d = row + w.fstep_x * float(j + dj - big_j0)
            if inside(d, p):
                acc[i, j] = acc[i, j] + texton_value(coeffs, t0, w.texton_rows, d, p.order) * sign


@wp.kernel
def splat_impacts(
    windows: wp.array(dtype=Window),
    cell_window: wp.array(dtype=wp.int32),
    coeffs: wp.array2d(dtype=Any),
    impacts: wp.array(dtype=wp.vec2),
    impact_cell: wp.array(dtype=wp.int32),
    marks: Marks,
    k0: int,
    height: int,
    row0: int,
    row1: int,
    acc: wp.array2d(dtype=Any),
):
    """Add the textons of impacts k0… to the output rows [row0, row1) of ``acc``
    (no atomics); ``normalize_rows`` turns the raw sums into noise values.

    For the CPU: one launch runs its threads one after another on one core,
    and concurrent launches own disjoint row bands, so plain writes are safe.
    Each pixel adds its impacts in the order of their cells (row-major in the
    global cell grid) and of their rank in the cell, whatever window holds it.
    """
    k = wp.tid() + k0
    c = impact_cell[k]
    w = windows[cell_window[c]]
    lab, sign = mark_of(marks, k)
    r_lo = wp.max(row0, w.out_row)
    r_hi = wp.min(row1, w.out_row + height) - 1
    if r_lo <= r_hi:
        P = impact_from_origin(w, c, impacts[k])
        t0 = w.texton_row + lab * w.texton_rows
        di = w.first[0] - w.out_row  # global row of output row i: i + di
        if w.grid != 0:
            splat_grid(w, P, coeffs, t0, sign, di, r_lo, r_hi, acc)
        else:
            splat_general(w, P, coeffs, t0, sign, di, r_lo, r_hi, acc)


@wp.func
def normalize_row(acc: wp.array2d(dtype=float), i: int, p: NoiseParams):
    normalize_row1(acc, i, p.mean, p.integral, p.lam)


@wp.func
def normalize_row(acc: wp.array2d(dtype=wp.vec3), i: int, p: NoiseParams):  # noqa: F811 (a Warp overload)
    normalize_row3(acc, i, p.mean, p.integral, p.lam)


@wp.kernel
def normalize_rows(windows: wp.array(dtype=Window), height: int, row0: int, acc: wp.array2d(dtype=Any)):
    """Raw sums to noise values, one output row per thread."""
    i = wp.tid() + row0
    normalize_row(acc, i, windows[i / height].p)


@wp.kernel
def gather_raster(
    windows: wp.array(dtype=Window),
    coeffs: wp.array2d(dtype=Any),
    impacts: wp.array(dtype=wp.vec2),
    offsets: wp.array(dtype=wp.int32),
    marks: Marks,
    height: int,
    row0: int,
    out: wp.array2d(dtype=Any),
):
    """One thread per pixel of output rows row0…: sum the textons of the impacts of nearby cells.

    The pixel's position relative to the corner of its first cell is computed
    in float64 from its global index, so every window gives it the same value.
    """
    i, j = wp.tid()
    i = i + row0
    w = windows[i / height]
    p = w.p
    half = wp.float64(0.5)
    x = w.origin + w.step_x * (wp.float64(j + w.first[1]) + half) \
        + w.step_y * (wp.float64(i - w.out_row + w.first[0]) + half)
    cx_lo, cx_hi, cy_lo, cy_hi = cell_span(x, p.lo, p.hi, p.cells.size)
    size = p.cells.size
    ref = wp.vec2(float(x[0] - wp.float64(cx_lo) * wp.float64(size[0])),
                  float(x[1] - wp.float64(cy_lo) * wp.float64(size[1])))
    acc = coeffs.dtype(0.0)
    for cy in range(wp.max(cy_lo, w.cell0[1]), wp.min(cy_hi, w.cell0[1] + w.ncy - 1) + 1):
        ry = ref[1] - float(cy - cy_lo) * size[1]
        for cx in range(wp.max(cx_lo, w.cell0[0]), wp.min(cx_hi, w.cell0[0] + w.ncx - 1) + 1):
            rel = wp.vec2(ref[0] - float(cx - cx_lo) * size[0], ry)
            c = w.first_cell + (cy - w.cell0[1]) * w.ncx + (cx - w.cell0[0])
            for k in range(offsets[c], offsets[c + 1]):
                d = rel - impacts[k]
                if inside(d, p):
                    lab, sign = mark_of(marks, k)
                    acc = acc + texton_value(coeffs, w.texton_row + lab * w.texton_rows, w.texton_rows, d,
                                             p.order) * sign
    out[i, j] = normalize(acc, p)


#: The raster kernels for one channel (float) and three (vec3): a grey texton's
#: raster reads and writes one float a texel, not three.
for _lanes in (float, wp.vec3):
    wp.overload(splat_impacts, {"coeffs": wp.array2d(dtype=_lanes), "acc": wp.array2d(dtype=_lanes)})
    wp.overload(normalize_rows, {"acc": wp.array2d(dtype=_lanes)})
    wp.overload(gather_raster, {"coeffs": wp.array2d(dtype=_lanes), "out": wp.array2d(dtype=_lanes)})


@wp.kernel
def scatter_values(values: wp.array(dtype=Any), index: wp.array(dtype=wp.int64), out: wp.array(dtype=Any)):
    """out[index[t]] = values[t]: computed pixels into an image that holds the mean elsewhere."""
    t = wp.tid()
    out[index[t]] = values[t]


for _lanes in (float, wp.vec3):
    wp.overload(scatter_values, {"values": wp.array(dtype=_lanes), "out": wp.array(dtype=_lanes)})


# ------------------------------------------------------------------- points
@wp.struct
class TextonLookup:
    # one padded texton: the rows [row0, row0 + rows) of a coefficient stack
    coeffs: wp.array2d(dtype=wp.vec3)
    row0: int
    rows: int
    order: int


@wp.struct
class TextonLookup1:
    # the same, one channel
    coeffs: wp.array2d(dtype=float)
    row0: int
    rows: int
    order: int


@wp.func
def add_texton(t: TextonLookup, d: wp.vec2, acc: wp.vec3):
    return acc + texton_value(t.coeffs, t.row0, t.rows, d, t.order)


@wp.func
def add_texton(t: TextonLookup1, d: wp.vec2, acc: float):  # noqa: F811 (a Warp overload)
    return acc + texton_value(t.coeffs, t.row0, t.rows, d, t.order)


#: Σ h(x − q) over the impacts q with x − q in [lo, hi] (see impacts.cell_walk),
#: three channels and one.
sum_textons = cell_walk(add_texton, "sum_textons")
sum_textons1 = cell_walk(add_texton, "sum_textons1", zero=wp.float32)


@wp.struct
class PlaneNoise:
    """Texton noise in the plane, as a kernel evaluates it (the device API).

    Filled on the host by :func:`warp_texton.runtimes.warp_api.pack_plane`; its arrays
    live on the device it was packed for, and a kernel that takes it runs there.

    Attributes
    ----------
    params : NoiseParams
        The noise settings: the cells of the Poisson process (size, period,
        mean count, seed, Poisson mode), the texton's order, support box,
        intensity λ, mean and integral.
    coeffs : wp.array2d(dtype=wp.vec3)
        The texton's coefficients with a zero margin of ``PAD`` texels,
        unused channels zero.
    """

    params: NoiseParams
    coeffs: wp.array2d(dtype=wp.vec3)


@wp.struct
class PlaneNoise1:
    """Texton noise in the plane of a one-channel (grey) texton (the device API).

    Filled on the host by :func:`warp_texton.runtimes.warp_api.pack_plane` with
    ``channels=1``; ``plane_value`` of it returns a float, and reads one float a
    texel where ``PlaneNoise`` reads three.

    Attributes
    ----------
    params : NoiseParams
        As in ``PlaneNoise`` (the mean and integral in the first component).
    coeffs : wp.array2d(dtype=float)
        The texton's coefficients with a zero margin of ``PAD`` texels.
    """

    params: NoiseParams
    coeffs: wp.array2d(dtype=float)


@wp.func
def plane_value(noise: PlaneNoise, x: wp.vec2d) -> wp.vec3:
    """Texton noise at the texel-space point ``x`` (CGF eq. (2)).

    The value :func:`warp_texton.evaluate` gives at the point ``x`` (texel
    units, x to the right, y down), bit for bit on the same device: each call
    walks the cells around ``x`` and draws their impacts. Components past the
    texton's channels are zero. ``x`` must lie within the noise's cell range
    (±2³⁰ cells; ``evaluate`` refuses points beyond it, a kernel cannot).
    """
    p = noise.params
    look = TextonLookup()
    look.coeffs = noise.coeffs
    look.row0 = 0
    look.rows = noise.coeffs.shape[0]
    look.order = p.order
    return normalize(sum_textons(x, p.lo, p.hi, p.cells, look), p)


@wp.func
def plane_value(noise: PlaneNoise1, x: wp.vec2d) -> float:  # noqa: F811 (a Warp overload)
    """Texton noise of a one-channel texton at the texel-space point ``x``: the
    first component of ``plane_value`` of the same texton packed as three
    channels, bit for bit."""
    p = noise.params
    look = TextonLookup1()
    look.coeffs = noise.coeffs
    look.row0 = 0
    look.rows = noise.coeffs.shape[0]
    look.order = p.order
    return normalize(sum_textons1(x, p.lo, p.hi, p.cells, look), p)


@wp.func
def plane_noise(p: NoiseParams, coeffs: wp.array2d(dtype=wp.vec3)):
    noise = PlaneNoise()
    noise.params = p
    noise.coeffs = coeffs
    return noise


@wp.func
def plane_noise(p: NoiseParams, coeffs: wp.array2d(dtype=float)):  # noqa: F811 (a Warp overload)
    noise = PlaneNoise1()
    noise.params = p
    noise.coeffs = coeffs
    return noise


@wp.kernel
def evaluate_points(
    p: NoiseParams,
    coeffs: wp.array2d(dtype=Any),
    points: wp.array(dtype=wp.vec2d),
    out: wp.array(dtype=Any),
):
    """Noise at arbitrary points (texel units), drawing each nearby cell's impacts:
    ``plane_value``, the device API's function, at each point (one channel or three)."""
    t = wp.tid()
    out[t] = plane_value(plane_noise(p, coeffs), points[t])


for _lanes in (float, wp.vec3):
    wp.overload(evaluate_points, {"coeffs": wp.array2d(dtype=_lanes), "out": wp.array(dtype=_lanes)})
