"""What the Blender add-on computes without Blender (``warp_texton.blender.materials``): the model of an
image, its OSL shader for a Script node, and the bake on a mesh given by its loop triangles' corners."""

from __future__ import annotations

import re

import numpy as np
import pytest

from warp_texton import TextonError, Texton, read_image, write_image
from warp_texton.blender.materials import SURFACE_MNI, bake_corners, model_kind, model_of_image, osl_shader
from warp_texton.demo import demo_texture_path
from warp_texton.model.tiling import TilingModel


def random_texton(seed: int = 0) -> Texton:
    rng = np.random.default_rng(seed)
    return Texton(rng.standard_normal((8, 8, 3)) / 8, rng.uniform(0.3, 0.6, 3), 1)


def quad_corners(size: float = 1.0):
    """Two triangles of a square in z = 0, its UVs filling [0, 1]², as Blender's loop triangles give them."""
    p = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 0, 0], [1, 1, 0], [0, 1, 0]], np.float64) * size
    n = np.tile([0.0, 0.0, 1.0], (6, 1))
    uv = p[:, :2] / size
    return p, n, uv


def test_auto_chooses_by_the_structure_score_and_reports_progress():
    steps = []
    model = model_of_image(demo_texture_path(), progress=lambda f, msg: steps.append((f, msg)))
    # the demo photograph: the score picks the tiling model (its patch distance is the smaller)
    choice = model.metadata["method_choice"]
    assert model_kind(model) == ("tiling" if choice["tiling"] < choice["texton"] else "texton") == "tiling"
    fractions = [f for f, _ in steps]
    assert fractions == sorted(fractions) and 0.0 <= fractions[0] and fractions[-1] <= 1.0
    assert any("structure score" in msg for _, msg in steps)
    assert isinstance(model_of_image(demo_texture_path(), method="texton"), Texton)


@pytest.mark.parametrize("method", ["gaussian", "Auto"])
def test_an_unknown_method_is_refused(method):
    with pytest.raises(TextonError, match="method must be one of auto, texton, tiling"):
        model_of_image(demo_texture_path(), method=method)


def test_a_bad_image_is_one_texton_error(tmp_path):
    bad = tmp_path / "photo.png"
    bad.write_bytes(b"not a png")
    with pytest.raises(TextonError):
        model_of_image(bad)


def test_the_osl_shader_of_each_model():
    texton = random_texton()
    s = osl_shader(texton, texel_size=0.02, seed=3)
    assert s.coordinates == "surface" and s.name == "texton_surface.osl"
    defaults = dict(re.findall(r"^\s+(?:float|int) (\w+) = ([-\d.e]+),", s.source, re.M))
    assert "shader texton_surface(" in s.source
    assert float(defaults["texel_size"]) == pytest.approx(0.02, rel=1e-7)  # float32
    assert float(defaults["mni"]) == SURFACE_MNI and int(defaults["seed"]) == 3
    tiling = model_of_image(demo_texture_path(), method="tiling")
    t = osl_shader(tiling, texel_size=0.01)
    assert t.coordinates == "plane" and "shader tiling_plane(" in t.source and 'coordinates = "object"' in t.source


@pytest.mark.parametrize("kind", ["texton", "tiling"])
def test_the_bake_fills_the_uvs_and_its_normals_are_unit_and_up(kind, tmp_path):
    if kind == "texton":
        model = random_texton()
    else:
        grey = read_image(demo_texture_path())[:64, :64]
        write_image(tmp_path / "crop.png", grey)
        model = model_of_image(tmp_path / "crop.png", method="tiling")
        assert isinstance(model, TilingModel)
    bake = bake_corners(model, *quad_corners(), texel_size=1 / 32, resolution=32)
    assert bake.colour.shape == bake.normal.shape == (32, 32, 3)
    assert bake.colour.std() > 0.01  # a texture, not a flat colour
    n = 2.0 * bake.normal.astype(np.float64) - 1.0
    assert np.allclose(np.linalg.norm(n, axis=-1), 1.0, atol=0.02)  # float32 in [0, 1]: unit up to the clip
    assert (n[..., 2] > 0).all() and n[..., 2].mean() > 0.5


def test_corners_must_come_three_a_triangle():
    p, n, uv = quad_corners()
    with pytest.raises(TextonError, match="three corners a triangle"):
        bake_corners(random_texton(), p[:5], n[:5], uv[:5])
    with pytest.raises(TextonError, match="as many of each"):
        bake_corners(random_texton(), p, n[:3], uv)
