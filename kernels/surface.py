"""Surface texton noise (CGF §6): a 3-D hashed-cell Poisson process projected on
tangent planes, evaluated at points and in a ray-cast renderer.

Units are texels: the host divides world positions by the texel size. The
impacts are those of the cubic cells of kernels/impacts.py (the plane's hash
with a third coordinate and a domain tag, so the two processes are
independent). At a point y with frame (u1, u2, n)
an impact x adds (1 − 2|⟨y − x, n⟩|/r)⁺ h_c(⟨y − x, u1⟩, ⟨y − x, u2⟩), where
h_c is the texton centred on its support and r the slab thickness (the
support's larger side).
"""

import warp as wp

from .impacts import Cells3, cell_walk3
from .noise2d import PAD, texton_value

wp.set_module_options({"enable_backward": False, "optimization_level": 3})


@wp.struct
class SurfaceParams:
    cells: Cells3  # the 3-D Poisson process of impacts
    order: int
    half: float  # r / 2
    centre: wp.vec2  # centre of the texton support in texton coordinates
    lo: wp.vec2  # texton support, texton coordinates
    hi: wp.vec2
    shift: wp.vec3  # λ (r/2) ∫h: the mean of the raw sum (CGF Prop. 3)
    inv_scale: float  # 1 / √(λ r / 3)
    mean: wp.vec3
    up: wp.vec3  # the frame rule's directions a and b
    side: wp.vec3


@wp.func
def tangent_frame(n: wp.vec3, a: wp.vec3, b: wp.vec3):
    """u1 from the rule v = P_n(a) + ⟨a, n⟩⁴ P_n(b), P_n the tangent projection.

    v is continuous in n and vanishes only at isolated normals (a closed
    surface must have such points); where it does, b's projection (or any
    direction) stands in. Returns (u1, u2 = n × u1).
    """
    ca = wp.dot(a, n)
    c4 = ca * ca * ca * ca
    v = (a - n * ca) + (b - n * wp.dot(b, n)) * c4
    length = wp.length(v)
    if length < 1.0e-6:
        v = b - n * wp.dot(b, n)
        length = wp.length(v)
        if length < 1.0e-6:
            v = wp.cross(n, a)
            length = wp.length(v)
    u1 = v / length
    return u1, wp.cross(n, u1)


@wp.struct
class SlabLookup:
    # the point's frame and the texton, centred on its support
    coeffs: wp.array2d(dtype=wp.vec3)
    u1: wp.vec3
    u2: wp.vec3
    n: wp.vec3
    half: float
    centre: wp.vec2
    lo: wp.vec2
    hi: wp.vec2
    order: int


@wp.func
def add_slab(c: SlabLookup, d: wp.vec3, acc: wp.vec3):
    # an impact within r/2 of the tangent plane adds (1 − 2|⟨d, n⟩|/r) h_c(⟨d, u1⟩, ⟨d, u2⟩)
    t = wp.dot(d, c.n)
    if wp.abs(t) < c.half:
        z = wp.vec2(wp.dot(d, c.u1), wp.dot(d, c.u2)) + c.centre
        if z[0] >= c.lo[0] and z[0] <= c.hi[0] and z[1] >= c.lo[1] and z[1] <= c.hi[1]:
            acc = acc + texton_value(c.coeffs, 0, c.coeffs.shape[0], z, c.order) * (1.0 - wp.abs(t) / c.half)
    return acc


#: Σ of the slab contributions over the impacts of the cubes near a point (see impacts.cell_walk3).
sum_slab = cell_walk3(add_slab, "sum_slab")


@wp.func
def surface_value(p: SurfaceParams, coeffs: wp.array2d(dtype=wp.vec3), y: wp.vec3, u1: wp.vec3, u2: wp.vec3,
                  n: wp.vec3):
    # the rotated cube of side r around y lies in this axis-aligned box
    ext = wp.vec3(
        p.half * (wp.abs(u1[0]) + wp.abs(u2[0]) + wp.abs(n[0])),
        p.half * (wp.abs(u1[1]) + wp.abs(u2[1]) + wp.abs(n[1])),
        p.half * (wp.abs(u1[2]) + wp.abs(u2[2]) + wp.abs(n[2])),
    )
    look = SlabLookup()
    look.coeffs = coeffs
    look.u1 = u1
    look.u2 = u2
    look.n = n
    look.half = p.half
    look.centre = p.centre
    look.lo = p.lo
    look.hi = p.hi
    look.order = p.order
    acc = sum_slab(y, ext, p.cells, look)
    return p.mean + (acc - p.shift) * p.inv_scale


@wp.kernel
def evaluate_surface(
    p: SurfaceParams,
    coeffs: wp.array2d(dtype=wp.vec3),
    points: wp.array(dtype=wp.vec3),
    normals: wp.array(dtype=wp.vec3),
    tangents: wp.array(dtype=wp.vec3),
    use_tangents: int,
    out: wp.array(dtype=wp.vec3),
):
    """Surface noise at points (texel units) with unit normals; frames from the
    rule, or from given tangents (already orthogonal to the normals, unit)."""
    k = wp.tid()
    n = normals[k]
    u1 = wp.vec3(0.0)
    u2 = wp.vec3(0.0)
    if use_tangents != 0:
        u1 = tangents[k]
        u2 = wp.cross(n, u1)
    else:
        u1, u2 = tangent_frame(n, p.up, p.side)
    out[k] = surface_value(p, coeffs, points[k], u1, u2, n)


@wp.struct
class Camera:
    origin: wp.vec3  # texel units
    right: wp.vec3
    up: wp.vec3
    forward: wp.vec3
    tan_half_fov: float  # vertical
    aspect: float  # width / height
    light: wp.vec3  # unit direction towards the light
    background: wp.vec3


@wp.kernel
def render_surface(
    p: SurfaceParams,
    coeffs: wp.array2d(dtype=wp.vec3),
    mesh: wp.uint64,
    vertex_normals: wp.array(dtype=wp.vec3),
    indices: wp.array(dtype=wp.int32),
    cam: Camera,
    row0: int,
    out: wp.array2d(dtype=wp.vec3),
):
    """Ray-cast one pixel: surface noise at the hit, simple diffuse shading."""
    i, j = wp.tid()
    i = i + row0
    h = out.shape[0]
    w = out.shape[1]
    sx = (2.0 * (float(j) + 0.5) / float(w) - 1.0) * cam.tan_half_fov * cam.aspect
    sy = (1.0 - 2.0 * (float(i) + 0.5) / float(h)) * cam.tan_half_fov
    d = wp.normalize(cam.forward + cam.right * sx + cam.up * sy)
    q = wp.mesh_query_ray(mesh, cam.origin, d, 1.0e30)
    if not q.result:
        out[i, j] = cam.background
        return
    f = q.face
    n = (vertex_normals[indices[3 * f]] * q.u + vertex_normals[indices[3 * f + 1]] * q.v
         + vertex_normals[indices[3 * f + 2]] * (1.0 - q.u - q.v))
    # smooth normals, except across creases: where the interpolated normal leaves
    # the face's by more than 30°, the face normal keeps flat faces flat
    if wp.length(n) < 1.0e-6:
        n = q.normal
    n = wp.normalize(n)
    if wp.dot(n, q.normal) < 0.866:
        n = q.normal
    y = cam.origin + d * q.t
    u1, u2 = tangent_frame(n, p.up, p.side)
    colour = surface_value(p, coeffs, y, u1, u2, n)
    shade = 0.3 + 0.7 * wp.abs(wp.dot(n, cam.light))
    out[i, j] = wp.vec3(wp.clamp(colour[0], 0.0, 1.0), wp.clamp(colour[1], 0.0, 1.0),
                        wp.clamp(colour[2], 0.0, 1.0)) * shade


__all__ = ["PAD", "SurfaceParams", "Camera", "evaluate_surface", "render_surface", "tangent_frame"]
