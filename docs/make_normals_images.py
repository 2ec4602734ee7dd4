"""Render the hard-edge pictures of docs/model.md ("Normals"): a box and a washer
(a CAD-like part with a hole), before and after corner normals split by angle.

"Before" is the rule the renderer had until corner normals: one normal per
vertex (trimesh's mean of the faces around it), interpolated across the face,
and the face's own normal wherever the two part by more than 30°, a test made
per pixel (an ellipse on every face of a box with shared corners: inside it
the smooth normal, outside it the face's). It is rebuilt here from the public
API (``cast_rays`` with the mesh's vertex normals, ``surface_noise`` at the
hits). "After" is ``render_mesh`` with its default, ``normals="angle"``.

For each part the script also prints the correlation, over the object, of the
renders of the part with shared corners and the same part with no vertex shared
(a triangle soup, as an STL file is read): the measure of issue 33.

    python docs/make_normals_images.py
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import trimesh
from PIL import Image, ImageDraw

from warp_texton import Camera, analyze, read_image, render_mesh, surface_noise
from warp_texton.demo import demo_texture_path
from warp_texton.surface.frames import up_rotation
from warp_texton.surface.render import LIGHT, cast_rays

OUT = Path(__file__).resolve().parent / "images" / "surface"
SHAPE = (288, 384)
BACKGROUND = 0.92
#: The old crease test: the face normal where the interpolated vertex normal leaves it by more than 30°.
OLD_CREASE_COS = 0.866


def parts() -> dict[str, trimesh.Trimesh]:
    return {"box": trimesh.creation.box(extents=(2.0, 1.0, 1.0)),
            "washer": trimesh.creation.annulus(0.45, 1.0, 0.5, sections=64)}


def soup(mesh: trimesh.Trimesh) -> trimesh.Trimesh:
    """The same triangles with no vertex shared."""
    return trimesh.Trimesh(mesh.triangles.reshape(-1, 3), np.arange(3 * len(mesh.faces)).reshape(-1, 3), process=False)


def rebuilt(mesh, texton, texel, camera, seed, normals="mesh", crease=True) -> np.ndarray:
    """A render from the public API: the interpolated normals of ``normals`` (the mesh's
    vertex normals: the old rule's), with the old per-pixel crease test if ``crease``."""
    hits = cast_rays(mesh, SHAPE, camera, normals=normals)
    hit = hits.hit
    n = hits.normal[hit].astype(np.float64)
    if crease:
        fn = np.asarray(mesh.face_normals)[hits.face[hit]]
        bent = np.sum(n * fn, axis=1) < OLD_CREASE_COS
        n[bent] = fn[bent]
    g = np.clip(surface_noise(texton, hits.points(), n, texel, seed=seed), 0.0, 1.0)
    light = up_rotation("z") @ np.asarray(LIGHT, np.float64)
    shade = 0.3 + 0.7 * np.abs(n @ (light / np.linalg.norm(light)))
    img = np.full(SHAPE + (3,), BACKGROUND, np.float32)
    img[hit] = (np.repeat(g, 3, axis=1) if g.shape[1] == 1 else g) * shade[:, None]
    return img


def correlation(a, b) -> float:
    on = np.any(a != np.float32(BACKGROUND), axis=2) | np.any(b != np.float32(BACKGROUND), axis=2)
    return float(np.corrcoef(a[on].ravel(), b[on].ravel())[0, 1])


def labelled(img: np.ndarray, text: str) -> Image.Image:
    pic = Image.fromarray(np.round(np.clip(img, 0, 1) * 255).astype(np.uint8))
    ImageDraw.Draw(pic).text((8, 6), text, fill=(20, 20, 20))
    return pic


def main() -> int:
    texton = analyze(read_image(demo_texture_path()), size=32, seed=0)
    OUT.mkdir(parents=True, exist_ok=True)
    seed = 1
    for name, mesh in parts().items():
        texel = float(np.linalg.norm(mesh.bounds[1] - mesh.bounds[0])) / 256
        camera = Camera.framing(mesh, orbit=(-55.0, 30.0), zoom=1.1 if name == "box" else 1.35)
        old = rebuilt(mesh, texton, texel, camera, seed)
        old_split = rebuilt(soup(mesh), texton, texel, camera, seed)
        new = render_mesh(mesh, texton, SHAPE, texel_size=texel, camera=camera, seed=seed)
        new_split = render_mesh(soup(mesh), texton, SHAPE, texel_size=texel, camera=camera, seed=seed)
        # rebuilt with the new normals and no crease test, it is render_mesh's image: the "before" is faithful
        gap = np.abs(rebuilt(mesh, texton, texel, camera, seed, "angle", crease=False) - new).max()
        print(f"{name}: shared vs split corners, correlation over the object: before {correlation(old, old_split):.3f},"
              f" after {correlation(new, new_split):.3f} ({len(mesh.faces)} faces; the rebuilt renderer is within "
              f"{gap:.1e} of render_mesh)")
        pair = Image.new("RGB", (2 * SHAPE[1], SHAPE[0]))
        pair.paste(labelled(old, "before: per-pixel crease test"), (0, 0))
        pair.paste(labelled(new, "after: normals split by angle (30°)"), (SHAPE[1], 0))
        path = OUT / f"hard_edges_{name}.png"
        pair.save(path)
        print(f"{path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
