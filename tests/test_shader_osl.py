"""The OSL export in its real client: Blender's Cycles renders the exported
shaders, and the pixels equal ``evaluate`` (plane) and ``surface_noise``
(sphere) at the surface points the pixel centres see."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import OpenEXR
import pytest
import trimesh

from clients import run_blender
from warp_texton import Texton, TextonError, evaluate, surface_noise
from warp_texton.shader_osl import MAX_EMBEDDED_FLOATS, PLANE_FILE, SURFACE_FILE, i32, osl_files

RENDER_SCRIPT = Path(__file__).with_name("blender_osl_render.py")
SIZE = 96
#: Pixels of the Blender render whose value must lie within TOLERANCE of the range.
MIN_AGREEMENT = 0.999
TOLERANCE = 1e-3


def random_texton(channels: int, order: int, size: int = 8, seed: int = 0) -> Texton:
    rng = np.random.default_rng(seed)
    return Texton(rng.standard_normal((size, size, channels)) / size, rng.uniform(0.3, 0.6, channels), order)


def render(tmp_path: Path, jobs: list[dict]) -> list[dict]:
    """Render ``jobs`` (blender_osl_render.py's format; arrays given as NumPy) in one Blender process."""
    renders = []
    for n, job in enumerate(jobs):
        job = dict(job)
        for key in ("vertices", "faces", "uvs"):
            if key in job:
                path = tmp_path / f"{n}_{key}.npy"
                np.save(path, job[key])
                job[key] = str(path)
        job["out"] = str(tmp_path / f"render{n}.exr")
        job.setdefault("width", SIZE)
        job.setdefault("height", SIZE)
        renders.append(job)
    spec = tmp_path / "spec.json"
    report = tmp_path / "report.json"
    spec.write_text(json.dumps({"renders": renders, "report": str(report)}))
    run_blender(RENDER_SCRIPT, spec, timeout=600)
    out = json.loads(report.read_text())
    for job, rep in zip(renders, out):
        rep["rgba"] = OpenEXR.File(job["out"]).channels()["RGBA"].pixels.astype(np.float64)
        rep["vertex_normals"] = np.load(job["out"] + ".normals.npy").astype(np.float64)
    return out


def pixel_centres(scale: float, size: int = SIZE) -> tuple[np.ndarray, np.ndarray]:
    """World (x, y) of the pixel centres of an orthographic view of width ``scale``
    centred on the origin, looking down −z; row 0 at the top (+y)."""
    c = (np.arange(size) + 0.5) * scale / size - scale / 2
    return np.meshgrid(c, -c)


def agreement(rgba: np.ndarray, expected: np.ndarray, covered: np.ndarray, channels: int) -> tuple[float, float]:
    """(fraction of covered pixels within TOLERANCE of the range, largest error / range)."""
    got = rgba[..., :3][covered]
    want = expected[covered]
    if channels == 1:
        want = np.repeat(want[:, :1], 3, axis=1)
    span = float(want.max() - want.min())
    err = np.abs(got - want).max(axis=1) / span
    return float(np.mean(err <= TOLERANCE)), float(err.max())


def plane_mesh(half: float) -> dict:
    v = np.array([[-half, -half, 0], [half, -half, 0], [half, half, 0], [-half, half, 0]], np.float64)
    return {"vertices": v, "faces": np.array([[0, 1, 2], [0, 2, 3]]),
            "uvs": (v[:, :2] + half) / (2 * half)}


PLANE_CASES = [
    # channels, order, mni, seed, period, coordinates: the Poisson sampler's two branches
    # (cell means about 11 and 3), a seed above 2**31, a period, both coordinate modes
    pytest.param(3, 1, 30.0, 7, None, "object", id="rgb-order1-ptrs-object"),
    pytest.param(1, 3, 8.0, 2**31 + 5, (24.0, 40.0), "input", id="grey-order3-mult-period-uv"),
]


@pytest.mark.slow
@pytest.mark.parametrize("channels, order, mni, seed, period, coordinates", PLANE_CASES)
def test_plane_shader_renders_evaluate(tmp_path, channels, order, mni, seed, period, coordinates):
    texton = random_texton(channels, order)
    texel = 0.04  # world (or UV) units per texel: about 4 pixels per texel, see docs/renderers.md
    scale = 1.8  # the view; the plane (2 x 2) covers it
    files = osl_files(texton, mni=mni, seed=seed, period=period, texel_size=texel)
    osl = tmp_path / PLANE_FILE
    osl.write_bytes(files[PLANE_FILE])
    job = {"osl": str(osl), "mode": "internal", "inputs": {"coordinates": coordinates}, "ortho_scale": scale,
           **plane_mesh(1.0)}
    if coordinates == "input":
        job["inputs"]["texel_size"] = 0.02  # UV units per texel: the 2-unit plane is one UV square
        job["uv_input"] = "Vector"
    (rep,) = render(tmp_path, [job])
    x, y = pixel_centres(scale)
    if coordinates == "input":
        u, v = (x + 1.0) / 2.0, (y + 1.0) / 2.0
        pts = np.stack([u / 0.02, (1.0 - v) / 0.02], -1)
    else:
        pts = np.stack([x / texel, -y / texel], -1)
    want = evaluate(texton, pts.reshape(-1, 2), mni=mni, seed=seed, period=period, device="cpu")
    want = want.reshape(SIZE, SIZE, channels)
    covered = rep["rgba"][..., 3] == 1.0
    assert covered.all()
    frac, worst = agreement(rep["rgba"], want, covered, channels)
    print(f"plane {channels}ch order {order}: {frac:.5f} within {TOLERANCE} of the range, max error {worst:.2e}; "
          f"compile {rep['compile_s']:.2f} s, render {rep['render_s']:.2f} s")
    assert frac >= MIN_AGREEMENT


def sphere_hits(mesh: trimesh.Trimesh, vertex_normals: np.ndarray, x: np.ndarray, y: np.ndarray):
    """Where orthographic rays down −z at (x, y) hit the front faces (normal z > 0)
    of a mesh shaded smooth with these vertex normals:
    (hit mask, points, interpolated normals), in float64."""
    normals = mesh.face_normals
    front = np.flatnonzero(normals[:, 2] > 0)
    tri = mesh.vertices[mesh.faces[front]]  # (F, 3, 3)
    q = np.stack([x.ravel(), y.ravel()], -1)
    face = np.full(len(q), -1)
    bary = np.zeros((len(q), 3))
    a, b, c = tri[:, 0, :2], tri[:, 1, :2], tri[:, 2, :2]
    det = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (c[:, 0] - a[:, 0]) * (b[:, 1] - a[:, 1])
    for start in range(0, len(q), 1024):
        p = q[start:start + 1024, None, :]
        l1 = ((p[..., 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (c[:, 0] - a[:, 0]) * (p[..., 1] - a[:, 1])) / det
        l2 = ((b[:, 0] - a[:, 0]) * (p[..., 1] - a[:, 1]) - (p[..., 0] - a[:, 0]) * (b[:, 1] - a[:, 1])) / det
        inside = (l1 >= 0) & (l2 >= 0) & (l1 + l2 <= 1)
        rows, cols = np.nonzero(inside)
        face[start + rows] = cols
        bary[start + rows] = np.stack([1 - l1[rows, cols] - l2[rows, cols], l1[rows, cols], l2[rows, cols]], -1)
    hit = face >= 0
    pts = np.einsum("nk,nkd->nd", bary[hit], tri[face[hit]])
    # smooth shading: the vertex normals interpolated with the hit's barycentric coordinates
    nrm = np.einsum("nk,nkd->nd", bary[hit], vertex_normals[mesh.faces[front[face[hit]]]])
    return hit.reshape(x.shape), pts, nrm / np.linalg.norm(nrm, axis=1)[:, None]


@pytest.mark.slow
def test_surface_shader_renders_surface_noise(tmp_path):
    texton = random_texton(3, 1, seed=1)
    texel, mni, seed = 0.06, 60.0, 3
    scale = 1.2  # the sphere (radius 1) fills the view: no grazing rim, where the sub-pixel jitter of the
    # camera rays (a box filter of width 0.01 pixel) moves the hit point along the surface
    mesh = trimesh.creation.icosphere(subdivisions=3, radius=1.0)
    files = osl_files(texton, mni=mni, seed=seed, texel_size=texel)
    osl = tmp_path / SURFACE_FILE
    osl.write_bytes(files[SURFACE_FILE])
    job = {"osl": str(osl), "mode": "external", "ortho_scale": scale,
           "vertices": mesh.vertices, "faces": mesh.faces, "smooth": True}
    (rep,) = render(tmp_path, [job])
    x, y = pixel_centres(scale)
    hit, pts, nrm = sphere_hits(mesh, rep["vertex_normals"], x, y)
    want = np.zeros((SIZE, SIZE, 3))
    want[hit] = surface_noise(texton, pts, nrm, texel, mni=mni, seed=seed, device="cpu")
    alpha = rep["rgba"][..., 3]
    covered = hit & (alpha == 1.0)
    frac, worst = agreement(rep["rgba"], want, covered, 3)
    print(f"sphere: {covered.sum()} covered pixels ({(hit != (alpha > 0)).sum()} differ in coverage), "
          f"{frac:.5f} within {TOLERANCE} of the range, max error {worst:.2e}; "
          f"compile {rep['compile_s']:.2f} s, render {rep['render_s']:.2f} s")
    assert covered.sum() > 0.7 * hit.sum()
    assert frac >= MIN_AGREEMENT


def test_files_and_constants():
    t = random_texton(3, 1)
    files = osl_files(t, mni=30, seed=2**32 - 1, texel_size=0.5)
    assert sorted(files) == sorted([PLANE_FILE, SURFACE_FILE])
    plane = files[PLANE_FILE].decode()
    assert "int seed = -1," in plane  # 2**32 − 1 as OSL's signed int
    assert "float texel_size = 0.5," in plane
    assert i32(0x9E3779B9) == 0x9E3779B9 - 2**32 and i32(5) == 5


def test_errors():
    big = Texton(np.zeros((70, 70, 3)) + 0.1, [0.5, 0.5, 0.5])
    assert 76 * 76 * 3 > MAX_EMBEDDED_FLOATS
    with pytest.raises(TextonError, match="too large for an OSL shader"):
        osl_files(big)
    with pytest.raises(TextonError, match="texton must be a Texton"):
        osl_files(np.zeros((4, 4)))
    with pytest.raises(TextonError, match="seed"):
        osl_files(random_texton(1, 1), seed=-1)
    with pytest.raises(TextonError, match="texel_size"):
        osl_files(random_texton(1, 1), texel_size=0)
    with pytest.raises(TextonError, match="poisson"):
        osl_files(random_texton(1, 1), poisson="fast")
