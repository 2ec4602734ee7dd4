"""A bake's normal texture in its GLB (warp_texton.surface.relief): the glTF validator (the session's
``every_glb_is_valid``) checks every GLB written here; the material references the normals, which are unit
vectors pointing out of the surface (z > 0) and follow the baked luminance."""

import json
import struct

import numpy as np
import pytest
import trimesh

from warp_texton import TextonError, bake_mesh
from warp_texton.surface.relief import baked_normals, write_baked_relief
from tests.helpers import random_texton


@pytest.fixture(scope="module")
def baked():
    mesh = trimesh.creation.torus(1.0, 0.4, major_sections=24, minor_sections=12)
    return bake_mesh(mesh, random_texton((10, 10), channels=3, order=3, seed=2), 0.02, resolution=128, device="cpu")


def _gltf(path):
    data = path.read_bytes()
    n = struct.unpack_from("<I", data, 12)[0]
    return json.loads(data[20:20 + n])


def test_the_glb_holds_a_normal_texture(baked, tmp_path):
    out = write_baked_relief(baked, tmp_path / "torus_relief.glb", strength=2.0)
    doc = _gltf(out)
    mat = doc["materials"][0]
    assert "baseColorTexture" in mat["pbrMetallicRoughness"]
    k = mat["normalTexture"]["index"]
    assert doc["images"][doc["textures"][k]["source"]]["mimeType"] == "image/png"
    assert k != mat["pbrMetallicRoughness"]["baseColorTexture"]["index"]
    import trimesh as tm

    back = tm.load(out, force="mesh")
    assert back.visual.material.normalTexture is not None


def test_normals_are_unit_and_out_of_the_surface(baked):
    n = 2.0 * baked_normals(baked, 2.0).astype(np.float64) - 1.0
    assert np.allclose(np.linalg.norm(n, axis=-1), 1.0, atol=1e-5)
    assert n[..., 2].min() > 0.0
    cov = np.asarray(baked.coverage, bool)
    assert n[cov][:, :2].std() > 0.05  # relief where the noise is
    with pytest.raises(TextonError, match="strength"):
        baked_normals(baked, -1.0)
    with pytest.raises(TextonError, match="glb"):
        write_baked_relief(baked, "x.obj")
