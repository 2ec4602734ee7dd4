"""Tiling models in batches and Dask arrays: the same pixels as ``synthesize``, bit for bit."""

import numpy as np
import pytest

from warp_texton import TextonError, analyze, load_texton, synthesize, synthesize_batch
from warp_texton.model.tiling import TilingModel


@pytest.fixture(scope="module")
def models():
    rng = np.random.default_rng(4)
    u = rng.random((80, 72, 3)).astype(np.float32)
    v = rng.gamma(2.0, 0.2, (64, 64, 3)).astype(np.float32)
    from tests.helpers import running_bond

    from warp_texton.model.lattice import Lattice

    wall = running_bond((128, 128))
    lattice = TilingModel(wall, 40, 16, 0.0, {}, "variance", None, (True, True),
                          Lattice.from_vectors([(16, 16), (16, -16)], wall.shape, (True, True)))
    return [analyze(u, method="tiling", side=12), analyze(v, method="tiling", side=10, histogram="preserve"),
            lattice]


def test_batch_items_are_synthesize(models):
    images, params = synthesize_batch(models, 6, (24, 40), seed=5, scale=(0.5, 2.0), rotation=(0, 360),
                                      offset=((-1e4, 1e4), (-1e4, 1e4)), device="cpu")
    assert images.shape == (6, 24, 40, 3) and set(params.texton.tolist()) <= {0, 1, 2}
    for k in range(6):
        again = synthesize(models[int(params.texton[k])], (24, 40), **params.item(k), device="cpu")
        assert np.array_equal(images[k], again)
    # items differ (their own seeds and placements)
    assert not np.array_equal(images[0], images[1])


def test_batch_of_grey_models_and_warp_output(models):
    g = TilingModel(models[0].example[..., :1], side=12.0, blend="variance")
    w, params = synthesize_batch(g, 3, (16, 16), seed=np.array([1, 2, 3]), device="cpu", output="warp")
    assert w.shape == (3, 16, 16, 1)
    assert np.array_equal(w.numpy()[2], synthesize(g, (16, 16), **params.item(2), device="cpu"))


@pytest.mark.parametrize("kwargs, words", [
    ({"mni": 10.0}, "mni"),
    ({"offset": (4e9, 0.0)}, "texels"),
])
def test_batch_refusals(models, kwargs, words):
    with pytest.raises(TextonError, match=words):
        synthesize_batch(models[0], 2, (8, 8), device="cpu", **kwargs)


def test_batch_passes_periods_and_filters_to_synthesize(models):
    # a tiling model's periods and footprint filters reach batches: item k is synthesize's raster
    for m in (models[0], models[2]):  # a lattice model too
        for kwargs in ({"period": (64, 48)}, {"filter": "anisotropic"}):
            b, params = synthesize_batch(m, 2, (16, 16), seed=np.array([3, 4]), scale=0.25, device="cpu", **kwargs)
            assert np.array_equal(b[1], synthesize(m, (16, 16), **params.item(1), **kwargs, device="cpu")), kwargs


def test_batch_refuses_mixed_kinds(models):
    texton = analyze(models[0].example, size=16, seed=0)
    with pytest.raises(TextonError, match="must all be textons or all tiling models"):
        synthesize_batch([texton, models[0]], 2, (8, 8), device="cpu")


def test_dask_chunks_assemble_to_synthesize(models):
    pytest.importorskip("dask")
    from warp_texton.noise.dask_arrays import synthesize_dask

    for m in models:
        lazy = synthesize_dask(m, (70, 90), chunks=(32, 25), seed=3, scale=0.8, rotation=15.0, offset=(7.5, -3.0),
                               device="cpu")
        whole = synthesize(m, (70, 90), seed=3, scale=0.8, rotation=15.0, offset=(7.5, -3.0), device="cpu")
        assert lazy.chunks[0] == (32, 32, 6)
        assert np.array_equal(lazy.compute(scheduler="threads"), whole)


def test_dask_refusals(models):
    pytest.importorskip("dask")
    from warp_texton.noise.dask_arrays import synthesize_dask

    with pytest.raises(TextonError, match="mni"):
        synthesize_dask(models[0], (64, 64), chunks=32, mni=5.0, device="cpu")
    with pytest.raises(TextonError, match="texels"):
        synthesize_dask(models[0], (64, 64), chunks=32, offset=(5e9, 0.0), device="cpu")


def test_zarr_store_of_a_tiling_model(models, tmp_path):
    pytest.importorskip("zarr")
    import zarr

    from warp_texton.noise.dask_arrays import write_zarr

    report = write_zarr(tmp_path / "t.zarr", models[1], (48, 60), chunks=16, dtype="float32", seed=2, device="cpu",
                        workers=1)
    z = zarr.open_array(str(tmp_path / "t.zarr"))
    assert np.array_equal(z[:], synthesize(models[1], (48, 60), seed=2, device="cpu"))
    attrs = z.attrs["warp_texton"]
    assert attrs["texton"]["kind"] == "tiling" and attrs["texton"]["histogram"] == "preserve"
    assert report["shape"] == (48, 60, 3)


def test_cli_zarr_of_a_tiling_model(models, tmp_path, capsys):
    pytest.importorskip("zarr")
    import zarr

    from warp_texton.cli import main

    models[0].save(tmp_path / "m.exr")
    assert main(["synthesize", str(tmp_path / "m.exr"), "-o", str(tmp_path / "o.zarr"), "--width", "40",
                 "--height", "30", "--chunk", "16", "--seed", "4", "--dtype", "float32", "--device", "cpu"]) == 0
    assert "tiling and blending" in capsys.readouterr().out
    back = load_texton(tmp_path / "m.exr")
    assert np.array_equal(zarr.open_array(str(tmp_path / "o.zarr"))[:], synthesize(back, (30, 40), seed=4,
                                                                                   device="cpu"))
