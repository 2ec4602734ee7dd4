"""Rasterising a mesh's UV layout: which triangle owns each texel of a texture.

Texel (i, j) of an H × W texture has its centre at (j + ½, i + ½) in texel
coordinates (x = u W, y = (1 − v) H: row 0 is the top of the image, where
v = 1). A texel belongs to the triangles whose UV triangle holds its centre
with the top-left rule for centres exactly on an edge: an edge shared by two
triangles is walked in opposite directions by them, so exactly one takes the
centre. Of several triangles (overlapping UVs), the highest face index wins
(an atomic max, so the result does not depend on thread timing), and ``cover``
counts them all, which is how overlapping UVs are detected.

Driven by: ``warp_texton.surface.bake``.
"""

import warp as wp

wp.set_module_options({"enable_backward": False, "optimization_level": 3})


@wp.func
def edge(a: wp.vec2d, b: wp.vec2d, p: wp.vec2d):
    # twice the signed area of (a, b, p): > 0 when p is left of a → b
    return (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0])


@wp.func
def holds(a: wp.vec2d, b: wp.vec2d, p: wp.vec2d):
    # p is on the inner side of edge a → b of a counter-clockwise triangle, or on a top-left edge
    e = edge(a, b, p)
    if e > wp.float64(0.0):
        return True
    if e < wp.float64(0.0):
        return False
    dy = b[1] - a[1]
    return dy < wp.float64(0.0) or (dy == wp.float64(0.0) and b[0] > a[0])


@wp.kernel
def claim_texels(
    corners: wp.array(dtype=wp.vec2d),
    first: int,
    owner: wp.array2d(dtype=wp.int32),
    cover: wp.array2d(dtype=wp.int32),
):
    """Mark the texels whose centres lie in UV triangle f (corners 3f..3f+2, in texel coordinates)."""
    f = wp.tid() + first
    a = corners[3 * f]
    b = corners[3 * f + 1]
    c = corners[3 * f + 2]
    area = edge(a, b, c)
    if area == wp.float64(0.0):
        return  # a degenerate UV triangle covers no texel centre
    if area < wp.float64(0.0):  # walk it counter-clockwise
        t = b
        b = c
        c = t
    h = owner.shape[0]
    w = owner.shape[1]
    half = wp.float64(0.5)
    x0 = wp.max(int(wp.ceil(wp.min(wp.min(a[0], b[0]), c[0]) - half)), 0)
    x1 = wp.min(int(wp.floor(wp.max(wp.max(a[0], b[0]), c[0]) - half)), w - 1)
    y0 = wp.max(int(wp.ceil(wp.min(wp.min(a[1], b[1]), c[1]) - half)), 0)
    y1 = wp.min(int(wp.floor(wp.max(wp.max(a[1], b[1]), c[1]) - half)), h - 1)
    for i in range(y0, y1 + 1):
        for j in range(x0, x1 + 1):
            p = wp.vec2d(wp.float64(j) + half, wp.float64(i) + half)
            if holds(a, b, p) and holds(b, c, p) and holds(c, a, p):
                wp.atomic_max(owner, i, j, f)
                wp.atomic_add(cover, i, j, 1)


__all__ = ["claim_texels"]
