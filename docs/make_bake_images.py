"""Pictures of baked textures for docs/: a baked Stanford bunny and a baked torus.

Each picture is the texture atlas (left) beside a render of the GLB written by
``write_baked`` and read back with trimesh, made by looking up each pixel's UV
in the texture (``render_baked``, as a renderer shows the asset), with the
bake's numbers printed under it.

The bunny is the Stanford bunny range scan that the pymeshfix wheel ships
(``pip install --no-deps pymeshfix``: the file only, without VTK); the texton
is learnt from an RGB mix of scikit-image's grass, gravel and brick (CC0), as
in the benchmarks.

    python docs/make_bake_images.py
"""

from __future__ import annotations

import importlib.util
import sys
import tempfile
from pathlib import Path

import numpy as np
import trimesh
from PIL import Image, ImageDraw

from warp_texton import analyze, bake_mesh, render_baked, write_baked
from warp_texton.surface.mesh import default_texel_size

OUT = Path(__file__).resolve().parent / "images" / "surface"
SIDE = 448  # each panel's side in pixels


def bunny_path() -> Path | None:
    spec = importlib.util.find_spec("pymeshfix")  # no import: pymeshfix needs VTK
    if spec is None or not spec.submodule_search_locations:
        return None
    path = Path(spec.submodule_search_locations[0]) / "examples" / "StanfordBunny.ply"
    return path if path.is_file() else None


def colour_texture(side: int = 512) -> np.ndarray:
    """An RGB texture: grass, gravel and brick (CC0) mixed so that the channels correlate."""
    from skimage import data

    mix = np.array([[0.60, 0.30, 0.10], [0.35, 0.45, 0.20], [0.20, 0.30, 0.50]])
    stack = np.stack([getattr(data, n)()[:side, :side] for n in ("grass", "gravel", "brick")], axis=-1) / 255.0
    return np.ascontiguousarray(stack @ mix.T, dtype=np.float32)


def panel(name: str, mesh, texton, resolution: int, texel: float, view, zoom: float) -> Image.Image:
    from warp_texton import Camera

    baked = bake_mesh(mesh, texton, texel, resolution=resolution, seed=1)
    with tempfile.TemporaryDirectory() as tmp:
        (glb,) = write_baked(baked, Path(tmp) / name, fmt="glb")
        (loaded,) = trimesh.load(glb, process=False).geometry.values()
        # the GLB is Y-up (glTF): the same view of the Z-up mesh, framed in the GLB's world
        cam = Camera.framing(loaded, orbit=view, zoom=zoom, up="y")
        img = render_baked(loaded, (SIDE, SIDE), camera=cam, up="y")
        size_mb = glb.stat().st_size / 2**20
    atlas = Image.fromarray((np.clip(baked.texture, 0, 1) * 255).round().astype(np.uint8)).resize((SIDE, SIDE),
                                                                                              Image.LANCZOS)
    render = Image.fromarray((img * 255).round().astype(np.uint8))
    out = Image.new("RGB", (2 * SIDE + 8, SIDE + 28), (255, 255, 255))
    out.paste(atlas, (0, 0))
    out.paste(render, (SIDE + 8, 0))
    caption = (f"{name}: {len(mesh.faces)} faces, {resolution}x{resolution} atlas ({baked.uv_source}), "
               f"{baked.texels_per_texton_texel:.2f} texels per texton texel, GLB {size_mb:.1f} MiB")
    ImageDraw.Draw(out).text((4, SIDE + 8), caption, fill=(0, 0, 0))
    print(caption)
    return out


def main() -> int:
    path = bunny_path()
    if path is None:
        print("pymeshfix's Stanford bunny is not installed: pip install --no-deps pymeshfix", file=sys.stderr)
        return 1
    texton = analyze(colour_texture(), size=32, seed=0)
    OUT.mkdir(parents=True, exist_ok=True)
    bunny = trimesh.load(path, force="mesh", process=False)
    torus = trimesh.creation.torus(major_radius=1.0, minor_radius=0.4)
    jobs = [
        ("bunny", bunny, 2048, default_texel_size(bunny) / 2, (-60, 20), 1.2),
        ("torus", torus, 1024, default_texel_size(torus) / 2, (-55, 35), 1.3),
    ]
    for name, mesh, resolution, texel, view, zoom in jobs:
        panel(name, mesh, texton, resolution, texel, view, zoom).save(OUT / f"{name}_baked.png", optimize=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
