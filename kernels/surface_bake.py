"""Rasterising a mesh's UV layout: which triangle owns each texel of a texture.

Texel (i, j) of an H × W texture has its centre at (j + ½, i + ½) in texel
coordinates (x = u W, y = (1 − v) H: row 0 is the top of the image, where
v = 1). A texel belongs to the triangles whose UV triangle holds its centre
with the top-left rule for centres exactly on an edge: an edge shared by two
triangles is walked in opposite directions by them, so exactly one takes the
centre. Of several triangles (overlapping UVs), the highest face index wins
(an atomic max, so the result does not depend on thread timing), and ``cover``
counts them all, which is how overlapping UVs are detected.

:func:`texel_faces` gives each baked texel its face's affine map (texel coordinates → barycentric
weights), its 3-D corners and unit normal and the texel's footprint on the surface; :func:`sample_points` places a bake's samples on the surface: the texel's offsets mapped through its
face's affine map (texel coordinates → barycentric weights → 3-D point) and the renderer's normal there,
in float64 with the operations in the order the NumPy form had (the bake's values did not move).

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


@wp.func
def norm3(v: wp.vec3d):
    # the square root of the squares summed in order (NumPy's norm over three components)
    return wp.sqrt((v[0] * v[0] + v[1] * v[1]) + v[2] * v[2])


@wp.func
def cross3(a: wp.vec3d, b: wp.vec3d):
    # NumPy's cross product: each component a product minus a product, in its order
    return wp.vec3d(a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


@wp.kernel
def sample_points(
    texels: wp.array(dtype=wp.int64),
    offsets: wp.array(dtype=wp.vec2d),
    cols: wp.array(dtype=wp.int64),
    rows: wp.array(dtype=wp.int64),
    a2: wp.array(dtype=wp.vec2d),
    inv: wp.array(dtype=wp.mat22d),
    p3: wp.array2d(dtype=wp.vec3d),
    faces: wp.array(dtype=wp.int64),
    cnormals: wp.array2d(dtype=wp.vec3d),
    fn: wp.array(dtype=wp.vec3d),
    texel: wp.float64,
    first: int,
    pts: wp.array(dtype=wp.vec3d),
    nrm: wp.array(dtype=wp.vec3d),
):
    """Sample t = first + tid: offset t mod S of texel ``texels[t // S]`` (S offsets from the texel's
    centre, in texels); its point in texton texels and its unit normal (the face's corner normals
    interpolated, the face normal where they vanish). Samples past the face's edges extrapolate on
    its plane (the texel's footprint on the tangent plane)."""
    t = wp.tid() + first
    n_off = offsets.shape[0]
    k = texels[t // n_off]
    o = offsets[t % n_off]
    half = wp.float64(0.5)
    qx = (wp.float64(cols[k]) + half + o[0]) - a2[k][0]
    qy = (wp.float64(rows[k]) + half + o[1]) - a2[k][1]
    m = inv[k]
    w1 = m[0, 0] * qx + m[0, 1] * qy
    w2 = m[1, 0] * qx + m[1, 1] * qy
    w0 = (wp.float64(1.0) - w1) - w2
    p = (p3[k, 0] * w0 + p3[k, 1] * w1) + p3[k, 2] * w2
    pts[t] = p / texel
    f = faces[k]
    n = (cnormals[f, 0] * w0 + cnormals[f, 1] * w1) + cnormals[f, 2] * w2
    length = norm3(n)
    if length > wp.float64(1e-6):
        nrm[t] = n / length
    else:
        nrm[t] = fn[k]


@wp.kernel
def texel_faces(
    owner: wp.array(dtype=wp.int64),
    faces: wp.array2d(dtype=wp.int64),
    corners: wp.array(dtype=wp.vec2d),
    vertices: wp.array(dtype=wp.vec3d),
    cnormals: wp.array2d(dtype=wp.vec3d),
    texel: wp.float64,
    first: int,
    a2: wp.array(dtype=wp.vec2d),
    inv: wp.array(dtype=wp.mat22d),
    p3: wp.array2d(dtype=wp.vec3d),
    fn: wp.array(dtype=wp.vec3d),
    footprint: wp.array(dtype=wp.vec3d),
):
    """Texel t = first + tid of face ``owner[t]``: the face's first UV corner, the inverse of its UV
    edge matrix, its 3-D corners, its unit normal (the first corner normal where the face has no
    area) and the texel's footprint in texton texels (side along x, side along y, area)."""
    t = wp.tid() + first
    f = owner[t]
    c = wp.int64(3) * f
    a = corners[c]
    e1 = corners[c + wp.int64(1)] - a
    e2 = corners[c + wp.int64(2)] - a
    det = e1[0] * e2[1] - e1[1] * e2[0]
    a2[t] = a
    m = wp.mat22d(e2[1] / det, -e2[0] / det, -e1[1] / det, e1[0] / det)
    inv[t] = m
    p0 = vertices[faces[f, 0]]
    p1 = vertices[faces[f, 1]]
    p2 = vertices[faces[f, 2]]
    p3[t, 0] = p0
    p3[t, 1] = p1
    p3[t, 2] = p2
    d1 = p1 - p0
    d2 = p2 - p0
    n = cross3(d1, d2)
    length = norm3(n)
    if length > wp.float64(0.0):
        fn[t] = n / length
    else:
        fn[t] = cnormals[f, 0]
    # d(point)/d(texel x) and d(point)/d(texel y): the footprint's sides
    jx = (d1 * m[0, 0] + d2 * m[1, 0]) / texel
    jy = (d1 * m[0, 1] + d2 * m[1, 1]) / texel
    footprint[t] = wp.vec3d(norm3(jx), norm3(jy), norm3(cross3(jx, jy)))


__all__ = ["claim_texels", "sample_points", "texel_faces"]
