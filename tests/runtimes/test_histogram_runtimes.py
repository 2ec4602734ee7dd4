"""Histogram transforms outside the host outputs: the device API, the shader exports, the viewer.

A texton analysed with ``histogram="preserve"`` shows its example's colours in
every host output (tests/test_histogram.py). The device API, the GLSL export
(its preview and the viewer's WebGL2 mode, in Chromium) and the OSL export (in
Blender's Cycles) apply the same transform and are compared with the host
outputs; ``dsn``, the Gaussian model's reference, refuses such a texton with one
``TextonError`` naming the alternative: no runtime shows the Gaussian values
silently.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
import trimesh
import warp as wp

import device_kernels as user
import warp_texton.runtimes.warp_api as td
from view.test_view import small_rgb
from warp_texton import (FilterOptions, Texton, TextonError, analyze, dsn, evaluate, read_image,
                         surface_noise, synthesize)
from warp_texton.noise.filtering import RasterPixels, pixel_shares
from warp_texton.noise.raster import raster_geometry
from warp_texton.runtimes.export import write_shader_preview
from warp_texton.demo import demo_texture_path

from helpers import run_cli

REFUSED = r"texton has a histogram transform .*, which {} does not apply: it would show Gaussian values"


@pytest.fixture(scope="module")
def grey():
    return analyze(read_image(demo_texture_path()), size=16, seed=0, histogram="preserve")


@pytest.fixture(scope="module")
def rgb_example(tmp_path_factory):
    return read_image(small_rgb(tmp_path_factory.mktemp("rgb") / "rgb64.png"))


@pytest.fixture(scope="module")
def rgb(rgb_example):
    return analyze(rgb_example, size=16, order=3, seed=0, histogram="preserve")


def launch(kernel, n, inputs, device, dtype=wp.vec3):
    out = wp.zeros(n, dtype=dtype, device=device)
    wp.launch(kernel, dim=n, inputs=inputs, outputs=[out], device=device)
    return out.numpy()


def same(got, want, device):
    """Bit for bit on the CPU, where the host maps the values with the same functions; on
    CUDA the mapping runs on the GPU, whose float32 arithmetic may contract differently:
    1e-5 of the range (the tables' float32 rounding is 1e-7 of it)."""
    if device == "cpu":
        assert np.array_equal(got, want)
    else:
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-5 * float(np.ptp(want)))


def plain(t: Texton) -> Texton:
    return Texton(t.coeffs, t.mean, t.order, t.metadata)


def test_dsn_refuses_a_texton_with_a_transform(grey):
    """dsn is the Gaussian model's discrete reference: it does not map its values."""
    with pytest.raises(TextonError, match=REFUSED.format(r"dsn \(the discrete spot noise of the Gaussian model\)")) \
            as err:
        dsn(grey, (8, 8))
    assert err.value.param == "texton" and "histogram='gaussian'" in str(err.value) and "synthesize" in str(err.value)
    assert dsn(plain(grey), (8, 8)).shape == (8, 8, 1)


# ------------------------------------------------------------------ device API
@pytest.mark.parametrize("which", ["grey", "rgb"])
def test_plane_colour_is_evaluate(which, request, device):
    texton = request.getfixturevalue(which)
    pts = np.random.default_rng(1).uniform(-80, 80, (400, 2))
    kw = dict(mni=20, seed=5, period=(40.0, 36.0))
    got = launch(user.plane_colour_at, len(pts), [td.pack_plane(texton, device=device, **kw),
                                                  td.pack_colours(texton, mni=kw["mni"], device=device),
                                                  wp.array(pts, dtype=wp.vec2d, device=device)], device)
    c = texton.channels
    want = evaluate(texton, pts, device=device, **kw)
    same(got[:, :c], want, device)
    gauss = evaluate(plain(texton), pts, device=device, **kw)
    assert np.abs(want - gauss).max() > 0.05  # the transform changed the values: it was applied
    # a texton without a transform: the values as they are
    got = launch(user.plane_colour_at, len(pts), [td.pack_plane(plain(texton), device=device, **kw),
                                                  td.pack_colours(plain(texton), device=device),
                                                  wp.array(pts, dtype=wp.vec2d, device=device)], device)
    same(got[:, :c], gauss, device)


@pytest.mark.parametrize("options", [FilterOptions("mip"), FilterOptions("anisotropic", max_aniso=4, lod_bias=0.3)],
                         ids=["mip", "anisotropic"])
def test_filtered_colour_is_filtered_synthesize(rgb, rgb_example, options, device):
    h, w = 24, 20
    J = np.zeros((h, w, 2, 2))
    J[..., 0, 0] = np.linspace(0.7, 3.0, w)[None, :]
    J[..., 1, 0] = 0.4
    J[..., 1, 1] = np.geomspace(0.5, 200.0, h)[:, None]  # up to past the kept levels: the mean colour
    kw = dict(mni=25, seed=3)
    place = dict(scale=0.8, rotation=15.0, offset=(-300.0, 20.0))
    raster = synthesize(rgb, (h, w), filter=options, jacobian=J, device=device, **place, **kw)
    pixels = RasterPixels((h, w), *raster_geometry((h, w), *place.values()), J)
    J32 = wp.array(J.reshape(-1, 2, 2).astype(np.float32), dtype=wp.mat22, device=device)
    noise = td.pack_filtered(rgb, filter=options, device=device, **kw)
    cmap = td.pack_colours(rgb, mni=kw["mni"], device=device)
    got = launch(user.filtered_colour_at, h * w, [noise, cmap, wp.array(pixels.centres(0, h * w), dtype=wp.vec2d,
                                                                         device=device), J32], device)
    same(got.reshape(h, w, 3), raster, device)
    shares = launch(user.shares_at, h * w, [noise, cmap, J32], device, dtype=float)
    same(shares, pixel_shares(rgb, pixels, options), device)
    assert shares.max() > 0.5 and shares.min() == 0.0  # near pixels keep most of the variance, far ones none
    mean = raster[-1].reshape(-1, 3)  # past the kept levels: the example's mean colour (share 0)
    np.testing.assert_allclose(mean, np.broadcast_to(rgb_example.mean(axis=(0, 1)), mean.shape), atol=2e-3)


def test_surface_colour_is_surface_noise(rgb, device):
    sphere = trimesh.creation.icosphere(subdivisions=3, radius=1.1)
    points, normals = sphere.vertices + [2.0, -1.0, 0.5], sphere.vertex_normals
    kw = dict(mni=40, seed=2, up="y")
    got = launch(user.surface_colour_at, len(points), [
        td.pack_surface(rgb, 0.02, device=device, **kw), td.pack_colours(rgb, device=device),
        wp.array(points, dtype=wp.vec3d, device=device), wp.array(normals, dtype=wp.vec3d, device=device)], device)
    same(got, surface_noise(rgb, points, normals, 0.02, device=device, **kw), device)


def test_pack_colours_refuses():
    with pytest.raises(TextonError, match="texton must be a Texton or a TilingModel, got ndarray"):
        td.pack_colours(np.zeros((4, 4, 1)))


# ------------------------------------------------------------------------ GLSL
@pytest.fixture(scope="module")
def browser():
    from clients import chromium_browser

    with chromium_browser() as b:
        yield b


@pytest.mark.slow
@pytest.mark.parametrize("which, place", [("grey", {}), ("rgb", dict(scale=0.7, rotation=30.0, offset=(1.0e6, -5.0)))],
                         ids=["grey", "rgb-placed"])
def test_glsl_preview_shows_the_colours(which, place, request, browser, tmp_path):
    from test_shader_glsl import SHAPE, TOLERANCE, open_preview, read

    texton = request.getfixturevalue(which)
    page = open_preview(browser, write_shader_preview(texton, tmp_path / "p.html", SHAPE, mni=30, seed=2, **place))
    got = read(page, "readFloat", SHAPE)[..., :texton.channels]
    ref = synthesize(texton, SHAPE, mni=30, seed=2, device="cpu", **place)
    err = np.abs(got - ref).max(axis=-1) / float(np.ptp(ref))
    print(f"{which}: max error {err.max():.2e} of the range")
    assert err.max() <= TOLERANCE
    gauss = synthesize(plain(texton), SHAPE, mni=30, seed=2, device="cpu", **place)
    assert np.abs(gauss - ref).max() > 0.05 * np.ptp(ref)  # the transform changes the values the page matches


@pytest.mark.slow
def test_glsl_filtered_and_surface_colours(rgb, rgb_example, browser, tmp_path):
    """The filtered variant with its shares (scales out to past the kept levels: the
    example's mean colour) and the surface variant, against the package."""
    from test_shader_glsl import TOLERANCE, open_preview, pixel_centres

    from warp_texton.noise.engine import noise_setup
    from warp_texton.runtimes.glsl.texton import glsl_noise

    page = open_preview(browser, write_shader_preview(rgb, tmp_path / "p.html", (4, 4), mni=30, seed=3))
    errors = {}
    for scale in (0.6, 0.1, 0.02, 0.002):
        shape = (8, 10)
        place = dict(scale=scale, rotation=20.0, offset=(321.5, -77.25))
        ref = synthesize(rgb, shape, mni=30, seed=3, filter="anisotropic", device="cpu", **place)
        pts, step = pixel_centres(shape, **place)
        cell = np.array(noise_setup(rgb, 30).cell)
        base = np.floor(pts / cell)
        inputs = np.zeros((len(pts), 12), np.float32)
        inputs[:, :2], inputs[:, 2:4] = base, pts - base * cell
        inputs[:, 4:6], inputs[:, 6:8] = step[:, 0], step[:, 1]
        got = np.array(page.evaluate("x => window.textonNoise.evaluatePoints('filtered', x)",
                                     inputs.ravel().tolist()), np.float32).reshape(shape + (4,))[..., :3]
        errors[scale] = np.abs(got - ref).max() / float(np.ptp(rgb.histogram.lut))
    np.testing.assert_allclose(ref.reshape(-1, 3), np.broadcast_to(rgb_example.mean(axis=(0, 1)), (80, 3)), atol=2e-3)
    rng = np.random.default_rng(4)
    normals = rng.normal(size=(200, 3))
    points = 40.0 * normals / np.linalg.norm(normals, axis=1, keepdims=True)
    sref = surface_noise(rgb, points, normals, 1.0, mni=30, seed=3, device="cpu")
    n = (normals / np.sqrt((normals ** 2).sum(axis=1, keepdims=True))).astype(np.float32)
    cube = float(glsl_noise(rgb, mni=30, seed=3).settings["cube"])
    base = np.floor(points / cube)
    inputs = np.zeros((len(points), 12), np.float32)
    inputs[:, :3], inputs[:, 4:7], inputs[:, 8:11] = base, points - base * cube, n
    got = np.array(page.evaluate("x => window.textonNoise.evaluatePoints('surface', x)", inputs.ravel().tolist()),
                   np.float32).reshape(-1, 4)[:, :3]
    errors["surface"] = np.abs(got - sref).max() / float(np.ptp(sref))
    print("max error of the range:", {k: f"{v:.2e}" for k, v in errors.items()})
    assert max(errors.values()) <= TOLERANCE


def test_filtered_colour_of_one_texel_is_the_unfiltered_colour(rgb, device):
    """One lookup of level 0 is the unfiltered noise: its share is 1 and its colour that of
    colour_value, as synthesize gives it for a raster that needs no filtering."""
    pts = np.random.default_rng(3).uniform(-30, 30, (200, 2))
    J = wp.array(np.broadcast_to(np.eye(2, dtype=np.float32), (200, 2, 2)).copy(), dtype=wp.mat22, device=device)
    cmap = td.pack_colours(rgb, device=device)
    a = launch(user.filtered_colour_at, 200, [td.pack_filtered(rgb, seed=4, filter="anisotropic", device=device), cmap,
                                              wp.array(pts, dtype=wp.vec2d, device=device), J], device)
    b = launch(user.plane_colour_at, 200, [td.pack_plane(rgb, seed=4, device=device), cmap,
                                           wp.array(pts, dtype=wp.vec2d, device=device)], device)
    assert np.array_equal(a, b)


# ------------------------------------------------------------------------- OSL
@pytest.mark.slow
def test_osl_renders_the_colours(grey, rgb, tmp_path):
    """Blender's Cycles renders the OSL shaders of histogram-preserving textons (the table
    embedded): the plane's pixels are evaluate's colours, the sphere's surface_noise's."""
    from test_shader_osl import (MIN_AGREEMENT, PLANE_TEXEL, SIZE, TOLERANCE, agreement, jitter_box, pixel_centres,
                                 plane_mesh, render, sphere_hits)

    from warp_texton.runtimes.osl.texton import PLANE_FILE, SURFACE_FILE, osl_files

    plane_scale, sphere_scale, texel = 1.8, 1.2, 0.06
    mesh = trimesh.creation.icosphere(subdivisions=3, radius=1.0)
    jobs = []
    for n, texton in enumerate((grey, rgb)):
        osl = tmp_path / f"{n}_{PLANE_FILE}"
        osl.write_bytes(osl_files(texton, mni=30, seed=7 + n, texel_size=PLANE_TEXEL)[PLANE_FILE])
        jobs.append({"osl": str(osl), "mode": "internal", "inputs": {"coordinates": "object"},
                     "ortho_scale": plane_scale, "output": "Color", **plane_mesh(1.0)})
    osl = tmp_path / SURFACE_FILE
    osl.write_bytes(osl_files(rgb, mni=60, seed=3, texel_size=texel)[SURFACE_FILE])
    jobs.append({"osl": str(osl), "mode": "external", "ortho_scale": sphere_scale, "vertices": mesh.vertices,
                 "faces": mesh.faces, "smooth": True})
    reports = render(tmp_path, jobs)
    x, y = pixel_centres(plane_scale)
    for n, (texton, rep) in enumerate(zip((grey, rgb), reports)):
        def values(dx, dy):
            pts = np.stack([(x + dx) / PLANE_TEXEL, -(y + dy) / PLANE_TEXEL], -1).reshape(-1, 2)
            return evaluate(texton, pts, mni=30, seed=7 + n, device="cpu").reshape(SIZE, SIZE, texton.channels)

        covered = rep["rgba"][..., 3] == 1.0
        a = agreement(rep["rgba"], *jitter_box(values, plane_scale), covered, texton.channels)
        print(f"plane, {texton.channels} channel(s), histogram-preserving: {a}")
        assert covered.all() and a["fraction"] >= MIN_AGREEMENT and a["max_outside_jitter"] <= TOLERANCE
    rep = reports[2]
    x, y = pixel_centres(sphere_scale)

    def surface(dx, dy):
        h, pts, nrm = sphere_hits(mesh, rep["vertex_normals"], x + dx, y + dy)
        out = np.zeros((SIZE, SIZE, 3))
        out[h] = surface_noise(rgb, pts, nrm, texel, mni=60, seed=3, device="cpu")
        return out

    hit = sphere_hits(mesh, rep["vertex_normals"], x, y)[0]
    covered = hit & (rep["rgba"][..., 3] == 1.0)
    a = agreement(rep["rgba"], *jitter_box(surface, sphere_scale), covered, 3)
    print(f"sphere, 3 channels, histogram-preserving: {a}")
    # the RGB tables are steep in places: where the camera's jitter square spans more than the
    # tolerance, the value it saw is not known; every pixel lies within its square
    assert covered.sum() == SIZE * SIZE and a["fraction_unambiguous"] >= MIN_AGREEMENT
    assert a["max_outside_jitter"] <= TOLERANCE


def test_exports_carry_the_transform(rgb, tmp_path):
    """The command line exports a histogram-preserving texton with its tables: GLSL as two
    float textures beside the coefficient textures, OSL embedded in both shaders."""
    path = tmp_path / "rgb.exr"
    rgb.save(path)
    assert run_cli(["shader", path, "--lang", "glsl", "-o", tmp_path / "glsl", "-q"]) == 0
    meta = json.loads((tmp_path / "glsl" / "texton_noise.json").read_text())
    assert meta["textures"]["texton_colours"] == {"file": "texton_colours.f32", "width": 1024, "height": 33,
                                                  "format": "RGBA32F"}
    tables = np.fromfile(tmp_path / "glsl" / "texton_colours.f32", "<f4").reshape(33, 1024, 4)
    assert np.array_equal(tables[-1, :, :3], rgb.histogram.lut.T.astype(np.float32))
    assert "const bool TN_HISTOGRAM = true;" in (tmp_path / "glsl" / "texton_noise.glsl").read_text()
    assert run_cli(["shader", path, "--lang", "osl", "-o", tmp_path / "osl", "-q"]) == 0
    for name in ("texton_plane.osl", "texton_surface.osl"):
        assert "float L[3072] = {" in (tmp_path / "osl" / name).read_text()
