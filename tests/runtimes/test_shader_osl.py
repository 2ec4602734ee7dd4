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
from helpers import cli_script
from warp_texton import Texton, TextonError, evaluate, surface_noise
from warp_texton.surface.mesh import srgb_to_linear
from warp_texton.runtimes.osl.texton import MAX_EMBEDDED_FLOATS, PLANE_FILE, SURFACE_FILE, i32, osl_files

RENDER_SCRIPT = Path(__file__).resolve().parents[1].joinpath("blender_osl_render.py")
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


def agreement(rgba: np.ndarray, expected: np.ndarray, lo: np.ndarray, hi: np.ndarray, covered: np.ndarray,
              channels: int) -> dict:
    """How the render's covered pixels compare with the noise: the fraction within
    TOLERANCE of the range of the value at the pixel centre, the largest error
    there, and the largest distance from the values at the corners of the square
    the camera's jittered sample lies in (box filter of width 0.01 pixel), all
    relative to the range."""
    got = rgba[..., :3][covered]
    want, lo, hi = (a[covered] for a in (expected, lo, hi))
    if channels == 1:
        want, lo, hi = (np.repeat(a[:, :1], 3, axis=1) for a in (want, lo, hi))
    span = float(want.max() - want.min())
    err = np.abs(got - want).max(axis=1) / span
    outside = np.maximum(lo - got, got - hi).clip(0).max(axis=1) / span
    # pixels whose jitter square holds a jump of the noise (order 0: the nearest-texel
    # texton is piecewise constant): the value the camera saw there is not known
    ambiguous = (hi - lo).max(axis=1) / span > TOLERANCE
    return {"fraction": float(np.mean(err <= TOLERANCE)), "max_error": float(err.max()),
            "max_outside_jitter": float(outside.max()), "pixels": int(covered.sum()),
            "ambiguous": int(ambiguous.sum()), "fraction_unambiguous": float(np.mean(err[~ambiguous] <= TOLERANCE))}


def jitter_box(values, scale: float):
    """``values(dx, dy)`` at the pixel centres and at the corners of the square of
    half-side 0.005 pixel around them: (centre, corner minimum, corner maximum)."""
    j = 0.005 * scale / SIZE
    corners = np.stack([values(sx * j, sy * j) for sx in (-1, 1) for sy in (-1, 1)])
    return values(0.0, 0.0), corners.min(axis=0), corners.max(axis=0)


def plane_mesh(half: float) -> dict:
    v = np.array([[-half, -half, 0], [half, -half, 0], [half, half, 0], [-half, half, 0]], np.float64)
    return {"vertices": v, "faces": np.array([[0, 1, 2], [0, 2, 3]]),
            "uvs": (v[:, :2] + half) / (2 * half)}


#: (channels, order, exported mni, seed, period, poisson, coordinates, the node's mni or None,
#: output): the Poisson sampler's two branches (cell means about 11 and 3) and the Gaussian
#: counts, orders 0, 1, 3 and 5, a seed above 2**31, a period, both coordinate modes, an mni
#: set on the node (the sampler's constants then come from OSL's exp and log), the sRGB-decoded output
PLANE_CASES = [
    (3, 1, 30.0, 7, None, "exact", "object", None, "Color"),
    (1, 3, 8.0, 2**31 + 5, (24.0, 40.0), "exact", "input", None, "Color"),
    (3, 0, 30.0, 11, None, "gaussian", "object", None, "Color"),
    (3, 5, 30.0, 5, None, "exact", "object", 40.0, "Linear"),
]
#: world (object) units per texel in the object mode, UV units per texel in the UV mode
PLANE_TEXEL = 0.04
UV_TEXEL = 0.02


@pytest.mark.slow
def test_plane_shader_renders_evaluate(tmp_path):
    scale = 1.8  # the view; the plane (2 x 2, one UV square) covers it: about 4 pixels per texel
    jobs, cases = [], []
    for n, (channels, order, mni, seed, period, poisson, coordinates, node_mni, output) in enumerate(PLANE_CASES):
        texton = random_texton(channels, order, seed=n)
        osl = tmp_path / f"{n}_{PLANE_FILE}"
        osl.write_bytes(osl_files(texton, mni=mni, seed=seed, period=period, poisson=poisson,
                                  texel_size=PLANE_TEXEL)[PLANE_FILE])
        job = {"osl": str(osl), "mode": "internal", "inputs": {"coordinates": coordinates}, "ortho_scale": scale,
               "output": output, **plane_mesh(1.0)}
        if coordinates == "input":
            job["inputs"]["texel_size"] = UV_TEXEL
            job["uv_input"] = "Vector"
        if node_mni is not None:
            job["inputs"]["mni"] = node_mni
        jobs.append(job)
        cases.append((texton, node_mni or mni, seed, period, poisson, coordinates, output))
    reports = render(tmp_path, jobs)
    x, y = pixel_centres(scale)
    for (texton, mni, seed, period, poisson, coordinates, output), rep in zip(cases, reports):
        def values(dx, dy):
            if coordinates == "input":
                u, v = (x + dx + 1.0) / 2.0, (y + dy + 1.0) / 2.0
                pts = np.stack([u / UV_TEXEL, (1.0 - v) / UV_TEXEL], -1)
            else:
                pts = np.stack([(x + dx) / PLANE_TEXEL, -(y + dy) / PLANE_TEXEL], -1)
            out = evaluate(texton, pts.reshape(-1, 2), mni=mni, seed=seed, period=period, poisson=poisson,
                           device="cpu")
            out = out.reshape(SIZE, SIZE, texton.channels)
            if output == "Linear":
                with np.errstate(invalid="ignore"):  # the power branch of negative values, not taken
                    return srgb_to_linear(out)
            return out

        covered = rep["rgba"][..., 3] == 1.0
        assert covered.all()
        a = agreement(rep["rgba"], *jitter_box(values, scale), covered, texton.channels)
        print(f"plane, {texton.channels} channel(s), order {texton.order}, {poisson}, mni {mni:g}, {coordinates}, "
              f"{output}: "
              f"{a}; compile {rep['compile_s']:.2f} s, render {rep['render_s']:.2f} s")
        if texton.order == 0:
            # a jump can pass between the corners of the jitter square: judge the pixels without one
            assert a["fraction_unambiguous"] >= MIN_AGREEMENT
        else:
            assert a["fraction"] >= MIN_AGREEMENT
            assert a["max_outside_jitter"] <= TOLERANCE


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


#: (channels, order, mni, seed, poisson, up): the PTRS and product branches, a seed
#: above 2**31, another up axis for the frame rule
SPHERE_CASES = [
    (3, 1, 60.0, 3, "exact", (0.0, 0.0, 1.0)),
    (1, 3, 20.0, 2**32 - 1, "exact", (0.0, 1.0, 0.0)),
]


@pytest.mark.slow
def test_surface_shader_renders_surface_noise(tmp_path):
    texel = 0.06  # world units per texel: about 5 pixels per texel
    scale = 1.2  # the sphere (radius 1) fills the view: no grazing rim, where the sub-pixel jitter
    # of the camera rays moves the hit point far along the surface
    mesh = trimesh.creation.icosphere(subdivisions=3, radius=1.0)
    jobs, textons = [], []
    for n, (channels, order, mni, seed, poisson, up) in enumerate(SPHERE_CASES):
        texton = random_texton(channels, order, seed=10 + n)
        osl = tmp_path / f"{n}_{SURFACE_FILE}"
        osl.write_bytes(osl_files(texton, mni=mni, seed=seed, poisson=poisson, up=up, texel_size=texel)[SURFACE_FILE])
        jobs.append({"osl": str(osl), "mode": "external", "ortho_scale": scale,
                     "vertices": mesh.vertices, "faces": mesh.faces, "smooth": True})
        textons.append(texton)
    reports = render(tmp_path, jobs)
    x, y = pixel_centres(scale)
    for (channels, order, mni, seed, poisson, up), texton, rep in zip(SPHERE_CASES, textons, reports):
        hit = sphere_hits(mesh, rep["vertex_normals"], x, y)[0]

        def values(dx, dy):
            h, pts, nrm = sphere_hits(mesh, rep["vertex_normals"], x + dx, y + dy)
            out = np.zeros((SIZE, SIZE, channels))
            out[h] = surface_noise(texton, pts, nrm, texel, mni=mni, seed=seed, poisson=poisson, up=up,
                                   device="cpu")
            return out

        alpha = rep["rgba"][..., 3]
        covered = hit & (alpha == 1.0)
        a = agreement(rep["rgba"], *jitter_box(values, scale), covered, channels)
        print(f"sphere, {channels} channel(s), order {order}, mni {mni:g}, up {up}: {a}, "
              f"{int((hit != (alpha > 0)).sum())} pixels differ in coverage; "
              f"compile {rep['compile_s']:.2f} s, render {rep['render_s']:.2f} s")
        assert covered.sum() == hit.sum() == SIZE * SIZE
        assert a["fraction"] >= MIN_AGREEMENT
        assert a["max_outside_jitter"] <= TOLERANCE


INT_PROBE = """
shader int_probe(output color Color = 0)
{
    point q = transform("object", P);
    int k = int(floor((1.0 - q[1]) * 48.0)) * 96 + int(floor((q[0] + 1.0) * 48.0));  // the pixel's index
    int x = k * -1640531535 + 1013904223;  // spread over all 32 bits (2654435761 as OSL's int)
    int h = avalanche(x);
    Color = color(float(srl(h, 16)), float(h & 65535), float(srl(rand_pcg(x), 8)));
}
"""


def avalanche_np(x: np.ndarray) -> np.ndarray:
    # kernels/impacts.py avalanche, in NumPy's uint32 (wrapping multiplication, logical shifts)
    x = x ^ (x >> 16)
    x = x * np.uint32(0x7FEB352D)
    x = x ^ (x >> 15)
    x = x * np.uint32(0x846CA68B)
    return x ^ (x >> 16)


def rand_pcg_np(state: np.ndarray) -> np.ndarray:
    # warp/native/rand.h rand_pcg
    b = state * np.uint32(747796405) + np.uint32(2891336453)
    c = ((b >> ((b >> 28) + 4)) ^ b) * np.uint32(277803737)
    return (c >> 22) ^ c


@pytest.mark.slow
def test_integer_arithmetic_in_cycles(tmp_path):
    # the hash and PCG step of the exported source, in Cycles' OSL, against uint32 arithmetic:
    # multiplication wraps, the masked shifts are logical, constants above 2**31 are right
    source = osl_files(random_texton(1, 1))[PLANE_FILE].decode()
    osl = tmp_path / "int_probe.osl"
    osl.write_text(source[: source.index("\nshader texton_plane(")] + INT_PROBE)
    (rep,) = render(tmp_path, [{"osl": str(osl), "ortho_scale": 2.0, **plane_mesh(1.0)}])
    k = np.arange(SIZE * SIZE, dtype=np.uint32).reshape(SIZE, SIZE)
    with np.errstate(over="ignore"):
        x = k * np.uint32(2654435761) + np.uint32(1013904223)
        h = avalanche_np(x)
        p = rand_pcg_np(x)
    rgb = rep["rgba"][..., :3]
    assert np.array_equal(rgb[..., 0], h >> 16)
    assert np.array_equal(rgb[..., 1], h & 65535)
    assert np.array_equal(rgb[..., 2], p >> 8)


#: The exact-point renders: 64 pixels per world unit and 16 texels per world unit (powers of
#: two), so a pixel centre and its texel coordinates are float32 numbers in the shader and here.
EXACT_PIXELS = 64.0
EXACT_TEXEL = 1.0 / 16.0
SNAP = """
    point p_hit = transform("object", P);
    // the pixel's centre, whatever point of the pixel the camera's jittered ray hit
    float sx = (floor(p_hit[0] * 64.0) + 0.5) / 64.0;
    float sy = (floor(p_hit[1] * 64.0) + 0.5) / 64.0;
"""


def exact_point_source(source: str, kind: str) -> str:
    """The exported shader evaluated at its pixel's centre instead of the ray's hit:
    the plane at (x, -y) / texel, the surface at the unit sphere's point above it."""
    if kind == "plane":
        old = "        point q = transform(coordinates, P);\n"
        new = SNAP + "        point q = point(sx, sy, 0.0);\n"
    else:
        old = "    point y = transform(space, P) / texel_size;\n    normal n = normalize(transform(space, N));\n"
        new = SNAP + ("    float sz = sqrt(1.0 - sx * sx - sy * sy);\n"
                      "    point y = point(sx, sy, sz) / texel_size;\n"
                      "    normal n = normalize(normal(sx, sy, sz));\n")
    assert source.count(old) == 1
    return source.replace(old, new)


@pytest.mark.slow
def test_shaders_draw_the_kernels_impacts(tmp_path):
    # Without the camera's jitter (each shader snaps its point to the pixel centre) the
    # renders differ from the kernels by float rounding only: a cell whose count or
    # impacts differed would change its pixels by about a texton's weight / sqrt(lambda),
    # percents of the range. Plane: RGB order 1 (PTRS counts); sphere: RGB order 1, MNI 60.
    texton = random_texton(3, 1, seed=4)
    files = osl_files(texton, mni=30.0, seed=9, texel_size=EXACT_TEXEL)
    sphere = osl_files(texton, mni=60.0, seed=9, texel_size=EXACT_TEXEL)[SURFACE_FILE]
    jobs = []
    for kind, source, size, mesh in (("plane", files[PLANE_FILE], 96, plane_mesh(1.0)),
                                      ("surface", sphere, 80, None)):
        osl = tmp_path / f"exact_{kind}.osl"
        osl.write_text(exact_point_source(source.decode(), kind))
        if mesh is None:
            ico = trimesh.creation.icosphere(subdivisions=3, radius=1.0)
            mesh = {"vertices": ico.vertices, "faces": ico.faces}
        jobs.append({"osl": str(osl), "ortho_scale": size / EXACT_PIXELS, "width": size, "height": size, **mesh})
    plane_rep, sphere_rep = render(tmp_path, jobs)
    for kind, rep, size in (("plane", plane_rep, 96), ("surface", sphere_rep, 80)):
        # the pixel centres as the shaders compute them, in float32
        c = ((np.arange(size) - size // 2 + 0.5) / EXACT_PIXELS).astype(np.float32)
        sx, sy = np.meshgrid(c, c[::-1])
        if kind == "plane":
            pts = np.stack([sx / np.float32(EXACT_TEXEL), -sy / np.float32(EXACT_TEXEL)], -1).reshape(-1, 2)
            want = evaluate(texton, pts.astype(np.float64), mni=30.0, seed=9, device="cpu")
        else:
            sz = np.sqrt(np.float32(1.0) - sx * sx - sy * sy)
            p = np.stack([sx, sy, sz], -1).reshape(-1, 3).astype(np.float64)
            want = surface_noise(texton, p, p, EXACT_TEXEL, mni=60.0, seed=9, device="cpu")
        want = want.reshape(size, size, 3)
        got = rep["rgba"][..., :3]
        assert (rep["rgba"][..., 3] == 1.0).all()
        err = np.abs(got - want).max(axis=-1) / (want.max() - want.min())
        print(f"{kind} at exact points: max error {err.max():.2e} of the range, "
              f"{int((err > 1e-4).sum())} of {err.size} pixels beyond 1e-4, {int((err == 0).sum())} equal")
        assert err.max() < 1e-4


def test_files_and_constants():
    t = random_texton(3, 1)
    files = osl_files(t, mni=30, seed=2**32 - 1, texel_size=0.5)
    assert sorted(files) == sorted([PLANE_FILE, SURFACE_FILE])
    plane = files[PLANE_FILE].decode()
    assert "int seed = -1," in plane  # 2**32 − 1 as OSL's signed int
    assert "float texel_size = 0.5," in plane
    assert i32(0x9E3779B9) == 0x9E3779B9 - 2**32 and i32(5) == 5


def test_errors():
    big = Texton(np.full((257, 256, 3), 0.1), [0.5, 0.5, 0.5])
    assert 267 * 266 * 3 > MAX_EMBEDDED_FLOATS >= 266 * 266 * 3
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


def test_export_shader_writes_the_osl_files(tmp_path):
    """export_shader(..., "osl") writes osl_files' sources and a description marked as
    the package's, so --overwrite may replace the folder; the CLI writes the same."""
    import subprocess

    from warp_texton import export_shader

    t = random_texton(3, 3)
    out = export_shader(t, "osl", tmp_path / "osl", mni=40, seed=5, texel_size=0.25, up="y")
    want = osl_files(t, mni=40, seed=5, texel_size=0.25, up="y")
    assert sorted(p.name for p in out.iterdir()) == sorted([*want, "texton_noise_osl.json"])
    for name, content in want.items():
        assert (out / name).read_bytes() == content
    meta = json.loads((out / "texton_noise_osl.json").read_text())
    assert meta["language"] == "osl" and meta["settings"]["texel_size"] == 0.25 and meta["settings"]["up"] == "y"
    export_shader(t, "osl", out, overwrite=True)  # an export of the package: replaceable
    assert (out / PLANE_FILE).read_bytes() == osl_files(t)[PLANE_FILE]  # the defaults again
    with pytest.raises(TextonError, match="filter is an option of the glsl export"):
        export_shader(t, "osl", tmp_path / "f", filter="mip")
    with pytest.raises(TextonError, match="texel_size is an option of the osl export"):
        export_shader(t, "glsl", tmp_path / "g", texel_size=0.5)
    assert not (tmp_path / "f").exists() and not (tmp_path / "g").exists()

    t.save(tmp_path / "t.exr")
    script = cli_script()
    if script is None:
        pytest.skip("the warp-texton console script is not installed")
    cli = subprocess.run([script, "shader", str(tmp_path / "t.exr"), "--lang", "osl", "-o",
                          str(tmp_path / "cli"), "--mni", "40", "--seed", "5", "--texel-size", "0.25", "--up", "y"],
                         capture_output=True, text=True)
    assert cli.returncode == 0, cli.stderr
    for name, content in want.items():
        assert (tmp_path / "cli" / name).read_bytes() == content
    bad = subprocess.run([script, "shader", str(tmp_path / "t.exr"), "--lang", "osl", "-o",
                          str(tmp_path / "bad"), "--filter", "mip"], capture_output=True, text=True)
    assert bad.returncode == 2 and len(bad.stderr.strip().splitlines()) == 1 and "--filter" in bad.stderr
    assert not (tmp_path / "bad").exists()
