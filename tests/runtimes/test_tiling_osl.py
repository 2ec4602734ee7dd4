"""The OSL port of a tiling model in its real client: Blender's Cycles (CPU) compiles and renders
the exported ``tiling_plane`` shader, and the pixels equal ``evaluate`` at the points the pixel
centres see, within the tolerance the texton noise's OSL export meets (tests/runtimes/test_shader_osl.py:
99.9 % of the pixels within 10⁻³ of the range, none farther than 10⁻³ from the values over the
camera's jitter square); examples read wrapped and lattice models (issue 39) alike."""

from __future__ import annotations

import json

import numpy as np
import pytest

from test_shader_osl import (EXACT_PIXELS, EXACT_TEXEL, MIN_AGREEMENT, SIZE, TOLERANCE, agreement, exact_point_source,
                             jitter_box, pixel_centres, plane_mesh, render)
from helpers import running_bond
from warp_texton import TextonError, analyze, evaluate, export_shader
from warp_texton.model.lattice import Lattice
from warp_texton.model.tiling import TilingModel
from warp_texton.runtimes.osl import tiling as ts
from warp_texton.surface.mesh import srgb_to_linear


def brick(channels: int, step: int = 4) -> np.ndarray:
    """scikit-image's brick (CC0) at every ``step``-th texel; RGB: three shifted copies."""
    from skimage import data

    g = data.brick()[::step, ::step].astype(np.float32) / 255.0
    if channels == 1:
        return g
    return np.stack([g, np.roll(g, 17, axis=0), 1.0 - np.roll(g, 31, axis=1)], axis=-1)


#: (model, seed, coordinates, texel size, output): grey and RGB, the default blend and the
#: linear one with the luminance guide and a fractional side, a seed above 2**31, both
#: coordinate modes, the sRGB-decoded output.
CASES = [
    (lambda: TilingModel(brick(1), 32.0, 16, 0.0, {}, "variance"), 3, "object", 0.01, "Color"),
    (lambda: TilingModel(brick(3), 32.0, 16, 0.0, {}, "variance"), 2**31 + 9, "input", 0.004, "Color"),
    (lambda: TilingModel(brick(3), 21.7, 4, 2.0, {}, "linear"), 11, "object", 0.02, "Linear"),
    # histogram-preserving: the tables embedded, applied after the blend
    (lambda: preserving(3), 5, "object", 0.01, "Color"),
    (lambda: preserving(1), 2**32 - 2, "input", 0.004, "Color"),
    # issue 39: a seamless running bond read wrapped, snapped to its lattice (N = 128; clamped: N = 2¹⁶,
    # with the guide) and to its courses (grey)
    (lambda: wrapped(), 13, "object", 0.01, "Color"),
    (lambda: bond_lattice(), 2**31 + 3, "input", 0.004, "Color"),
    (lambda: bond_lattice(clamped=True), 17, "object", 0.01, "Linear"),
    (lambda: courses(), 19, "object", 0.02, "Color"),
]

BOTH = (True, True)


def wrapped() -> TilingModel:
    """The running bond read wrapped on both axes, with a side as large as the example."""
    return TilingModel(running_bond(), 128.0, 16, 0.0, {}, "variance", None, BOTH)


def bond_lattice(clamped: bool = False) -> TilingModel:
    """The running bond snapped to its 2-D lattice: wrapped (N = 128), or read clamped (N = 2¹⁶) with a
    fractional side and the luminance guide."""
    u = running_bond()
    if clamped:
        return TilingModel(u, 21.5, 8, 1.0, {}, "variance", None, (False, False),
                           Lattice.from_vectors([(16, 16), (16, -16)], u.shape))
    return TilingModel(u, 40.0, 16, 0.0, {}, "variance", None, BOTH,
                       Lattice.from_vectors([(16, 16), (16, -16)], u.shape, BOTH))


def courses() -> TilingModel:
    """The grey running bond snapped to its courses (a 1-D lattice, 16 texels high), read wrapped."""
    u = running_bond(channels=1)
    return TilingModel(u, 45.0, 16, 0.0, {}, "variance", None, BOTH, Lattice.from_vectors([(16, 0)], u.shape, BOTH))


def preserving(channels: int) -> TilingModel:
    """A histogram-preserving model of the brick (its Gaussianised example and tables), side 23.5, guide 1."""
    m = analyze(brick(channels), method="tiling", histogram="preserve")
    return TilingModel(m.example, 23.5, 8, 1.0, {}, m.blend, m.histogram)


@pytest.mark.slow
def test_plane_shader_renders_evaluate(tmp_path):
    scale = 1.8  # the view; the plane (2 x 2, one UV square) covers it
    jobs, cases = [], []
    for n, (make, seed, coordinates, texel, output) in enumerate(CASES):
        model = make()
        osl = tmp_path / f"{n}_{ts.OSL_FILE}"
        osl.write_bytes(ts.tiling_osl_files(model, seed, texel)[ts.OSL_FILE])
        jobs.append({"osl": str(osl), "mode": "internal", "inputs": {"coordinates": coordinates}, "ortho_scale": scale,
                     "output": output, **plane_mesh(1.0), **({"uv_input": "Vector"} if coordinates == "input" else {})})
        cases.append((model, seed, coordinates, texel, output))
    reports = render(tmp_path, jobs)
    x, y = pixel_centres(scale)
    for (model, seed, coordinates, texel, output), rep in zip(cases, reports):
        def values(dx, dy):
            if coordinates == "input":
                u, v = (x + dx + 1.0) / 2.0, (y + dy + 1.0) / 2.0
                pts = np.stack([u / texel, (1.0 - v) / texel], -1)
            else:
                pts = np.stack([(x + dx) / texel, -(y + dy) / texel], -1)
            out = evaluate(model, pts.reshape(-1, 2), seed=seed, device="cpu").reshape(SIZE, SIZE, model.channels)
            return srgb_to_linear(out) if output == "Linear" else out

        covered = rep["rgba"][..., 3] == 1.0
        assert covered.all()
        a = agreement(rep["rgba"], *jitter_box(values, scale), covered, model.channels)
        print(f"tiling plane, {model!r}, seed {seed}, {coordinates}, {output}: {a}; "
              f"compile {rep['compile_s']:.2f} s, render {rep['render_s']:.2f} s")
        # the example's sharp edges (mortar lines) change the value by more than the tolerance within
        # the camera's jitter square on many pixels: judge those by the square's range (as the texton
        # test judges its order-0 texton), the others by the value at the centre
        assert a["max_outside_jitter"] <= TOLERANCE
        assert a["fraction_unambiguous"] >= MIN_AGREEMENT


@pytest.mark.slow
def test_shader_at_exact_points(tmp_path):
    # Without the camera's jitter (the shader snaps its point to the pixel centre, a float32
    # number here and there) the render differs from evaluate by float rounding only: a vertex
    # whose hash, draws or whole-texel position differed would shift its patch by texels,
    # changing its pixels by a good part of the range.
    models = [TilingModel(brick(1), 32.0, 16, 0.0, {}, "variance"), TilingModel(brick(3), 21.7, 4, 2.0, {}, "linear"),
              preserving(3), bond_lattice(), bond_lattice(clamped=True), courses()]
    jobs = []
    for n, model in enumerate(models):
        osl = tmp_path / f"exact_{n}.osl"
        osl.write_text(exact_point_source(ts.tiling_osl_files(model, 5 + n, EXACT_TEXEL)[ts.OSL_FILE].decode(),
                                          "plane"))
        jobs.append({"osl": str(osl), "ortho_scale": 96 / EXACT_PIXELS, "width": 96, "height": 96, **plane_mesh(1.0)})
    for n, (model, rep) in enumerate(zip(models, render(tmp_path, jobs))):
        c = ((np.arange(96) - 48 + 0.5) / EXACT_PIXELS).astype(np.float32)
        sx, sy = np.meshgrid(c, c[::-1])
        pts = np.stack([sx / np.float32(EXACT_TEXEL), -sy / np.float32(EXACT_TEXEL)], -1).reshape(-1, 2)
        want = evaluate(model, pts.astype(np.float64), seed=5 + n, device="cpu").reshape(96, 96, model.channels)
        got = rep["rgba"][..., :model.channels]
        assert (rep["rgba"][..., 3] == 1.0).all()
        err = np.abs(got - want).max(axis=-1) / (want.max() - want.min())
        print(f"tiling at exact points, {model!r}: max error {err.max():.2e} of the range, "
              f"{int((err > 1e-4).sum())} of {err.size} pixels beyond 1e-4, {int((err == 0).sum())} equal")
        assert err.max() < 1e-4


def test_files_and_refusals(tmp_path):
    model = TilingModel(brick(3, 8), 12.0)
    out = export_shader(model, "osl", tmp_path / "osl", seed=2**32 - 1, texel_size=0.25)
    assert sorted(p.name for p in out.iterdir()) == ["texton_noise_osl.json", "tiling_plane.osl"]
    source = (out / "tiling_plane.osl").read_text()
    assert "int seed = -1," in source and "float texel_size = 0.25," in source
    assert f"float T[{64 * 64 * 3}]" in source
    meta = json.loads((out / "texton_noise_osl.json").read_text())
    assert meta["settings"]["method"] == "tiling" and meta["settings"]["texel_size"] == 0.25
    guided = ts.tiling_osl_files(TilingModel(brick(3, 8), 12.0, 16, 1.0), 0)[ts.OSL_FILE].decode()
    assert f"float T[{64 * 64 * 4}]" in guided  # the guide travels as a fourth value a texel
    assert "float L[" not in source  # no tables: the blend as it is
    hist = analyze(brick(3, 8), method="tiling", side=12, histogram="preserve")
    mapped = ts.tiling_osl_files(hist, 0)[ts.OSL_FILE].decode()
    stride = 3 if hist.lattice is None else 6  # where analyze finds a lattice, its mean travels too
    assert f"float L[{3 * 1024}]" in mapped and f"float T[{64 * 64 * stride}]" in mapped  # the tables embedded
    # a lattice model carries its lattice-periodic mean beside each texel; its wrap and lattice are described
    bond = bond_lattice(clamped=True)
    lattice = ts.tiling_osl_files(bond, 0)[ts.OSL_FILE].decode()
    assert f"float T[{128 * 128 * 7}]" in lattice and ", lattice (16, -16); (16, 16)" in lattice.splitlines()[0]
    out = export_shader(wrapped(), "osl", tmp_path / "osl", seed=1, overwrite=True)
    settings = json.loads((out / "texton_noise_osl.json").read_text())["settings"]
    assert settings["wrap"] == [True, True] and settings["lattice"] is None
    assert settings["centre_box"] == [[0, 128], [0, 128]]
    with pytest.raises(TextonError, match="too large for an OSL shader"):
        ts.tiling_osl_files(TilingModel(np.zeros((600, 512, 3), np.float32), 8.0))
    with pytest.raises(TextonError, match="filter do not apply"):
        export_shader(model, "osl", tmp_path / "f", filter="mip")
    with pytest.raises(TextonError, match="mni do not apply"):
        export_shader(model, "osl", tmp_path / "m", mni=50)
    with pytest.raises(TextonError, match="texel_size"):
        export_shader(model, "osl", tmp_path / "t", texel_size=0)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["osl"]


def test_cli_writes_the_osl_export(tmp_path, capsys):
    from helpers import run_cli

    model = TilingModel(brick(1, 8), 12.0)
    model.save(tmp_path / "m.exr")
    assert run_cli(["shader", tmp_path / "m.exr", "--lang", "osl", "-o", tmp_path / "osl", "--seed", "6",
                    "--texel-size", "0.02"]) == 0
    want = ts.tiling_osl_files(model, 6, 0.02)[ts.OSL_FILE]
    assert (tmp_path / "osl" / ts.OSL_FILE).read_bytes() == want
    assert "osl export of a tiling model" in capsys.readouterr().out
    assert run_cli(["shader", tmp_path / "m.exr", "--lang", "osl", "-o", tmp_path / "bad", "--period", "8", "8"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "--period" in err, err
    assert not (tmp_path / "bad").exists()
