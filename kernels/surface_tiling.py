"""Tiling and blending on surfaces without UVs: triplanar projection of ``tiling_value``.

A surface point p (texel units, float64) with unit normal n sees the planar
tiling of ``kernels/noise_tiling.py`` in the three planes orthogonal to the
frame's axes (right e1, front e2 = up × right, up e3), each plane with its own
``Tiling`` (the same example, an independent seed). Plane k is weighted by
|⟨n, e_k⟩| raised to 2^squarings (sharpened, as the tiling's own barycentric
weights), weights below CUTOFF × the largest dropped, then normalised; the
planes are blended like the tiling's patches: variance-preserving
(μ + Σ k (v − μ) / √(Σ k²)) or linear. Where one plane alone has weight (a
face orthogonal to an axis) the value is that plane's ``tiling_value``, bit for bit.

Each plane's coordinates keep the example upright and unmirrored seen from
outside (x to the right, y down in the example): the floor (n along +e3) reads
(⟨p, e1⟩, −⟨p, e2⟩), the ceiling (⟨p, e1⟩, ⟨p, e2⟩); walls read y = −⟨p, e3⟩
(the example's up is the world's up) and x = ±⟨p, e2⟩ (n along ±e1) or
∓⟨p, e1⟩ (n along ±e2). The sign flips where a plane's weight is 0, so the
blend stays continuous.

Driven by: ``warp_texton.surface.tiling``.
"""

import warp as wp

from .noise_tiling import Tiling, tiling_value

wp.set_module_options({"enable_backward": False, "optimization_level": 3})

#: Plane weights below this fraction of the largest are zero (those planes are not read), as the
#: tiling drops its patches' (noise_tiling.CUTOFF).
CUTOFF = wp.constant(1.0e-4)


@wp.struct
class Triplanar:
    right: wp.vec3d  # e1 (float64: positions are projected exactly)
    front: wp.vec3d  # e2 = e3 × e1
    up: wp.vec3d  # e3
    right32: wp.vec3  # the same axes in float32, for the normals
    front32: wp.vec3
    up32: wp.vec3
    squarings: int  # the weights' exponent is 2^squarings
    variance_preserving: int  # 1: the tiling's variance-preserving blend; 0: linear
    mean: wp.vec3  # the example's mean colour (the planes' Tiling.mean)


@wp.func
def plane_weight(c: float, squarings: int):
    # |c|^(2^squarings) by repeated squaring (float32 products), as the tiling sharpens its weights
    r = wp.abs(c)
    for i in range(squarings):
        r = r * r
    return r


@wp.func
def triplanar_value(tx: Tiling, ty: Tiling, tz: Tiling, f: Triplanar, p: wp.vec3d, n: wp.vec3):
    # the tiling on a surface at p (texel units) with unit normal n: three planes blended by the normal
    p1 = wp.dot(p, f.right)
    p2 = wp.dot(p, f.front)
    p3 = wp.dot(p, f.up)
    c1 = wp.dot(n, f.right32)
    c2 = wp.dot(n, f.front32)
    c3 = wp.dot(n, f.up32)
    k1 = plane_weight(c1, f.squarings)
    k2 = plane_weight(c2, f.squarings)
    k3 = plane_weight(c3, f.squarings)
    km = wp.max(k1, wp.max(k2, k3)) * CUTOFF
    if k1 < km:
        k1 = 0.0
    if k2 < km:
        k2 = 0.0
    if k3 < km:
        k3 = 0.0
    # walls: the example's up along the world's up; the floor and ceiling unmirrored from outside
    x1 = wp.vec2d(p2, -p3)
    if c1 < 0.0:
        x1 = wp.vec2d(-p2, -p3)
    x2 = wp.vec2d(-p1, -p3)
    if c2 < 0.0:
        x2 = wp.vec2d(p1, -p3)
    x3 = wp.vec2d(p1, -p2)
    if c3 < 0.0:
        x3 = wp.vec2d(p1, p2)
    # one plane alone (a face orthogonal to an axis): its tiling, bit for bit
    if k1 == 0.0 and k2 == 0.0:
        return tiling_value(tz, x3)
    if k1 == 0.0 and k3 == 0.0:
        return tiling_value(ty, x2)
    if k2 == 0.0 and k3 == 0.0:
        return tiling_value(tx, x1)
    total = k1 + k2 + k3
    k1 = k1 / total
    k2 = k2 / total
    k3 = k3 / total
    acc = wp.vec3(0.0)
    if k1 > 0.0:
        acc = acc + (tiling_value(tx, x1) - f.mean) * k1
    if k2 > 0.0:
        acc = acc + (tiling_value(ty, x2) - f.mean) * k2
    if k3 > 0.0:
        acc = acc + (tiling_value(tz, x3) - f.mean) * k3
    if f.variance_preserving != 0:
        acc = acc / wp.sqrt(k1 * k1 + k2 * k2 + k3 * k3)
    return f.mean + acc


@wp.kernel
def triplanar_points(tx: Tiling, ty: Tiling, tz: Tiling, f: Triplanar, pos: wp.array(dtype=wp.vec3d),
                     nrm: wp.array(dtype=wp.vec3), out: wp.array(dtype=wp.vec3)):
    k = wp.tid()
    out[k] = triplanar_value(tx, ty, tz, f, pos[k], nrm[k])
