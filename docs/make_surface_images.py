"""Render the surface-noise pictures of docs/: real meshes without UVs.

Meshes: pyvista's example files (nut.ply: genus 1; airplane.ply: many parts,
open surfaces), read with trimesh from the pyvista wheel without importing
pyvista (install it with ``pip install --no-deps pyvista``). Textures: the
package's demo grass and scikit-image's gravel (CC0).

    python docs/make_surface_images.py
"""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import numpy as np
import trimesh

from warp_texton import Camera, analyze, read_image, render_mesh, write_image
from warp_texton.demo import demo_texture_path

OUT = Path(__file__).resolve().parent / "images" / "surface"


def pyvista_examples() -> Path | None:
    spec = importlib.util.find_spec("pyvista")
    if spec is None or not spec.submodule_search_locations:
        return None
    return Path(spec.submodule_search_locations[0]) / "examples"


def main() -> int:
    examples = pyvista_examples()
    if examples is None:
        print("pyvista is not installed: pip install --no-deps pyvista", file=sys.stderr)
        return 1
    from skimage import data

    grass = analyze(read_image(demo_texture_path()), size=32, seed=0)
    gravel = analyze(data.gravel().astype(np.float32) / 255.0, size=32, seed=0)
    OUT.mkdir(parents=True, exist_ok=True)
    jobs = [
        ("nut.ply", gravel, (1.0, -1.2, 1.4), 1 / 300, 1.0),
        ("airplane.ply", grass, (-0.6, -1.0, 0.8), 1 / 600, 1.6),
    ]
    for name, texton, direction, texel_fraction, zoom in jobs:
        mesh = trimesh.load(str(examples / name), force="mesh", process=False)
        diag = float(np.linalg.norm(mesh.bounds[1] - mesh.bounds[0]))
        cam = Camera.framing(mesh, direction=direction, zoom=zoom)
        img = render_mesh(mesh, texton, (384, 512), texel_size=diag * texel_fraction, camera=cam, seed=1)
        path = OUT / (Path(name).stem + ".png")
        write_image(path, img)
        print(f"{path}: {len(mesh.vertices)} vertices, {len(mesh.faces)} faces")
    return 0


if __name__ == "__main__":
    sys.exit(main())
