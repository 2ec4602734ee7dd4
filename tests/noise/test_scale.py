"""Scale: windows bit-identical to one large raster, batches, output on the
device, Dask arrays and Zarr stores, progress and Ctrl-C.

The exactness tests compare with ``np.testing.assert_array_equal``: a window is
computed from the global indices of its pixels and impacts are stored as (cell,
float32 offset in the cell), so a chunk of a large raster must equal, bit for
bit, the same pixels of one call for the whole raster, whatever the method, the
order, the scale and the rotation.
"""

from __future__ import annotations

import json
import math
import os
import re
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

import warp_texton
import warp_texton.noise.canvas
import warp_texton.noise.batches
from warp_texton.noise.dask_arrays import synthesize_dask, write_zarr
from helpers import assert_nothing_written, assert_same_noise, ctrl_c_default, noise_sd, parts, random_texton, run_cli
from warp_texton import FilterOptions, TextonError, evaluate, render_plane, synthesize, synthesize_batch
from warp_texton.core.limits import set_memory_budget, set_work_budget, work_log

GEOMETRIES = [
    pytest.param(1.0, 0.0, (0.0, 0.0), id="grid"),
    pytest.param(1.0, 0.0, (-1000.3, 77.7), id="grid-far"),
    pytest.param(2.5, 30.0, (-1000.3, 77.7), id="scaled-rotated"),
    pytest.param(0.7, -115.0, (3.3, -2.2), id="shrunk-rotated"),
    pytest.param(0.37, 12.0, (1.0e5, -3.0e4), id="far-shrunk"),
]


def windows_of(shape, rng, n):
    """Random windows (r0, c0, h, w) of an H × W raster, plus the four that meet at an interior corner."""
    h, w = shape
    out = []
    for _ in range(n):
        r0, c0 = int(rng.integers(0, h)), int(rng.integers(0, w))
        out.append((r0, c0, int(rng.integers(1, h - r0 + 1)), int(rng.integers(1, w - c0 + 1))))
    r, c = h // 3, w // 2
    out += [(0, 0, r, c), (0, c, r, w - c), (r, 0, h - r, c), (r, c, h - r, w - c)]
    return out


# --------------------------------------------------------------------------- #
# Windows: bit for bit the pixels of one large raster                          #
# --------------------------------------------------------------------------- #
class TestWindows:
    @pytest.mark.parametrize("order", (0, 1, 3, 5))
    @pytest.mark.parametrize("scale, rotation, offset", GEOMETRIES)
    def test_windows_equal_the_large_raster(self, order, scale, rotation, offset, device):
        t = random_texton((7, 9), channels=3, order=order, seed=60 + order)
        shape = (46, 58)
        kw = dict(mni=30.0, seed=11, scale=scale, rotation=rotation, offset=offset, device=device)
        big = synthesize(t, shape, **kw)
        for r0, c0, h, w in windows_of(shape, np.random.default_rng(order), 4):
            win = synthesize(t, (h, w), pixel_offset=(r0, c0), **kw)
            np.testing.assert_array_equal(win, big[r0:r0 + h, c0:c0 + w], err_msg=f"window {(r0, c0, h, w)}")

    @pytest.mark.parametrize("scale, rotation", [(1.0, 0.0), (0.8, 41.0)])
    def test_cpu_gather_windows_equal_the_large_raster(self, scale, rotation):
        t = random_texton((8, 8), channels=1, order=1, seed=70)
        kw = dict(seed=2, scale=scale, rotation=rotation, device="cpu", method="gather")
        big = synthesize(t, (40, 50), **kw)
        for r0, c0, h, w in windows_of((40, 50), np.random.default_rng(5), 3):
            np.testing.assert_array_equal(synthesize(t, (h, w), pixel_offset=(r0, c0), **kw),
                                          big[r0:r0 + h, c0:c0 + w])

    def test_shifted_offset_at_scale_one_is_the_same_window(self, device):
        # at scale 1 without rotation, offset + (c0, r0) places the same pixels exactly
        t = random_texton(channels=3, seed=71)
        big = synthesize(t, (30, 40), offset=(-7.0, 3.0), device=device)
        part = synthesize(t, (12, 15), offset=(-7.0 + 20, 3.0 + 9), device=device)
        np.testing.assert_array_equal(part, big[9:21, 20:35])

    @pytest.mark.parametrize("filter", ("mip", "anisotropic", FilterOptions("supersample", supersample=3)))
    def test_filtered_windows_equal_the_large_raster(self, filter, device):
        t = random_texton(channels=1, seed=72)
        kw = dict(seed=4, scale=0.3, rotation=20.0, filter=filter, device=device)
        big = synthesize(t, (24, 30), **kw)
        np.testing.assert_array_equal(synthesize(t, (10, 13), pixel_offset=(9, 11), **kw), big[9:19, 11:24])

    def test_strips_equal_one_pass(self, monkeypatch, device):
        # a large raster is computed in strips, each with its own block of impacts
        t = random_texton(channels=3, order=3, seed=73)
        kw = dict(seed=5, scale=1.3, rotation=-20.0, device=device)
        whole = synthesize(t, (60, 50), **kw)
        monkeypatch.setattr(warp_texton.noise.canvas, "STRIP_WORK", 7 * 50)  # strips of 7 rows
        assert len(warp_texton.noise.canvas.strips(60, 50)) == 9
        np.testing.assert_array_equal(synthesize(t, (60, 50), **kw), whole)

    @pytest.mark.parametrize("filter", ("anisotropic", FilterOptions("supersample", supersample=2)))
    def test_plane_strips_equal_one_pass(self, monkeypatch, filter, device):
        t = random_texton(channels=3, seed=75)
        whole = render_plane(t, (40, 30), tilt=80.0, filter=filter, device=device)
        monkeypatch.setattr(warp_texton.noise.canvas, "STRIP_WORK", 30 * 8 * 2)
        np.testing.assert_array_equal(render_plane(t, (40, 30), tilt=80.0, filter=filter, device=device), whole)

    def test_windows_still_equal_evaluate(self, device):
        # the new offsets keep raster == points to float rounding (1e-4 of the noise's sd)
        t = random_texton(channels=3, order=1, seed=74)
        g = synthesize(t, (20, 24), seed=3, scale=0.9, rotation=15.0, pixel_offset=(1000, -2000), device=device)
        i, j = np.mgrid[1000:1020, -2000:-1976]
        th = math.radians(15.0)
        u, v = (j + 0.5) / 0.9, (i + 0.5) / 0.9
        pts = np.stack([math.cos(th) * u - math.sin(th) * v, math.sin(th) * u + math.cos(th) * v], -1).reshape(-1, 2)
        assert_same_noise(g, evaluate(t, pts, seed=3, device=device).reshape(g.shape), t, rtol=1e-4)

    @pytest.mark.parametrize("bad, match", [((1,), "pixel_offset must be a pair"), ((0.5, 0), r"pixel_offset\[0\]"),
                                            ((0, 2**31), r"pixel_offset\[1\].*2\*\*30")])
    def test_bad_pixel_offset(self, bad, match):
        with pytest.raises(TextonError, match=match):
            synthesize(random_texton(), (4, 4), pixel_offset=bad, device="cpu")


# --------------------------------------------------------------------------- #
# Batches                                                                      #
# --------------------------------------------------------------------------- #
def mixed_textons():
    """Textons of different sizes and orders (one channel count)."""
    return [random_texton((r, s), channels=3, order=o, seed=80 + k, mean=None)
            for k, (r, s, o) in enumerate([(6, 9, 0), (10, 7, 1), (12, 12, 3), (5, 5, 5), (16, 14, 1)])]


class TestBatch:
    def test_items_are_their_synthesize_calls(self, device):
        ts = mixed_textons()
        images, params = synthesize_batch(ts, 20, (28, 36), seed=9, scale=(0.4, 2.5), rotation=(-180, 180),
                                          offset=((-1e4, 1e4), (-50.0, 50.0)), device=device)
        assert images.shape == (20, 28, 36, 3) and images.dtype == np.float32
        assert len(params) == 20 and set(params.texton) == set(range(5))  # every texton used
        for k in range(20):
            alone = synthesize(ts[params.texton[k]], (28, 36), **params.item(k), device=device)
            np.testing.assert_array_equal(images[k], alone, err_msg=f"item {k}")

    def test_options_are_shared_and_groups_split(self, monkeypatch, device):
        # period, Gaussian counts, order-0 textons; groups of 3 items (several passes)
        monkeypatch.setattr(warp_texton.noise.canvas, "STRIP_WORK", 3 * 16 * 20)
        ts = [random_texton((6, 6), channels=1, order=o, seed=90 + o) for o in (0, 1)]
        kw = dict(mni=12.0, period=(30.0, 40.0), poisson="gaussian")
        images, params = synthesize_batch(ts, 8, (16, 20), seed=1, scale=(0.5, 2.0), device=device, **kw)
        for k in range(8):
            np.testing.assert_array_equal(
                images[k], synthesize(ts[params.texton[k]], (16, 20), **params.item(k), device=device, **kw))

    def test_filtered_items(self, device):
        # small scales need the filters: those items go through them, one by one
        t = random_texton(channels=3, seed=91)
        images, params = synthesize_batch(t, 6, (12, 14), seed=2, scale=(0.05, 2.0), filter="anisotropic",
                                          device=device)
        assert (params.scale < 0.4).any() and (params.scale > 1.0).any()
        for k in range(6):
            np.testing.assert_array_equal(
                images[k], synthesize(t, (12, 14), **params.item(k), filter="anisotropic", device=device))

    def test_explicit_per_item_arrays(self, device):
        ts = mixed_textons()[:2]
        seeds = np.array([5, 5, 2**32 - 1, 0])
        scale = np.array([1.0, 1.0, 0.5, 3.0])
        rotation = np.array([0.0, 90.0, 10.0, -30.0])
        offset = np.array([[0.0, 0.0], [0.0, 0.0], [1e6, -2e6], [3.5, 4.25]])
        images, params = synthesize_batch(ts, 4, (10, 12), seed=seeds, scale=scale, rotation=rotation,
                                          offset=offset, texton_index=np.array([0, 0, 1, 1]), device=device)
        np.testing.assert_array_equal(params.seed, seeds)
        np.testing.assert_array_equal(params.rotation, rotation)
        np.testing.assert_array_equal(params.offset, offset)
        assert not np.array_equal(images[0], images[1])  # turned by 90 degrees
        np.testing.assert_array_equal(images[2], synthesize(ts[1], (10, 12), seed=2**32 - 1, scale=0.5,
                                                            rotation=10.0, offset=(1e6, -2e6), device=device))

    def test_draws(self):
        p = warp_texton.noise.batches.draw_batch_params
        a = p(3, 2000, 7, (0.5, 2.0), (10.0, 20.0), ((-5.0, 5.0), (100.0, 101.0)))
        assert a.seed.min() >= 0 and a.seed.max() < 2**32 and len(set(a.seed)) > 1990
        assert ((a.scale >= 0.5) & (a.scale <= 2.0)).all() and ((a.rotation >= 10) & (a.rotation <= 20)).all()
        assert ((a.offset[:, 1] >= 100) & (a.offset[:, 1] <= 101)).all()
        # log-uniform scales: log2(scale) uniform on [-1, 1], mean 0 ± 0.58/√2000 ≈ 0.013
        assert abs(np.log2(a.scale).mean()) < 5 * 0.58 / math.sqrt(2000)
        # textons uniform: each of 3 about 667 ± 21
        assert (np.abs(np.bincount(a.texton, minlength=3) - 2000 / 3) < 5 * 21).all()
        # one stream per parameter: fixing the rotation leaves the other draws as they were
        b = p(3, 2000, 7, (0.5, 2.0), 45.0, ((-5.0, 5.0), (100.0, 101.0)))
        np.testing.assert_array_equal(a.seed, b.seed)
        np.testing.assert_array_equal(a.scale, b.scale)
        np.testing.assert_array_equal(a.offset, b.offset)
        assert (b.rotation == 45.0).all()
        c = p(3, 2000, 8, (0.5, 2.0), (10.0, 20.0), (0.0, 0.0))
        assert not np.array_equal(a.seed, c.seed)

    def test_items_differ_and_have_the_texton_statistics(self, device):
        # 64 independent items: the mean over them is m ± σ/√(N) per pixel
        t = random_texton(channels=1, seed=92, mean=0.4)
        images, _ = synthesize_batch(t, 64, (16, 16), seed=3, device=device)
        sd = noise_sd(t)
        pix = images[:, 8, 8, 0].astype(np.float64)
        assert abs(pix.mean() - 0.4) < 5 * sd / 8
        assert 0.5 * sd < pix.std() < 1.5 * sd
        assert not np.array_equal(images[0], images[1])

    def test_gather_batch_equals_splat_batch(self, device):
        ts = mixed_textons()
        kw = dict(seed=4, scale=(0.5, 2.0), rotation=(0, 360))
        a, _ = synthesize_batch(ts, 6, (20, 22), method="splat", device="cpu", **kw)
        b, _ = synthesize_batch(ts, 6, (20, 22), method="gather", device=device, **kw)
        for k in range(6):
            assert_same_noise(a[k], b[k], ts[0], 1e-4, 0.02)

    @pytest.mark.parametrize("kw, match", [
        (dict(count=0), "count must be at least 1"),
        (dict(count=2.5), "count must be an integer"),
        (dict(textons=[]), "textons is empty"),
        (dict(textons=["a"]), r"textons\[0\] must be a Texton"),
        (dict(scale=(2.0, 1.0)), r"scale range must have lo <= hi"),
        (dict(rotation=(0.0, float("nan"))), "rotation range must be finite"),
        (dict(scale=(0.0, 1.0)), "scale range must be > 0"),
        (dict(scale=np.array([1.0, -1.0, 1.0])), "scale values must be > 0"),
        (dict(offset=((0, 1), (2, float("inf")))), "offset y range must be finite"),
        (dict(offset=np.zeros((2, 2))), r"offset: an array gives one \(x, y\) per item: shape \(3, 2\)"),
        (dict(seed=np.array([1, 2])), r"seed: an array gives one integer seed per item"),
        (dict(texton_index=np.array([0, 1, 0])), r"texton_index values must be in \[0, 1\)"),
        (dict(output="torch"), "output must be one of numpy, warp"),
        (dict(filter="box"), "filter must be one of"),
    ])
    def test_bad_input(self, kw, match):
        args = dict(textons=[random_texton()], count=3)
        args.update(kw)
        with pytest.raises(TextonError, match=match):
            synthesize_batch(args.pop("textons"), args.pop("count"), (8, 8), device="cpu", **args)

    def test_mixed_channel_counts_are_refused(self):
        with pytest.raises(TextonError, match=r"textons\[1\] has 1 channel\(s\) but textons\[0\] has 3"):
            synthesize_batch([random_texton(channels=3), random_texton(channels=1)], 2, (8, 8), device="cpu")

    def test_count_beyond_the_memory_budget_is_refused_before_allocating(self):
        set_memory_budget("64M")
        try:
            with pytest.raises(TextonError, match=r"a batch of 100000 256x256 rasters .* over the memory budget"):
                synthesize_batch(random_texton(), 100_000, (256, 256), device="cpu")
        finally:
            set_memory_budget(None)

    def test_huge_count_of_tiny_rasters_is_refused_before_drawing_parameters(self):
        """Each item's parameters and window cost memory too: 10**12 items of one pixel are
        refused by the budget, not by a MemoryError from drawing 10**12 parameters."""
        with pytest.raises(TextonError, match=r"a batch of 1000000000000 1x1 rasters .* over the memory budget"):
            synthesize_batch(random_texton(), 10**12, (1, 1), device="cpu")

    def test_many_tiny_items_are_priced_by_their_setup(self, monkeypatch):
        """Each item's setup is work (BATCH_ITEM_OPS), checked before any item is drawn: a
        batch whose pixels cost almost nothing is still refused, and without drawing parameters."""
        drawn = []
        monkeypatch.setattr(warp_texton.noise.batches, "draw_batch_params", lambda *a, **k: drawn.append(a))
        set_work_budget(1e7)
        try:
            with pytest.raises(TextonError, match=r"a batch of 1000 1x1 rasters at MNI 30 needs about 1(\.\d+)?e\+08 "
                                                  r"operations") as info:
                synthesize_batch(random_texton(), 1000, (1, 1), device="cpu")
        finally:
            set_work_budget(None)
        assert info.value.param == "count" and not drawn

    def test_the_whole_batch_is_priced_not_a_group(self):
        """200 items of 64² at MNI 32000 are 2.6e10 lookups: refused by a 1e10 budget although each group
        of items fits it."""
        with work_log() as log:
            set_work_budget(1e10)
            try:
                with pytest.raises(TextonError, match=r"a batch of 200 64x64 rasters at MNI 32000 .* over the work"):
                    synthesize_batch(random_texton(), 200, (64, 64), mni=2000 * 16, device="cpu")
            finally:
                set_work_budget(None)
        assert log and log[-1][1] > 1e10


# --------------------------------------------------------------------------- #
# Output on the device                                                         #
# --------------------------------------------------------------------------- #
class TestDeviceOutput:
    @pytest.mark.parametrize("channels", (1, 3))
    def test_synthesize(self, channels, device):
        import warp as wp

        t = random_texton(channels=channels, seed=100)
        kw = dict(seed=3, scale=0.9, rotation=10.0, device=device)
        a = synthesize(t, (17, 23), **kw)
        w = synthesize(t, (17, 23), output="warp", **kw)
        assert isinstance(w, wp.array) and str(w.device) == device
        assert w.shape == (17, 23, channels) and w.dtype == wp.float32 and w.is_contiguous
        np.testing.assert_array_equal(w.numpy(), a)

    def test_filtered_and_points_and_plane(self, device):
        import warp as wp

        t = random_texton(channels=3, seed=101)
        f = dict(scale=0.2, filter="anisotropic", device=device)
        np.testing.assert_array_equal(synthesize(t, (9, 10), output="warp", **f).numpy(), synthesize(t, (9, 10), **f))
        pts = np.random.default_rng(1).uniform(-100, 100, (50, 2))
        e = evaluate(t, pts, device=device, output="warp")
        assert isinstance(e, wp.array) and e.shape == (50, 3)
        np.testing.assert_array_equal(e.numpy(), evaluate(t, pts, device=device))
        assert evaluate(t, np.zeros((0, 2)), device=device, output="warp").shape == (0, 3)
        # a view that sees the horizon: mean above it, noise below (a scatter on the device)
        for filt in ("mip", FilterOptions("supersample", supersample=2)):
            p = render_plane(t, (20, 16), tilt=80.0, filter=filt, device=device, output="warp")
            assert isinstance(p, wp.array)
            np.testing.assert_array_equal(p.numpy(), render_plane(t, (20, 16), tilt=80.0, filter=filt, device=device))

    def test_batch(self, device):
        import warp as wp

        ts = mixed_textons()
        images, _ = synthesize_batch(ts, 5, (8, 9), seed=1, device=device, output="warp")
        assert isinstance(images, wp.array) and images.shape == (5, 8, 9, 3)
        np.testing.assert_array_equal(images.numpy(), synthesize_batch(ts, 5, (8, 9), seed=1, device=device)[0])

    def test_dlpack_hand_over_to_numpy_is_zero_copy(self):
        t = random_texton(channels=3, seed=102)
        w = synthesize(t, (6, 7), device="cpu", output="warp")
        a = np.from_dlpack(w)
        np.testing.assert_array_equal(a, synthesize(t, (6, 7), device="cpu"))
        assert a.__array_interface__["data"][0] == w.ptr  # the same memory, not a copy

    def test_dlpack_hand_over_to_torch(self, device):
        torch = pytest.importorskip("torch")
        t = random_texton(channels=3, seed=103)
        w = synthesize(t, (6, 7), device=device, output="warp")
        x = torch.from_dlpack(w)
        assert tuple(x.shape) == (6, 7, 3) and x.dtype == torch.float32
        np.testing.assert_array_equal(x.cpu().numpy(), synthesize(t, (6, 7), device=device))

    def test_bad_output(self):
        for fn in (lambda o: synthesize(random_texton(), (4, 4), device="cpu", output=o),
                   lambda o: evaluate(random_texton(), [[0, 0]], device="cpu", output=o),
                   lambda o: render_plane(random_texton(), (4, 4), device="cpu", output=o)):
            with pytest.raises(TextonError, match="output must be one of numpy, warp, got 'torch'"):
                fn("torch")


# --------------------------------------------------------------------------- #
# Dask and Zarr                                                                #
# --------------------------------------------------------------------------- #
@pytest.fixture(scope="module")
def zarr():
    """Zarr (and Dask): the ``dask`` extra, which CI installs."""
    pytest.importorskip("dask")
    return pytest.importorskip("zarr")


@pytest.mark.usefixtures("zarr")
class TestDask:
    @pytest.mark.parametrize("order, scale, rotation", [(1, 1.0, 0.0), (3, 0.8, 33.0), (0, 2.0, -70.0)])
    def test_chunks_equal_one_call(self, order, scale, rotation, device):
        t = random_texton((7, 8), channels=3, order=order, seed=110 + order)
        kw = dict(seed=6, scale=scale, rotation=rotation, offset=(-300.5, 12.25), device=device)
        lazy = synthesize_dask(t, (75, 90), chunks=(16, 25), **kw)
        assert lazy.shape == (75, 90, 3) and lazy.dtype == np.float32
        assert lazy.chunks == ((16, 16, 16, 16, 11), (25, 25, 25, 15), (3,))
        whole = synthesize(t, (75, 90), **kw)
        np.testing.assert_array_equal(lazy.compute(scheduler="threads"), whole)
        # random windows, across chunk borders, and synthesize windows of the same raster
        for r0, c0, h, w in windows_of((75, 90), np.random.default_rng(order), 4):
            np.testing.assert_array_equal(lazy[r0:r0 + h, c0:c0 + w].compute(scheduler="sync"),
                                          synthesize(t, (h, w), pixel_offset=(r0, c0), **kw))

    def test_filtered_chunks(self):
        t = random_texton(channels=1, seed=113)
        kw = dict(scale=0.25, filter="mip", device="cpu")
        np.testing.assert_array_equal(synthesize_dask(t, (30, 40), chunks=11, **kw).compute(),
                                      synthesize(t, (30, 40), **kw))

    @pytest.mark.parametrize("dtype", ("float32", "float16", "uint16", "uint8"))
    def test_zarr_store(self, zarr, tmp_path, dtype):
        t = random_texton(channels=3, seed=114, gain=0.5)  # wide values: some clip in integer types
        kw = dict(seed=2, rotation=15.0, device="cpu")
        path = tmp_path / "noise.zarr"
        with pytest.warns(UserWarning, match="clipped") if dtype.startswith("uint") else _no_warning():
            report = write_zarr(path, t, (50, 70), chunks=(20, 32), dtype=dtype, **kw)
        z = zarr.open_array(str(path), mode="r")
        assert z.shape == (50, 70, 3) and z.chunks == (20, 32, 3) and str(z.dtype) == dtype
        whole = synthesize(t, (50, 70), **kw)
        if dtype.startswith("uint"):
            top = np.iinfo(dtype).max
            np.testing.assert_array_equal(z[:], np.round(np.clip(whole, 0, 1) * top).astype(dtype))
            assert report["clipped"] == int(((whole < 0) | (whole > 1)).any(axis=-1).sum()) > 0
        else:
            np.testing.assert_array_equal(z[:], whole.astype(dtype))
            assert report["clipped"] == 0
        meta = z.attrs["warp_texton"]
        assert meta["noise"]["seed"] == 2 and meta["noise"]["rotation"] == 15.0 and meta["texton"]["order"] == 1
        assert parts(tmp_path) == [] and sorted(p.name for p in tmp_path.iterdir()) == ["noise.zarr"]

    def test_zarr_on_local_processes(self, zarr, tmp_path):
        t = random_texton(channels=1, seed=115)
        path = tmp_path / "p.zarr"
        write_zarr(path, t, (40, 48), chunks=16, dtype="float32", scheduler="processes", workers=2, seed=1, device="cpu")
        np.testing.assert_array_equal(zarr.open_array(str(path))[:], synthesize(t, (40, 48), seed=1, device="cpu"))

    @pytest.mark.slow
    def test_zarr_on_a_local_cluster_of_processes(self, zarr, tmp_path):
        distributed = pytest.importorskip("distributed")
        t = random_texton(channels=3, seed=116)
        path = tmp_path / "c.zarr"
        with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None,
                                      silence_logs=50) as cluster:
            write_zarr(path, t, (64, 80), chunks=(24, 30), dtype="float32", scheduler=cluster.scheduler_address, seed=3,
                       scale=0.7, rotation=20.0, device="cpu")
            with distributed.Client(cluster) as client:  # the lazy array, computed by the cluster's processes
                lazy = synthesize_dask(t, (64, 80), chunks=(24, 30), seed=3, scale=0.7, rotation=20.0, device="cpu")
                computed = client.compute(lazy[10:50, 25:70]).result()
        whole = synthesize(t, (64, 80), seed=3, scale=0.7, rotation=20.0, device="cpu")
        np.testing.assert_array_equal(zarr.open_array(str(path))[:], whole)
        np.testing.assert_array_equal(computed, whole[10:50, 25:70])

    def test_existing_store_is_refused_then_replaced_with_overwrite(self, zarr, tmp_path):
        t = random_texton(seed=117)
        path = tmp_path / "a.zarr"
        write_zarr(path, t, (10, 10), chunks=5, dtype="float32", seed=1, device="cpu")
        with pytest.raises(TextonError, match="exists; replace it with overwrite"):
            write_zarr(path, t, (10, 10), chunks=5, dtype="float32", seed=2, device="cpu")
        np.testing.assert_array_equal(zarr.open_array(str(path))[:], synthesize(t, (10, 10), seed=1, device="cpu"))
        write_zarr(path, t, (10, 10), chunks=5, dtype="float32", seed=2, device="cpu", overwrite=True)
        np.testing.assert_array_equal(zarr.open_array(str(path))[:], synthesize(t, (10, 10), seed=2, device="cpu"))
        assert sorted(p.name for p in tmp_path.iterdir()) == ["a.zarr"]

    @pytest.mark.parametrize("make", [
        lambda p: (p.mkdir(), (p / "thesis.tex").write_text("x")),
        lambda p: (p.mkdir(), (p / "zarr.json").write_text('{"attributes": {"other": 1}}')),
        lambda p: (p.mkdir(), (p / "zarr.json").write_text("not json")),
        lambda p: p.write_text("a file"),
    ])
    def test_overwrite_replaces_only_our_stores(self, zarr, tmp_path, make):
        """--overwrite must not delete what the package did not write: a folder is replaced only
        if its zarr.json carries the package's attributes."""
        path = tmp_path / "a.zarr"
        make(path)
        before = sorted(str(p.relative_to(tmp_path)) for p in tmp_path.rglob("*"))
        with pytest.raises(TextonError, match=r"not a Zarr store written by warp-texton") as info:
            write_zarr(path, random_texton(), (10, 10), chunks=5, device="cpu", overwrite=True)
        assert info.value.param == "overwrite"
        assert sorted(str(p.relative_to(tmp_path)) for p in tmp_path.rglob("*")) == before

    @pytest.mark.parametrize("shape, chunks, match", [
        ((2**30, 2**30), 4096, r"cut into 68719476736 blocks of 4096x4096 needs about .* over the memory budget"),
        ((65536, 65536), 16, r"cut into 16777216 blocks of 16x16 needs about .* over the memory budget"),
        ((65536, 65536), 256, r"cut into 65536 blocks of 256x256 needs about .* over the work budget"),
    ])
    def test_store_priced_before_its_chunk_list(self, zarr, tmp_path, monkeypatch, shape, chunks, match):
        import warp_texton.noise.dask_arrays as D

        monkeypatch.setattr(D._Plan, "grid", lambda self: pytest.fail("chunk list built"))
        set_memory_budget("4G")
        try:
            with pytest.raises(TextonError, match=match) as info:
                write_zarr(tmp_path / "a.zarr", random_texton(), shape, chunks=chunks, device="cpu")
        finally:
            set_memory_budget(None)
        assert info.value.param == "chunks" and not list(tmp_path.iterdir())

    def test_a_failing_chunk_leaves_nothing(self, tmp_path, monkeypatch):
        t = random_texton(seed=118)
        calls = []

        def broken(*args, **kwargs):
            calls.append(1)
            if len(calls) == 3:
                raise OSError(28, "No space left on device")
            return synthesize(*args, **kwargs)

        monkeypatch.setattr(warp_texton.noise.dask_arrays, "synthesize", broken)
        path = tmp_path / "b.zarr"
        with pytest.raises(OSError, match="No space"):
            write_zarr(path, t, (20, 20), chunks=5, dtype="float32", device="cpu", workers=1)
        assert list(tmp_path.iterdir()) == []

    @pytest.mark.parametrize("kw, match", [
        (dict(chunks=0), r"chunks \(rows\) must be at least 1"),
        (dict(chunks=(8, -1)), r"chunks \(columns\) must be at least 1"),
        (dict(chunks=100), r"chunks 100x100 exceed the 50x40 raster"),
        (dict(shape=(0, 5)), r"shape\[0\] \(height\) must be at least 1"),
        (dict(shape=(2**31, 5)), "each side must be at most 2\\*\\*30"),
        (dict(mni=-1), "mni must be a finite number > 0"),
        (dict(method="fast"), "method must be one of"),
        (dict(offset=(1e13, 0)), "the noise is defined within"),
    ])
    def test_bad_input(self, kw, match, tmp_path):
        args = dict(shape=(40, 50), chunks=8)
        args.update(kw)
        with pytest.raises(TextonError, match=match):
            synthesize_dask(random_texton(), device="cpu", **args)
        with pytest.raises(TextonError, match=match):
            write_zarr(tmp_path / "x.zarr", random_texton(), device="cpu", **args)
        assert list(tmp_path.iterdir()) == []

    def test_bad_zarr_options(self, tmp_path):
        t = random_texton()
        for kw, match in [(dict(dtype="int8"), "dtype must be one of float16"),
                          (dict(scheduler="nowhere"), "scheduler must be threads, processes or a scheduler address"),
                          (dict(workers=0), "workers must be at least 1"), (dict(colour=1), "unknown options: colour")]:
            with pytest.raises(TextonError, match=match):
                write_zarr(tmp_path / "x.zarr", t, (10, 10), chunks=5, device="cpu", **kw)
        assert list(tmp_path.iterdir()) == []


class _no_warning:
    def __enter__(self):
        import warnings

        self._catch = warnings.catch_warnings()
        self._catch.__enter__()
        warnings.simplefilter("error")

    def __exit__(self, *exc):
        self._catch.__exit__(*exc)


# --------------------------------------------------------------------------- #
# Command line                                                                 #
# --------------------------------------------------------------------------- #
@pytest.fixture
def texton_path(tmp_path):
    path = tmp_path / "t.exr"
    random_texton((8, 8), channels=3, seed=120).save(path)
    return path


def one_error_line(capsys, argv, match, *outputs):
    status = run_cli(argv)
    captured = capsys.readouterr()
    assert status == 2, captured.err
    lines = captured.err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("warp-texton: error: "), captured.err
    assert re.search(match, lines[0]), lines[0]
    for out in outputs:
        assert_nothing_written(out)


class TestCli:
    def test_zarr(self, zarr, tmp_path, texton_path, capsys):
        out = tmp_path / "big.zarr"
        argv = ["synthesize", texton_path, "-o", out, "--width", 70, "--height", 50, "--chunk", 32, "--seed", 4,
                "--rotation", 10, "--device", "cpu", "--dtype", "float32"]
        assert run_cli(argv) == 0
        assert "float32 Zarr in chunks of 32x32" in capsys.readouterr().out
        t = warp_texton.load_texton(texton_path)
        np.testing.assert_array_equal(zarr.open_array(str(out))[:],
                                      synthesize(t, (50, 70), seed=4, rotation=10.0, device="cpu"))
        one_error_line(capsys, argv, r"big\.zarr: exists; (give|replace it with) --overwrite")
        assert run_cli(argv[:-2] + ["--overwrite", "-q", "--half"]) == 0
        assert str(zarr.open_array(str(out)).dtype) == "float16"

    @pytest.mark.parametrize("extra, match", [
        (["--chunk", "0"], "--chunk must be a positive number"),
        (["--chunk", "500"], r"--chunk 500 exceeds the 70x50 raster"),
        (["--dtype", "uint16", "--half"], "--half and --dtype uint16 disagree"),
        (["--scheduler", "somewhere"], "scheduler must be threads, processes or a scheduler address"),
        (["--compression", "zip"], "--compression applies to .exr and .tif"),
        (["--workers", "0"], "--workers must be at least 1"),
    ])
    def test_zarr_errors(self, zarr, tmp_path, texton_path, capsys, extra, match):
        out = tmp_path / "e.zarr"
        one_error_line(capsys, ["synthesize", texton_path, "-o", out, "--width", 70, "--height", 50,
                                "--device", "cpu", *extra], match, out)

    @pytest.mark.parametrize("extra, match", [
        (["--chunk", "64"], "--chunk apply to .zarr outputs only"),
        (["--dtype", "float32"], r"\.png stores \(uint8, uint16\), not 'float32'"),
        (["--compression", "piz"], "compression applies to .exr and .tif/.tiff outputs, not .png"),
    ])
    def test_image_errors(self, tmp_path, texton_path, capsys, extra, match):
        out = tmp_path / "e.png"
        one_error_line(capsys, ["synthesize", texton_path, "-o", out, "--width", 20, "--height", 20,
                                "--device", "cpu", *extra], match, out)

    def test_formats(self, tmp_path, texton_path):
        import OpenEXR

        exr = tmp_path / "h.exr"
        assert run_cli(["synthesize", texton_path, "-o", exr, "--width", 20, "--height", 10, "--half",
                        "--compression", "piz", "-q", "--device", "cpu"]) == 0
        f = OpenEXR.File(str(exr))
        assert f.header()["compression"] == OpenEXR.PIZ_COMPRESSION
        assert f.channels()["RGB"].pixels.dtype == np.float16
        png = tmp_path / "s.png"
        assert run_cli(["render-plane", texton_path, "-o", png, "--width", 16, "--height", 12, "--dtype", "uint16",
                        "-q", "--device", "cpu"]) == 0
        assert warp_texton.read_image(png).shape == (12, 16, 3)

    def test_progress_bar_on_long_work(self, tmp_path, texton_path, capsys, monkeypatch):
        monkeypatch.setattr("warp_texton.core.progress.PROGRESS_DELAY", 0.0)
        monkeypatch.setattr("warp_texton.core.progress.terminal", lambda: True)  # capsys is no terminal
        monkeypatch.setattr(warp_texton.noise.canvas, "STRIP_WORK", 64 * 8)  # 8 strips
        out = tmp_path / "p.png"
        assert run_cli(["synthesize", texton_path, "-o", out, "--width", 64, "--height", 64, "--device", "cpu"]) == 0
        assert "synthesize" in capsys.readouterr().err  # the bar's label
        assert run_cli(["synthesize", texton_path, "-o", out, "--width", 64, "--height", 64, "--device", "cpu",
                        "-q"]) == 0
        assert capsys.readouterr().err == ""

    @pytest.mark.slow
    @pytest.mark.parametrize("output", ("noise.exr", "noise.zarr"))
    def test_ctrl_c_stops_promptly_with_one_line(self, request, tmp_path, texton_path, output):
        out = tmp_path / output
        chunks = []
        if output.endswith(".zarr"):
            request.getfixturevalue("zarr")
            chunks = ["--chunk", "1024"]
        # about a minute of work on two cores, in strips (or chunks) of a fraction of a second
        proc = subprocess.Popen([sys.executable, "-m", "warp_texton.cli.parser", "synthesize", str(texton_path), "-o",
                                 str(out), "--width", "16384", "--height", "8192", "--rotation", "30",
                                 "--mni", "60", "--device", "cpu", *chunks],
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, preexec_fn=ctrl_c_default)
        time.sleep(6.0)
        assert proc.poll() is None, proc.communicate()
        t0 = time.perf_counter()
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=60)
        stopped = time.perf_counter() - t0
        assert proc.returncode == 130, err
        lines = [ln for ln in err.replace("\r", "\n").splitlines() if ln.strip() and "%" not in ln]
        assert lines == ["warp-texton: interrupted; nothing written"], err
        assert "Traceback" not in err
        assert stopped < 15.0, stopped
        assert not out.exists() and parts(tmp_path) == []


# --------------------------------------------------------------------------- #
# Memory stays bounded on a large Zarr write                                   #
# --------------------------------------------------------------------------- #
@pytest.mark.slow
def test_large_zarr_write_keeps_memory_bounded(zarr, tmp_path):
    """An 8192 x 8192 RGB store (805 MB as float32) in 512 x 512 chunks: the writing
    process grows by a few chunks (3 MiB each as float32), not by the raster."""
    script = (
        "import json, resource, sys, numpy as np\n"
        "import warp_texton as wt\n"
        "from warp_texton.noise.dask_arrays import write_zarr\n"
        "t = wt.Texton(0.05 * np.random.default_rng(0).standard_normal((16, 16, 3)), [0.5] * 3)\n"
        "wt.synthesize(t, (512, 512), device='cpu')\n"
        "base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss\n"
        "write_zarr(sys.argv[1], t, (8192, 8192), chunks=512, dtype='float32', mni=10.0, device='cpu', workers=2)\n"
        "peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss\n"
        "print(json.dumps({'base_kib': base, 'peak_kib': peak}))\n")
    done = subprocess.run([sys.executable, "-c", script, str(tmp_path / "big.zarr")], capture_output=True, text=True,
                          check=True, timeout=600)
    rss = json.loads(done.stdout.strip().splitlines()[-1])
    grown = (rss["peak_kib"] - rss["base_kib"]) / 1024
    assert grown < 250, f"the process grew by {grown:.0f} MiB while writing an 805 MB raster"
    z = zarr.open_array(str(tmp_path / "big.zarr"))
    assert z.shape == (8192, 8192, 3)
    assert np.isfinite(z[8000:8192, 100:300]).all() and z[8000:8192, 100:300].std() > 0
    assert os.path.getsize(tmp_path / "big.zarr" / "zarr.json") > 0
