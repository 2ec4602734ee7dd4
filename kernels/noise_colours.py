"""Histogram transforms on the device: noise values mapped to an example's colours.

A texton analysed with ``histogram="preserve"`` synthesises Gaussian values;
its :class:`~warp_texton.model.histogram.HistogramTransform` maps them back: a value
v is standardised with the noise's own moments, g = (v − m) / σ, each channel
is looked up in its inverse-CDF table (linear between the entries of a
Gaussian grid, clamped past it), and the result is rotated back to colours,
z M + centre. A filtered value keeps a share s of the noise's variance and is
looked up in the tables prefiltered for s (two rows around it, blended
linearly); the share of a footprint J is read from the texton's table of
shares over the footprint's two extents and the angle of its major axis
(docs/histogram.md). The host maps every output's values with these
functions (``warp_texton.noise.colours``), so a user's kernel that calls them gives
the package's colours.

Driven by: ``warp_texton.noise.colours``, ``warp_texton.runtimes.warp_api``.
"""

import warp as wp

from .noise_filter import Filter, FilteredNoise, filtered_value, footprint_lookups

wp.set_module_options({"enable_backward": False, "optimization_level": 3})

PI = wp.constant(3.14159265358979)


@wp.struct
class ColourMap:
    """A texton's histogram transform as a kernel applies it (the device API).

    Filled on the host by :func:`warp_texton.runtimes.warp_api.pack_colours`; its arrays
    live on the device it was packed for.

    Attributes
    ----------
    enabled : int
        0 for a texton without a transform: the functions return the values.
    channels : int
        1 or 3; the other components of a value pass through.
    matrix : wp.mat33
        The principal axes as rows (colour = z M + centre).
    centre, mean, std : wp.vec3
        The example's mean colour; the noise's mean and standard deviation per channel.
    tables : wp.array3d(dtype=float)
        (S, C, K): row i is the inverse-CDF table prefiltered for the share
        i / (S − 1); row S − 1 is the table itself.
    gauss_range : float
        The tables' Gaussian grid spans [−gauss_range, gauss_range].
    shares : wp.array3d(dtype=float)
        (E, E, A) shares of the variance kept by footprints of extents
        2^(log_first + k log_step) (major, minor) and major-axis angle a π / A.
    log_first, log_step : float
        The extents' grid, in log2 texels.
    """

    enabled: int
    channels: int
    matrix: wp.mat33
    centre: wp.vec3
    mean: wp.vec3
    std: wp.vec3
    tables: wp.array3d(dtype=float)
    gauss_range: float
    shares: wp.array3d(dtype=float)
    log_first: float
    log_step: float


@wp.func
def table_value(cmap: ColourMap, row: int, c: int, g: float) -> float:
    # table row `row` of channel c at the Gaussian value g, linear, clamped
    k = cmap.tables.shape[2]
    pos = wp.clamp((g + cmap.gauss_range) * (float(k - 1) / (2.0 * cmap.gauss_range)), 0.0, float(k - 1))
    i0 = wp.min(int(pos), k - 2)
    t = pos - float(i0)
    return cmap.tables[row, c, i0] * (1.0 - t) + cmap.tables[row, c, i0 + 1] * t


@wp.func
def mapped(cmap: ColourMap, v: wp.vec3, j0: int, ts: float) -> wp.vec3:
    # rows j0 and j0 + 1 blended by ts (ts = 0: row j0 alone)
    z = wp.vec3(0.0)
    for c in range(cmap.channels):
        g = (v[c] - cmap.mean[c]) / cmap.std[c]
        if wp.isnan(g):
            z[c] = g
        else:
            a = table_value(cmap, j0, c, g)
            if ts > 0.0:
                a = a * (1.0 - ts) + table_value(cmap, j0 + 1, c, g) * ts
            z[c] = a
    out = v
    for r in range(cmap.channels):
        acc = cmap.centre[r]
        for c in range(cmap.channels):
            acc = acc + z[c] * cmap.matrix[c, r]
        out[r] = acc
    return out


@wp.func
def colour_value(cmap: ColourMap, v: wp.vec3) -> wp.vec3:
    """The colour of the noise value ``v`` (``plane_value``, ``surface_value``): what
    ``evaluate``, ``synthesize`` and ``surface_noise`` of the texton return for
    the unfiltered noise, bit for bit on the same device."""
    if cmap.enabled == 0:
        return v
    return mapped(cmap, v, cmap.tables.shape[0] - 1, 0.0)


@wp.func
def colour_share(cmap: ColourMap, v: wp.vec3, share: float) -> wp.vec3:
    """The colour of a filtered noise value ``v`` that kept the share ``share`` (in
    [0, 1], clamped) of the noise's variance: the tables prefiltered for it."""
    if cmap.enabled == 0:
        return v
    steps = cmap.tables.shape[0]
    s = wp.clamp(share, 0.0, 1.0)
    if wp.isnan(share):
        s = 0.0
    sp = s * float(steps - 1)
    j0 = wp.min(int(sp), steps - 2)
    return mapped(cmap, v, j0, sp - float(j0))


@wp.func
def extent_index(cmap: ColourMap, extent: float):
    n = cmap.shares.shape[0]
    pos = wp.clamp((wp.log2(extent) - cmap.log_first) / cmap.log_step, 0.0, float(n - 1))
    if wp.isnan(pos):
        pos = 0.0
    i = wp.min(int(pos), n - 2)
    return i, pos - float(i)


@wp.func
def footprint_share(cmap: ColourMap, J: wp.mat22) -> float:
    """The share of the noise's variance kept by a pixel of footprint ``J`` (columns:
    the texel-space steps of one pixel), modelled as a Gaussian filter of J's
    second moments; before the fade of the MIP filters (:func:`filtered_colour`)."""
    s = wp.max(wp.max(wp.abs(J[0, 0]), wp.abs(J[0, 1])), wp.max(wp.abs(J[1, 0]), wp.abs(J[1, 1])))
    if s == 0.0:
        s = 1.0
    K = J / s  # squares that cannot overflow
    m00 = K[0, 0] * K[0, 0] + K[0, 1] * K[0, 1]
    m01 = K[0, 0] * K[1, 0] + K[0, 1] * K[1, 1]
    m11 = K[1, 0] * K[1, 0] + K[1, 1] * K[1, 1]
    half = 0.5 * (m00 + m11)
    disc = wp.sqrt(0.25 * (m00 - m11) * (m00 - m11) + m01 * m01)
    major = s * wp.sqrt(half + disc)
    minor = s * wp.sqrt(wp.max(half - disc, 0.0))
    angle = 0.5 * wp.atan2(2.0 * m01, m00 - m11)
    i, ti = extent_index(cmap, major)
    j, tj = extent_index(cmap, minor)
    na = cmap.shares.shape[2]
    a = angle / PI
    a = a - wp.floor(a)
    pk = a * float(na)
    k = wp.min(int(pk), na - 1)
    tk = pk - float(k)
    k1 = (k + 1) % na
    out = float(0.0)
    for di in range(2):
        wi = 1.0 - ti
        if di == 1:
            wi = ti
        for dj in range(2):
            wj = 1.0 - tj
            if dj == 1:
                wj = tj
            row = cmap.shares[i + di, j + dj, k] * (1.0 - tk) + cmap.shares[i + di, j + dj, k1] * tk
            out = out + wi * wj * row
    return wp.clamp(out, 0.0, 1.0)


@wp.func
def faded_share(f: Filter, levels: int, cmap: ColourMap, J: wp.mat22) -> float:
    # the footprint's share, faded as the filter f fades the noise to its mean
    # within its last kept MIP level (`levels` kept), and 0 past it
    major, axis, n, lod = footprint_lookups(f, J)
    if n == 1 and lod == 0.0:
        return 1.0  # one lookup of level 0 is the unfiltered noise, with all its variance
    fade = wp.clamp(float(levels) - lod, 0.0, 1.0)
    if wp.isnan(lod):
        fade = 0.0
    return footprint_share(cmap, J) * fade * fade


@wp.func
def filtered_share(noise: FilteredNoise, cmap: ColourMap, J: wp.mat22) -> float:
    """The share of the noise's variance that ``filtered_value(noise, x, J)`` keeps: 1
    where the filter makes one lookup of level 0 (the unfiltered noise), else the
    footprint's share (:func:`footprint_share`), faded as the filter fades the noise
    to its mean within its last kept MIP level (0 past it)."""
    return faded_share(noise.filter, noise.pyramid.levels, cmap, J)


@wp.func
def filtered_colour(noise: FilteredNoise, cmap: ColourMap, x: wp.vec2d, J: wp.mat22) -> wp.vec3:
    """The colour of the filtered noise at ``x`` for the footprint ``J``: the pixel of
    ``synthesize(..., filter=..., jacobian=J)`` centred on ``x`` for a texton with a
    histogram transform, bit for bit on the same device."""
    return colour_share(cmap, filtered_value(noise, x, J), filtered_share(noise, cmap, J))


@wp.kernel
def map_values(cmap: ColourMap, values: wp.array(dtype=wp.vec3)):
    i = wp.tid()
    values[i] = colour_value(cmap, values[i])


@wp.kernel
def map_shared_values(cmap: ColourMap, values: wp.array(dtype=wp.vec3), shares: wp.array(dtype=float)):
    i = wp.tid()
    values[i] = colour_share(cmap, values[i], shares[i])


@wp.kernel
def pixel_shares(cmap: ColourMap, J: wp.array(dtype=wp.mat22), fade: int, f: Filter, levels: int,
                 out: wp.array(dtype=float)):
    # fade 1: the MIP filters' shares (faded); 0: the footprint's own (supersampling)
    i = wp.tid()
    if fade == 1:
        out[i] = faded_share(f, levels, cmap, J[i])
    else:
        out[i] = footprint_share(cmap, J[i])
