"""Baked meshes opened by real clients: the Khronos glTF validator and Blender.

Required in CI (``.ci/run`` installs node's ``gltf-validator`` from
``tests/node/package.json`` and the ``bpy`` wheel); skipped elsewhere when a
client is missing (tests/clients.py).
"""

from __future__ import annotations

import json
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
import trimesh

from clients import require, run_blender
from warp_texton import Camera, Texton, bake_mesh, write_baked
from warp_texton.surface.bake import lookup
from warp_texton.surface.jobs import SurfaceJob, run_jobs
from warp_texton.surface.mesh_files import texture_8bit
from warp_texton.surface.render import cast_rays

pytest.importorskip("xatlas")

NODE_DIR = Path(__file__).resolve().parents[1] / "node"
NODE = shutil.which("node")


def validate(paths) -> dict:
    """The glTF validator's counts and messages for each file (tests/node/validate.js)."""
    require(NODE is not None and (NODE_DIR / "node_modules" / "gltf-validator").is_dir(),
            "node and the glTF validator (cd tests/node && npm ci)")
    proc = subprocess.run([NODE, str(NODE_DIR / "validate.js"), *map(str, paths)], capture_output=True, text=True,
                          timeout=120, check=True)
    return json.loads(proc.stdout)


def _texton():
    rng = np.random.default_rng(1)
    return Texton(rng.standard_normal((8, 8, 3)) / 32, [0.55, 0.45, 0.3])


@pytest.fixture(scope="module")
def meshes(tmp_path_factory):
    """A Z-up torus as PLY and a Y-up one as OBJ (the formats' conventions for --up auto)."""
    folder = tmp_path_factory.mktemp("meshes")
    torus = trimesh.creation.torus(1.0, 0.35, major_sections=48, minor_sections=24)  # axis along z
    torus.export(folder / "torus_z.ply")
    turned = torus.copy()
    turned.apply_transform(trimesh.transformations.rotation_matrix(-np.pi / 2, [1, 0, 0]))  # z up -> y up
    turned.export(folder / "torus_y.obj")
    return folder


def test_the_validator_finds_no_error_nor_warning_in_the_glbs_the_package_writes(meshes, tmp_path):
    texton = _texton()
    kinds = {  # output folder -> (mesh, job options)
        "baked_z_up": ("torus_z.ply", {"bake": 128}),
        "baked_y_up": ("torus_y.obj", {"bake": 128}),
        "baked_xatlas": ("torus_z.ply", {"bake": 64, "charts": "xatlas"}),
        "vertex_colours": ("torus_z.ply", {"fmt": "glb"}),
        "baked_16_bits": ("torus_z.ply", {"bake": 64, "dtype": "uint16"}),
    }
    jobs = [SurfaceJob(str(meshes / mesh), texton, str(tmp_path / out), 0.02, device="cpu", **options)
            for out, (mesh, options) in kinds.items()]
    results = run_jobs(jobs)
    assert [r.status for r in results] == ["done"] * len(jobs), [r.message for r in results]
    # a bake read back from the package's own GLB: its UVs, turned back with --up auto (y for .glb)
    again = SurfaceJob(results[0].outputs[0], texton, str(tmp_path / "rebaked"), 0.02, bake=64, device="cpu")
    rebaked = run_jobs([again])[0]
    assert rebaked.status == "done"
    glbs = [r.outputs[0] for r in (*results, rebaked)]
    assert all(g.endswith(".glb") for g in glbs) and len(glbs) == 6
    for path, report in validate(glbs).items():
        assert (report["errors"], report["warnings"]) == (0, 0), (path, report["messages"])


def test_the_validator_sees_what_it_should_refuse(tmp_path):
    # the check is live: a GLB with a position out of range of its accessor's bounds is an error
    mesh = trimesh.creation.box()
    data = bytearray(mesh.export(file_type="glb"))
    broken = tmp_path / "broken.glb"
    broken.write_bytes(bytes(data[:-12]))  # cut short: the binary chunk no longer holds its buffer
    (report,) = validate([broken]).values()
    assert report["errors"] > 0


# ------------------------------------------------------------------ Blender

WIDTH, HEIGHT = 80, 60
CAMERA = Camera(position=(2.4, -2.9, 2.2), target=(0.0, 0.0, 0.0), fov=40.0)


@pytest.fixture(scope="module")
def baked_torus(meshes, tmp_path_factory):
    """A Z-up torus baked at 256² and written as GLB and as OBJ."""
    folder = tmp_path_factory.mktemp("baked")
    mesh = trimesh.load(meshes / "torus_z.ply", process=False)
    baked = bake_mesh(mesh, _texton(), 0.01, resolution=256, device="cpu", up="z")
    write_baked(baked, folder / "torus", fmt="glb")
    write_baked(baked, folder / "torus", fmt="obj")
    return baked, folder


def _blender(fmt: str, baked_torus, tmp_path):
    baked, folder = baked_torus
    script = Path(__file__).resolve().parents[1] / "blender_mesh.py"
    out_json, out_png = tmp_path / "info.json", tmp_path / "render.png"
    run_blender(script, fmt, folder / f"torus.{fmt}", out_json, out_png, ",".join(map(str, CAMERA.position)),
                ",".join(map(str, CAMERA.target)), str(CAMERA.fov), str(WIDTH), str(HEIGHT), timeout=600)
    from PIL import Image

    return json.loads(out_json.read_text()), np.asarray(Image.open(out_png).convert("RGBA"), np.float64) / 255.0


def _expected(baked):
    """The texture (its 8-bit file values) looked up bilinearly where the package's ray cast hits."""
    hits = cast_rays(baked.mesh, (HEIGHT, WIDTH), CAMERA, device="cpu")
    img = np.zeros((HEIGHT, WIDTH, 3))
    tri = hits.faces[hits.face[hits.hit]]
    uv = np.einsum("nk,nkd->nd", hits.bary[hits.hit], np.asarray(baked.mesh.visual.uv)[tri])
    img[hits.hit] = lookup(texture_8bit(baked.texture)[0] / 255.0, uv)
    return hits.hit, img


@pytest.mark.slow
@pytest.mark.parametrize("fmt", ["glb", "obj"])
def test_blender_imports_the_torus_flat_with_its_srgb_texture_and_renders_it_as_the_package(fmt, baked_torus,
                                                                                         tmp_path):
    baked, _ = baked_torus
    info, render = _blender(fmt, baked_torus, tmp_path)
    lo, hi = np.array(info["min"]), np.array(info["max"])
    # lies flat in Blender's Z-up world: 2 (R + r) across x and y, 2 r high, as the PLY
    assert np.allclose(hi - lo, [2.7, 2.7, 0.7], atol=0.02), (lo, hi)
    (material,) = info["materials"]
    assert material["base_color_from"] == "TEX_IMAGE"
    assert material["colorspace"] == "sRGB" and material["size"] == [256, 256]
    hit, expected = _expected(baked)
    seen = render[:, :, 3] > 0.5
    # the silhouettes agree but for pixels their edges cross (the two ray casts round differently;
    # measured: none of 1,319 differ)
    assert np.count_nonzero(seen ^ hit) <= 0.01 * np.count_nonzero(hit)
    import scipy.ndimage as ndi

    inside = ndi.binary_erosion(seen & hit, iterations=1)
    diff = np.abs(render[:, :, :3] - expected)[inside]
    # Blender decodes the 8-bit sRGB texture to linear floats and its render is encoded back to 8
    # bits: half a step of rounding, plus float rounding of the bilinear weights where the two ray
    # casts land a hair apart. Measured (Blender 5.0, Cycles CPU): median 0.32/255, largest 1.26/255;
    # one pixel of shift between the two renders would give a median of 20/255.
    assert np.median(diff) <= 1.0 / 255.0
    assert diff.max() <= 3.0 / 255.0


@pytest.mark.slow
def test_blender_shows_a_vertex_colour_glb_through_its_material(meshes, tmp_path):
    job = SurfaceJob(str(meshes / "torus_z.ply"), _texton(), str(tmp_path), 0.05, fmt="glb", device="cpu")
    (result,) = run_jobs([job])
    assert result.status == "done"
    script = Path(__file__).resolve().parents[1] / "blender_mesh.py"
    run_blender(script, "glb", result.outputs[0], tmp_path / "info.json", tmp_path / "render.png",
                ",".join(map(str, CAMERA.position)), ",".join(map(str, CAMERA.target)), str(CAMERA.fov), "16", "12",
                timeout=600)
    info = json.loads((tmp_path / "info.json").read_text())
    assert np.allclose(np.array(info["max"]) - np.array(info["min"]), [2.7, 2.7, 0.7], atol=0.02)
    (material,) = info["materials"]
    # Blender's importer feeds COLOR_0 to the Base Color when the primitive has a material
    assert material["base_color_from"] == "VERTEX_COLOR"


# ------------------------------------------------------------------ normals in Blender

def _parts():
    """CAD-like parts and coarse smooth ones, side by side in one mesh (none touches another)."""
    parts = [trimesh.creation.box(extents=(2.0, 1.0, 1.0)), trimesh.creation.cylinder(0.5, 1.5, sections=32),
             trimesh.creation.annulus(0.3, 0.6, 0.5, sections=48), trimesh.creation.capsule(1.0, 0.4),
             trimesh.creation.icosphere(1), trimesh.creation.cone(0.5, 1.0, sections=24)]
    for i, part in enumerate(parts):
        part.apply_translation([3.0 * i, 0.0, 0.0])
    return trimesh.util.concatenate(parts)


def _blender_normals(fmt, path, tmp_path, angle=30.0):
    script = Path(__file__).resolve().parents[1] / "blender_normals.py"
    out = tmp_path / f"{Path(path).stem}_normals.json"
    run_blender(script, fmt, path, out, str(angle), timeout=600)
    return {k: np.array(v) for k, v in json.loads(out.read_text()).items()}


def _assert_same_normals(mesh, ours, theirs, atol):
    """Blender's normal of each corner against ours at the same position on the same plane
    (the meshes number, split and join faces differently): every corner of ours there agrees."""
    from scipy.spatial import cKDTree

    # a corner is its position and its face's plane (coplanar faces at a position are one corner)
    mine = np.concatenate([np.asarray(mesh.vertices)[mesh.faces].reshape(-1, 3),
                           np.repeat(mesh.face_normals, 3, axis=0)], axis=1)
    found = cKDTree(mine).query_ball_point(np.concatenate([theirs["positions"], theirs["face_normals"]], axis=1),
                                           1e-3)
    ours = ours.reshape(-1, 3)
    assert all(found)
    worst = max(float(np.abs(ours[idx] - n).max()) for idx, n in zip(found, theirs["normals"]))
    assert worst <= atol, worst


@pytest.mark.slow
@pytest.mark.parametrize("angle", [30.0, 15.0])
def test_corner_normals_are_blenders_smooth_by_angle(tmp_path, angle):
    """The package's corner normals (normals="angle") against Blender's Smooth by Angle on a box,
    a cylinder, a washer, a capsule, an 80-face icosphere and a cone: Blender computes in float32
    (measured: within 1.5e-5)."""
    from warp_texton.surface.mesh import corner_normals

    mesh = _parts()
    mesh.export(tmp_path / "parts.ply")
    theirs = _blender_normals("ply", tmp_path / "parts.ply", tmp_path, angle)
    assert len(theirs["normals"]) == 3 * len(mesh.faces)
    _assert_same_normals(mesh, corner_normals(mesh, "angle", angle), theirs, 1e-4)


@pytest.mark.slow
def test_blender_imports_a_baked_box_with_its_split_normals(tmp_path):
    """A baked box's GLB: Blender reads one normal per face on each corner (hard edges), as
    the bake evaluated the noise with, and the validator passes the file."""
    box = trimesh.creation.box(extents=(2.0, 1.0, 1.0))
    baked = bake_mesh(box, _texton(), 0.05, resolution=64, device="cpu", up="z")
    (glb,) = write_baked(baked, tmp_path / "box", fmt="glb")
    (report,) = validate([glb]).values()
    assert (report["errors"], report["warnings"]) == (0, 0), report["messages"]
    theirs = _blender_normals("glb", glb, tmp_path)
    m = baked.mesh
    assert len(theirs["normals"]) == 3 * len(m.faces)
    flat = np.repeat(m.face_normals[:, None, :], 3, axis=1)
    _assert_same_normals(m, flat, theirs, 1e-4)  # glTF's normals are float32
