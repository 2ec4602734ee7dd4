"""The GLSL port of a tiling model in a real headless Chromium (WebGL2 on SwiftShader): the
preview page's float pixels against ``synthesize`` of the same window (issue 28: at least 99 %
of the pixels within 2/255, grey and RGB models, offset, scale and rotation; issue 39: examples
read wrapped, 2-D and 1-D lattices), the export's files, and what the export refuses for a tiling
model."""

from __future__ import annotations

import json

import numpy as np
import pytest

from clients import chromium_browser
from helpers import run_cli, running_bond
from warp_texton import Texton, TextonError, analyze, export_shader, synthesize
from warp_texton.model.lattice import Lattice
from warp_texton.model.tiling import TilingModel
from warp_texton.runtimes.glsl import tiling as ts
from warp_texton.runtimes.export import write_shader_preview

#: Within 2/255 on at least 99 % of the pixels (the issue's bound).
TOLERANCE = 2.0 / 255.0
MIN_AGREEMENT = 0.99


def brick(channels: int) -> np.ndarray:
    """scikit-image's brick (CC0), 256 × 256 (every second texel); RGB: three shifted copies."""
    from skimage import data

    g = data.brick()[::2, ::2].astype(np.float32) / 255.0
    if channels == 1:
        return g
    return np.stack([g, np.roll(g, 17, axis=0), 1.0 - np.roll(g, 31, axis=1)], axis=-1)


@pytest.fixture(scope="module")
def models():
    return {
        "grey": analyze(brick(1), method="tiling"),
        "rgb": analyze(brick(3), method="tiling"),
        # a fractional side, linear blend, sharpness 4 and the luminance guide (exp in the weights)
        "guide": TilingModel(brick(3), 37.3, 4, 2.0, {}, "linear"),
        # histogram-preserving: the Gaussianised example blended, then the per-channel tables
        "hist_grey": analyze(brick(1), method="tiling", histogram="preserve"),
        "hist_rgb": with_tables(analyze(brick(3), method="tiling", histogram="preserve"), 41.3, 8, 1.0),
        **lattice_models(),
    }


#: The running bond's lattice (dy, dx) and its courses.
BOND = [(16, 16), (16, -16)]
COURSES = [(16, 0)]


def lattice_models() -> dict:
    """Issue 39's models of a seamless running bond (128²): read wrapped on both axes (a side as large as
    the example) or on x only (the guide, a fractional side); snapped to its 2-D lattice (wrapped: N = 128;
    clamped: N = 2¹⁶), to its courses (grey), and a histogram-preserving one with the lattice."""
    rgb, grey = running_bond(channels=3), running_bond(channels=1)
    both = (True, True)
    hist = analyze(rgb, method="tiling", histogram="preserve")
    return {
        "wrapped": TilingModel(rgb, 128.0, 16, 0.0, {}, "variance", None, both),
        "wrapped_x": TilingModel(rgb, 37.3, 4, 2.0, {}, "linear", None, (True, False)),
        "lattice": TilingModel(rgb, 40.0, 16, 0.0, {}, "variance", None, both, Lattice.from_vectors(BOND, rgb.shape, both)),
        "lattice_clamped": TilingModel(rgb, 21.5, 8, 1.0, {}, "variance", None, (False, False),
                                       Lattice.from_vectors(BOND, rgb.shape)),
        "courses_grey": TilingModel(grey, 45.0, 16, 0.0, {}, "variance", None, both,
                                    Lattice.from_vectors(COURSES, grey.shape, both)),
        "lattice_hist": TilingModel(hist.example, 33.0, 16, 0.0, {}, hist.blend, hist.histogram, both,
                                    Lattice.from_vectors(BOND, rgb.shape, both)),
    }


@pytest.fixture(scope="module")
def browser():
    with chromium_browser() as b:
        yield b


def open_page(browser, path):
    page = browser.new_page()
    errors: list[str] = []
    page.on("pageerror", lambda e: errors.append(str(e)))
    page.goto(path.as_uri())
    page.wait_for_function("window.textonNoise !== undefined || document.getElementById('status').textContent "
                           "!== 'drawing...'", timeout=120_000)
    assert not errors, errors
    assert page.evaluate("window.textonNoise !== undefined"), page.inner_text("#status")
    return page


SHAPE = (96, 128)
CASES = {
    "grey_scale1": dict(model="grey", seed=1),
    "grey_placed": dict(model="grey", seed=2, scale=0.7, rotation=25.0, offset=(-300.25, 123.5)),
    "rgb_scale1": dict(model="rgb", seed=3, offset=(40.0, -7.0)),
    "rgb_placed": dict(model="rgb", seed=4, scale=1.6, rotation=-40.0, offset=(55.5, 1000.0)),
    "rgb_far": dict(model="rgb", seed=5, scale=0.5, rotation=10.0, offset=(1.0e6, -3.0e7)),
    "guide_placed": dict(model="guide", seed=2**32 - 1, scale=0.9, rotation=70.0, offset=(-5000.0, 20.0)),
    "hist_grey_scale1": dict(model="hist_grey", seed=6),
    "hist_rgb_placed": dict(model="hist_rgb", seed=7, scale=0.8, rotation=15.0, offset=(2.0e5, -640.5)),
    # issue 39: wrapped examples and lattices (far offsets: the anchor's position mod N from the host)
    "wrapped_scale1": dict(model="wrapped", seed=8, offset=(-77.0, 300.0)),
    "wrapped_x_placed": dict(model="wrapped_x", seed=9, scale=0.6, rotation=33.0, offset=(-4.0e4, 917.25)),
    "lattice_scale1": dict(model="lattice", seed=10),
    "lattice_far": dict(model="lattice", seed=11, scale=0.7, rotation=-20.0, offset=(1.0e6, -3.0e7)),
    "lattice_clamped_placed": dict(model="lattice_clamped", seed=12, scale=1.3, rotation=50.0, offset=(-2.5e5, 61.5)),
    "courses_grey_placed": dict(model="courses_grey", seed=13, scale=0.5, rotation=5.0, offset=(333.0, -7.0e6)),
    "lattice_hist_placed": dict(model="lattice_hist", seed=2**32 - 2, scale=0.9, rotation=-65.0, offset=(3.0e4, 2.0e4)),
}


@pytest.mark.slow
@pytest.mark.parametrize("case", CASES)
def test_preview_equals_synthesize(case, models, browser, tmp_path, record_property):
    kw = dict(CASES[case])
    model = models[kw.pop("model")]
    path = write_shader_preview(model, tmp_path / "tiling.html", SHAPE, **kw)
    html = path.read_text()
    assert "://" not in html and 'id="noise"' in html  # self-contained: nothing fetched
    page = open_page(browser, path)
    got = np.array(page.evaluate("window.textonNoise.readFloat()"), np.float32).reshape(*SHAPE, 4)
    ref = synthesize(model, SHAPE, device="cpu", **kw)
    c = model.channels
    err = np.abs(got[..., :c] - ref).max(axis=-1)
    fraction = float(np.mean(err <= TOLERANCE))
    record_property("fraction_within_2_255", fraction)
    record_property("max_error", float(err.max()))
    print(f"{case}: {fraction:.5f} of the pixels within 2/255, max error {err.max():.2e}, "
          f"median {np.median(err):.1e}, {int((err == 0).sum())} of {err.size} equal")
    assert float(ref.std()) > 0.05  # the window shows the example's structure
    assert fraction >= MIN_AGREEMENT
    if c == 1:  # the canvas shows the grey value in every channel
        assert np.array_equal(got[..., 0], got[..., 1])
    if model.histogram is not None:  # the page applied the tables: the blend alone is far from it
        blend = synthesize(without_tables(model), SHAPE, device="cpu", **kw)
        assert np.abs(blend - ref).max() > 0.5


def with_tables(model: TilingModel, side: float, sharpness: int, guide_weight: float) -> TilingModel:
    """A histogram-preserving model's example and tables with another side, sharpness and guide weight."""
    return TilingModel(model.example, side, sharpness, guide_weight, {}, model.blend, model.histogram)


def without_tables(model: TilingModel) -> TilingModel:
    """The same blend of the same (Gaussianised) example, without the histogram tables."""
    return TilingModel(model.example, model.side, model.sharpness, model.guide_weight, {}, model.blend)


@pytest.mark.slow
def test_float32_positions_from_the_origin(models, browser, tmp_path):
    """What tiling_noise(x) keeps without an anchor (x in float32 from the origin, as the OSL
    port and a shader of one's own compute it), 10⁴ texels from the origin: the issue's bound
    still holds; the anchored page at 10⁶ texels keeps float rounding only."""
    for name in ("guide", "lattice_clamped"):  # and a lattice model: tiling_noise(x) snaps from P mod N too
        float32_from_the_origin(models[name], browser, tmp_path)


def float32_from_the_origin(model, browser, tmp_path):
    kw = dict(seed=3, scale=0.8, rotation=20.0)
    for anchored, dist, bound in ((False, 1.0e4, TOLERANCE), (True, 1.0e6, 1e-4)):
        html = ts.tiling_preview_html(model, SHAPE, offset=(dist, -dist), anchored=anchored, **kw)
        (tmp_path / "p.html").write_text(html)
        page = open_page(browser, tmp_path / "p.html")
        got = np.array(page.evaluate("window.textonNoise.readFloat()"), np.float32).reshape(*SHAPE, 4)[..., :3]
        ref = synthesize(model, SHAPE, device="cpu", offset=(dist, -dist), **kw)
        err = np.abs(got - ref).max(axis=-1)
        print(f"{model!r}, {'anchored' if anchored else 'tiling_noise(x)'} at {dist:g} texels: "
              f"{np.mean(err <= TOLERANCE):.4f} within 2/255, max {err.max():.2e}")
        assert np.mean(err <= bound) >= MIN_AGREEMENT


def test_anchor_is_the_kernels_grid(models):
    """tiling_anchor's vertex and rounding are those of kernels/noise_tiling.py: x − rel is the
    whole-texel position P of the anchor, and p − P = frac lies in [−½, ½)."""
    model = models["guide"]
    rng = np.random.default_rng(0)
    for x in rng.uniform(-1e7, 1e7, size=(50, 2)):
        (a, b), frac, rel = ts.tiling_anchor(model, x)
        P = x - rel
        assert np.array_equal(P, np.round(P)) and np.all(frac >= -0.5) and np.all(frac < 0.5)
        s = float(np.float32(model.side))
        p = np.array([s * (a + b * 0.5), s * b * ts.SQRT3_2])
        assert np.allclose(p - P, frac, atol=1e-6)
        # x lies in the lattice cell of (a, b): skewed coordinates in [a, a + 1) x [b, b + 1)
        sy = x[1] / s / ts.SQRT3_2
        sx = x[0] / s - 0.5 * sy
        assert a <= sx < a + 1 and b <= sy < b + 1


def test_anchor_mod_is_the_kernels_position_mod(models):
    """anchor_mod is P(anchor) mod N of tiling_anchor's vertex, as the kernels' lattice snap takes a vertex's
    position (tiling_draw.position_mod of the float64 rounded position): in [0, N), also far from the origin
    and at negative positions; (0, 0) without a lattice."""
    model = models["lattice_clamped"]
    n = model.lattice.modulus
    assert n == 2**16
    rng = np.random.default_rng(3)
    for x in np.concatenate([rng.uniform(-1e9, 1e9, (40, 2)), rng.uniform(-300, 300, (40, 2))]):
        _, _, rel = ts.tiling_anchor(model, x)
        (a, b), frac, _ = ts.tiling_anchor(model, x)
        s = float(np.float32(model.side))
        P = np.floor(np.array([s * (a + b * 0.5), s * b * ts.SQRT3_2]) + 0.5)
        got = ts.anchor_mod(model, x)
        assert got == (int(P[0] - n * np.floor(P[0] / n)), int(P[1] - n * np.floor(P[1] / n)))
        assert all(0 <= v < n for v in got)
    assert ts.anchor_mod(models["wrapped"], (-1e6, 3e5)) == (0, 0)


def test_export_carries_the_lattice(models, tmp_path):
    """A lattice model's export adds its lattice-periodic mean (tiling_mean.f32, RGB, grey in R) and its
    constants; the description records the wrap, the centres and the lattice. A wrapped model without a
    lattice writes the files of any other model."""
    model = models["lattice"]
    out = export_shader(model, "glsl", tmp_path / "ex", seed=3)
    assert sorted(p.name for p in out.iterdir()) == ["preview.html", "texton_noise.js", "texton_noise.json",
                                                     "tiling_example.f32", "tiling_mean.f32", "tiling_noise.glsl"]
    mean = np.fromfile(out / "tiling_mean.f32", "<f4").reshape(128, 128, 4)
    assert np.array_equal(mean[..., :3], model.mean_image) and not mean[..., 3].any()
    meta = json.loads((out / "texton_noise.json").read_text())
    settings = meta["settings"]
    assert settings["wrap"] == [True, True] and settings["centre_box"] == [[0, 128], [0, 128]]
    assert settings["lattice"]["modulus"] == 128 and sorted(map(tuple, settings["lattice"]["vectors"])) == \
        [(16.0, -16.0), (16.0, 16.0)]
    source = (out / "tiling_noise.glsl").read_text()
    k = model.lattice.dual_matrix
    for line in ("const int TL_RANK = 2;", "const int TL_MODULUS = 128;", "const ivec2 TL_WRAP = ivec2(1, 1);",
                 f"const ivec2 TL_K1 = ivec2({k[0, 1]}, {k[0, 0]});", f"const ivec2 TL_K2 = ivec2({k[1, 1]}, {k[1, 0]});"):
        assert line in source, line
    header = next(line for line in source.splitlines() if line.startswith("// Generated by"))
    assert header.endswith(", wrapped on x and y, lattice (16, -16); (16, 16), seed 3")
    grey = ts.mean_texture(models["courses_grey"])
    assert np.array_equal(grey[..., 0], models["courses_grey"].mean_image[..., 0]) and not grey[..., 1:].any()
    export_shader(models["wrapped_x"], "glsl", out, overwrite=True)
    assert not (out / "tiling_mean.f32").exists()
    source = (out / "tiling_noise.glsl").read_text()
    (lx, nx), (ly, ny) = models["wrapped_x"].centre_box
    assert (lx, nx) == (0, 128) and f"const ivec2 TL_CENTRE_LO = ivec2(0, {ly});" in source
    assert "const int TL_RANK = 0;" in source and "const ivec2 TL_WRAP = ivec2(1, 0);" in source


def test_export_writes_its_files(models, tmp_path):
    model = models["rgb"]
    out = export_shader(model, "glsl", tmp_path / "ex", seed=7)
    mean = ["tiling_mean.f32"] if model.lattice is not None else []  # where analyze finds a lattice
    assert sorted(p.name for p in out.iterdir()) == sorted(["preview.html", "texton_noise.js", "texton_noise.json",
                                                            "tiling_example.f32", "tiling_noise.glsl", *mean])
    tex = np.fromfile(out / "tiling_example.f32", "<f4").reshape(256, 256, 4)
    assert np.array_equal(tex[..., :3], model.example) and not tex[..., 3].any()
    meta = json.loads((out / "texton_noise.json").read_text())
    assert meta["settings"]["method"] == "tiling" and meta["settings"]["seed"] == 7
    source = (out / "tiling_noise.glsl").read_text()
    assert source.startswith("#version 300 es\n") and "const uint TL_SEED = 7u;" in source
    guided = ts.example_texture(models["guide"])
    assert np.array_equal(guided[..., 3], models["guide"].guide)
    # an export of a texton may be overwritten by one of a tiling model, and back: the same marker file
    texton = Texton(np.random.default_rng(0).standard_normal((8, 8, 1)) / 8, [0.5])
    export_shader(texton, "glsl", out, overwrite=True)
    assert not (out / "tiling_example.f32").exists() and (out / "texton_coeffs.f32").is_file()
    export_shader(model, "glsl", out, overwrite=True)
    assert not (out / "texton_coeffs.f32").exists() and (out / "tiling_example.f32").is_file()


def test_export_carries_the_tables(models, tmp_path):
    """A histogram-preserving model's export adds its tables as tiling_colours.f32 (the unfiltered
    inverse-CDF table the host maps with, channel c in component c); a model without tables has none,
    and its library passes the blend through (TL_HISTOGRAM false)."""
    model = models["hist_rgb"]
    out = export_shader(model, "glsl", tmp_path / "ex", seed=3)
    assert sorted(p.name for p in out.iterdir()) == ["preview.html", "texton_noise.js", "texton_noise.json",
                                                     "tiling_colours.f32", "tiling_example.f32", "tiling_noise.glsl"]
    meta = json.loads((out / "texton_noise.json").read_text())
    assert meta["textures"]["tiling_colours"] == {"file": "tiling_colours.f32", "width": 1024, "height": 1,
                                                  "format": "RGBA32F"}
    tables = np.fromfile(out / "tiling_colours.f32", "<f4").reshape(1024, 4)
    assert np.array_equal(tables[:, :3], model.histogram.prefiltered[-1].T.astype(np.float32))
    assert not tables[:, 3].any()
    assert np.array_equal(np.fromfile(out / "tiling_example.f32", "<f4").reshape(256, 256, 4)[..., :3], model.example)
    assert "const bool TL_HISTOGRAM = true;" in (out / "tiling_noise.glsl").read_text()
    # back to a model without tables: its export removes the tables' file
    export_shader(models["rgb"], "glsl", out, overwrite=True)
    assert not (out / "tiling_colours.f32").exists()
    assert "const bool TL_HISTOGRAM = false;" in (out / "tiling_noise.glsl").read_text()


@pytest.mark.parametrize("kwargs, match", [
    (dict(mni=40), "mni do not apply to the shader export of a tiling model"),
    (dict(period=(64, 64), poisson="gaussian"), "period, poisson do not apply"),
    (dict(filter="mip"), "filter do not apply"),
    (dict(filter="none", up="y"), "up do not apply"),
    (dict(texel_size=0.5), "texel_size is an option of the osl export"),
    (dict(seed=-1), "seed"),
])
def test_export_refuses(models, tmp_path, kwargs, match):
    with pytest.raises(TextonError, match=match):
        export_shader(models["grey"], "glsl", tmp_path / "ex", **kwargs)
    assert list(tmp_path.iterdir()) == []


def test_refuses_a_large_example_and_far_windows(tmp_path):
    big = TilingModel(np.zeros((2100, 40, 1), np.float32), 8.0)
    with pytest.raises(TextonError, match="too large for glsl.*2048"):
        export_shader(big, "glsl", tmp_path / "ex")
    small = TilingModel(np.zeros((40, 40, 1), np.float32), 8.0)
    with pytest.raises(TextonError, match="defined within"):
        write_shader_preview(small, tmp_path / "p.html", (16, 16), offset=(3e9, 0))
    with pytest.raises(TextonError, match="at most 2048 pixels"):
        write_shader_preview(small, tmp_path / "p.html", (16, 4096))
    with pytest.raises(TextonError, match="mni do not apply"):
        write_shader_preview(small, tmp_path / "p.html", (16, 16), mni=10)
    assert list(tmp_path.iterdir()) == []


def test_cli_writes_the_export_and_the_page(models, tmp_path, capsys):
    path = tmp_path / "bricks.exr"
    models["grey"].save(path)
    assert run_cli(["shader", path, "--lang", "glsl", "-o", tmp_path / "ex", "--html", tmp_path / "p.html",
                    "--width", "20", "--height", "10", "--offset", "1e6", "3", "--seed", "4"]) == 0
    assert (tmp_path / "ex" / "tiling_noise.glsl").is_file()
    html = (tmp_path / "p.html").read_text()
    assert 'width="20" height="10"' in html and "const uint TL_SEED = 4u;" in html
    out = capsys.readouterr().out
    assert "tiling model" in out
    assert run_cli(["shader", path, "--lang", "glsl", "-o", tmp_path / "ex2", "--mni", "40"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "--mni" in err, err
    assert run_cli(["shader", path, "--lang", "glsl", "-o", tmp_path / "ex3", "--filter", "mip"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "--filter" in err, err
    assert not (tmp_path / "ex2").exists() and not (tmp_path / "ex3").exists()
