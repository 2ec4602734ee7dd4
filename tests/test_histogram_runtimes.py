"""Histogram transforms outside the host outputs: the device API, the shader exports, the viewer.

A texton analysed with ``histogram="preserve"`` shows its example's colours in
every host output (tests/test_histogram.py). Each runtime here either applies
the same transform (and is compared with the host outputs) or refuses such a
texton with one ``TextonError`` that names what it does not apply and the
alternative: no runtime shows the Gaussian values silently.
"""

from __future__ import annotations

import numpy as np
import pytest
import trimesh
import warp as wp

import device_kernels as user
import warp_texton.device as td
from test_view import small_rgb
from warp_texton import (FilterOptions, Texton, TextonError, analyze, dsn, evaluate, export_shader, read_image,
                         surface_noise, synthesize)
from warp_texton.filtering import RasterPixels, pixel_shares
from warp_texton.raster import raster_geometry
from warp_texton.shader import write_shader_preview
from warp_texton.demo import demo_texture_path
from warp_texton.view_webgl import shader_payload

from helpers import run_cli

REFUSED = r"texton has a histogram transform .*, which {} does not apply: it would show Gaussian values"


@pytest.fixture(scope="module")
def grey():
    return analyze(read_image(demo_texture_path()), size=16, seed=0, histogram="preserve")


@pytest.fixture(scope="module")
def rgb(tmp_path_factory):
    path = small_rgb(tmp_path_factory.mktemp("rgb") / "rgb64.png")
    return analyze(read_image(path), size=16, order=3, seed=0, histogram="preserve")


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


REFUSERS = {
    "the glsl export": lambda t, d: export_shader(t, "glsl", d / "out"),
    "the osl export": lambda t, d: export_shader(t, "osl", d / "out"),
    "the glsl export ": lambda t, d: write_shader_preview(t, d / "out", (8, 8)),  # the preview
    "dsn .*": lambda t, d: dsn(t, (8, 8)),
    "the glsl export  ": lambda t, d: shader_payload(t, filters=("none",)),  # the viewer's WebGL2 mode
}


@pytest.mark.parametrize("target", REFUSERS)
def test_runtimes_without_the_transform_refuse(grey, tmp_path, target):
    with pytest.raises(TextonError, match=REFUSED.format(target.strip())) as err:
        REFUSERS[target](grey, tmp_path)
    assert err.value.param == "texton" and "histogram='gaussian'" in str(err.value)
    assert not (tmp_path / "out").exists() and list(tmp_path.iterdir()) == []  # nothing half-written


def test_cli_shader_refuses(grey, tmp_path, capsys):
    path = tmp_path / "grass.exr"
    grey.save(path)
    for lang in ("glsl", "osl"):
        assert run_cli(["shader", path, "--lang", lang, "-o", tmp_path / "out"]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and f"which the {lang} export does not apply" in err[0], err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["grass.exr"]


# ------------------------------------------------------------------ device API
@pytest.mark.parametrize("which", ["grey", "rgb"])
def test_plane_colour_is_evaluate(which, request, device):
    texton = request.getfixturevalue(which)
    pts = np.random.default_rng(1).uniform(-80, 80, (400, 2))
    kw = dict(mni=20, seed=5, period=(40.0, 36.0))
    got = launch(user.plane_colour_at, len(pts), [td.pack_plane(texton, device=device, **kw),
                                                  td.pack_colours(texton, device=device),
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
def test_filtered_colour_is_filtered_synthesize(rgb, options, device):
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
    cmap = td.pack_colours(rgb, device=device)
    got = launch(user.filtered_colour_at, h * w, [noise, cmap, wp.array(pixels.centres(0, h * w), dtype=wp.vec2d,
                                                                         device=device), J32], device)
    same(got.reshape(h, w, 3), raster, device)
    shares = launch(user.shares_at, h * w, [noise, cmap, J32], device, dtype=float)
    same(shares, pixel_shares(rgb, pixels, options), device)
    assert shares.max() > 0.5 and shares.min() == 0.0  # near pixels keep most of the variance, far ones none
    mean = raster[-1].reshape(-1, 3)  # past the kept levels: the example's mean colour (share 0)
    np.testing.assert_allclose(mean, np.broadcast_to(rgb.histogram.centre, mean.shape), atol=2e-3)


def test_surface_colour_is_surface_noise(rgb, device):
    sphere = trimesh.creation.icosphere(subdivisions=3, radius=1.1)
    points, normals = sphere.vertices + [2.0, -1.0, 0.5], sphere.vertex_normals
    kw = dict(mni=40, seed=2, up="y")
    got = launch(user.surface_colour_at, len(points), [
        td.pack_surface(rgb, 0.02, device=device, **kw), td.pack_colours(rgb, device=device),
        wp.array(points, dtype=wp.vec3d, device=device), wp.array(normals, dtype=wp.vec3d, device=device)], device)
    same(got, surface_noise(rgb, points, normals, 0.02, device=device, **kw), device)


def test_pack_colours_refuses():
    with pytest.raises(TextonError, match="texton must be a Texton, got ndarray"):
        td.pack_colours(np.zeros((4, 4, 1)))
