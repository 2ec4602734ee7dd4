"""The device API for tiling models: a user's kernel (tests/device_kernels.py, and the docs
example docs/examples/warp_tiling.py, written only from warp_texton.runtimes.warp_api) calls
``tiling_value`` on the struct ``pack_tiling`` packs and gets ``evaluate``'s and ``synthesize``'s
values bit for bit on the ``device`` fixture's device (``--device cuda:0`` on a GPU machine)."""

from __future__ import annotations

import functools
import importlib.util
import sys
from pathlib import Path

import numpy as np
import pytest
import warp as wp

import device_kernels as user
from warp_texton import TextonError, analyze, evaluate, synthesize
from warp_texton.model.tiling import TilingModel
from warp_texton.runtimes import pack_colours, pack_tiling
from warp_texton.runtimes import warp_api as td

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE = ROOT / "docs" / "examples" / "warp_tiling.py"


@functools.cache
def example_module():
    spec = importlib.util.spec_from_file_location("warp_tiling", EXAMPLE)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # Warp reads the kernels' source through the module
    spec.loader.exec_module(module)
    return module


def example(channels: int, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    # blocky structure plus fine noise: a patch shifted by a texel or a wrong vertex shows
    blocks = np.kron(rng.random((8, 8, channels)), np.ones((12, 12, 1)))
    return (0.7 * blocks + 0.3 * rng.random((96, 96, channels))).astype(np.float32)


MODELS = {
    "grey_variance": lambda: TilingModel(example(1), 20.0, 16, 0.0, {}, "variance"),
    "rgb_linear_guide": lambda: TilingModel(example(3, 1), 13.7, 4, 1.5, {}, "linear"),
}


@pytest.mark.parametrize("name", MODELS)
def test_user_kernel_is_evaluate(name, device):
    model = MODELS[name]()
    rng = np.random.default_rng(2)
    pts = np.concatenate([rng.uniform(-500, 500, (2000, 2)), rng.uniform(-1e8, 1e8, (200, 2)),
                          np.mgrid[0:16, 0:16].reshape(2, -1).T + 0.5])  # texel centres: the example's own texels
    for seed in (0, 2**32 - 1):
        t = pack_tiling(model, seed=seed, device=device)
        out = wp.zeros(len(pts), dtype=wp.vec3, device=device)
        wp.launch(user.tiling_at, dim=len(pts), inputs=[t, wp.array(pts, dtype=wp.vec2d, device=device)],
                  outputs=[out], device=device)
        got = out.numpy()
        want = evaluate(model, pts, seed=seed, device=device)
        assert np.array_equal(got[:, :model.channels], want)
        assert not got[:, model.channels:].any()
        assert want.std() > 0.1  # not a constant


def preserving(channels: int, seed: int = 0, **kw) -> TilingModel:
    """A histogram-preserving model (the Gaussianised example and the per-channel tables) of skewed,
    8-bit-like values: the tables change the blend's values by a good part of the range."""
    u = np.round(example(channels, seed) ** 2.5 * 255) / 255
    return analyze(u.astype(np.float32), method="tiling", histogram="preserve", **kw)


@pytest.mark.parametrize("channels, side, guide", [(1, 20, 0.0), (3, 13.7, 1.5)], ids=["grey", "rgb_guide"])
def test_user_kernel_maps_the_blend_with_the_tables(channels, side, guide, device):
    """pack_tiling + pack_colours: colour_value(cmap, tiling_value(t, x)) in a user's kernel is
    evaluate's value of a histogram-preserving model, bit for bit on the CPU (the host maps with the
    same functions there); on CUDA within 1e-5 of the range (texton noise's bound,
    tests/runtimes/test_histogram_runtimes.py)."""
    m = preserving(channels, 3)
    model = TilingModel(m.example, side, 8, guide, {}, m.blend, m.histogram)
    rng = np.random.default_rng(4)
    pts = np.concatenate([rng.uniform(-500, 500, (2000, 2)), rng.uniform(-1e8, 1e8, (200, 2))])
    t = pack_tiling(model, seed=7, device=device)
    cmap = pack_colours(model, device=device)
    assert int(cmap.enabled) == 1 and cmap.tables.shape == (33, channels, 1024)
    out = wp.zeros(len(pts), dtype=wp.vec3, device=device)
    wp.launch(user.tiling_colour_at, dim=len(pts), inputs=[t, cmap, wp.array(pts, dtype=wp.vec2d, device=device)],
              outputs=[out], device=device)
    got = out.numpy()[:, :channels]
    want = evaluate(model, pts, seed=7, device=device)
    if device == "cpu":
        assert np.array_equal(got, want)
    else:
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-5 * float(np.ptp(want)))
    # the tables were applied: the blend alone (Gaussianised values) is far from the colours
    blend = evaluate(TilingModel(model.example, side, 8, guide, {}, model.blend), pts, seed=7, device=device)
    assert np.abs(blend - want).max() > 0.5
    assert want.min() >= 0.0 and want.max() <= 1.0 + 1e-6


def test_docs_example_is_synthesize(device):
    ex = example_module()
    model = TilingModel(example(3, 4), 16.0, 8, 0.0, {}, "variance")
    hist = preserving(3, 5, side=16)
    places = (dict(), dict(scale=0.7, rotation=30.0, offset=(1.0e6 + 0.25, -3.5)),
              dict(scale=2.5, rotation=-100.0, offset=(-77.0, 12.125)))
    for m, place in [(model, p) for p in places] + [(hist, dict(scale=1.3, rotation=-20.0, offset=(5.5e4, 9.0)))]:
        got = ex.window(m, (24, 40), seed=9, device=device, **place)
        want = synthesize(m, (24, 40), seed=9, device=device, **place)
        if device == "cpu" or m.histogram is None:
            assert np.array_equal(got, want)
        else:  # the tables map on the host (CPU) for synthesize, on the GPU in the kernel
            np.testing.assert_allclose(got, want, rtol=0, atol=1e-5 * float(np.ptp(want)))


def test_docs_example_runs(tmp_path):
    ex = example_module()
    path = tmp_path / "bricks.png"
    ex.main([str(path), "--device", "cpu"])
    assert path.is_file() and path.stat().st_size > 1000


def test_pack_tiling_refuses(device):
    model = MODELS["grey_variance"]()
    with pytest.raises(TextonError, match="model must be a TilingModel"):
        pack_tiling(np.zeros((8, 8)))
    with pytest.raises(TextonError, match="seed"):
        pack_tiling(model, seed=-1, device=device)
    with pytest.raises(TextonError, match="device"):
        pack_tiling(model, device="tpu")
    assert td.Tiling is not None and td.tiling_value is not None and "pack_tiling" in td.__all__
