"""Baked textures (``bake_mesh``, ``write_baked``): surface noise on UV coordinates.

Conventions checked here: texel (i, j) of an R × R texture has its centre at
u = (j + ½)/R, v = 1 − (i + ½)/R (row 0 at the top, as glTF and image files
store it; trimesh and OBJ count v upwards). A renderer's bilinear lookup at
(u, v) mixes the four texels around x = uR − ½, y = (1 − v)R − ½.

Tolerances come from the noise's own modulus of continuity: a bilinear lookup
is a convex combination of four texel values, each the noise at (or the
average over the footprint around) a surface point within distance s of the
looked-up point, so it lies within ω(s) = max |g(P) − g(y)| over |P − y| ≤ s
of g(y). ω is estimated per point by evaluating the noise on a circle of
radius s around it (16 directions; ×1.5 for the disc's interior): in the
tangent plane on a plane, and on a curved mesh at the surface points (with
their interpolated normals, which turn the frames) whose UVs lie on a circle
of that many texels around the point's UV.
"""

from __future__ import annotations

import json
import struct
import sys

import numpy as np
import pytest
import trimesh
from PIL import Image

from helpers import parts, random_texton
from warp_texton import BakedMesh, Texton, TextonError, bake_mesh, surface_noise, texture_mesh, write_baked
from warp_texton.surface.bake import check_uvs, to_8bit
from warp_texton.core.limits import set_memory_budget
from warp_texton.surface.frames import tangent_frames
from warp_texton.surface.mesh import srgb_to_linear, vertex_normals
from warp_texton.surface.mesh_files import gltf_rotation

pytestmark = pytest.mark.filterwarnings("ignore:.*texels apart:UserWarning")


def bilinear(texture: np.ndarray, uv: np.ndarray) -> np.ndarray:
    """A renderer's bilinear lookup (clamped at the border) of texture at uv (N, 2)."""
    r = texture.shape[0]
    x = uv[:, 0] * r - 0.5
    y = (1.0 - uv[:, 1]) * r - 0.5
    x0 = np.clip(np.floor(x).astype(int), 0, r - 1)
    y0 = np.clip(np.floor(y).astype(int), 0, r - 1)
    x1, y1 = np.clip(x0 + 1, 0, r - 1), np.clip(y0 + 1, 0, r - 1)
    fx = np.clip(x - x0, 0, 1)[:, None]
    fy = np.clip(y - y0, 0, 1)[:, None]
    t = texture.astype(np.float64)
    return ((t[y0, x0] * (1 - fx) + t[y0, x1] * fx) * (1 - fy) + (t[y1, x0] * (1 - fx) + t[y1, x1] * fx) * fy)


def plane_with_uvs(size=1.0, z=0.0):
    """A square [0, size]² at height z, two triangles, UV = (x, y) / size."""
    v = np.array([[0, 0, z], [size, 0, z], [size, size, z], [0, size, z]], float)
    uv = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], float)
    return trimesh.Trimesh(v, [[0, 1, 2], [0, 2, 3]], visual=trimesh.visual.TextureVisuals(uv=uv), process=False)


def modulus(texton, points, normals, texel, s, **kw):
    """ω(s) at each point: the largest change of the noise over a circle of radius s (world
    units) in the tangent plane, ×1.5 (see the module docstring)."""
    u1, u2 = tangent_frames(normals)
    g0 = surface_noise(texton, points, normals, texel, **kw)
    worst = np.zeros(len(points))
    s = np.broadcast_to(np.asarray(s, np.float64), (len(points),))[:, None]
    for a in np.linspace(0, 2 * np.pi, 16, endpoint=False):
        d = np.cos(a) * u1 + np.sin(a) * u2
        g = surface_noise(texton, points + s * d, normals, texel, **kw)
        worst = np.maximum(worst, np.abs(g - g0).max(axis=1))
    return 1.5 * worst + 1e-5


def surface_samples(mesh, count, seed):
    """Random points on the faces of a textured mesh and at its vertices: (faces, barycentric weights)."""
    rng = np.random.default_rng(seed)
    f = np.r_[rng.integers(0, len(mesh.faces), count), np.arange(len(mesh.faces))]
    w = np.r_[rng.dirichlet((1.0, 1.0, 1.0), count), np.tile([1.0, 0.0, 0.0], (len(mesh.faces), 1))]
    return f, w


def on_surface(mesh, f, w):
    """(points, normals, uv) at barycentric weights w of faces f (w may reach past the face:
    its plane, as the bake's footprints do)."""
    tri = np.asarray(mesh.faces)[f]
    p = np.einsum("nk,nkd->nd", w, np.asarray(mesh.vertices)[tri])
    n = np.einsum("nk,nkd->nd", w, vertex_normals(mesh)[tri])
    uv = np.einsum("nk,nkd->nd", w, np.asarray(mesh.visual.uv)[tri])
    return p, n, uv


def modulus_uv(texton, mesh, f, w, texels, resolution, texel, **kw):
    """ω at surface points, over the surface points whose UVs lie ``texels`` texture texels away."""
    tri = np.asarray(mesh.faces)[f]
    uv = np.asarray(mesh.visual.uv)[tri] * resolution
    inv = np.linalg.inv(np.stack([uv[:, 1] - uv[:, 0], uv[:, 2] - uv[:, 0]], 2))  # uv offset → (w1, w2)
    p0, n0, _ = on_surface(mesh, f, w)
    g0 = surface_noise(texton, p0, n0, texel, **kw)
    worst = np.zeros(len(f))
    for a in np.linspace(0, 2 * np.pi, 16, endpoint=False):
        dw = np.einsum("nij,j->ni", inv, texels * np.array([np.cos(a), np.sin(a)]))
        p, n, _ = on_surface(mesh, f, w + np.c_[-dw.sum(axis=1), dw])
        worst = np.maximum(worst, np.abs(surface_noise(texton, p, n, texel, **kw) - g0).max(axis=1))
    return 1.5 * worst + 1e-5


T = random_texton(channels=3, seed=1, mean=(0.3, 0.5, 0.7))


def smooth_texton() -> Texton:
    """Coefficients smoothed over ~2 texels: a noise that changes little within a texel, so a
    bake at a few texels per texton texel is close to it everywhere."""
    import scipy.ndimage as ndi

    a = ndi.gaussian_filter(np.random.default_rng(2).standard_normal((16, 16, 3)), (2.0, 2.0, 0))
    t = Texton(a, [0.3, 0.5, 0.7], 1)
    return Texton(a * 0.1 / np.sqrt(np.diag(t.covariance()))[None, None, :], [0.3, 0.5, 0.7], 1)


TS = smooth_texton()


class TestPlane:
    def test_texels_are_the_noise_at_their_centres(self, device):
        """Texel (i, j) of a bake of the unit plane (UV = xy) is g at ((j + ½)/R, 1 − (i + ½)/R, 0)."""
        r = 32
        baked = bake_mesh(plane_with_uvs(), T, 1 / 64, resolution=r, seed=3, supersample=1, device=device)
        assert isinstance(baked, BakedMesh) and baked.uv_source == "mesh" and baked.coverage.all()
        assert baked.texels_per_texton_texel == pytest.approx(0.5) and baked.samples == 1
        j, i = np.meshgrid(np.arange(r), np.arange(r))
        pts = np.stack([(j.ravel() + 0.5) / r, 1 - (i.ravel() + 0.5) / r, np.zeros(r * r)], axis=1)
        g = surface_noise(T, pts, np.tile([0, 0, 1.0], (r * r, 1)), 1 / 64, seed=3, device=device)
        np.testing.assert_allclose(baked.texture.reshape(-1, 3), g, atol=1e-6)

    def test_supersampling_averages_the_footprint(self, device):
        """At 4 texton texels per texel the default takes 4 × 4 samples at the centres of a
        4 × 4 grid over each texel, and averages them: exactly that mean of surface_noise."""
        r = 16
        baked = bake_mesh(plane_with_uvs(), T, 1 / 64, resolution=r, seed=2, device=device)
        assert baked.texels_per_texton_texel == pytest.approx(0.25) and baked.samples == 16
        offs = (np.arange(4) + 0.5) / 4
        ox, oy = np.meshgrid(offs, offs)
        j, i = np.meshgrid(np.arange(r), np.arange(r))
        x = (j.ravel()[:, None] + ox.ravel()[None]) / r
        y = 1 - (i.ravel()[:, None] + oy.ravel()[None]) / r
        pts = np.stack([x.ravel(), y.ravel(), np.zeros(x.size)], axis=1)
        g = surface_noise(T, pts, np.tile([0, 0, 1.0], (len(pts), 1)), 1 / 64, seed=2, device=device)
        np.testing.assert_allclose(baked.texture.reshape(-1, 3), g.reshape(r * r, 16, 3).mean(axis=1), atol=2e-6)
        # anti-aliased: the averages vary less than point samples (16 samples, 1 texel apart,
        # correlated over the texton: the variance drops, by far less than 16)
        point = bake_mesh(plane_with_uvs(), T, 1 / 64, resolution=r, seed=2, supersample=1, device=device)
        assert baked.texture.var() < 0.8 * point.texture.var()

    def test_texels_per_texton_texel_is_reported(self, device):
        for res, want in ((64, 1.0), (128, 2.0), (32, 0.5)):
            b = bake_mesh(plane_with_uvs(size=2.0), T, 2 / 64, resolution=res, supersample=1, device=device)
            assert b.texels_per_texton_texel == pytest.approx(want)

    def test_render_of_the_bake_matches_render_mesh(self, device):
        """Looking straight down at the plane: a pixel's ray hits (x, y, 0) with UV (x, y); the
        bake's bilinear lookup there, shaded as render_mesh shades, matches render_mesh's
        per-pixel noise within ω of half a bake texel's diagonal (and a flipped v does not)."""
        from warp_texton import Camera, render_mesh

        texel, res, h = 1 / 64, 256, 48
        plane = plane_with_uvs()
        baked = bake_mesh(plane, T, texel, resolution=res, seed=4, supersample=1, device=device)
        cam = Camera((0.5, 0.5, 3.0), (0.5, 0.5, 0.0), up=(0, 1.0, 0), fov=15.0)
        light = np.array([0.3, -0.2, 1.0])
        img = render_mesh(plane, T, (h, h), texel_size=texel, camera=cam, seed=4, light=light, device=device)
        tan = np.tan(np.radians(7.5))
        sy, sx = np.meshgrid((1 - 2 * (np.arange(h) + 0.5) / h) * tan, (2 * (np.arange(h) + 0.5) / h - 1) * tan,
                             indexing="ij")
        xy = np.stack([0.5 + 3.0 * sx.ravel(), 0.5 + 3.0 * sy.ravel()], axis=1)  # hits on z = 0
        inside = np.all((xy > 0.01) & (xy < 0.99), axis=1)
        shade = 0.3 + 0.7 * light[2] / np.linalg.norm(light)
        looked = np.clip(bilinear(baked.texture, xy[inside]), 0, 1) * shade
        got = img.reshape(-1, 3)[inside].astype(np.float64)
        pts = np.c_[xy[inside], np.zeros(inside.sum())]
        s = np.sqrt(2) / 2 / res  # a lookup's texel centres are ≤ half a diagonal away
        omega = modulus(T, pts, np.tile([0, 0, 1.0], (len(pts), 1)), texel, s, seed=4, device=device)
        assert np.all(np.abs(looked - got).max(axis=1) <= omega * shade + 1e-5)
        flipped = np.clip(bilinear(baked.texture, np.c_[xy[inside, 0], 1 - xy[inside, 1]]), 0, 1) * shade
        assert np.mean(np.abs(flipped - got).max(axis=1) > omega * shade) > 0.5


TORUS_TEXEL = 0.1  # about 5 texture texels per texton texel at 256²


@pytest.fixture(scope="module")
def torus(device):
    pytest.importorskip("xatlas")
    mesh = trimesh.creation.torus(1.0, 0.35, major_sections=48, minor_sections=24)
    return mesh, bake_mesh(mesh, TS, TORUS_TEXEL, resolution=256, seed=5, supersample=1, device=device)


@pytest.fixture(scope="module")
def baked(device):
    return bake_mesh(plane_with_uvs(), T, 1 / 32, resolution=64, seed=1, device=device)


class TestAtlas:
    def test_atlas_layout(self, torus):
        mesh, baked = torus
        assert baked.uv_source == "atlas"
        out = baked.mesh
        uv = np.asarray(out.visual.uv)
        assert uv.min() >= 0 and uv.max() <= 1 and len(out.vertices) >= len(mesh.vertices)
        assert out.area == pytest.approx(mesh.area, rel=1e-9)  # the same surface, split along seams
        assert 0.2 < baked.coverage.mean() < 0.95
        assert baked.texture.shape == (256, 256, 3) and baked.texture.dtype == np.float32

    def test_lookups_at_surface_points_are_the_surface_noise(self, torus, device):
        """At random surface points and at every vertex: the bake's bilinear lookup at the point's
        UV is within ω(s) of surface_noise there, with s = 2.5 times the largest world length of
        a texel on the point's face (the four texels are ≤ ½√2 texel away, and a gutter texel
        holds the value of a chart texel ≤ 1.5 texels further)."""
        _, baked = torus
        out = baked.mesh
        f, w = surface_samples(out, 3000, 6)
        p, n, uv = on_surface(out, f, w)
        assert 3 < baked.texels_per_texton_texel < 8
        g = surface_noise(TS, p, n, TORUS_TEXEL, seed=5, device=device)
        omega = modulus_uv(TS, out, f, w, 2.5, 256, TORUS_TEXEL, seed=5, device=device)
        err = np.abs(bilinear(baked.texture, uv) - g).max(axis=1)
        assert np.mean(err <= omega) > 0.995, np.mean(err <= omega)
        assert err.mean() < 0.5 * omega.mean()
        # the bound is loose (ω over 2.5 texels); the lookups are far closer than a texture that does
        # not follow the UVs (v flipped)
        wrong = np.abs(bilinear(baked.texture, np.c_[uv[:, 0], 1 - uv[:, 1]]) - g).max(axis=1)
        assert err.mean() < 0.1 * wrong.mean()

    def test_no_seam_between_charts(self, torus, device):
        """Along edges cut by the atlas (one 3-D edge, two UV edges), lookups on the two sides
        agree within 2ω (each is within ω of the noise at the same point); without the gutter
        they do not."""
        mesh, baked = torus
        out = baked.mesh
        v = np.round(np.asarray(out.vertices), 9)
        _, key = np.unique(v, axis=0, return_inverse=True)
        key = key.ravel()
        f = np.asarray(out.faces)
        uv = np.asarray(out.visual.uv)
        sides = {}
        for face in f:
            for a, b in ((face[0], face[1]), (face[1], face[2]), (face[2], face[0])):
                k = (min(key[a], key[b]), max(key[a], key[b]))
                pa, pb = (a, b) if key[a] <= key[b] else (b, a)
                sides.setdefault(k, []).append((pa, pb))
        seams = [s for s in sides.values() if len(s) == 2 and (s[0][0] != s[1][0] or s[0][1] != s[1][1])]
        assert len(seams) > 20
        t = np.linspace(0.1, 0.9, 5)
        ua, ub, faces, weights = [], [], [], []
        where = {}
        for k, face in enumerate(f):
            for c in range(3):
                where.setdefault((face[c], face[(c + 1) % 3]), (k, c))
        for (a0, a1), (b0, b1) in seams:
            ua.append(uv[a0] + t[:, None] * (uv[a1] - uv[a0]))
            ub.append(uv[b0] + t[:, None] * (uv[b1] - uv[b0]))
            k, c = where[(a0, a1)] if (a0, a1) in where else where[(a1, a0)]
            first = f[k][c] == a0
            wa = np.zeros((len(t), 3))
            wa[:, c] = 1 - t if first else t
            wa[:, (c + 1) % 3] = t if first else 1 - t
            faces.append(np.full(len(t), k))
            weights.append(wa)
        ua, ub, faces, weights = map(np.concatenate, (ua, ub, faces, weights))
        np.testing.assert_allclose(on_surface(out, faces, weights)[2], ua, atol=1e-12)
        omega = modulus_uv(TS, out, faces, weights, 2.5, 256, TORUS_TEXEL, seed=5, device=device)
        gap = np.abs(bilinear(baked.texture, ua) - bilinear(baked.texture, ub)).max(axis=1)
        assert np.mean(gap <= 2 * omega) > 0.99
        # the same atlas (as the mesh's own UVs) without a gutter
        bare = bake_mesh(out, TS, TORUS_TEXEL, resolution=256, seed=5, supersample=1, gutter=0, device=device)
        assert bare.uv_source == "mesh"
        np.testing.assert_array_equal(bare.coverage, baked.coverage)
        gap0 = np.abs(bilinear(bare.texture, ua) - bilinear(bare.texture, ub)).max(axis=1)
        assert gap0.mean() > 5 * gap.mean()  # the gutter is what closes the seams

    def test_render_of_the_baked_glb_matches_render_mesh(self, torus, tmp_path, device):
        """The GLB written, read back and rendered with lookups in its texture (render_baked) against
        render_mesh's per-pixel noise, same camera: on the pixels both hit, within ω of 2.5 texels
        of the noise at the hit (the lookup's texels) plus half an 8-bit step, times the shade."""
        from warp_texton import Camera, render_baked, render_mesh
        from warp_texton.surface.render import cast_rays

        mesh, baked = torus
        (glb,) = write_baked(baked, tmp_path / "torus", fmt="glb")
        # the scene's one geometry: force="mesh" would concatenate and recompute the normals
        (loaded,) = trimesh.load(glb, process=False).geometry.values()
        # glTF is Y-up: the Z-up torus was turned to +Y; turned back, it is the bake's mesh
        turn = gltf_rotation("z")
        np.testing.assert_allclose(loaded.vertex_normals, baked.mesh.vertex_normals @ turn.T, atol=1e-6)
        back = np.eye(4)
        back[:3, :3] = turn.T
        loaded.apply_transform(back)
        np.testing.assert_allclose(loaded.vertices, baked.mesh.vertices, atol=1e-6)
        np.testing.assert_allclose(loaded.vertex_normals, baked.mesh.vertex_normals, atol=1e-6)
        cam = Camera.framing(mesh, orbit=(-40, 35), zoom=1.4)
        ref = render_mesh(mesh, TS, (96, 96), texel_size=TORUS_TEXEL, camera=cam, seed=5, device=device).astype(np.float64)
        img = render_baked(loaded, (96, 96), camera=cam, device=device).astype(np.float64)
        hits = cast_rays(loaded, (96, 96), cam, device=device)
        bg = np.float32(0.92)
        both = np.any(ref != bg, axis=2) & np.any(img != bg, axis=2) & hits.hit
        assert both.mean() > 0.3 and np.mean(np.any(ref != bg, axis=2) != hits.hit) < 0.01
        face, bary = hits.face[both], hits.bary[both]
        omega = modulus_uv(TS, loaded, face, bary, 2.5, 256, TORUS_TEXEL, seed=5, device=device)
        shade = hits.shade[both].astype(np.float64)
        err = np.abs(img[both] - ref[both]).max(axis=1)
        assert np.mean(err <= (omega + 0.5 / 255) * shade + 1e-6) > 0.99
        assert err.mean() < 0.02  # the noise's sd is 0.1: the render of the bake is the noise

    def test_gutter_continues_the_chart(self, device):
        """A plane whose UVs fill the middle of the texture: the gutter texels hold the noise where
        the plane continues (exact on a plane), up to `gutter` texels out; beyond, the mean."""
        import scipy.ndimage as ndi

        mesh = plane_with_uvs()
        mesh.visual = trimesh.visual.TextureVisuals(uv=0.25 + 0.5 * np.asarray(mesh.visual.uv))
        r, gutter = 64, 3
        baked = bake_mesh(mesh, T, 1 / 32, resolution=r, seed=3, supersample=1, gutter=gutter, device=device)
        assert baked.coverage.sum() == 32 * 32
        dist = ndi.distance_transform_edt(~baked.coverage)
        ring = (dist > 0) & (dist <= gutter)
        i, j = np.nonzero(ring)
        u, v = (j + 0.5) / r, 1 - (i + 0.5) / r
        pts = np.stack([(u - 0.25) * 2, (v - 0.25) * 2, np.zeros(len(u))], axis=1)  # the plane continued
        g = surface_noise(T, pts, np.tile([0, 0, 1.0], (len(u), 1)), 1 / 32, seed=3, device=device)
        np.testing.assert_allclose(baked.texture[ring], g, atol=1e-6)
        beyond = dist > gutter
        np.testing.assert_array_equal(baked.texture[beyond], np.broadcast_to(np.float32(T.mean), (beyond.sum(), 3)))


class TestFiles:
    def test_glb_loads_back_with_uvs_material_and_image(self, baked, tmp_path):
        (glb,) = write_baked(baked, tmp_path / "plane", fmt="glb")
        assert glb.name == "plane.glb"
        scene = trimesh.load(glb, process=False)
        (mesh,) = scene.geometry.values()
        assert isinstance(mesh.visual, trimesh.visual.TextureVisuals)
        np.testing.assert_allclose(mesh.visual.uv, baked.mesh.visual.uv, atol=1e-6)
        image = mesh.visual.material.baseColorTexture
        np.testing.assert_array_equal(np.asarray(image.convert("RGB")), to_8bit(baked.texture))
        # the glTF itself: a PBR material whose base colour is the PNG, TEXCOORD_0 on the primitive
        gltf = glb_json(glb)
        (material,) = gltf["materials"]
        assert "baseColorTexture" in material["pbrMetallicRoughness"]
        assert gltf["images"][0]["mimeType"] == "image/png"
        assert "TEXCOORD_0" in gltf["meshes"][0]["primitives"][0]["attributes"]
        assert parts(tmp_path) == []

    def test_obj_mtl_png(self, baked, tmp_path):
        paths = write_baked(baked, tmp_path / "plane", fmt="obj", texture="exr")
        assert [p.name for p in paths] == ["plane.obj", "plane.mtl", "plane.png", "plane_texture.exr"]
        mtl = (tmp_path / "plane.mtl").read_text().splitlines()
        assert "map_Kd plane.png" in mtl and any(ln.startswith("Kd 1.0") for ln in mtl)
        assert "mtllib plane.mtl" in (tmp_path / "plane.obj").read_text()
        np.testing.assert_array_equal(np.asarray(Image.open(tmp_path / "plane.png").convert("RGB")),
                                      to_8bit(baked.texture))
        loaded = trimesh.load(tmp_path / "plane.obj", process=False)
        np.testing.assert_allclose(loaded.visual.uv, baked.mesh.visual.uv, atol=1e-6)
        from warp_texton import read_image

        np.testing.assert_array_equal(read_image(tmp_path / "plane_texture.exr"), baked.texture)

    def test_exr_linear_and_png_texture(self, baked, tmp_path):
        from warp_texton import read_image

        write_baked(baked, tmp_path / "a", fmt="glb", texture="exr", linear=True)
        lin = read_image(tmp_path / "a_texture.exr")
        np.testing.assert_allclose(lin, srgb_to_linear(np.clip(baked.texture, 0, 1)), rtol=1e-6, atol=1e-7)
        write_baked(baked, tmp_path / "b", fmt="glb", texture="png")
        png = np.asarray(Image.open(tmp_path / "b_texture.png"))
        np.testing.assert_array_equal(png, to_8bit(baked.texture))

    def test_all_files_or_none(self, baked, tmp_path):
        (tmp_path / "plane_texture.exr").mkdir()  # the last file cannot be written
        with pytest.raises(TextonError, match="is a folder"):
            write_baked(baked, tmp_path / "plane", fmt="obj", texture="exr")
        assert sorted(p.name for p in tmp_path.iterdir()) == ["plane_texture.exr"]
        assert parts(tmp_path) == []

    def test_vertex_colours_in_glb_are_linear(self, tmp_path, device):
        """glTF's COLOR_0 is linear: a GLB of vertex colours holds round(255 · decode(g))."""
        mesh = trimesh.creation.icosphere(subdivisions=2)
        srgb = texture_mesh(mesh, T, 0.05, device=device)
        lin = texture_mesh(mesh, T, 0.05, device=device, linear=True)
        g = np.clip(surface_noise(T, mesh.vertices, vertex_normals(mesh), 0.05, device=device), 0, 1)
        np.testing.assert_array_equal(np.asarray(lin.visual.vertex_colors)[:, :3], np.round(srgb_to_linear(g) * 255))
        np.testing.assert_array_equal(np.asarray(srgb.visual.vertex_colors)[:, :3], np.round(g * 255))
        path = tmp_path / "ball.glb"
        lin.export(path)
        colours = glb_accessor(path, "COLOR_0")
        np.testing.assert_array_equal(colours[:, :3], np.asarray(lin.visual.vertex_colors)[:, :3])



class TestGltfUp:
    """glTF is Y-up by definition: a GLB's geometry is turned from the bake's up axis to +Y."""

    def test_a_z_up_torus_lies_flat_in_its_glb(self, torus, tmp_path):
        mesh, baked = torus
        assert baked.up == (0.0, 0.0, 1.0)
        (glb,) = write_baked(baked, tmp_path / "torus", fmt="glb")
        (loaded,) = trimesh.load(glb, process=False).geometry.values()
        assert np.argmin(loaded.extents) == 1  # Y, glTF's up: the ring lies flat
        np.testing.assert_allclose(loaded.extents, np.asarray(mesh.extents)[[0, 2, 1]], atol=1e-6)
        np.testing.assert_allclose(loaded.vertices, baked.mesh.vertices @ gltf_rotation("z").T, atol=1e-6)
        # UVs and texture as they are; the OBJ keeps the input's axes
        np.testing.assert_allclose(loaded.visual.uv, baked.mesh.visual.uv, atol=1e-6)
        np.testing.assert_array_equal(np.asarray(loaded.visual.material.baseColorTexture.convert("RGB")),
                                      to_8bit(baked.texture))
        obj = write_baked(baked, tmp_path / "torus", fmt="obj")[0]
        np.testing.assert_allclose(trimesh.load(obj, process=False).vertices, baked.mesh.vertices, atol=1e-6)

    def test_round_trip_z_up_ply_to_glb_read_back_y_up(self, tmp_path, device):
        """A Z-up PLY torus, baked to GLB and read back with the GLB's up (auto: Y), renders as
        the bake in its own Z-up world: the same camera, light and frame, the same pixels."""
        pytest.importorskip("xatlas")
        from warp_texton import render_baked
        from warp_texton.surface.jobs import resolve_up

        ply = tmp_path / "torus.ply"
        trimesh.creation.torus(1.0, 0.35, major_sections=32, minor_sections=16).export(ply)
        mesh = trimesh.load(ply, process=False)
        up = resolve_up("auto", str(ply))
        assert up == "z"
        baked = bake_mesh(mesh, T, 0.05, resolution=64, supersample=1, up=up, device=device)
        (glb,) = write_baked(baked, tmp_path / "torus", fmt="glb")
        (loaded,) = trimesh.load(glb, process=False).geometry.values()
        back = resolve_up("auto", str(glb))
        assert back == "y"
        for orbit in ((-55, 25), (30, 60)):
            want = render_baked(baked, (48, 64), up=up, orbit=orbit, device=device)
            got = render_baked(loaded, (48, 64), up=back, orbit=orbit, device=device)
            # the GLB's texture is 8-bit: half a step; rays through turned triangles may differ at
            # silhouette pixels only
            diff = np.abs(got - want).max(axis=2)
            assert np.mean(diff > 0.5 / 255 + 1e-6) < 0.005, (orbit, np.mean(diff > 0.5 / 255 + 1e-6))

    def test_a_y_up_bake_is_written_as_it_is(self, baked, tmp_path, device):
        """A bake whose up is already Y: the GLB holds its coordinates unchanged."""
        plane = bake_mesh(plane_with_uvs(), T, 1 / 32, resolution=16, up="y", device=device)
        assert plane.up == (0.0, 1.0, 0.0)
        (glb,) = write_baked(plane, tmp_path / "p", fmt="glb")
        (loaded,) = trimesh.load(glb, process=False).geometry.values()
        np.testing.assert_allclose(loaded.vertices, plane.mesh.vertices, atol=1e-7)


def glb_json(path) -> dict:
    data = path.read_bytes()
    length, kind = struct.unpack_from("<I4s", data, 12)
    assert data[:4] == b"glTF" and kind == b"JSON"
    return json.loads(data[20:20 + length])


def glb_accessor(path, attribute) -> np.ndarray:
    """The values of a primitive attribute of a GLB, read from its binary chunk."""
    data = path.read_bytes()
    length = struct.unpack_from("<I", data, 12)[0]
    gltf = json.loads(data[20:20 + length])
    binary = data[20 + length + 8:]
    acc = gltf["accessors"][gltf["meshes"][0]["primitives"][0]["attributes"][attribute]]
    view = gltf["bufferViews"][acc["bufferView"]]
    dtype = {5121: np.uint8, 5126: np.float32}[acc["componentType"]]
    width = {"VEC3": 3, "VEC4": 4}[acc["type"]]
    start = view.get("byteOffset", 0) + acc.get("byteOffset", 0)
    return np.frombuffer(binary, dtype, acc["count"] * width, start).reshape(-1, width)


class TestErrors:
    @pytest.mark.parametrize(
        "uv, match",
        [
            ([[0, 0], [1, 0], [1, 1], [0, float("nan")]], "its UVs hold 1 NaN"),
            ([[0, 0], [2, 0], [2, 2], [0, 2]], r"its UVs reach \[0, 2\], outside \[0, 1\]"),
            ([[0, 0], [1, 0], [1, 1]], r"its UVs have shape \(3, 2\)"),
        ],
    )
    def test_unusable_uvs(self, uv, match, device):
        mesh = plane_with_uvs()
        mesh.visual = trimesh.visual.TextureVisuals(uv=np.asarray(uv, float)) if len(uv) == 4 else mesh.visual
        if len(uv) != 4:
            with pytest.raises(TextonError, match=match):
                check_uvs(np.asarray(uv, float), 4)
            return
        with pytest.raises(TextonError, match=rf"^floor: {match}.*uv='atlas'"):
            bake_mesh(mesh, T, 0.1, resolution=16, name="floor", device=device)

    def test_overlapping_uvs(self, device):
        # both triangles mapped onto the same half of the texture
        v = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], float)
        uv = np.array([[0, 0], [1, 0], [1, 1], [1, 0]], float)
        mesh = trimesh.Trimesh(v, [[0, 1, 2], [0, 3, 2]], visual=trimesh.visual.TextureVisuals(uv=uv),
                               process=False)
        with pytest.raises(TextonError, match=r"^mesh: its UVs overlap \(\d+\.\d % .*uv='atlas'"):
            bake_mesh(mesh, T, 0.1, resolution=32, device=device)
        pytest.importorskip("xatlas")
        assert bake_mesh(mesh, T, 0.1, resolution=32, uv="atlas", device=device).uv_source == "atlas"

    @pytest.mark.parametrize(
        "kw, match",
        [
            (dict(resolution=0), "resolution must be at least 1"),
            (dict(resolution=2.5), "resolution must be an integer"),
            (dict(resolution=20000), "resolution must be at most 16384"),
            (dict(uv="mine"), "uv must be one of auto, mesh, atlas"),
            (dict(supersample=0), "supersample must be at least 1"),
            (dict(gutter=-1), "gutter must be at least 0"),
            (dict(texel_size=0.0), "texel_size"),
            (dict(texton=np.ones((4, 4))), "texton must be a Texton"),
            (dict(mesh=trimesh.Trimesh()), "mesh is empty"),
        ],
    )
    def test_bad_arguments(self, kw, match, device):
        args = dict(mesh=plane_with_uvs(), texton=T, texel_size=0.1, resolution=16, device=device)
        args.update(kw)
        with pytest.raises(TextonError, match=match):
            bake_mesh(**args)

    def test_no_uvs_with_uv_mesh(self, device):
        with pytest.raises(TextonError, match="has no UVs"):
            bake_mesh(trimesh.creation.box(), T, 0.1, resolution=16, uv="mesh", device=device)

    def test_memory_budget(self, device):
        set_memory_budget("1M")
        try:
            with pytest.raises(TextonError, match=r"a 4096x4096 bake needs about .* over the memory budget"):
                bake_mesh(plane_with_uvs(), T, 0.1, resolution=4096, device=device)
        finally:
            set_memory_budget(None)

    def test_missing_xatlas(self, monkeypatch, device):
        monkeypatch.setitem(sys.modules, "xatlas", None)  # import fails as if not installed
        with pytest.raises(TextonError, match=r"needs the xatlas package: pip install 'warp-texton\[mesh\]'"):
            bake_mesh(trimesh.creation.box(), T, 0.1, resolution=16, device=device)
        # a mesh with UVs needs no atlas
        assert bake_mesh(plane_with_uvs(), T, 0.1, resolution=16, device=device).uv_source == "mesh"


def test_bake_work_is_priced_before_sampling(monkeypatch):
    """Every sample of a bake is a point of the surface noise: a supersample that would take
    longer than the work budget is refused before the first sample, naming the knobs."""
    import warp_texton.surface.bake as B
    from warp_texton.core.limits import set_work_budget

    called = []
    monkeypatch.setattr(B, "evaluate_points", lambda *a, **k: called.append(a))
    set_work_budget(1e9)
    try:
        with pytest.raises(TextonError, match=r"a 64x64 bake with (about )?[\d.e+]+ samples at MNI 60 .* over the work "
                                              r"budget of 1e\+09; "
                                              r"use a smaller resolution, a smaller supersample") as info:
            bake_mesh(plane_with_uvs(), random_texton(), 0.01, resolution=64, supersample=64, device="cpu")
    finally:
        set_work_budget(None)
    assert not called and info.value.param == "supersample" and "resolution" in info.value.mentions


@pytest.mark.parametrize("uv, kwargs", [("atlas", {"supersample": 64}), ("atlas", {"mni": 20000}),
                                        ("mesh", {"supersample": 64})])
def test_bake_priced_before_the_atlas(monkeypatch, uv, kwargs):
    """A bake that no atlas could make affordable is refused before the atlas and the
    texels' setup (seconds and a gigabyte at 2048²), from the mesh's area and the texels
    it would cover; a bake within the budget gets past that first estimate."""
    import warp_texton.surface.bake as B

    setup = []
    monkeypatch.setattr(B, "make_atlas", lambda *a, **k: setup.append("atlas"))
    monkeypatch.setattr(B, "_claimed", lambda *a, **k: setup.append("claimed"))
    mesh = plane_with_uvs() if uv == "mesh" else trimesh.creation.icosphere(subdivisions=3)
    with pytest.raises(TextonError, match=r"a 2048x2048 bake with about [\d.e+]+ samples at MNI [\d.]+ needs about "
                                          r".* over the work budget") as info:
        bake_mesh(mesh, random_texton(), 0.01, resolution=2048, uv=uv, device="cpu", **kwargs)
    assert not setup and info.value.param == "supersample"
    with pytest.raises(TypeError):  # past the estimate: the stand-in atlas returns nothing
        bake_mesh(mesh, random_texton(), 0.01, resolution=256, uv=uv, device="cpu")
    assert setup
