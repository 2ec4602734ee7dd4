"""The device API (warp_texton.runtimes.warp_api): a user's kernels give the package's values bit for bit.

The kernels of tests/device_kernels.py and docs/examples/warp_heightfield.py are
written only from the public API, in modules of their own, as a user's are.
On the ``device`` fixture (``--device cuda:0`` on a GPU machine) they must give
exactly (``np.array_equal``) what ``evaluate``, the filtered ``synthesize`` and
``surface_noise`` give on that device for the same inputs.
"""

from __future__ import annotations

import functools
import importlib.util
import re
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import pytest
import trimesh
import warp as wp

import device_kernels as user
from helpers import random_texton
from warp_texton import FilterOptions, Texton, TextonError, evaluate, surface_noise, synthesize, tangent_frames
from warp_texton.runtimes import warp_api as td
from warp_texton.noise.filtering import RasterPixels
from warp_texton.noise.raster import raster_geometry

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE = ROOT / "docs" / "examples" / "warp_heightfield.py"


def colour_texton(order=1, shape=(10, 12)) -> Texton:
    return random_texton(shape, channels=3, order=order, seed=order)


def launch(kernel, n, inputs, device):
    out = wp.zeros(n, dtype=wp.vec3, device=device)
    wp.launch(kernel, dim=n, inputs=inputs, outputs=[out], device=device)
    return out.numpy()


@functools.cache
def example_module():
    spec = importlib.util.spec_from_file_location("warp_heightfield", EXAMPLE)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # Warp reads the kernels' source through the module
    spec.loader.exec_module(module)
    return module


# ------------------------------------------------------------------- plane
@pytest.mark.parametrize("order", [0, 1, 3])
def test_grey_plane_value_is_the_first_channel(order, device):
    """A grey texton packed on one channel (PlaneNoise1: float coefficients, a float
    value) gives evaluate's values, and the first component of its three-channel
    form, bit for bit."""
    texton = random_texton((9, 11), channels=1, order=order, seed=order + 4)
    rng = np.random.default_rng(order)
    pts = np.concatenate([rng.uniform(-60, 60, (300, 2)), rng.uniform(-3, 3, (50, 2)) + [-1.0e6, 2.0e6]])
    grey = td.pack_plane(texton, mni=25, seed=3, device=device, channels=1)
    assert grey.coeffs.dtype == wp.float32 and grey.coeffs.ndim == 2
    out = wp.zeros(len(pts), dtype=float, device=device)
    wp.launch(user.plane_grey_at, dim=len(pts), inputs=[grey, wp.array(pts, dtype=wp.vec2d, device=device)],
              outputs=[out], device=device)
    three = launch(user.plane_at, len(pts), [td.pack_plane(texton, mni=25, seed=3, device=device),
                                             wp.array(pts, dtype=wp.vec2d, device=device)], device)
    want = evaluate(texton, pts, mni=25, seed=3, device=device)
    assert np.array_equal(out.numpy(), want[:, 0]) and np.array_equal(out.numpy(), three[:, 0])
    assert np.ptp(want) > 0


def test_pack_plane_channels_errors():
    with pytest.raises(TextonError, match="channels must be 1 or 3"):
        td.pack_plane(random_texton((4, 4), channels=1), device="cpu", channels=2)
    with pytest.raises(TextonError, match="channels=1 packs a grey texton"):
        td.pack_plane(colour_texton(), device="cpu", channels=1)


@pytest.mark.parametrize("order", [0, 1, 3])
@pytest.mark.parametrize("seed, period", [(0, None), (7, (40.0, 30.5))])
def test_plane_value_is_evaluate(order, seed, period, device):
    texton = colour_texton(order)
    rng = np.random.default_rng(order + seed)
    pts = np.concatenate([rng.uniform(-60, 60, (300, 2)), rng.uniform(-3, 3, (50, 2)) + [1.0e6, -1.0e6]])
    noise = td.pack_plane(texton, mni=20, seed=seed, period=period, device=device)
    got = launch(user.plane_at, len(pts), [noise, wp.array(pts, dtype=wp.vec2d, device=device)], device)
    want = evaluate(texton, pts, mni=20, seed=seed, period=period, device=device)
    assert np.array_equal(got, want)
    assert np.ptp(want[:, 0]) > 0  # not a constant


@pytest.mark.parametrize("poisson, cell_factor", [("gaussian", 0.6), ("exact", 1.1)])
def test_plane_value_follows_poisson_and_cells(poisson, cell_factor, device):
    texton = random_texton((8, 8), channels=1)
    pts = np.random.default_rng(3).uniform(-40, 40, (200, 2))
    noise = td.pack_plane(texton, seed=5, poisson=poisson, cell_factor=cell_factor, device=device)
    got = launch(user.plane_at, len(pts), [noise, wp.array(pts, dtype=wp.vec2d, device=device)], device)
    want = evaluate(texton, pts, seed=5, poisson=poisson, cell_factor=cell_factor, device=device)
    assert np.array_equal(got[:, :1], want)
    assert not got[:, 1:].any()  # components past the texton's channels are zero


@pytest.mark.parametrize("order", [0, 1, 3])
@pytest.mark.parametrize("seed, period", [(1, None), (9, (64.0, 48.0))])
def test_heightfield_example_is_evaluate(order, seed, period, device):
    """The docs' example: a placement with scale, rotation and a far offset, computed in its kernel."""
    ex = example_module()
    texton = random_texton((8, 8), channels=1, order=order, seed=seed)
    example = ex.Example(texton, (24, 32), seed=seed, scale=0.7, rotation=30.0, offset=(1.0e6 + 0.25, -3.5),
                         period=period, device=device)
    example.step()
    texels = example.texels.numpy().reshape(-1, 2)
    want = evaluate(texton, texels, seed=seed, period=period, device=device)
    assert np.array_equal(example.values.numpy().reshape(-1, 3)[:, :1], want)
    z = example.vertices.numpy().reshape(-1, 3)[:, 2]
    assert np.array_equal(z, np.float32(example.height) * want[:, 0])
    # the placement the example documents: offset + R(rotation) (j, i) / scale
    i, j = np.divmod(np.arange(24 * 32), 32)
    th = np.radians(30.0)
    expect = np.stack([1.0e6 + 0.25 + (np.cos(th) * j - np.sin(th) * i) / 0.7,
                       -3.5 + (np.sin(th) * j + np.cos(th) * i) / 0.7], -1)
    assert np.allclose(texels, expect, rtol=0, atol=1e-6)


def test_renderers_page_shows_the_example_as_it_is():
    """The code docs/renderers.md shows of the example is the example's, verbatim."""
    section = (ROOT / "docs" / "renderers.md").read_text().split("## Warp kernels")[1].split("\n## ")[0]
    shown = re.findall(r"```python\n(.*?)```", section, re.S)
    source = EXAMPLE.read_text()
    assert shown and all(block in source for block in shown)


@pytest.mark.slow
def test_heightfield_example_runs_as_a_script(tmp_path):
    out = tmp_path / "field.ply"
    run = subprocess.run([sys.executable, str(EXAMPLE), str(out), "--device", "cpu", "--size", "16", "24",
                          "--rotation", "20"], capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stderr
    mesh = trimesh.load(out, process=False)
    assert mesh.vertices.shape == (16 * 24, 3) and mesh.faces.shape == (2 * 15 * 23, 3)
    assert np.ptp(mesh.vertices[:, 2]) > 0
    assert [p.name for p in tmp_path.iterdir()] == ["field.ply"]  # no temporary file left


# ---------------------------------------------------------------- filtered
@pytest.mark.parametrize("options", [FilterOptions("mip"), FilterOptions("anisotropic"),
                                     FilterOptions("anisotropic", max_aniso=4, lod_bias=0.3, fade_energy=0.05)],
                         ids=["mip", "anisotropic", "anisotropic-settings"])
@pytest.mark.parametrize("order", [1, 3])
def test_filtered_value_is_filtered_synthesize(options, order, device):
    texton = colour_texton(order)
    h, w = 20, 24
    J = np.zeros((h, w, 2, 2))
    J[..., 0, 0] = 1.5
    J[..., 0, 1] = 0.7
    J[..., 1, 1] = np.linspace(0.5, 40.0, h)[:, None]  # up to past the kept levels
    kw = dict(mni=25, seed=3, period=(50.0, 70.0))
    place = dict(scale=0.7, rotation=25.0, offset=(1.0e6, -20.0))
    raster = synthesize(texton, (h, w), filter=options, jacobian=J, device=device, **place, **kw)
    centres = RasterPixels((h, w), *raster_geometry((h, w), *place.values()), J).centres(0, h * w)
    noise = td.pack_filtered(texton, filter=options, device=device, **kw)
    got = launch(user.filtered_at, h * w, [noise, wp.array(centres, dtype=wp.vec2d, device=device),
                                           wp.array(J.reshape(-1, 2, 2).astype(np.float32), dtype=wp.mat22,
                                                    device=device)], device)
    assert np.array_equal(got.reshape(h, w, 3), raster)
    assert np.ptp(raster[0, :, 0]) > 0 and np.ptp(raster[:, 0, 0]) > 0


@pytest.mark.parametrize("kind", ["mip", "anisotropic"])
def test_grey_filtered_value_is_the_first_channel(kind, device):
    """A grey texton's FilteredNoise1 gives, bit for bit, the first component of its
    three-channel FilteredNoise (the same lookups on one float a texel)."""
    texton = random_texton((12, 9), channels=1, seed=8)
    rng = np.random.default_rng(1)
    pts = rng.uniform(-50, 50, (300, 2))
    J = (rng.normal(size=(300, 2, 2)) * 4.0).astype(np.float32)
    args = [wp.array(pts, dtype=wp.vec2d, device=device), wp.array(J, dtype=wp.mat22, device=device)]
    out = wp.zeros(len(pts), dtype=float, device=device)
    wp.launch(user.filtered_grey_at, dim=len(pts), inputs=[td.pack_filtered(texton, seed=2, filter=kind, device=device,
                                                                            channels=1), *args],
              outputs=[out], device=device)
    three = launch(user.filtered_at, len(pts), [td.pack_filtered(texton, seed=2, filter=kind, device=device), *args],
                   device)
    assert np.array_equal(out.numpy(), three[:, 0])
    assert np.ptp(three[:, 0]) > 0 and not three[:, 1:].any()


def test_filtered_value_of_a_pixel_footprint_is_plane_value(device):
    """A footprint of one texel needs one lookup of level 0: the unfiltered noise, bit for bit."""
    texton = colour_texton(1)
    pts = np.random.default_rng(2).uniform(-30, 30, (100, 2))
    J = np.broadcast_to(np.eye(2, dtype=np.float32), (100, 2, 2)).copy()
    filt = td.pack_filtered(texton, seed=4, filter="mip", device=device)
    plain = td.pack_plane(texton, seed=4, device=device)
    a = launch(user.filtered_at, 100, [filt, wp.array(pts, dtype=wp.vec2d, device=device),
                                       wp.array(J, dtype=wp.mat22, device=device)], device)
    b = launch(user.plane_at, 100, [plain, wp.array(pts, dtype=wp.vec2d, device=device)], device)
    assert np.array_equal(a, b)


# ----------------------------------------------------------------- surface
def sphere_points(seed=0):
    sphere = trimesh.creation.icosphere(subdivisions=3, radius=1.3)
    rng = np.random.default_rng(seed)
    points = sphere.vertices + np.array([5.0, -3.0, 2.0])
    normals = sphere.vertex_normals * rng.uniform(0.5, 2.0, (len(points), 1))  # any length
    return points, normals


@pytest.mark.parametrize("order, up, seed", [(1, "z", 0), (3, "y", 11), (0, (1.0, 1.0, 0.0), 2)])
def test_surface_value_is_surface_noise(order, up, seed, device):
    texton = colour_texton(order)
    points, normals = sphere_points(seed)
    kw = dict(mni=40, seed=seed, up=up)
    noise = td.pack_surface(texton, 0.013, device=device, **kw)
    got = launch(user.surface_at, len(points), [noise, wp.array(points, dtype=wp.vec3d, device=device),
                                                wp.array(normals, dtype=wp.vec3d, device=device)], device)
    # the walk, and on the CPU the block path, which surface_noise promises equal to it bit for bit there
    methods = ["points", "blocks"] if device == "cpu" else ["points"]
    for method in methods:
        assert np.array_equal(got, surface_noise(texton, points, normals, 0.013, method=method, device=device,
                                                 **kw)), method
    assert np.ptp(got[:, 0]) > 0


def test_surface_frame_value_is_surface_noise_with_tangents(device):
    texton = colour_texton(3)
    points, normals = sphere_points(4)
    _, tangents = tangent_frames(normals)  # the rule's u2: the texture turned by 90 degrees
    want = surface_noise(texton, points, normals, 0.02, tangents=tangents, seed=2, method="points", device=device)
    # what surface_noise does with its inputs: float64 unit normals, tangents projected on the tangent
    # plane and normalised, both then rounded to float32; positions divided by the texel size
    n64 = normals / np.sqrt(normals[:, 0] ** 2 + normals[:, 1] ** 2 + normals[:, 2] ** 2)[:, None]
    t64 = tangents - n64 * np.sum(tangents * n64, axis=1)[:, None]
    t64 = t64 / np.linalg.norm(t64, axis=1)[:, None]
    noise = td.pack_surface(texton, 0.02, seed=2, device=device)
    got = launch(user.surface_frame_at, len(points), [
        noise, wp.array(points / 0.02, dtype=wp.vec3d, device=device), wp.array(n64, dtype=wp.vec3, device=device),
        wp.array(t64, dtype=wp.vec3, device=device)], device)
    assert np.array_equal(got, want)


@pytest.mark.parametrize("order", [1, 3])
def test_grey_surface_values_are_the_first_channel(order, device):
    """A grey texton packed on one channel (SurfaceNoise1: float coefficients, a float
    value) gives surface_noise's values, and the first component of its three-channel
    form, bit for bit, by both device functions."""
    texton = random_texton((9, 11), channels=1, order=order, seed=order + 6)
    points, normals = sphere_points(order + 2)
    grey = td.pack_surface(texton, 0.015, mni=40, seed=5, device=device, channels=1)
    assert grey.coeffs.dtype == wp.float32 and grey.coeffs.ndim == 2
    three = td.pack_surface(texton, 0.015, mni=40, seed=5, device=device)
    args = [wp.array(points, dtype=wp.vec3d, device=device), wp.array(normals, dtype=wp.vec3d, device=device)]
    out = wp.zeros(len(points), dtype=float, device=device)
    wp.launch(user.surface_grey_at, dim=len(points), inputs=[grey, *args], outputs=[out], device=device)
    want = surface_noise(texton, points, normals, 0.015, mni=40, seed=5, method="points", device=device)
    assert np.array_equal(out.numpy(), want[:, 0])
    assert np.array_equal(out.numpy(), launch(user.surface_at, len(points), [three, *args], device)[:, 0])
    assert np.ptp(want) > 0
    # the frame form, at the texel-space points with the rule's frames
    n32 = (normals / np.linalg.norm(normals, axis=1)[:, None]).astype(np.float32)
    _, u2 = tangent_frames(n32)
    frame_args = [wp.array(points / 0.015, dtype=wp.vec3d, device=device), wp.array(n32, dtype=wp.vec3, device=device),
                  wp.array(np.ascontiguousarray(u2, np.float32), dtype=wp.vec3, device=device)]
    out1 = wp.zeros(len(points), dtype=float, device=device)
    wp.launch(user.surface_frame_grey_at, dim=len(points), inputs=[grey, *frame_args], outputs=[out1], device=device)
    assert np.array_equal(out1.numpy(), launch(user.surface_frame_at, len(points), [three, *frame_args], device)[:, 0])


def test_pack_surface_refuses_one_channel_of_colour():
    with pytest.raises(TextonError, match="channels=1 packs a grey texton"):
        td.pack_surface(colour_texton(1), 0.01, device="cpu", channels=1)
    with pytest.raises(TextonError, match="channels must be 1 or 3"):
        td.pack_surface(random_texton((4, 4), channels=1), 0.01, device="cpu", channels=2)


# ------------------------------------------------------------------- errors
def test_packers_refuse_bad_input():
    texton = random_texton((8, 8))
    cases = [
        (lambda: td.pack_plane(np.zeros((8, 8)), device="cpu"), "texton must be a Texton"),
        (lambda: td.pack_plane(texton, mni=0, device="cpu"), "mni must be a finite number > 0"),
        (lambda: td.pack_plane(texton, seed=-1, device="cpu"), r"seed must be an integer in \[0, 2\*\*32\)"),
        (lambda: td.pack_plane(texton, period=(64,), device="cpu"), "period must be a pair"),
        (lambda: td.pack_plane(texton, period=(64, 0), device="cpu"), r"period\[1\]"),
        (lambda: td.pack_plane(texton, poisson="normal", device="cpu"), "poisson must be one of exact, gaussian"),
        (lambda: td.pack_plane(texton, cell_factor=0.0, device="cpu"), "cell_factor"),
        (lambda: td.pack_plane(texton, device="tpu"), "device"),
        (lambda: td.pack_filtered(texton, filter="none", device="cpu"), "filter must be a footprint filter"),
        (lambda: td.pack_filtered(texton, filter="supersample", device="cpu"), "filter must be a footprint filter"),
        (lambda: td.pack_filtered(texton, filter="box", device="cpu"), "filter must be one of"),
        (lambda: td.pack_filtered(texton, mni=-1, device="cpu"), "mni"),
        (lambda: td.pack_surface(texton, 0.0, device="cpu"), "texel_size must be a finite number > 0"),
        (lambda: td.pack_surface("texton.exr", 0.01, device="cpu"), "texton must be a Texton"),
        (lambda: td.pack_surface(texton, 0.01, up=(0, 0, 0), device="cpu"), "up"),
        (lambda: td.pack_surface(texton, 0.01, poisson="x", device="cpu"), "poisson must be one of"),
        (lambda: td.pack_surface(texton, 0.01, cell_factor=1e-3, device="cpu"), "cell_factor"),
        (lambda: td.pack_surface(texton, 0.01, seed=2**32, device="cpu"), "seed"),
    ]
    for call, message in cases:
        with pytest.raises(TextonError, match=message):
            call()


# ------------------------------------------------------------------- CUDA
@pytest.mark.slow
def test_user_kernels_compile_for_cuda():
    """A user's module that calls the device API compiles for CUDA (NVRTC, no GPU needed)."""
    from warp_texton.core.runtime import init_warp

    init_warp()
    if 86 not in wp.get_cuda_supported_archs():
        pytest.skip("this Warp build's NVRTC cannot compile for sm_86 here")
    for module in (user, example_module()):
        with tempfile.TemporaryDirectory() as d:
            files = wp.compile_aot_module(module, arch=86, module_dir=d)
            assert files and all(Path(f).stat().st_size > 0 for f in files), module.__name__
