"""Anti-aliased texton noise: MIP-mapped and anisotropic filtering of the texton (CGF §5).

Texton noise is a sum of shifted textons, so averaging the noise over a
pixel's footprint F is the noise of the filtered texton h ∗ 1_F / |F| with the
same impacts. The kernels here replace h by a prefiltered texton from a MIP
pyramid: level ℓ holds 2^ℓ × 2^ℓ block means of the coefficients, and

    h_ℓ(y) = Σ_k α_ℓ(k) ψ((y − o_ℓ) / 2^ℓ − k),   o_ℓ = (2^ℓ − 1) / 2,

so ∫h_ℓ = ∫h at every level. Each pixel blends two levels (trilinear) and, for
"anisotropic", averages N such lookups placed along the major axis of its
footprint. Every lookup sums the impacts over the whole support of h_ℓ, so the
expected value of the sum is λ ∫h exactly and the filtered noise keeps the
texton mean.

Driven by: ``warp_texton.noise.colours``, ``warp_texton.noise.filtering``,
``warp_texton.runtimes.warp_api``.
"""

from typing import Any

import warp as wp

from .impacts import cell_walk
from .noise_raster import NoiseParams, texton_value

wp.set_module_options({"enable_backward": False, "optimization_level": 3})

#: Filter modes (``Filter.mode``): one lookup per level at the footprint's major
#: length, or up to ``max_aniso`` lookups along its major axis.
MIP = wp.constant(1)
ANISOTROPIC = wp.constant(2)


@wp.struct
class Pyramid:
    # Level ℓ: padded coefficients in rows [row0[ℓ], row0[ℓ] + rows[ℓ]) of `coeffs`
    # (a common width, zeros past each level's columns); its texels are 2^ℓ wide
    # (`step`), its coefficient (0, 0) sits at `origin`, and h_ℓ vanishes outside
    # the box [lo, hi] relative to the impact.
    coeffs: wp.array2d(dtype=wp.vec3)
    row0: wp.array(dtype=wp.int32)
    rows: wp.array(dtype=wp.int32)
    step: wp.array(dtype=float)
    origin: wp.array(dtype=float)
    lo: wp.array(dtype=wp.vec2)
    hi: wp.array(dtype=wp.vec2)
    levels: int  # real levels; level `levels` stands for the mean (h ≡ 0 after normalising)
    order: int


@wp.struct
class Pyramid1:
    # the same for a one-channel (grey) texton: float coefficients
    coeffs: wp.array2d(dtype=float)
    row0: wp.array(dtype=wp.int32)
    rows: wp.array(dtype=wp.int32)
    step: wp.array(dtype=float)
    origin: wp.array(dtype=float)
    lo: wp.array(dtype=wp.vec2)
    hi: wp.array(dtype=wp.vec2)
    levels: int
    order: int


@wp.struct
class Filter:
    mode: int  # MIP or ANISOTROPIC
    max_aniso: int  # most lookups along the major axis
    lod_bias: float  # added to log2 of the lookup width


@wp.struct
class Level:
    # one MIP level, as a lookup reads it
    row0: int  # first row in the coefficient stack
    rows: int
    inv_step: float  # 1 / texel side
    origin: float  # position of coefficient (0, 0)
    lo: wp.vec2  # h_ℓ vanishes outside [lo, hi] relative to the impact
    hi: wp.vec2


@wp.func
def level_params(pyr: Any, lvl: int):
    lv = Level()
    lv.row0 = pyr.row0[lvl]
    lv.rows = pyr.rows[lvl]
    lv.inv_step = 1.0 / pyr.step[lvl]
    lv.origin = pyr.origin[lvl]
    lv.lo = pyr.lo[lvl]
    lv.hi = pyr.hi[lvl]
    return lv


@wp.func
def lookup(coeffs: wp.array2d(dtype=Any), lv: Level, d: wp.vec2, order: int):
    # h_ℓ(d), zero outside the level's box (one channel or three)
    if d[0] < lv.lo[0] or d[0] > lv.hi[0] or d[1] < lv.lo[1] or d[1] > lv.hi[1]:
        return coeffs.dtype(0.0)
    y = wp.vec2((d[0] - lv.origin) * lv.inv_step, (d[1] - lv.origin) * lv.inv_step)
    return texton_value(coeffs, lv.row0, lv.rows, y, order)


@wp.func
def footprint_axes(J: wp.mat22):
    # Principal axes of the footprint J [-½, ½]²: its covariance is J Jᵀ / 12.
    # Returns (major length σ1, minor length σ2, unit major direction).
    # J is scaled to a largest entry of 1 first, so that squares cannot overflow.
    s = wp.max(wp.max(wp.abs(J[0, 0]), wp.abs(J[0, 1])), wp.max(wp.abs(J[1, 0]), wp.abs(J[1, 1])))
    if s == 0.0:
        return 0.0, 0.0, wp.vec2(1.0, 0.0)
    K = J / s
    m00 = K[0, 0] * K[0, 0] + K[0, 1] * K[0, 1]
    m01 = K[0, 0] * K[1, 0] + K[0, 1] * K[1, 1]
    m11 = K[1, 0] * K[1, 0] + K[1, 1] * K[1, 1]
    half = 0.5 * (m00 + m11)
    disc = wp.sqrt(wp.max(0.25 * (m00 - m11) * (m00 - m11) + m01 * m01, 0.0))
    l1 = half + disc
    l2 = wp.max(half - disc, 0.0)
    # eigenvector of l1: pick the better conditioned of the two forms
    u = wp.vec2(1.0, 0.0)
    a = wp.vec2(m01, l1 - m00)
    b = wp.vec2(l1 - m11, m01)
    na = wp.length(a)
    nb = wp.length(b)
    if na >= nb and na > 0.0:
        u = a / na
    elif nb > 0.0:
        u = b / nb
    return s * wp.sqrt(l1), s * wp.sqrt(l2), u


@wp.func
def lookup_range(d0: wp.vec2, stride: wp.vec2, n: int, lo: wp.vec2, hi: wp.vec2):
    # the q in [0, n) with lo <= d0 + q stride <= hi on both axes, as (first, last);
    # empty when last < first
    a = 0.0
    b = float(n - 1)
    for axis in range(2):
        s = stride[axis]
        if s > 0.0:
            a = wp.max(a, (lo[axis] - d0[axis]) / s)
            b = wp.min(b, (hi[axis] - d0[axis]) / s)
        elif s < 0.0:
            a = wp.max(a, (hi[axis] - d0[axis]) / s)
            b = wp.min(b, (lo[axis] - d0[axis]) / s)
    return int(wp.ceil(a - 1.0e-5)), int(wp.floor(b + 1.0e-5))


@wp.struct
class PyramidLookup:
    # one pixel's lookups: levels a and b blended with weights w0, w1, at the
    # offsets first + q stride (q < n) from each impact
    coeffs: wp.array2d(dtype=wp.vec3)
    order: int
    a: Level
    b: Level
    w0: float
    w1: float
    first: wp.vec2
    stride: wp.vec2
    n: int
    box_lo: wp.vec2  # the union of the two levels' boxes
    box_hi: wp.vec2


@wp.struct
class PyramidLookup1:
    # the same for a one-channel texton
    coeffs: wp.array2d(dtype=float)
    order: int
    a: Level
    b: Level
    w0: float
    w1: float
    first: wp.vec2
    stride: wp.vec2
    n: int
    box_lo: wp.vec2
    box_hi: wp.vec2


@wp.func
def add_lookups(c: Any, d: wp.vec2, acc: Any):
    # the lookups q with d + first + q stride inside the coarser level's box
    d0 = d + c.first
    q0, q1 = lookup_range(d0, c.stride, c.n, c.box_lo, c.box_hi)
    dk = d0 + c.stride * float(q0)
    for q in range(q0, q1 + 1):
        v = lookup(c.coeffs, c.a, dk, c.order) * c.w0
        if c.w1 > 0.0:
            v = v + lookup(c.coeffs, c.b, dk, c.order) * c.w1
        acc = acc + v
        dk = dk + c.stride
    return acc


#: Σ over the impacts q with x − q in [lo, hi] of the pixel's lookups (see impacts.cell_walk),
#: three channels and one.
sum_lookups = cell_walk(add_lookups, "sum_lookups")
sum_lookups1 = cell_walk(add_lookups, "sum_lookups1", zero=wp.float32)


@wp.func
def pyramid_lookup(pyr: Pyramid):
    look = PyramidLookup()
    look.coeffs = pyr.coeffs
    return look


@wp.func
def pyramid_lookup(pyr: Pyramid1):  # noqa: F811 (a Warp overload)
    look = PyramidLookup1()
    look.coeffs = pyr.coeffs
    return look


@wp.func
def sum_pyramid(x: wp.vec2d, lo: wp.vec2, hi: wp.vec2, cells: Any, look: PyramidLookup):
    return sum_lookups(x, lo, hi, cells, look)


@wp.func
def sum_pyramid(x: wp.vec2d, lo: wp.vec2, hi: wp.vec2, cells: Any, look: PyramidLookup1):  # noqa: F811
    return sum_lookups1(x, lo, hi, cells, look)


@wp.func
def mean_of(p: NoiseParams, pyr: Pyramid):
    return p.mean


@wp.func
def mean_of(p: NoiseParams, pyr: Pyramid1):  # noqa: F811 (a Warp overload)
    return p.mean[0]


@wp.func
def filtered_normalize(acc: wp.vec3, p: NoiseParams, n: int, real: float):
    a = acc / float(n)
    return p.mean + (a - p.integral * (p.lam * real)) / wp.sqrt(p.lam)


@wp.func
def filtered_normalize(acc: float, p: NoiseParams, n: int, real: float):  # noqa: F811 (a Warp overload)
    # the vec3 form's operations on the first channel
    a = acc / float(n)
    return p.mean[0] + (a - p.integral[0] * (p.lam * real)) / wp.sqrt(p.lam)


@wp.func
def footprint_lookups(f: Filter, J: wp.mat22):
    # The filter's choice for the footprint J: (major length, unit major axis,
    # lookups n, MIP level ≥ 0 before the fade), as filtering.footprint_levels
    # computes it on the host.
    major, minor, axis = footprint_axes(J)
    n = int(1)
    width = major
    if f.mode == ANISOTROPIC:
        if major > minor * float(f.max_aniso):
            n = f.max_aniso
        elif minor > 0.0:
            n = int(wp.ceil(major / minor - 1.0e-4))
        n = wp.max(n, 1)
        width = wp.max(minor, major / float(n))
    lod = 0.0
    if width > 0.0:
        lod = wp.max(wp.log2(width) + f.lod_bias, 0.0)
    return major, axis, n, lod


@wp.struct
class FilteredNoise:
    """Texton noise filtered for a footprint, as a kernel evaluates it (the device API).

    Filled on the host by :func:`warp_texton.runtimes.warp_api.pack_filtered`; its arrays
    live on the device it was packed for.

    Attributes
    ----------
    params : NoiseParams
        The noise settings, as in ``PlaneNoise``.
    pyramid : Pyramid
        The texton's MIP levels (block means of the coefficients, padded and
        stacked) with their boxes, steps and origins, and the number of levels
        the filter keeps (:func:`warp_texton.noise.filtering.kept_levels`).
    filter : Filter
        The filter's mode (``MIP`` or ``ANISOTROPIC``), ``max_aniso`` and level bias.
    """

    params: NoiseParams
    pyramid: Pyramid
    filter: Filter


@wp.func
def filtered_sum(noise: Any, x: wp.vec2d, J: wp.mat22):
    # filtered_value of a FilteredNoise (vec3) or a FilteredNoise1 (float)
    p = noise.params
    pyr = noise.pyramid
    major, axis, n, lod = footprint_lookups(noise.filter, J)
    # past the kept levels (or not finite): the mean; compared as floats before
    # any int conversion
    if lod >= float(pyr.levels) or wp.isnan(lod):
        return mean_of(p, pyr)
    l0 = int(wp.floor(lod))
    frac = lod - float(l0)
    l1 = wp.min(l0 + 1, pyr.levels - 1)
    w0 = 1.0 - frac
    w1 = frac
    real = 1.0  # weight of the real levels; the rest goes to the mean
    if l0 + 1 >= pyr.levels:
        w1 = 0.0
        real = w0
    if frac == 0.0:
        w1 = 0.0
    if w1 == 0.0:
        l1 = l0  # one level: keep its (smaller) box
    # lookups at x + δ_k, δ_k = axis · major · ((k + ½)/n − ½)
    spread = axis * (major * (0.5 - 0.5 / float(n)))
    first = -spread
    stride = wp.vec2(0.0)
    if n > 1:
        stride = spread * (2.0 / float(n - 1))
    # impacts that any lookup can see: the union of the level boxes, grown by the spread
    box_lo = wp.min(pyr.lo[l0], pyr.lo[l1])
    box_hi = wp.max(pyr.hi[l0], pyr.hi[l1])
    ext = wp.vec2(wp.abs(spread[0]), wp.abs(spread[1]))
    lo = box_lo - ext
    hi = box_hi + ext
    look = pyramid_lookup(pyr)
    look.order = pyr.order
    look.a = level_params(pyr, l0)
    look.b = level_params(pyr, l1)
    look.w0 = w0
    look.w1 = w1
    look.first = first
    look.stride = stride
    look.n = n
    look.box_lo = box_lo
    look.box_hi = box_hi
    return filtered_normalize(sum_pyramid(x, lo, hi, p.cells, look), p, n, real)


@wp.func
def filtered_value(noise: FilteredNoise, x: wp.vec2d, J: wp.mat22) -> wp.vec3:
    """Texton noise at the texel-space point ``x`` averaged over the footprint ``J`` (CGF §5).

    The columns of ``J`` are the texel-space steps of one pixel along its two
    axes (the pixel covers x + J [−½, ½]²), as ``synthesize(...,
    jacobian=...)`` takes them, in float32. The lookup width w is the
    footprint's major length ("mip"), or max(minor, major / N) with N =
    min(⌈major / minor⌉, max_aniso) lookups spaced along the major axis
    ("anisotropic"); the level is log2(w) + bias, blended linearly between
    two levels. Past the last kept level the noise fades to its mean. The
    value of ``synthesize`` with a "mip" or "anisotropic" filter at a pixel
    whose centre is ``x`` and footprint ``J``, bit for bit on the same device.
    """
    return filtered_sum(noise, x, J)


@wp.struct
class FilteredNoise1:
    """Filtered texton noise of a one-channel (grey) texton (the device API).

    Filled by :func:`warp_texton.runtimes.warp_api.pack_filtered` with ``channels=1``:
    ``filtered_value`` of it returns a float and reads one float a texel.

    Attributes
    ----------
    params : NoiseParams
        As in ``FilteredNoise``.
    pyramid : Pyramid1
        The texton's MIP levels with float coefficients.
    filter : Filter
        As in ``FilteredNoise``.
    """

    params: NoiseParams
    pyramid: Pyramid1
    filter: Filter


@wp.func
def filtered_value(noise: FilteredNoise1, x: wp.vec2d, J: wp.mat22) -> float:  # noqa: F811 (a Warp overload)
    """Filtered texton noise of a one-channel texton at ``x`` over the footprint
    ``J``: the first component of ``filtered_value`` of the same texton packed as
    three channels, bit for bit."""
    return filtered_sum(noise, x, J)


@wp.func
def filtered_noise(p: NoiseParams, pyr: Pyramid, f: Filter):
    noise = FilteredNoise()
    noise.params = p
    noise.pyramid = pyr
    noise.filter = f
    return noise


@wp.func
def filtered_noise(p: NoiseParams, pyr: Pyramid1, f: Filter):  # noqa: F811 (a Warp overload)
    noise = FilteredNoise1()
    noise.params = p
    noise.pyramid = pyr
    noise.filter = f
    return noise


@wp.kernel
def filtered_points(
    p: NoiseParams,
    pyr: Any,
    f: Filter,
    points: wp.array(dtype=wp.vec2d),
    jac: wp.array(dtype=wp.mat22),
    jac_stride: int,
    out: wp.array(dtype=Any),
):
    """Filtered noise at points (texel units) with footprints ``jac[t * jac_stride]``:
    ``filtered_value``, the device API's function, at each point (one channel or three)."""
    t = wp.tid()
    out[t] = filtered_value(filtered_noise(p, pyr, f), points[t], jac[t * jac_stride])


wp.overload(filtered_points, {"pyr": Pyramid, "out": wp.array(dtype=wp.vec3)})
wp.overload(filtered_points, {"pyr": Pyramid1, "out": wp.array(dtype=float)})
