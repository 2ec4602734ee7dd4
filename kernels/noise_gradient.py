"""Exact derivatives of texton noise and of tiling models in the plane.

Beside each value it differentiates (as Warp's ``noise_2d`` keeps ``noise_2d_gradient``):

* texton noise: g(x) = m + (Σ_j h(x − x_j) − λ ∫h) / √λ, so ∇g = Σ_j ∇h(x − x_j) / √λ, over the
  same impacts in the same order (``impacts.cell_walk`` with ``noise_raster``'s support box, cells
  and seeds): ``texton_slope`` is ∇h for the texton's own interpolation. Order 3 and 5 B-splines
  are C² and C⁴: exact. Order 1 (bilinear) is piecewise linear: on the kinks (a coordinate of
  x − x_j an integer) the slope is the one of the texel cell that ``texton_value`` reads there
  (the one to the right / below: a one-sided derivative). Order 0 is piecewise constant: 0.
* tiling models: the blend V = mean + Σ k_i (e_i − mean) / N (N = Σ k_i, or √(Σ k_i²) for the
  variance-preserving blend; with a lattice the periodic mean's part Σ k_i m_i / Σ k_i is added)
  differentiated with its weights k_i = w_i^s · exp(β (g_i − max g)) (w_i barycentric, linear in
  x; g_i the bilinear guide) and the bilinear example e_i; the cutoff that drops tiny weights and
  the example's bilinear kinks are taken as ``tiling_value`` takes them (one-sided). docs/relief.md.

Each kernel returns the value with the gradient (rows of a ``mat33``: value, ∂/∂x, ∂/∂y per channel),
so the host maps histogram tables through T'(g) ∇g with the g the value kernels give.

Driven by: ``warp_texton.noise.relief``.
"""

from typing import Any

import warp as wp

from .impacts import cell_walk
from .noise_raster import PAD, NoiseParams, TextonLookup, bspline_weight
from .noise_tiling import Lattice, Tiling, cut_weights, lattice_point, lattice_triangle, sharpened, triangle_weights
from .tiling_draw import texel_address

wp.set_module_options({"enable_backward": False, "optimization_level": 3})


@wp.func
def bspline_slope(t: float, order: int):
    # dψ/dt of the centred B-spline ψ of order 3 or 5 (bspline_weight's), odd in t
    a = wp.abs(t)
    s = 1.0
    if t < 0.0:
        s = -1.0
    if order == 3:
        if a < 1.0:
            return s * (-2.0 * a + 1.5 * a * a)
        if a < 2.0:
            b = 2.0 - a
            return -s * 0.5 * b * b
        return 0.0
    # order 5: d/da of (1/120) Σ_j c_j (3 − a − j)_+^5
    acc = 0.0
    c = wp.vec4(1.0, -6.0, 15.0, -20.0)
    for j in range(4):
        u = 3.0 - a - float(j)
        if u > 0.0:
            acc = acc + c[j] * u * u * u * u
    return -s * acc * (5.0 / 120.0)


@wp.func
def texton_slope(coeffs: wp.array2d(dtype=wp.vec3), row0: int, rows: int, y: wp.vec2, order: int):
    # (h(y), ∂h/∂x, ∂h/∂y) as the rows of a mat33, for y inside the support: noise_raster.texton_value and its
    # derivative, the taps and clamps of that function
    cols = coeffs.shape[1]
    zero = wp.vec3(0.0)
    if order == 0:
        j = wp.clamp(int(wp.floor(y[0] + 0.5)) + PAD, 0, cols - 1)
        i = row0 + wp.clamp(int(wp.floor(y[1] + 0.5)) + PAD, 0, rows - 1)
        return wp.matrix_from_rows(coeffs[i, j], zero, zero)
    if order == 1:
        fx = wp.floor(y[0])
        fy = wp.floor(y[1])
        tx = y[0] - fx
        ty = y[1] - fy
        j = wp.clamp(int(fx) + PAD, 0, cols - 2)
        i = row0 + wp.clamp(int(fy) + PAD, 0, rows - 2)
        top = coeffs[i, j] * (1.0 - tx) + coeffs[i, j + 1] * tx
        bottom = coeffs[i + 1, j] * (1.0 - tx) + coeffs[i + 1, j + 1] * tx
        dx = (coeffs[i, j + 1] - coeffs[i, j]) * (1.0 - ty) + (coeffs[i + 1, j + 1] - coeffs[i + 1, j]) * ty
        return wp.matrix_from_rows(top * (1.0 - ty) + bottom * ty, dx, bottom - top)
    half = (order + 1) // 2
    j0 = int(wp.floor(y[0])) - half + 1
    i0 = int(wp.floor(y[1])) - half + 1
    val = wp.vec3(0.0)
    gx = wp.vec3(0.0)
    gy = wp.vec3(0.0)
    for a in range(order + 1):
        i = i0 + a
        wy = bspline_weight(y[1] - float(i), order)
        dy = bspline_slope(y[1] - float(i), order)
        ii = row0 + wp.clamp(i + PAD, 0, rows - 1)
        row = wp.vec3(0.0)
        drow = wp.vec3(0.0)
        for b in range(order + 1):
            j = j0 + b
            c = coeffs[ii, wp.clamp(j + PAD, 0, cols - 1)]
            row = row + c * bspline_weight(y[0] - float(j), order)
            drow = drow + c * bspline_slope(y[0] - float(j), order)
        val = val + row * wy
        gx = gx + drow * wy
        gy = gy + row * dy
    return wp.matrix_from_rows(val, gx, gy)


@wp.func
def add_slope(t: TextonLookup, d: wp.vec2, acc: wp.mat33):
    return acc + texton_slope(t.coeffs, t.row0, t.rows, d, t.order)


@wp.func
def zero_slope(x: float):
    return wp.mat33(x, x, x, x, x, x, x, x, x)


#: Σ (h, ∂h/∂x, ∂h/∂y)(x − q) over the impacts q with x − q in [lo, hi]: the value walk's cells and impacts.
sum_slopes = cell_walk(add_slope, "sum_slopes", zero=zero_slope)


@wp.func
def plane_slope(p: NoiseParams, coeffs: wp.array2d(dtype=wp.vec3), x: wp.vec2d):
    """(g(x), ∂g/∂x, ∂g/∂y) of texton noise as the rows of a mat33 (noise_raster.plane_value's value)."""
    look = TextonLookup()
    look.coeffs = coeffs
    look.row0 = 0
    look.rows = coeffs.shape[0]
    look.order = p.order
    s = sum_slopes(x, p.lo, p.hi, p.cells, look)
    r = wp.sqrt(p.lam)
    return wp.matrix_from_rows(p.mean + (s[0] - p.integral * p.lam) / r, s[1] / r, s[2] / r)


@wp.kernel
def texton_gradient_points(p: NoiseParams, coeffs: wp.array2d(dtype=wp.vec3), points: wp.array(dtype=wp.vec2d),
                           out: wp.array(dtype=wp.mat33)):
    """Value and gradient of texton noise at each point (texel units)."""
    t = wp.tid()
    out[t] = plane_slope(p, coeffs, points[t])


# ------------------------------------------------------------------ tiling models
@wp.func
def bilinear_slope(img: wp.array2d(dtype=Any), q: wp.vec2, wrap: wp.vec2i):
    # (value, ∂/∂x, ∂/∂y) of noise_tiling.bilinear at q, for either texel type: its taps and addressing; on a
    # texel row or column the slope of the cell to the right / below (one-sided, where the value's floor puts it)
    rows = img.shape[0]
    cols = img.shape[1]
    fx = q[0] - 0.5
    fy = q[1] - 0.5
    x0 = wp.floor(fx)
    y0 = wp.floor(fy)
    tx = fx - x0
    ty = fy - y0
    j0 = texel_address(int(x0), cols, wrap[0])
    i0 = texel_address(int(y0), rows, wrap[1])
    j1 = texel_address(int(x0) + 1, cols, wrap[0])
    i1 = texel_address(int(y0) + 1, rows, wrap[1])
    # a clamped edge holds the image constant past its last texel centre
    sx = 1.0
    sy = 1.0
    if j0 == j1:
        sx = 0.0
    if i0 == i1:
        sy = 0.0
    a = img[i0, j0]
    b = img[i0, j1]
    c = img[i1, j0]
    d = img[i1, j1]
    top = a * (1.0 - tx) + b * tx
    bottom = c * (1.0 - tx) + d * tx
    val = top * (1.0 - ty) + bottom * ty
    if tx == 0.0 and ty == 0.0:
        val = a
    return val, ((b - a) * (1.0 - ty) + (d - c) * ty) * sx, (bottom - top) * sy


@wp.func
def example_slope(img: wp.array2d(dtype=wp.vec3), q: wp.vec2, wrap: wp.vec2i):
    # bilinear_slope of the example (or the mean image) as the rows of a mat33
    val, dx, dy = bilinear_slope(img, q, wrap)
    return wp.matrix_from_rows(val, dx, dy)


@wp.func
def guide_slope(img: wp.array2d(dtype=float), q: wp.vec2, wrap: wp.vec2i):
    # bilinear_slope of the guide as (value, ∂/∂x, ∂/∂y)
    val, dx, dy = bilinear_slope(img, q, wrap)
    return wp.vec3(val, dx, dy)


@wp.func
def tiling_slope(t: Tiling, lat: Lattice, x: wp.vec2d):
    """(V(x), ∂V/∂x, ∂V/∂y) of a tiling model (noise_tiling.tiling_value, or blend_at on a periodic lattice)."""
    a, b, u, v = lattice_triangle(t, lat, x)
    # d(u, v)/d(x, y) of the skewed coordinates: sy = y / hy, sx = x / hx − sy / 2
    hx = float(lat.dx)
    hy = float(lat.dy)
    if lat.periodic == 0:
        hx = t.side
        hy = t.side * 0.8660254037844386
    du = wp.vec2(1.0 / hx, -0.5 / hy)
    dv = wp.vec2(0.0, 1.0 / hy)
    a0, b0, w0, w1, w2 = triangle_weights(a, b, u, v)
    w = wp.vec3(w0, w1, w2)
    dw0 = -du - dv
    dw1 = du
    dw2 = dv
    if u + v > 1.0:
        dw0 = du + dv
        dw1 = -dv
        dw2 = -du
    q0 = lattice_point(t, lat, x, a0, b0)
    q1 = lattice_point(t, lat, x, a + 1, b)
    q2 = lattice_point(t, lat, x, a, b + 1)
    g0 = wp.vec3(0.0)
    g1 = wp.vec3(0.0)
    g2 = wp.vec3(0.0)
    if t.guide_weight != 0.0:
        g0 = guide_slope(t.guide, q0, t.wrap)
        g1 = guide_slope(t.guide, q1, t.wrap)
        g2 = guide_slope(t.guide, q2, t.wrap)
    # the guide's largest value and its gradient (the max's first index, as wp.max picks any: ties are a null set)
    gm = g0
    if g1[0] > gm[0]:
        gm = g1
    if g2[0] > gm[0]:
        gm = g2
    k0 = sharpened(w[0], t.squarings, t.guide_weight, g0[0] - gm[0])
    k1 = sharpened(w[1], t.squarings, t.guide_weight, g1[0] - gm[0])
    k2 = sharpened(w[2], t.squarings, t.guide_weight, g2[0] - gm[0])
    k0, k1, k2 = cut_weights(k0, k1, k2)
    # dk/dx = k (s ∇w / w + β (∇g − ∇g_max)), s = 2^squarings
    s = float(1 << t.squarings)
    dgm = wp.vec2(gm[1], gm[2])
    dk0 = wp.vec2(0.0)
    dk1 = wp.vec2(0.0)
    dk2 = wp.vec2(0.0)
    if k0 > 0.0:
        dk0 = k0 * (dw0 * (s / w[0]) + t.guide_weight * (wp.vec2(g0[1], g0[2]) - dgm))
    if k1 > 0.0:
        dk1 = k1 * (dw1 * (s / w[1]) + t.guide_weight * (wp.vec2(g1[1], g1[2]) - dgm))
    if k2 > 0.0:
        dk2 = k2 * (dw2 * (s / w[2]) + t.guide_weight * (wp.vec2(g2[1], g2[2]) - dgm))
    # residuals r_i = e_i − mean (or − m_i with a lattice) and their gradients; the mean's part m_i
    e0 = example_slope(t.example, q0, t.wrap)
    e1 = example_slope(t.example, q1, t.wrap)
    e2 = example_slope(t.example, q2, t.wrap)
    zero = wp.vec3(0.0)
    m0 = wp.matrix_from_rows(t.mean, zero, zero)
    m1 = m0
    m2 = m0
    if t.rank != 0:
        m0 = example_slope(t.mean_image, q0, t.wrap)
        m1 = example_slope(t.mean_image, q1, t.wrap)
        m2 = example_slope(t.mean_image, q2, t.wrap)
    r0 = e0 - m0
    r1 = e1 - m1
    r2 = e2 - m2
    total = k0 + k1 + k2
    dtotal = dk0 + dk1 + dk2
    norm = total
    dnorm = dtotal
    if t.variance_preserving != 0:
        norm = wp.sqrt(k0 * k0 + k1 * k1 + k2 * k2)
        dnorm = (dk0 * k0 + dk1 * k1 + dk2 * k2) / norm
    # the residual blend R = Σ k r / N and the mean's M = Σ k m / Σ k (M = mean without a lattice)
    sr = r0[0] * k0 + r1[0] * k1 + r2[0] * k2
    R = sr / norm
    Rx = (r0[0] * dk0[0] + r1[0] * dk1[0] + r2[0] * dk2[0] + r0[1] * k0 + r1[1] * k1 + r2[1] * k2
          - R * dnorm[0]) / norm
    Ry = (r0[0] * dk0[1] + r1[0] * dk1[1] + r2[0] * dk2[1] + r0[2] * k0 + r1[2] * k1 + r2[2] * k2
          - R * dnorm[1]) / norm
    if t.rank == 0:
        return wp.matrix_from_rows(t.mean + R, Rx, Ry)
    M = (m0[0] * k0 + m1[0] * k1 + m2[0] * k2) / total
    Mx = (m0[0] * dk0[0] + m1[0] * dk1[0] + m2[0] * dk2[0] + m0[1] * k0 + m1[1] * k1 + m2[1] * k2
          - M * dtotal[0]) / total
    My = (m0[0] * dk0[1] + m1[0] * dk1[1] + m2[0] * dk2[1] + m0[2] * k0 + m1[2] * k1 + m2[2] * k2
          - M * dtotal[1]) / total
    return wp.matrix_from_rows(M + R, Mx + Rx, My + Ry)


@wp.kernel
def tiling_gradient_points(t: Tiling, lat: Lattice, points: wp.array(dtype=wp.vec2d),
                           out: wp.array(dtype=wp.mat33)):
    """Value and gradient of a tiling model at each point (noise units)."""
    k = wp.tid()
    out[k] = tiling_slope(t, lat, points[k])
