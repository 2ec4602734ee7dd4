"""Mesh assets: method="auto" by density, GLB inputs keep their normals, vertex-colour GLBs get a material."""

from __future__ import annotations

import json
import struct
from unittest import mock

import numpy as np
import pytest
import trimesh

import warp_texton.surface.points as surface
from warp_texton import Texton, surface_noise
from warp_texton.surface.jobs import SurfaceJob, run_jobs
from warp_texton.surface.mesh_files import COLOUR_MATERIAL, scene_mesh, with_colour_material


def _texton():
    return Texton(np.random.default_rng(0).standard_normal((8, 8, 1)) / 8, [0.5])


def _on_sphere(n, seed=0):
    d = np.random.default_rng(seed).normal(size=(n, 3))
    return d / np.linalg.norm(d, axis=1)[:, None]


class TestAutoMethod:
    def _chosen(self, points, normals):
        taken = []
        real = surface.gather_blocks

        def spy(*args, **kwargs):
            taken.append("blocks")
            return real(*args, **kwargs)

        with mock.patch.object(surface, "gather_blocks", side_effect=spy):
            values = surface_noise(_texton(), points, normals, 1.0, device="cpu")
        return ("blocks" if taken else "points"), values

    @pytest.mark.parametrize("radius, expected", [(10.0, "blocks"), (1e5, "points")])
    def test_auto_takes_blocks_for_dense_points_and_the_walk_for_sparse_ones(self, radius, expected):
        d = _on_sphere(2 * surface.AUTO_MIN_POINTS)
        pts = surface.texel_positions(d * radius, 1.0, surface.surface_setup(_texton(), 60.0), "points")
        setup = surface.surface_setup(_texton(), 60.0)
        blocked = surface.sort_into_blocks(pts, d.astype(np.float32), setup.cell, surface.walk_reach(setup.r))
        density = len(d) / len(blocked.starts)
        # the cases lie on either side of the threshold, by far
        assert (density >= 4 * surface.AUTO_MIN_DENSITY) if expected == "blocks" else \
            (density <= surface.AUTO_MIN_DENSITY / 4)
        chosen, values = self._chosen(d * radius, d)
        assert chosen == expected
        reference = surface_noise(_texton(), d * radius, d, 1.0, device="cpu", method="points")
        assert np.array_equal(values, reference)  # both paths give the same values

    def test_few_points_walk_whatever_their_density(self):
        d = _on_sphere(surface.AUTO_MIN_POINTS - 1)
        assert self._chosen(d * 10.0, d)[0] == "points"


class TestGlbNormals:
    def test_a_glb_input_keeps_the_normals_it_holds(self, tmp_path):
        sphere = trimesh.creation.icosphere(2)
        custom = np.tile([0.0, 0.0, 1.0], (len(sphere.vertices), 1))  # not the faces' average
        trimesh.Trimesh(sphere.vertices, sphere.faces, vertex_normals=custom, process=False).export(tmp_path / "s.glb")
        mesh = scene_mesh(trimesh.load(tmp_path / "s.glb", process=False))
        assert np.allclose(mesh.vertex_normals, custom)
        # trimesh's own joining recomputes them
        assert not np.allclose(trimesh.load(tmp_path / "s.glb", force="mesh", process=False).vertex_normals, custom)

    def test_node_transforms_turn_the_normals(self, tmp_path):
        sphere = trimesh.creation.icosphere(1)
        custom = np.tile([0.0, 0.0, 1.0], (len(sphere.vertices), 1))
        scene = trimesh.Scene()
        turn = trimesh.transformations.rotation_matrix(np.pi / 2, [1, 0, 0])  # z -> -y
        scene.add_geometry(trimesh.Trimesh(sphere.vertices, sphere.faces, vertex_normals=custom, process=False),
                           transform=turn)
        scene.export(tmp_path / "t.glb")
        mesh = scene_mesh(trimesh.load(tmp_path / "t.glb", process=False))
        assert np.allclose(mesh.vertex_normals, [0.0, -1.0, 0.0], atol=1e-6)


def _glb_json(data: bytes) -> dict:
    n = struct.unpack_from("<I", data, 12)[0]
    return json.loads(data[20:20 + n])


class TestVertexColourGlb:
    def test_a_vertex_colour_glb_has_a_white_material_that_its_colours_multiply(self, tmp_path):
        trimesh.creation.torus(1.0, 0.35).export(tmp_path / "t.ply")
        (result,) = run_jobs([SurfaceJob(str(tmp_path / "t.ply"), _texton(), str(tmp_path / "out"), 0.05,
                                         fmt="glb", device="cpu")])
        assert result.status == "done"
        data = (tmp_path / "out" / "t.glb").read_bytes()
        doc = _glb_json(data)
        (prim,) = doc["meshes"][0]["primitives"]
        assert "COLOR_0" in prim["attributes"] and doc["materials"][prim["material"]] == COLOUR_MATERIAL
        assert struct.unpack_from("<I", data, 8)[0] == len(data) and len(data) % 4 == 0
        counts = {k: doc["accessors"][prim["attributes"][k]]["count"] for k in ("COLOR_0", "POSITION")}
        assert counts["COLOR_0"] == counts["POSITION"]  # a colour per vertex (the validator checks the rest)

    def test_a_glb_without_colours_is_left_alone(self):
        data = trimesh.creation.box().export(file_type="glb")
        assert with_colour_material(data) == data


class TestSixteenBitTextures:
    def _baked(self, dtype="uint16", channels=3):
        from warp_texton import bake_mesh

        t = Texton(np.random.default_rng(0).standard_normal((8, 8, channels)) / 48, [0.5, 0.4, 0.3][:channels])
        return bake_mesh(trimesh.creation.torus(1.0, 0.35), t, 0.05, resolution=64, device="cpu", dtype=dtype)

    @staticmethod
    def _decode(png: bytes) -> np.ndarray:
        import imagecodecs

        return np.asarray(imagecodecs.png_decode(png))

    def test_every_png_of_a_uint16_bake_holds_16_bits(self, tmp_path):
        from warp_texton import write_baked

        pytest.importorskip("imagecodecs")
        baked = self._baked()
        expected = np.rint(np.clip(baked.texture, 0, 1) * 65535).astype(np.uint16)
        write_baked(baked, tmp_path / "t", fmt="glb", texture="png")
        write_baked(baked, tmp_path / "t", fmt="obj")
        data = (tmp_path / "t.glb").read_bytes()
        doc = _glb_json(data)
        view = doc["bufferViews"][doc["images"][0]["bufferView"]]
        start = 20 + struct.unpack_from("<I", data, 12)[0] + 8 + view.get("byteOffset", 0)
        for png in (data[start:start + view["byteLength"]], (tmp_path / "t.png").read_bytes(),
                    (tmp_path / "t_texture.png").read_bytes()):
            assert np.array_equal(self._decode(png), expected)
        assert struct.unpack_from("<I", data, 8)[0] == len(data)
        # the geometry and UVs around the swapped image are intact
        (back,) = trimesh.load(tmp_path / "t.glb", process=False).geometry.values()
        assert len(back.faces) == len(baked.mesh.faces)
        assert np.allclose(back.visual.uv, baked.mesh.visual.uv, atol=1e-6)

    def test_a_grey_uint16_texture_alone_is_one_channel(self, tmp_path):
        from PIL import Image

        from warp_texton import write_baked

        baked = self._baked(channels=1)
        write_baked(baked, tmp_path / "g", fmt="glb", texture="png")
        with Image.open(tmp_path / "g_texture.png") as img:
            assert img.mode.startswith("I;16") or img.mode == "I"
            assert np.array_equal(np.asarray(img).astype(np.uint16),
                                  np.rint(np.clip(baked.texture[:, :, 0], 0, 1) * 65535).astype(np.uint16))

    def test_a_type_png_cannot_hold_is_refused(self):
        from warp_texton import TextonError

        with pytest.raises(TextonError, match=r"dtype must be 'uint8' or 'uint16' .* got 'float32'; for float "
                                              r"values write the texture as EXR"):
            self._baked(dtype="float32")

    def test_a_job_with_uint16_writes_16_bit_pngs(self, tmp_path):
        pytest.importorskip("imagecodecs")
        trimesh.creation.torus(1.0, 0.35).export(tmp_path / "t.ply")
        soft = Texton(np.random.default_rng(0).standard_normal((8, 8, 1)) / 48, [0.5])  # nothing clipped
        job = SurfaceJob(str(tmp_path / "t.ply"), soft, str(tmp_path / "out"), 0.05, bake=32, fmt="obj",
                         texture="png", dtype="uint16", device="cpu")
        (result,) = run_jobs([job])
        assert result.status == "done"
        assert self._decode((tmp_path / "out" / "t.png").read_bytes()).dtype == np.uint16
        bad = run_jobs([SurfaceJob(str(tmp_path / "t.ply"), _texton(), str(tmp_path / "bad"), 0.05, bake=32,
                                   dtype="float16", device="cpu")])[0]
        assert bad.status == "failed" and bad.message.startswith(f"{tmp_path / 't.ply'}: dtype must be")
        assert not (tmp_path / "bad").exists() or list((tmp_path / "bad").iterdir()) == []
