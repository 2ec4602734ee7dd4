"""Tiling models on surfaces without UVs: the triplanar projection (kernels/surface_tiling.py).

* A face orthogonal to an axis shows that plane's tiling, bit for bit (``evaluate``).
* No seams: the values are continuous over a curved surface (jumps shrink with the step).
* ``render_mesh``'s pixels are ``surface_noise`` at the hit points; ``texture_mesh``'s
  colours are ``surface_noise`` at the vertices; ``bake_mesh`` writes a GLB (the session's
  glTF validator opens every GLB the tests write, tests/conftest.py) whose texels are the
  noise at their surface points.
* Texton-noise options get one TextonError naming them; the CLI's ``surface`` and jobs
  take a tiling model file.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import trimesh

from helpers import run_cli
from warp_texton import Camera, TextonError, bake_mesh, evaluate, render_mesh, surface_noise, texture_mesh, \
    write_baked
from warp_texton.model.tiling import TilingModel
from warp_texton.surface.bake import check_bake_arguments
from warp_texton.surface.jobs import SurfaceJob, run_jobs
from warp_texton.surface.render import cast_rays
from warp_texton.surface.tiling import plane_seeds


def model(channels=3, blend="variance", side=10.0, seed=0) -> TilingModel:
    """A tiling model of a smooth random example (bilinear lookups of it are continuous)."""
    rng = np.random.default_rng(seed)
    ex = (0.25 + 0.5 * rng.random((48, 48, channels))).astype(np.float32)
    return TilingModel(ex, side=side, blend=blend)


def quad(axis: int, sign: float, offset: float = 3.25, size: float = 40.0, n: int = 41):
    """Points of a square grid on the plane orthogonal to ``axis`` at ``offset`` and its normal ``sign`` e_axis."""
    u, v = np.meshgrid(np.linspace(-size, size, n), np.linspace(-size * 0.7, size * 1.3, n))
    pts = np.zeros((u.size, 3))
    others = [a for a in range(3) if a != axis]
    pts[:, others[0]] = u.ravel() + 0.123
    pts[:, others[1]] = v.ravel() - 0.377
    pts[:, axis] = offset
    nrm = np.zeros_like(pts)
    nrm[:, axis] = sign
    return pts, nrm


# the plane coordinates of kernels/surface_tiling.py for Z up: (axis, sign) -> (x, y) of a point
PLANE_COORDS = {
    (2, 1.0): lambda p: np.c_[p[:, 0], -p[:, 1]],  # the floor, seen from above
    (2, -1.0): lambda p: np.c_[p[:, 0], p[:, 1]],
    (0, 1.0): lambda p: np.c_[p[:, 1], -p[:, 2]],  # walls: the example's up is the world's up
    (0, -1.0): lambda p: np.c_[-p[:, 1], -p[:, 2]],
    (1, 1.0): lambda p: np.c_[-p[:, 0], -p[:, 2]],
    (1, -1.0): lambda p: np.c_[p[:, 0], -p[:, 2]],
}


class TestPlanes:
    @pytest.mark.parametrize("axis, sign", list(PLANE_COORDS))
    @pytest.mark.parametrize("channels", [1, 3])
    def test_a_face_orthogonal_to_an_axis_is_that_planes_tiling_bit_for_bit(self, axis, sign, channels, device):
        m = model(channels)
        texel = 0.5
        pts, nrm = quad(axis, sign)
        got = surface_noise(m, pts, nrm, texel, seed=11, device=device)
        seed = plane_seeds(11)[axis]  # the floor's plane takes the seed itself
        want = evaluate(m, PLANE_COORDS[axis, sign](pts / texel), seed=seed, device=device)
        assert got.shape == (len(pts), channels) and got.dtype == np.float32
        np.testing.assert_array_equal(got, want)

    @pytest.mark.parametrize("wrap, vectors", [((True, True), [(16, 16), (16, -16)]), ((False, True), [(16, 0)]),
                                               ((True, True), None)])
    def test_wrapped_and_lattice_models_on_a_face_are_that_planes_tiling(self, wrap, vectors, device):
        # the triplanar projection runs the planar tiling_value: a seamless brick wall read wrapped, snapped
        # to its lattice or its courses, is each face's plane bit for bit
        from tests.helpers import running_bond
        from warp_texton.model.lattice import Lattice

        ex = running_bond((128, 128))
        lat = None if vectors is None else Lattice.from_vectors(vectors, ex.shape, wrap)
        m = TilingModel(ex, 40, 16, 0.0, {}, "variance", None, wrap, lat)
        for axis, sign in ((0, 1.0), (2, 1.0)):
            pts, nrm = quad(axis, sign, size=200.0)
            got = surface_noise(m, pts, nrm, 0.5, seed=3, device=device)
            want = evaluate(m, PLANE_COORDS[axis, sign](pts / 0.5), seed=plane_seeds(3)[axis], device=device)
            np.testing.assert_array_equal(got, want)

    @pytest.mark.parametrize("channels", [1, 3])
    def test_a_histogram_preserving_model_maps_its_tables_on_surfaces_too(self, channels, device):
        # the tables run after the triplanar blend as after the planar one: a face orthogonal to an axis
        # is still evaluate of its plane bit for bit, and the values are colours, not Gaussianised ones
        from warp_texton import analyze

        rng = np.random.default_rng(5)
        ex = rng.gamma(2.0, 0.1, (48, 48, channels)).astype(np.float32)
        m = analyze(ex, method="tiling", side=10, histogram="preserve")
        assert m.histogram is not None
        pts, nrm = quad(0, 1.0)
        got = surface_noise(m, pts, nrm, 0.5, seed=4, device=device)
        want = evaluate(m, PLANE_COORDS[0, 1.0](pts / 0.5), seed=plane_seeds(4)[0], device=device)
        np.testing.assert_array_equal(got, want)
        assert got.min() >= ex.min() - 1e-6 and got.max() <= ex.max() + 1e-6

    def test_the_floor_is_synthesize_of_the_same_seed(self, device):
        # the floor reads (x, -y): a raster's pixel (i, j) at (j + ½, i + ½) is the point (j + ½, -(i + ½), z)
        from warp_texton import synthesize

        m = model()
        raster = synthesize(m, (24, 32), seed=5, device=device)
        i, j = np.meshgrid(np.arange(24), np.arange(32), indexing="ij")
        pts = np.stack([j.ravel() + 0.5, -(i.ravel() + 0.5), np.full(i.size, -7.0)], axis=1)
        got = surface_noise(m, pts, np.tile([0.0, 0.0, 2.0], (len(pts), 1)), 1.0, seed=5, device=device)
        np.testing.assert_array_equal(got.reshape(24, 32, 3), raster)

    def test_up_y_puts_the_floor_orthogonal_to_y(self, device):
        # up="y" (glTF): the frame is (x, -z, y); the floor (normal +y) reads (x, z)... as (⟨p, right⟩, -⟨p, front⟩)
        m = model()
        pts, nrm = quad(1, 1.0)
        got = surface_noise(m, pts, nrm, 1.0, seed=2, up="y", device=device)
        want = evaluate(m, np.c_[pts[:, 0], pts[:, 2]], seed=2, device=device)
        np.testing.assert_array_equal(got, want)

    def test_the_planes_are_independent(self, device):
        # three planes' seeds differ: the same coordinates on the floor and on a wall differ
        m = model()
        pts, _ = quad(2, 1.0)
        floor = surface_noise(m, pts, np.tile([0.0, 0.0, 1.0], (len(pts), 1)), 1.0, seed=4, device=device)
        seeds = plane_seeds(4)
        assert len(set(seeds)) == 3
        wall = evaluate(m, np.c_[pts[:, 0], -pts[:, 1]], seed=seeds[0], device=device)
        assert np.corrcoef(floor[:, 0], wall[:, 0])[0, 1] < 0.2

    def test_a_blend_zone_keeps_the_examples_variance(self, device):
        # on a sphere's diagonal normals (all three planes weighted) the variance-preserving blend keeps
        # the variance of single reads: independent points (far apart), compared with points of one plane
        m = model(channels=1, side=6.0)
        rng = np.random.default_rng(3)
        n = 20000
        pts = rng.uniform(-1e5, 1e5, (n, 3))
        diagonal = np.tile([1.0, 1.0, 1.0], (n, 1))
        floor = np.tile([0.0, 0.0, 1.0], (n, 1))
        blended = surface_noise(m, pts, diagonal, 1.0, seed=1, device=device)[:, 0]
        single = surface_noise(m, pts, floor, 1.0, seed=1, device=device)[:, 0]
        # the variance of a sample variance of n values: about 2σ⁴/n for near-Gaussian values (5 sd)
        tol = 5 * math.sqrt(2.0 / n) * 2
        assert abs(blended.var() / single.var() - 1) < tol, (blended.var(), single.var())
        assert abs(blended.mean() - single.mean()) < 5 * single.std() / math.sqrt(n) * 2
        linear = surface_noise(model(channels=1, side=6.0, blend="linear"), pts, diagonal, 1.0, seed=1,
                               device=device)[:, 0]
        assert linear.var() < 0.5 * single.var()  # the linear blend of three planes: about a third


def sphere_pairs(rng, count, radius, centre, step):
    """Pairs of points on a sphere ``step`` texels apart along great circles, and their normals."""
    n0 = rng.normal(size=(count, 3))
    n0 /= np.linalg.norm(n0, axis=1)[:, None]
    t = rng.normal(size=(count, 3))
    t -= n0 * np.sum(t * n0, axis=1)[:, None]
    t /= np.linalg.norm(t, axis=1)[:, None]
    a = step / radius
    n1 = n0 * math.cos(a) + t * math.sin(a)
    return centre + radius * n0, n0, centre + radius * n1, n1


def smooth_model() -> TilingModel:
    """A tiling model of a smooth example: its bilinear reads change little per texel, so that a
    seam (a jump of the size of the example's range) stands far above the bound below."""
    from scipy.ndimage import gaussian_filter

    ex = gaussian_filter(np.random.default_rng(5).random((64, 64)), 2.0, mode="wrap")
    ex = (ex - ex.min()) / (ex.max() - ex.min())
    return TilingModel(ex.astype(np.float32), side=12.0, blend="variance")


def planar_lipschitz(m: TilingModel, step: float) -> float:
    """The planar tiling's largest change per texel between points ``step`` apart (200 000 pairs)."""
    rng = np.random.default_rng(7)
    p = rng.uniform(-500, 500, (200000, 2))
    a = rng.uniform(0, 2 * np.pi, 200000)
    q = p + step * np.c_[np.cos(a), np.sin(a)]
    return float(np.abs(evaluate(m, q, seed=1, device="cpu") - evaluate(m, p, seed=1, device="cpu")).max()) / step


def jump_bound(m: TilingModel, lipschitz: float, length, angle):
    """The largest change of the triplanar value between points ``length`` texels apart whose
    normals part by ``angle`` radians. v = μ + Σ c_i d_i with c_i = k_i / √(Σ k²) (Σ c ≤ √3)
    and d_i = plane i's value − μ: the reads move by at most ``length`` in every plane (a
    projection shortens), so Σ c_i Δd_i ≤ √3 L length; the coefficients c_i = |n_i|^S /
    √(Σ |n_j|^2S) change by at most 2 √3 S per radian each (S = TRIPLANAR_SHARPNESS, the
    dominant |n_j| ≥ 1/√3), times |d| ≤ A = max |example − μ|; and the cutoff (1e-4 of
    the largest weight) adds at most 3e-4 A."""
    from warp_texton.surface.tiling import TRIPLANAR_SHARPNESS

    a = float(np.abs(m.example - m.mean3[:m.channels]).max())
    return math.sqrt(3) * lipschitz * length + 3 * 2 * math.sqrt(3) * TRIPLANAR_SHARPNESS * angle * a + 3e-4 * a


class TestContinuity:
    def test_no_seams_on_a_sphere(self, device):
        """Continuity: a seam (a jump that does not vanish with the step) keeps the largest jump
        over pairs a tenth of the step apart as large as over the full step; a continuous
        (Lipschitz) blend divides it by about ten. 40 000 pairs on a sphere of radius 40 texels
        cross the planes' sign changes, blend zones and the tiling's own triangles many times
        (about 60 pairs at the short step straddle any given seam curve). Every pair also stays
        within :func:`jump_bound`."""
        m = smooth_model()
        radius = 40.0
        centre = np.array([100.3, -50.7, 20.1])
        jumps = {}
        for step in (0.5, 0.05):
            p0, n0, p1, n1 = sphere_pairs(np.random.default_rng(1), 40000, radius, centre, step)
            v0 = surface_noise(m, p0, n0, 1.0, seed=9, device=device)
            v1 = surface_noise(m, p1, n1, 1.0, seed=9, device=device)
            jumps[step] = float(np.abs(v1 - v0).max())
            bound = jump_bound(m, planar_lipschitz(m, step), step, step / radius)
            assert jumps[step] <= bound, (step, jumps[step], bound)
        assert jumps[0.05] < 0.25 * jumps[0.5], jumps

    def test_neighbouring_vertices_of_a_fine_torus_are_close(self, device):
        # vertex colours of a torus (minor radius 40 texels, edges of about 0.3 texels, normals of
        # the mesh): every edge's jump within jump_bound of its length and its normals' angle
        m = smooth_model()
        torus = trimesh.creation.torus(1.0, 0.4, major_sections=720, minor_sections=400)
        texel = 0.01
        v = surface_noise(m, torus.vertices, torus.vertex_normals, texel, seed=2, device=device)[:, 0]
        e = torus.edges_unique
        length = np.linalg.norm(torus.vertices[e[:, 0]] - torus.vertices[e[:, 1]], axis=1) / texel
        n = torus.vertex_normals
        angle = np.arccos(np.clip(np.sum(n[e[:, 0]] * n[e[:, 1]], axis=1), -1.0, 1.0))
        lipschitz = planar_lipschitz(m, float(length.max()))
        jump = np.abs(v[e[:, 0]] - v[e[:, 1]])
        assert np.all(jump <= jump_bound(m, lipschitz, length, angle)), (jump.max(), length.max())


class TestMeshes:
    def test_render_pixels_are_surface_noise_at_the_hits(self, device):
        m = model()
        torus = trimesh.creation.torus(1.0, 0.4, major_sections=48, minor_sections=24)
        cam = Camera((2.5, -3.5, 2.5), (0, 0, 0), (0, 0, 1), 40.0)
        texel = 0.01
        img = render_mesh(torus, m, (48, 64), texel_size=texel, camera=cam, seed=3, device=device)
        hits = cast_rays(torus, (48, 64), cam, device=device)
        assert hits.hit.mean() > 0.2
        g = surface_noise(m, hits.points(), hits.normal[hits.hit], texel, seed=3, device=device)
        want = np.clip(g, 0.0, 1.0) * hits.shade[hits.hit][:, None]
        # the hits' positions are summed in the render's kernel and here in NumPy: float64 rounding
        # moves them by ~1e-14 texels, far below what changes a float32 value by more than its rounding
        np.testing.assert_allclose(img[hits.hit], want, rtol=0, atol=2e-6)
        np.testing.assert_array_equal(img[~hits.hit], np.float32(0.92))

    def test_vertex_colours_are_surface_noise_at_the_vertices(self, device):
        m = model()
        box = trimesh.creation.box(extents=(2.0, 1.0, 1.5))
        out = texture_mesh(box, m, 0.05, seed=1, device=device, warn=False)
        # the box's faces are flat (normals "angle"): each face's corners hold its own plane's tiling
        fn = out.face_normals[np.repeat(np.arange(len(out.faces)), 3)]
        corners = out.faces.reshape(-1)
        want = surface_noise(m, out.vertices[corners], fn, 0.05, seed=1, device=device)
        got = out.visual.vertex_colors[corners, :3]
        np.testing.assert_array_equal(got, np.round(np.clip(want, 0, 1) * 255).astype(np.uint8))

    def test_the_normals_options_apply(self, device):
        # normals="smooth" on a box: every vertex keeps one normal (the corner's diagonal), so the
        # colours are the three planes blended there, not a face's plane
        m = model()
        box = trimesh.creation.box(extents=(2.0, 1.0, 1.5))
        smooth = texture_mesh(box, m, 0.05, seed=1, device=device, warn=False, normals="smooth")
        assert len(smooth.vertices) == 8
        want = surface_noise(m, box.vertices, box.vertex_normals, 0.05, seed=1, device=device)
        np.testing.assert_array_equal(smooth.visual.vertex_colors[:, :3],
                                      np.round(np.clip(want, 0, 1) * 255).astype(np.uint8))
        flat = texture_mesh(box, m, 0.05, seed=1, device=device, warn=False, normals="flat")
        assert len(flat.vertices) == 24
        # a corner's three face copies hold its three planes' tilings, which differ from the blend
        first = flat.vertices[:, None, :] == box.vertices[None, :, :]
        corner_of = np.argmax(first.all(axis=2), axis=1)
        assert np.any(flat.visual.vertex_colors[:, :3] != smooth.visual.vertex_colors[corner_of, :3])

    def test_bake_texels_are_the_noise_at_their_points(self, device, tmp_path):
        m = model()
        plane = trimesh.Trimesh([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], [[0, 1, 2], [0, 2, 3]],
                                visual=trimesh.visual.TextureVisuals(uv=[[0, 0], [1, 0], [1, 1], [0, 1]]))
        baked = bake_mesh(plane, m, texel_size=1 / 32, resolution=32, supersample=1, seed=6, device=device)
        # texel (i, j) of a 32² texture on the unit square is the point ((j + ½)/32, 1 − (i + ½)/32, 0):
        # 1 texton texel a texel, so its value is the floor's tiling at (j + ½, (i + ½) − 32)
        i, j = np.meshgrid(np.arange(32), np.arange(32), indexing="ij")
        want = evaluate(m, np.c_[j.ravel() + 0.5, i.ravel() + 0.5 - 32.0], seed=6, device=device)
        np.testing.assert_allclose(baked.texture.reshape(-1, 3), want, rtol=0, atol=1e-6)
        paths = write_baked(baked, tmp_path / "plane", fmt="glb")
        assert paths[0].suffix == ".glb" and paths[0].stat().st_size > 0  # validated at the session's end

    def test_bake_of_a_torus_without_uvs_writes_a_glb(self, device, tmp_path):
        pytest.importorskip("xatlas")
        m = model()
        torus = trimesh.creation.torus(1.0, 0.35, major_sections=32, minor_sections=16)
        baked = bake_mesh(torus, m, 0.02, resolution=64, seed=1, device=device)
        assert baked.uv_source == "atlas" and baked.texture.shape == (64, 64, 3)
        inside = baked.texture[baked.coverage]
        assert abs(float(inside.mean()) - float(m.example.mean())) < 0.05
        (glb,) = write_baked(baked, tmp_path / "torus", fmt="glb")
        loaded = trimesh.load(glb, force="mesh")
        assert len(loaded.faces) == len(baked.mesh.faces)


class TestOptions:
    @pytest.mark.parametrize("option, value", [("mni", 30.0), ("poisson", "gaussian"), ("cell_factor", 0.5),
                                               ("method", "points"), ("tangents", np.ones((3, 3)))])
    def test_surface_noise_refuses_texton_options(self, option, value):
        p = np.random.default_rng(0).normal(size=(3, 3))
        with pytest.raises(TextonError, match=f"{option} does not apply to a tiling model") as e:
            surface_noise(model(), p, p, 0.1, device="cpu", **{option: value})
        assert e.value.param == option

    def test_several_options_in_one_error(self):
        p = np.ones((2, 3))
        with pytest.raises(TextonError, match="mni, poisson do not apply to a tiling model"):
            surface_noise(model(), p, p, 0.1, mni=10, poisson="gaussian", device="cpu")

    def test_meshes_renders_and_bakes_refuse_mni_and_method(self):
        m = model()
        torus = trimesh.creation.torus(1.0, 0.35, major_sections=12, minor_sections=6)
        calls = [lambda: texture_mesh(torus, m, 0.05, mni=30),
                 lambda: render_mesh(torus, m, (8, 8), mni=30, device="cpu"),
                 lambda: render_mesh(torus, m, (8, 8), method="blocks", device="cpu"),
                 lambda: bake_mesh(torus, m, 0.05, resolution=16, mni=100, device="cpu"),
                 lambda: bake_mesh(torus, m, 0.05, resolution=16, method="points", device="cpu"),
                 lambda: check_bake_arguments(m, 64, mni=30)]
        for call in calls:
            with pytest.raises(TextonError, match="does not apply to a tiling model"):
                call()

    def test_other_objects_are_refused_naming_both_kinds(self):
        with pytest.raises(TextonError, match="texton must be a Texton or a TilingModel"):
            render_mesh(trimesh.creation.box(), "bricks.exr", (8, 8))

    def test_a_side_along_up_is_refused(self):
        p = np.ones((2, 3))
        with pytest.raises(TextonError, match="side is parallel to up") as e:
            surface_noise(model(), p, p, 0.1, up="z", side=(0, 0, 2), device="cpu")
        assert e.value.param == "side"

    def test_far_points_are_refused(self):
        p = np.array([[3e9, 0.0, 0.0]])
        with pytest.raises(TextonError, match="too far from the origin"):
            surface_noise(model(), p, p, 1.0, device="cpu")


class TestFiles:
    def test_cli_surface_bakes_renders_and_colours_with_a_tiling_file(self, tmp_path):
        pytest.importorskip("xatlas")
        m = model()
        m.save(tmp_path / "bricks.exr")
        trimesh.creation.torus(1.0, 0.35, major_sections=24, minor_sections=12).export(tmp_path / "ring.obj")
        trimesh.creation.icosphere(subdivisions=2).export(tmp_path / "ball.ply")
        status = run_cli(["surface", tmp_path / "ring.obj", "--texton", tmp_path / "bricks.exr", "--out-dir",
                          tmp_path / "baked", "--bake", "64", "--render", "48x32", "--device", "cpu", "--quiet"])
        assert status == 0
        assert (tmp_path / "baked" / "ring.glb").stat().st_size > 0 and (tmp_path / "baked" / "ring.png").is_file()
        status = run_cli(["surface", tmp_path / "ball.ply", "--texton", tmp_path / "bricks.exr", "--out-dir",
                          tmp_path / "coloured", "--device", "cpu", "--quiet"])
        assert status == 0
        ball = trimesh.load(tmp_path / "coloured" / "ball.ply", process=False)
        assert ball.visual.vertex_colors[:, :3].std() > 5  # the example's texels, not one colour

    @pytest.mark.parametrize("extra", [(), ("--bake", "32"), ("--render", "16x16")])
    def test_cli_refuses_mni_for_a_tiling_file_in_one_line(self, tmp_path, capsys, extra):
        m = model()
        m.save(tmp_path / "bricks.exr")
        trimesh.creation.icosphere(subdivisions=1).export(tmp_path / "ball.ply")
        status = run_cli(["surface", tmp_path / "ball.ply", "--texton", tmp_path / "bricks.exr", "--out-dir",
                          tmp_path / "out", *extra, "--mni", "30", "--device", "cpu"])
        err = capsys.readouterr().err
        assert status == 2 and "--mni does not apply to a tiling model" in err and len(err.strip().splitlines()) == 1
        assert not (tmp_path / "out").exists() or not any((tmp_path / "out").iterdir())

    def test_jobs_take_a_model_or_its_file(self, tmp_path):
        import pickle

        m = model(channels=1)
        m.save(tmp_path / "bricks.exr")
        trimesh.creation.icosphere(subdivisions=2).export(tmp_path / "ball.ply")
        jobs = [SurfaceJob(str(tmp_path / "ball.ply"), t, str(tmp_path / name), render=(16, 16), device="cpu",
                           overwrite=True) for t, name in ((m, "a"), (str(tmp_path / "bricks.exr"), "b"))]
        jobs[0] = pickle.loads(pickle.dumps(jobs[0]))  # as an executor (Dask) hands it to a worker
        results = run_jobs(jobs)
        assert [r.status for r in results] == ["done", "done"], [r.message for r in results]
        a = trimesh.load(tmp_path / "a" / "ball.ply", process=False)
        b = trimesh.load(tmp_path / "b" / "ball.ply", process=False)
        np.testing.assert_array_equal(a.visual.vertex_colors, b.visual.vertex_colors)


@pytest.mark.slow
def test_blender_renders_a_tiling_bake_as_the_package_reads_it(tmp_path):
    """A torus baked with a tiling model, written as GLB, imported and rendered by Blender: its
    pixels are the texture looked up where the package's ray cast hits (the tolerance of the
    texton bakes' Blender test, tests/surface/test_clients_mesh.py: 8-bit sRGB decoding and
    re-encoding, half a step, and bilinear weights a hair apart)."""
    import json

    import scipy.ndimage as ndi
    from PIL import Image

    from clients import run_blender
    from warp_texton.surface.bake import lookup
    from warp_texton.surface.mesh_files import texture_8bit

    pytest.importorskip("xatlas")
    torus = trimesh.creation.torus(1.0, 0.35, major_sections=48, minor_sections=24)
    baked = bake_mesh(torus, model(), 0.01, resolution=256, seed=2, device="cpu", up="z")
    write_baked(baked, tmp_path / "torus", fmt="glb")
    width, height = 80, 60
    cam = Camera(position=(2.4, -2.9, 2.2), target=(0.0, 0.0, 0.0), fov=40.0)
    script = Path(__file__).resolve().parents[1] / "blender_mesh.py"
    run_blender(script, "glb", tmp_path / "torus.glb", tmp_path / "info.json", tmp_path / "render.png",
                ",".join(map(str, cam.position)), ",".join(map(str, cam.target)), str(cam.fov), str(width),
                str(height), timeout=600)
    info = json.loads((tmp_path / "info.json").read_text())
    (material,) = info["materials"]
    assert material["base_color_from"] == "TEX_IMAGE" and material["size"] == [256, 256]
    render = np.asarray(Image.open(tmp_path / "render.png").convert("RGBA"), np.float64) / 255.0
    hits = cast_rays(baked.mesh, (height, width), cam, device="cpu")
    expected = np.zeros((height, width, 3))
    tri = hits.faces[hits.face[hits.hit]]
    uv = np.einsum("nk,nkd->nd", hits.bary[hits.hit], np.asarray(baked.mesh.visual.uv)[tri])
    expected[hits.hit] = lookup(texture_8bit(baked.texture)[0] / 255.0, uv)
    seen = render[:, :, 3] > 0.5
    assert np.count_nonzero(seen ^ hits.hit) <= 0.01 * np.count_nonzero(hits.hit)
    inside = ndi.binary_erosion(seen & hits.hit, iterations=1)
    diff = np.abs(render[:, :, :3] - expected)[inside]
    assert np.median(diff) <= 1.0 / 255.0 and diff.max() <= 3.0 / 255.0
