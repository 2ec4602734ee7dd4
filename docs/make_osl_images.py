"""Render the OSL picture of docs/renderers.md with Blender's Cycles.

The exported surface shader on a smooth sphere (Cycles on the CPU, OSL, an
orthographic camera, one sample), beside ``surface_noise`` at the points the
pixel centres see, and their difference. Blender runs in its own interpreter
(tests/clients.py: ``.blender-venv`` or ``$WARP_TEXTON_BLENDER_PYTHON``) and
renders with tests/blender_osl_render.py, the script of the OSL tests.

    python docs/make_osl_images.py
"""

from __future__ import annotations

import json
import sys
import tempfile
from pathlib import Path

import numpy as np
import OpenEXR
import trimesh

from warp_texton import analyze, read_image, surface_noise, write_image
from warp_texton.demo import demo_texture_path
from warp_texton.runtimes.osl.texton import SURFACE_FILE, osl_files

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
from clients import run_blender  # noqa: E402  (the tests' Blender runner)

OUT = ROOT / "docs" / "images" / "renderers"
SIZE = 192
SCALE = 2.2  # the view, world units: the whole sphere (radius 1)
TEXEL = 0.02  # world units per texel


def main() -> int:
    texton = analyze(read_image(demo_texture_path()), size=32, iterations=30)
    mesh = trimesh.creation.icosphere(subdivisions=4, radius=1.0)
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        (d / SURFACE_FILE).write_bytes(osl_files(texton, mni=60, seed=1, texel_size=TEXEL)[SURFACE_FILE])
        np.save(d / "v.npy", mesh.vertices)
        np.save(d / "f.npy", mesh.faces)
        job = {"osl": str(d / SURFACE_FILE), "mode": "external", "ortho_scale": SCALE, "width": SIZE,
               "height": SIZE, "vertices": str(d / "v.npy"), "faces": str(d / "f.npy"), "smooth": True,
               "out": str(d / "sphere.exr")}
        (d / "spec.json").write_text(json.dumps({"renders": [job], "report": str(d / "report.json")}))
        run_blender(ROOT / "tests" / "blender_osl_render.py", d / "spec.json", timeout=600)
        rgba = OpenEXR.File(job["out"]).channels()["RGBA"].pixels.astype(np.float64)
        vertex_normals = np.load(job["out"] + ".normals.npy").astype(np.float64)
    # the reference at the pixel centres' hit points (the tests' ray cast of the smooth mesh)
    from test_shader_osl import sphere_hits

    c = (np.arange(SIZE) + 0.5) * SCALE / SIZE - SCALE / 2
    x, y = np.meshgrid(c, -c)
    hit, pts, nrm = sphere_hits(mesh, vertex_normals, x, y)
    want = np.zeros((SIZE, SIZE, 3))
    want[hit] = surface_noise(texton, pts, nrm, TEXEL, mni=60, seed=1, device="cpu")
    covered = hit & (rgba[..., 3] == 1.0)
    got = rgba[..., :3]
    background = 0.18
    panels = [np.where(covered[..., None], got, background), np.where(covered[..., None], want, background),
              np.where(covered[..., None], np.clip(100 * np.abs(got - want), 0, 1), background)]
    gap = np.full((SIZE, 4, 3), 1.0)
    OUT.mkdir(parents=True, exist_ok=True)
    write_image(OUT / "osl_sphere.png", np.concatenate([panels[0], gap, panels[1], gap, panels[2]], axis=1))
    span = want[covered].max() - want[covered].min()
    err = np.abs(got - want)[covered].max(axis=1) / span
    print(f"{OUT / 'osl_sphere.png'}: {covered.sum()} pixels, {np.mean(err <= 1e-3):.4%} within 1e-3 of the range, "
          f"max {err.max():.2e}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
