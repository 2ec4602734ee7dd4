"""Texton noise in your own Warp kernel: a heightfield displaced by it.

A grid of vertices is raised by texton noise, evaluated inside a Warp kernel
of this file through the device API of warp-texton (``warp_texton.runtimes.warp_api``):
the host packs the texton and the noise settings once (``pack_plane``), the
kernel calls ``plane_value`` at each vertex. The values are those of
``warp_texton.evaluate`` at the same texel points, bit for bit on the same
device (the test suite runs this file and checks it).

Vertex (i, j) of the grid lies at world (j, i) × spacing and sees the noise at
the texel point offset + R(rotation) · (j, i) / scale, the placement of
``synthesize``'s pixels without the half-pixel shift: ``scale`` is vertices
per texel. Run it as

    python docs/examples/warp_heightfield.py heightfield.ply --device cpu

(without a path it writes into a new temporary folder), and open the PLY
in any mesh viewer.
"""

from __future__ import annotations

import argparse
import math
import tempfile
from pathlib import Path

import numpy as np
import trimesh
import warp as wp

from warp_texton import analyze, load_texton, read_image
from warp_texton.runtimes import warp_api as td
from warp_texton.demo import demo_texture_path


@wp.struct
class Placement:
    # texel point of vertex (i, j): offset + (j, i) mapped by the columns step_j, step_i
    offset: wp.vec2d
    step_j: wp.vec2d
    step_i: wp.vec2d


@wp.func
def texel_point(place: Placement, i: int, j: int) -> wp.vec2d:
    return place.offset + place.step_j * wp.float64(j) + place.step_i * wp.float64(i)


@wp.kernel
def displace(noise: td.PlaneNoise, place: Placement, spacing: float, height: float,
             vertices: wp.array2d(dtype=wp.vec3), values: wp.array2d(dtype=wp.vec3),
             texels: wp.array2d(dtype=wp.vec2d)):
    i, j = wp.tid()
    x = texel_point(place, i, j)
    value = td.plane_value(noise, x)
    vertices[i, j] = wp.vec3(float(j) * spacing, float(i) * spacing, height * value[0])
    values[i, j] = value
    texels[i, j] = x


class Example:
    """A (rows × columns) heightfield raised by the noise of ``texton``; ``step()`` computes it."""

    def __init__(self, texton, shape=(128, 128), *, mni=30.0, seed=0, scale=1.0, rotation=0.0, offset=(0.0, 0.0),
                 period=None, spacing=0.01, height=0.2, device=None):
        self.shape = shape
        self.device = wp.get_device(device)
        self.spacing = spacing
        self.height = height
        self.noise = td.pack_plane(texton, mni=mni, seed=seed, period=period, device=self.device.alias)
        th = math.radians(rotation)
        self.place = Placement()
        self.place.offset = wp.vec2d(*offset)
        self.place.step_j = wp.vec2d(math.cos(th) / scale, math.sin(th) / scale)
        self.place.step_i = wp.vec2d(-math.sin(th) / scale, math.cos(th) / scale)
        self.vertices = wp.zeros(shape, dtype=wp.vec3, device=self.device)
        self.values = wp.zeros(shape, dtype=wp.vec3, device=self.device)
        self.texels = wp.zeros(shape, dtype=wp.vec2d, device=self.device)

    def step(self):
        with wp.ScopedTimer("displace", print=False, synchronize=True) as timer:
            wp.launch(displace, dim=self.shape, device=self.device,
                      inputs=[self.noise, self.place, self.spacing, self.height],
                      outputs=[self.vertices, self.values, self.texels])
        self.elapsed_ms = timer.elapsed

    def mesh(self) -> trimesh.Trimesh:
        """The heightfield as a triangle mesh (two triangles per grid square)."""
        h, w = self.shape
        idx = np.arange(h * w).reshape(h, w)
        a, b, c, d = idx[:-1, :-1], idx[:-1, 1:], idx[1:, :-1], idx[1:, 1:]
        faces = np.concatenate([np.stack([a, c, b], -1).reshape(-1, 3), np.stack([b, c, d], -1).reshape(-1, 3)])
        return trimesh.Trimesh(self.vertices.numpy().reshape(-1, 3), faces, process=False)


def main(argv=None) -> Path:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0],
                                     formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    parser.add_argument("out", nargs="?", help="the PLY file to write (default: in a new temporary folder)")
    parser.add_argument("--texton", help="a texton file (default: analyse the demo grass texture)")
    parser.add_argument("--device", default=None, help="Warp device: cpu, cuda, cuda:N")
    parser.add_argument("--size", type=int, nargs=2, default=(128, 128), metavar=("ROWS", "COLUMNS"))
    parser.add_argument("--mni", type=float, default=30.0)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--scale", type=float, default=1.0, help="vertices per texel")
    parser.add_argument("--rotation", type=float, default=0.0, help="degrees")
    parser.add_argument("--offset", type=float, nargs=2, default=(0.0, 0.0), metavar=("X", "Y"))
    parser.add_argument("--period", type=float, nargs=2, default=None, metavar=("PX", "PY"))
    args = parser.parse_args(argv)
    out = Path(args.out) if args.out else Path(tempfile.mkdtemp(prefix="heightfield-")) / "heightfield.ply"
    texton = load_texton(args.texton) if args.texton else analyze(read_image(demo_texture_path()), size=32)
    with wp.ScopedDevice(args.device):
        example = Example(texton, tuple(args.size), mni=args.mni, seed=args.seed, scale=args.scale,
                          rotation=args.rotation, offset=args.offset, period=args.period)
        example.step()
        mesh = example.mesh()
    print(f"{args.size[0]} x {args.size[1]} vertices in {example.elapsed_ms:.1f} ms on {example.device}")
    tmp = out.with_name(f".{out.name}.tmp.ply")  # written whole, then renamed
    mesh.export(tmp)
    tmp.replace(out)
    print(out)
    return out


if __name__ == "__main__":
    main()
