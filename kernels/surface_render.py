"""Ray-cast renders of meshes textured with surface noise (warp_texton/surface/render.py).

``cast_rays`` finds each pixel's hit (``wp.mesh_query_ray`` on a BVH in world
units around the mesh's centre), ``hit_points`` places the hits in float64
texel units for the surface noise (kernels/surface_points.py), and ``fill_image`` and
``shade_hits`` compose the image. These kernels run together, apart from the
noise's, so a render does not recompile with the surface kernels.

Driven by: ``warp_texton.surface.render``.
"""

from typing import Any

import warp as wp

wp.set_module_options({"enable_backward": False, "optimization_level": 3})

@wp.struct
class Camera:
    origin: wp.vec3  # world units, relative to the mesh's local origin
    right: wp.vec3
    up: wp.vec3
    forward: wp.vec3
    tan_half_fov: float  # vertical
    aspect: float  # width / height
    light: wp.vec3  # unit direction towards the light


@wp.kernel
def cast_rays(
    mesh: wp.uint64,
    corner_normals: wp.array(dtype=wp.vec3),
    cam: Camera,
    height: int,
    width: int,
    row0: int,
    col0: int,
    faces: wp.array2d(dtype=wp.int32),
    bary: wp.array2d(dtype=wp.vec2),
    normals: wp.array2d(dtype=wp.vec3),
    shade: wp.array2d(dtype=float),
):
    """Ray-cast one pixel (row0 + i, col0 + j) of a height × width image into
    element (i, j) of the outputs: the face hit (−1 for none), the barycentric
    weights of its first two vertices, the shading normal and the diffuse shade
    (zeros where nothing is hit). The shading normal interpolates the face's corner
    normals (corner k of face f at 3 f + k: split at creases on the host,
    warp_texton/surface/mesh.py ``corner_normals``). The mesh and the camera are in world units
    relative to a local origin (the host adds it back in float64)."""
    i, j = wp.tid()
    sx = (2.0 * (float(j + col0) + 0.5) / float(width) - 1.0) * cam.tan_half_fov * cam.aspect
    sy = (1.0 - 2.0 * (float(i + row0) + 0.5) / float(height)) * cam.tan_half_fov
    d = wp.normalize(cam.forward + cam.right * sx + cam.up * sy)
    q = wp.mesh_query_ray(mesh, cam.origin, d, 1.0e30)
    if not q.result:
        faces[i, j] = -1
        bary[i, j] = wp.vec2(0.0)
        normals[i, j] = wp.vec3(0.0)
        shade[i, j] = 0.0
        return
    f = q.face
    n = (corner_normals[3 * f] * q.u + corner_normals[3 * f + 1] * q.v
         + corner_normals[3 * f + 2] * (1.0 - q.u - q.v))
    if wp.length(n) < 1.0e-6:
        n = q.normal
    n = wp.normalize(n)
    faces[i, j] = f
    bary[i, j] = wp.vec2(q.u, q.v)
    normals[i, j] = n
    shade[i, j] = 0.3 + 0.7 * wp.abs(wp.dot(n, cam.light))


@wp.kernel
def hit_points(pixels: wp.array(dtype=wp.int32), face: wp.array(dtype=wp.int32), bary: wp.array(dtype=wp.vec2),
               normal: wp.array(dtype=wp.vec3), vertices: wp.array(dtype=wp.vec3d), faces: wp.array(dtype=wp.int32),
               texel: wp.float64, points: wp.array(dtype=wp.vec3d), normals: wp.array(dtype=wp.vec3)):
    """The hit of pixel pixels[k] (flat index into the ray cast's arrays) in float64
    texel units, from its face's vertices and weights (u, v, 1 − u − v), and its
    shading normal."""
    k = wp.tid()
    q = pixels[k]
    f = face[q]
    uv = bary[q]
    u = wp.float64(uv[0])
    v = wp.float64(uv[1])
    w = wp.float64(1.0) - u - v
    y = vertices[faces[3 * f]] * u + vertices[faces[3 * f + 1]] * v + vertices[faces[3 * f + 2]] * w
    points[k] = y / texel
    normals[k] = normal[q]


@wp.kernel
def fill_image(img: wp.array2d(dtype=wp.vec3), background: wp.vec3):
    i, j = wp.tid()
    img[i, j] = background


@wp.func
def spread(v: wp.vec3, grey: int):
    # grey noise, in channel 0, spread to RGB
    if grey != 0:
        return wp.vec3(v[0], v[0], v[0])
    return v


@wp.func
def spread(v: float, grey: int):  # noqa: F811 (a Warp overload: a one-channel value)
    return wp.vec3(v, v, v)


@wp.kernel
def shade_hits(pixels: wp.array(dtype=wp.int32), values: wp.array(dtype=Any), shade: wp.array(dtype=float),
               box_width: int, row0: int, col0: int, grey: int, img: wp.array2d(dtype=wp.vec3)):
    """Pixel pixels[k] (flat index into the ray cast's box) of the render: its noise
    value clipped to [0, 1] times its shade (grey noise, in channel 0 or as one
    float a pixel, spread to RGB)."""
    k = wp.tid()
    q = pixels[k]
    g = spread(values[k], grey)
    s = shade[q]
    img[row0 + q / box_width, col0 + q % box_width] = wp.vec3(wp.clamp(g[0], 0.0, 1.0) * s,
                                                              wp.clamp(g[1], 0.0, 1.0) * s,
                                                              wp.clamp(g[2], 0.0, 1.0) * s)


for _lanes in (float, wp.vec3):
    wp.overload(shade_hits, {"values": wp.array(dtype=_lanes)})

__all__ = ["Camera", "cast_rays", "fill_image", "hit_points", "shade_hits"]
