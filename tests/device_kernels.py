"""A user's Warp kernels, written only from the public device API (warp_texton.runtimes.warp_api).

They live in a module of their own, as a user's kernels do: Warp compiles the
device API's functions into this module. tests/test_device_api.py launches them.
"""

import warp as wp

from warp_texton.runtimes import warp_api as td


@wp.kernel
def plane_at(noise: td.PlaneNoise, points: wp.array(dtype=wp.vec2d), out: wp.array(dtype=wp.vec3)):
    t = wp.tid()
    out[t] = td.plane_value(noise, points[t])


@wp.kernel
def plane_grey_at(noise: td.PlaneNoise1, points: wp.array(dtype=wp.vec2d), out: wp.array(dtype=float)):
    t = wp.tid()
    out[t] = td.plane_value(noise, points[t])


@wp.kernel
def filtered_at(noise: td.FilteredNoise, points: wp.array(dtype=wp.vec2d), footprints: wp.array(dtype=wp.mat22),
                out: wp.array(dtype=wp.vec3)):
    t = wp.tid()
    out[t] = td.filtered_value(noise, points[t], footprints[t])


@wp.kernel
def filtered_grey_at(noise: td.FilteredNoise1, points: wp.array(dtype=wp.vec2d),
                     footprints: wp.array(dtype=wp.mat22), out: wp.array(dtype=float)):
    t = wp.tid()
    out[t] = td.filtered_value(noise, points[t], footprints[t])


@wp.kernel
def surface_at(noise: td.SurfaceNoise, points: wp.array(dtype=wp.vec3d), normals: wp.array(dtype=wp.vec3d),
               out: wp.array(dtype=wp.vec3)):
    t = wp.tid()
    out[t] = td.surface_value(noise, points[t], normals[t])


@wp.kernel
def surface_frame_at(noise: td.SurfaceNoise, points: wp.array(dtype=wp.vec3d), normals: wp.array(dtype=wp.vec3),
                     tangents: wp.array(dtype=wp.vec3), out: wp.array(dtype=wp.vec3)):
    t = wp.tid()
    out[t] = td.surface_frame_value(noise, points[t], normals[t], tangents[t])


@wp.kernel
def surface_grey_at(noise: td.SurfaceNoise1, points: wp.array(dtype=wp.vec3d), normals: wp.array(dtype=wp.vec3d),
                    out: wp.array(dtype=float)):
    t = wp.tid()
    out[t] = td.surface_value(noise, points[t], normals[t])


@wp.kernel
def surface_frame_grey_at(noise: td.SurfaceNoise1, points: wp.array(dtype=wp.vec3d),
                          normals: wp.array(dtype=wp.vec3), tangents: wp.array(dtype=wp.vec3),
                          out: wp.array(dtype=float)):
    t = wp.tid()
    out[t] = td.surface_frame_value(noise, points[t], normals[t], tangents[t])


@wp.kernel
def plane_colour_at(noise: td.PlaneNoise, cmap: td.ColourMap, points: wp.array(dtype=wp.vec2d),
                    out: wp.array(dtype=wp.vec3)):
    t = wp.tid()
    out[t] = td.colour_value(cmap, td.plane_value(noise, points[t]))


@wp.kernel
def filtered_colour_at(noise: td.FilteredNoise, cmap: td.ColourMap, points: wp.array(dtype=wp.vec2d),
                       footprints: wp.array(dtype=wp.mat22), out: wp.array(dtype=wp.vec3)):
    t = wp.tid()
    out[t] = td.filtered_colour(noise, cmap, points[t], footprints[t])


@wp.kernel
def surface_colour_at(noise: td.SurfaceNoise, cmap: td.ColourMap, points: wp.array(dtype=wp.vec3d),
                      normals: wp.array(dtype=wp.vec3d), out: wp.array(dtype=wp.vec3)):
    t = wp.tid()
    out[t] = td.colour_value(cmap, td.surface_value(noise, points[t], normals[t]))


@wp.kernel
def shares_at(noise: td.FilteredNoise, cmap: td.ColourMap, footprints: wp.array(dtype=wp.mat22),
              out: wp.array(dtype=float)):
    t = wp.tid()
    out[t] = td.filtered_share(noise, cmap, footprints[t])


@wp.kernel
def tiling_at(t: td.Tiling, points: wp.array(dtype=wp.vec2d), out: wp.array(dtype=wp.vec3)):
    k = wp.tid()
    out[k] = td.tiling_value(t, points[k])


@wp.kernel
def tiling_colour_at(t: td.Tiling, cmap: td.ColourMap, points: wp.array(dtype=wp.vec2d),
                     out: wp.array(dtype=wp.vec3)):
    k = wp.tid()
    out[k] = td.colour_value(cmap, td.tiling_value(t, points[k]))
