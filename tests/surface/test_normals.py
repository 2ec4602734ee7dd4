"""Corner normals split by angle (warp_texton/surface/mesh.py ``corner_normals``): hard edges stay
hard and smooth surfaces smooth, the same for shared and split vertices, in renders,
bakes, vertex colours and the command line (issue 33, item 1).

Before, the renderer and the bake interpolated one normal per vertex and replaced it
with the face normal per pixel where the two parted by more than 30°: on a box with
shared corners that draws an ellipse on every face (inside it the smooth normal, outside
the face's), and the same box with split corners rendered differently (correlation 0.80).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import trimesh

from helpers import run_cli
from warp_texton import Camera, Texton, TextonError, bake_mesh, render_baked, render_mesh, surface_noise
from warp_texton import texture_mesh
from warp_texton.surface.jobs import SurfaceJob, run_jobs
from warp_texton.surface.mesh import CREASE_ANGLE, NORMAL_MODES, corner_normals, split_corners, vertex_normals

BG = np.float32(0.92)


def _texton(channels=1):
    rng = np.random.default_rng(3)
    return Texton(rng.standard_normal((8, 8, channels)) / 8, [0.5] * channels)


def soup(mesh):
    """The same triangles, no vertex shared (an STL file read without merging)."""
    return trimesh.Trimesh(mesh.triangles.reshape(-1, 3), np.arange(3 * len(mesh.faces)).reshape(-1, 3), process=False)


def box():
    return trimesh.creation.box(extents=(2.0, 1.0, 1.0))


def cad_parts():
    """Boolean-free parts with hard edges: a cylinder and a washer (a tube with flat ends)."""
    return {"cylinder": trimesh.creation.cylinder(0.5, 1.5, sections=32),
            "washer": trimesh.creation.annulus(0.3, 0.6, 0.5, sections=48)}


def object_correlation(a, b):
    """Correlation of two renders over the pixels where either shows the object."""
    on = np.any(a != BG, axis=2) | np.any(b != BG, axis=2)
    return float(np.corrcoef(a[on].ravel(), b[on].ravel())[0, 1])


def brute_force(mesh, cos):
    """The definition, corner by corner: the corner-angle-weighted mean of the normals of
    the faces around the corner's position that its face reaches across edges that are not
    sharp (two faces, normals within the angle): Blender's Smooth by Angle."""
    v, f = np.asarray(mesh.vertices), np.asarray(mesh.faces)
    fn, angles = np.asarray(mesh.face_normals), np.asarray(mesh.face_angles)
    ids: dict = {}
    w = np.array([[ids.setdefault(tuple(v[i]), len(ids)) for i in face] for face in f])  # positions
    edge_faces: dict = {}
    for i, face in enumerate(w):
        for k in range(3):
            edge_faces.setdefault(frozenset((face[k], face[(k + 1) % 3])), []).append(i)
    out = np.zeros((len(f), 3, 3))
    for i in range(len(f)):
        for k in range(3):
            p, fan, todo = w[i, k], {i}, [i]
            while todo:
                g = todo.pop()
                for q in set(w[g]) - {p}:
                    pair = edge_faces[frozenset((p, q))]
                    if len(pair) == 2 and fn[pair[0]] @ fn[pair[1]] >= cos:
                        todo += [h for h in pair if h not in fan]
                        fan.update(pair)
            total = sum(angles[g, list(w[g]).index(p)] * fn[g] for g in fan)
            out[i, k] = total / np.linalg.norm(total)
    return out


class TestCornerNormals:
    def test_a_box_is_flat_and_smooth_is_the_diagonal(self):
        b = box()
        n = corner_normals(b)
        assert np.array_equal(n, np.repeat(b.face_normals[:, None, :], 3, axis=1))
        assert np.array_equal(corner_normals(b, "flat"), n)
        s = corner_normals(b, "smooth")
        # every corner of a box touches three faces at right angles, weighted alike: (±1, ±1, ±1)/√3
        assert np.allclose(np.abs(s), 1 / math.sqrt(3), atol=1e-12)
        assert np.allclose(corner_normals(b, "mesh"), vertex_normals(b)[b.faces])

    @pytest.mark.parametrize("angle", [10.0, CREASE_ANGLE, 60.0])
    def test_the_definition_on_cad_parts_and_a_rough_sphere(self, angle):
        rng = np.random.default_rng(0)
        sphere = trimesh.creation.icosphere(1)
        sphere.vertices = sphere.vertices * rng.uniform(0.9, 1.1, (len(sphere.vertices), 1))
        cos = math.cos(math.radians(angle))
        for mesh in (*cad_parts().values(), sphere):
            got = corner_normals(mesh, "angle", angle)
            np.testing.assert_allclose(got, brute_force(mesh, cos), atol=1e-12)

    def test_the_cylinder_has_flat_caps_and_a_smooth_side(self):
        cyl = cad_parts()["cylinder"]
        n = corner_normals(cyl)
        cap = np.abs(cyl.face_normals[:, 2]) > 0.99
        np.testing.assert_allclose(n[cap], np.repeat(cyl.face_normals[cap][:, None, :], 3, axis=1), atol=1e-12)
        # on the side: horizontal, radial, the same on every face a vertex touches
        side = n[~cap]
        assert np.abs(side[..., 2]).max() < 1e-12
        radial = cyl.vertices[cyl.faces[~cap]][..., :2]
        radial /= np.linalg.norm(radial, axis=2, keepdims=True)
        np.testing.assert_allclose(side[..., :2], radial, atol=1e-12)

    @pytest.mark.parametrize("make", [lambda: trimesh.creation.icosphere(3), lambda: trimesh.creation.torus(1.0, 0.35),
                                      lambda: trimesh.creation.capsule(1.0, 0.4)])
    def test_smooth_meshes_keep_their_vertex_normals_to_the_bit(self, make):
        mesh = make()
        want = vertex_normals(mesh)[mesh.faces]
        assert np.array_equal(corner_normals(mesh), want)
        assert np.array_equal(corner_normals(mesh, "smooth"), want)

    @pytest.mark.parametrize("mesh", [box(), *cad_parts().values()], ids=["box", *cad_parts()])
    def test_shared_and_split_vertices_get_the_same_normals(self, mesh):
        for mode in ("angle", "smooth", "flat"):  # the same sums, in another order
            np.testing.assert_allclose(corner_normals(soup(mesh), mode), corner_normals(mesh, mode), atol=1e-12)

    def test_zero_area_faces_take_the_mean_of_their_vertex(self):
        b = box()
        v = np.vstack([b.vertices, b.vertices[:1]])  # a needle: two corners at one position
        f = np.vstack([b.faces, [[0, 8, 1]]])
        m = trimesh.Trimesh(v, f, process=False)
        n = corner_normals(m)
        assert np.array_equal(n[:-1], corner_normals(b))
        assert np.allclose(np.linalg.norm(n[-1], axis=1), 1.0) and np.all(np.isfinite(n))

    @pytest.mark.parametrize("normals, angle, match", [
        ("auto", 30.0, "normals must be one of angle, smooth, flat, mesh"), (None, 30.0, "normals must be one of"),
        ("angle", -1.0, "crease_angle must be a number of degrees from 0 to 180"),
        ("angle", 180.5, "crease_angle must be"), ("angle", float("nan"), "crease_angle must be"),
        ("angle", "30", "crease_angle must be"), ("angle", True, "crease_angle must be")])
    def test_bad_options_are_refused(self, normals, angle, match):
        with pytest.raises(TextonError, match=match):
            corner_normals(box(), normals, angle)
        for call in (lambda: render_mesh(box(), _texton(), (8, 8), normals=normals, crease_angle=angle),
                     lambda: texture_mesh(box(), _texton(), 0.1, normals=normals, crease_angle=angle),
                     lambda: bake_mesh(box(), _texton(), 0.1, resolution=8, normals=normals, crease_angle=angle)):
            with pytest.raises(TextonError, match=match):
                call()
        assert NORMAL_MODES == ("angle", "smooth", "flat", "mesh")


class TestSplitCorners:
    def test_nothing_to_split_keeps_the_vertices(self):
        mesh = trimesh.creation.icosphere(2)
        vmap, faces, vn = split_corners(mesh.faces, corner_normals(mesh), len(mesh.vertices))
        assert np.array_equal(vmap, np.arange(len(mesh.vertices))) and np.array_equal(faces, mesh.faces)
        assert np.array_equal(vn, vertex_normals(mesh))

    def test_a_box_splits_into_a_vertex_per_face_corner(self):
        b = box()
        n = corner_normals(b)
        vmap, faces, vn = split_corners(b.faces, n, len(b.vertices))
        assert len(vmap) == 24  # 8 corners, 3 faces each
        assert np.array_equal(vmap[faces], b.faces)  # each corner keeps its position
        assert np.array_equal(vn[faces], n)  # and its normal


class TestRenders:
    """The issue's measure: the same box with shared and with split corners, rendered."""

    @pytest.mark.parametrize("name", ["box", "cylinder", "washer"])
    def test_shared_and_split_corners_render_alike(self, name, device):
        mesh = box() if name == "box" else cad_parts()[name]
        t = _texton()
        shared = render_mesh(mesh, t, (96, 128), device=device)
        split = render_mesh(soup(mesh), t, (96, 128), device=device)
        assert object_correlation(shared, split) >= 0.98
        # the split mesh with the normals it holds (each vertex on one face: the face's)
        held = render_mesh(soup(mesh), t, (96, 128), device=device, normals="mesh")
        assert object_correlation(shared, held) >= 0.98
        # the measure sees the difference that smooth normals across the edges make
        smooth = render_mesh(mesh, t, (96, 128), device=device, normals="smooth")
        assert object_correlation(shared, smooth) < 0.9

    def test_a_box_renders_as_its_flat_faces(self, device):
        t = _texton(3)
        np.testing.assert_array_equal(render_mesh(box(), t, (48, 64), device=device),
                                      render_mesh(box(), t, (48, 64), device=device, normals="flat"))

    def test_the_crease_angle_decides_what_is_smooth(self, device):
        # an icosphere of 80 faces: about 21° between neighbours
        sphere, t = trimesh.creation.icosphere(1), _texton()
        faceted = render_mesh(sphere, t, (48, 64), device=device, crease_angle=15.0)
        assert np.array_equal(faceted, render_mesh(sphere, t, (48, 64), device=device, normals="flat"))
        smooth = render_mesh(sphere, t, (48, 64), device=device)
        assert np.array_equal(smooth, render_mesh(sphere, t, (48, 64), device=device, normals="smooth"))
        assert object_correlation(smooth, faceted) < 0.9


class TestVertexColours:
    def test_each_face_of_a_box_holds_the_noise_of_its_plane(self, device):
        b, t = box(), _texton(3)
        out = texture_mesh(b, t, 0.05, device=device, warn=False)
        assert len(out.vertices) == 24 and len(out.faces) == len(b.faces)
        fn = np.repeat(b.face_normals, 3, axis=0)
        want = surface_noise(t, b.vertices[b.faces.reshape(-1)], fn, 0.05, device=device)
        want = np.round(np.clip(want, 0, 1) * 255).astype(np.uint8)
        got = np.asarray(out.visual.vertex_colors)[out.faces.reshape(-1), :3]
        np.testing.assert_array_equal(got, want)
        # the same colours from the split box
        again = texture_mesh(soup(b), t, 0.05, device=device, warn=False)
        np.testing.assert_array_equal(np.asarray(again.visual.vertex_colors)[again.faces.reshape(-1)],
                                      np.asarray(out.visual.vertex_colors)[out.faces.reshape(-1)])

    def test_a_smooth_mesh_keeps_its_vertices(self, device):
        mesh = trimesh.creation.icosphere(2)
        out = texture_mesh(mesh, _texton(), 0.05, device=device, warn=False)
        assert np.array_equal(out.vertices, mesh.vertices) and np.array_equal(out.faces, mesh.faces)


class TestBakes:
    def test_a_baked_box_carries_split_normals_and_renders_as_render_mesh(self, device, tmp_path):
        pytest.importorskip("xatlas")
        from warp_texton import write_baked

        b, t = box(), _texton()
        baked = bake_mesh(b, t, 0.05, resolution=256, device=device)
        m = baked.mesh
        # one normal per written vertex, the face's own on every corner
        np.testing.assert_allclose(np.asarray(m.vertex_normals)[m.faces],
                                   np.repeat(m.face_normals[:, None, :], 3, axis=1), atol=1e-12)
        (glb,) = write_baked(baked, tmp_path / "box", fmt="glb")  # the suite's validator reads it
        cam = Camera.framing(b)
        ref = render_mesh(b, t, (96, 128), texel_size=0.05, camera=cam, device=device)
        img = render_baked(baked, (96, 128), camera=cam, device=device)
        assert object_correlation(ref, img) > 0.9

    def test_the_faces_of_a_baked_box_are_flat_noise(self, device):
        """Each covered texel holds the noise at its point with its face's normal: what a
        render of the box shows there."""
        pytest.importorskip("xatlas")
        b, t, res = box(), _texton(), 64
        baked = bake_mesh(b, t, 0.05, resolution=res, supersample=1, gutter=0, device=device)
        m = baked.mesh
        rows, cols = np.nonzero(baked.coverage)
        # each texel centre's triangle in the atlas and its barycentric weights there (x = u R, y = (1 − v) R)
        uv = np.asarray(m.visual.uv)[m.faces] * [res, -res] + [0, res]  # (F, 3, 2) texel coordinates
        centre = np.stack([cols + 0.5, rows + 0.5], axis=1)
        a, e = uv[:, 0], np.stack([uv[:, 1] - uv[:, 0], uv[:, 2] - uv[:, 0]], axis=2)  # (F, 2), (F, 2, 2)
        w = np.einsum("fij,nfj->nfi", np.linalg.inv(e), centre[:, None, :] - a[None])  # (N, F, 2)
        inside = (w >= -1e-9).all(axis=2) & (w.sum(axis=2) <= 1 + 1e-9)
        assert inside.any(axis=1).all()
        f = inside.argmax(axis=1)
        w = w[np.arange(len(f)), f]
        bary = np.stack([1 - w[:, 0] - w[:, 1], w[:, 0], w[:, 1]], axis=1)
        pts = np.einsum("nk,nkd->nd", bary, np.asarray(m.vertices)[m.faces[f]])
        want = surface_noise(t, pts, m.face_normals[f], 0.05, device=device)[:, 0]
        np.testing.assert_allclose(baked.texture[rows, cols, 0], want, atol=1e-5)


class TestCommandLine:
    @pytest.mark.parametrize("extra, message", [
        (["--normals", "smooth", "--crease-angle", "40"], "--crease-angle applies to --normals angle, not smooth"),
        (["--crease-angle", "200"], "--crease-angle must be a number of degrees from 0 to 180, got 200"),
        (["--normals", "auto"], "--normals: invalid choice")])
    def test_crease_angle_applies_to_angle_normals(self, tmp_path, capsys, extra, message):
        b = tmp_path / "box.stl"
        box().export(b)
        assert run_cli(["surface", b, "--texton", tmp_path / "t.exr", "--out-dir", tmp_path / "o", *extra]) == 2
        (line,) = capsys.readouterr().err.splitlines()[-1:]
        assert message in line and "Traceback" not in line
        assert not (tmp_path / "o").exists()

    def test_jobs_pass_the_normals_on(self, tmp_path, device):
        t = _texton()
        b = tmp_path / "box.stl"
        soup(box()).export(b)  # an STL: a triangle soup
        jobs = [SurfaceJob(str(b), t, str(tmp_path / mode), 0.02, render=(48, 64), device=device, normals=mode,
                           fmt="glb") for mode in ("angle", "smooth")]
        results = run_jobs(jobs)
        assert [r.status for r in results] == ["done", "done"], [r.message for r in results]
        from PIL import Image

        imgs = [np.asarray(Image.open(r.outputs[1]), np.float64) for r in results]
        want = render_mesh(box(), t, (48, 64), texel_size=0.02, device=device, up="z")
        assert np.abs(imgs[0] - np.round(np.clip(want, 0, 1) * 255)).max() <= 1
        assert object_correlation(imgs[0] / 255, imgs[1] / 255) < 0.9
