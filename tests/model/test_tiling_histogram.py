"""Histogram-preserving tiling models (``analyze(..., method="tiling", histogram="preserve")``): what the model
stores, its files, and the colours of texels shown alone."""

from __future__ import annotations

import numpy as np
import pytest

from warp_texton import TextonError, analyze, evaluate, load_texton, synthesize
from warp_texton.cli import main
from warp_texton.model.histogram import HistogramTransform
from warp_texton.model.tiling import TilingModel


@pytest.fixture(scope="module")
def example():
    # 8-bit-like colours with ties, skewed and correlated, as photographs have
    rng = np.random.default_rng(11)
    g = rng.gamma(1.5, 1.0, (72, 64, 3)) @ np.array([[1.0, 0.0, 0.0], [0.5, 0.8, 0.0], [0.2, -0.3, 0.9]]).T
    return (np.round(np.clip(0.1 * g + 0.2, 0, 1) * 255) / 255).astype(np.float32)


@pytest.fixture(scope="module")
def model(example):
    return analyze(example, method="tiling", side=12, histogram="preserve")


def test_the_model_blends_the_gaussianised_example(model, example):
    assert isinstance(model.histogram, HistogramTransform) and model.histogram.channels == 3
    assert model.metadata["histogram"] == "preserve"
    g = model.example.astype(np.float64)
    np.testing.assert_allclose(g.mean(axis=(0, 1)), 0.0, atol=0.05)
    np.testing.assert_allclose(g.std(axis=(0, 1)), 1.0, atol=0.01)
    for c in range(3):  # per channel: a monotone map of the example's values (ranks kept)
        order = np.argsort(example[..., c].ravel(), kind="stable")
        assert np.all(np.diff(g[..., c].ravel()[order]) >= 0)
    # and the tables map the example back to its own colours
    assert np.abs(model.colours() - example).max() < 2e-3
    assert np.abs(model.colours() - example).mean() < 2e-4


def test_texels_shown_alone_keep_their_colours(model, example):
    # at scale 1 a pixel away from the blend zones shows one texel: the model without tables (same
    # example size, side and seed, so the same patches and weights) shows that texel's colour there,
    # and the histogram-preserving model maps the texel's Gaussian value back to it
    plain = TilingModel(example, model.side, model.sharpness, blend="variance", wrap=model.wrap,
                        lattice=model.lattice)
    p = synthesize(plain, (96, 96), seed=4, device="cpu").reshape(-1, 3)
    h = synthesize(model, (96, 96), seed=4, device="cpu").reshape(-1, 3)
    texels = {tuple(c) for c in np.round(example.reshape(-1, 3).astype(np.float64) * 1e5).astype(np.int64)}
    single = np.array([tuple(c) in texels for c in np.round(p.astype(np.float64) * 1e5).astype(np.int64)])
    assert single.mean() > 0.5
    assert np.abs(h[single] - p[single]).max() < 2e-3
    # evaluate is the pixels
    jj, ii = np.meshgrid(np.arange(96) + 0.5, np.arange(96) + 0.5)
    points = evaluate(model, np.stack([jj.ravel(), ii.ravel()], 1), seed=4, device="cpu")
    assert np.array_equal(points, h)


def test_files_round_trip(model, tmp_path):
    model.save(tmp_path / "m.exr")
    back = load_texton(tmp_path / "m.exr")
    assert isinstance(back, TilingModel) and back.histogram is not None
    assert np.array_equal(back.histogram.lut, model.histogram.lut)
    assert np.array_equal(back.histogram.matrix, model.histogram.matrix)
    assert np.array_equal(back.example, model.example)
    assert np.array_equal(synthesize(back, (32, 40), seed=2, scale=0.7, rotation=12.0, device="cpu"),
                          synthesize(model, (32, 40), seed=2, scale=0.7, rotation=12.0, device="cpu"))
    assert "histogram=preserve" in repr(back)


def test_grey_examples(example):
    m = analyze(example[..., 0], method="tiling", side=12, histogram="preserve")
    assert m.channels == 1 and m.histogram.channels == 1
    assert np.abs(m.colours() - example[..., :1]).max() < 2e-3
    assert synthesize(m, (16, 16), device="cpu").shape == (16, 16, 1)


def test_bad_histogram_options(example, model):
    with pytest.raises(TextonError, match="histogram must be one of gaussian, preserve"):
        analyze(example, method="tiling", histogram="keep")
    with pytest.raises(TextonError, match="histogram must be a HistogramTransform of 1"):
        TilingModel(model.example[..., :1], 12.0, histogram=model.histogram)


def test_cli_analyze_with_histogram_preserve(example, tmp_path, capsys):
    from warp_texton import write_image

    write_image(tmp_path / "ex.png", example)
    assert main(["analyze", str(tmp_path / "ex.png"), "--method", "tiling", "--histogram", "preserve", "--side", "12",
                 "-o", str(tmp_path / "m.exr"), "-q"]) == 0
    assert load_texton(tmp_path / "m.exr").histogram is not None
    assert main(["analyze", str(tmp_path / "ex.png"), "--method", "tiling", "--histogram", "preserve",
                 "-o", str(tmp_path / "m.texton")]) == 2
    assert capsys.readouterr().err.count("\n") == 1


def test_a_users_kernel_maps_tiling_value_with_the_texton_functions(model):
    # the tables are texton noise's: colour_value(make_colour_map(model), tiling_value(t, x)) in a Warp
    # kernel is evaluate's value bit for bit on the CPU (the device functions the host maps with)
    import warp as wp

    from warp_texton.kernels import noise_colours, noise_tiling
    from warp_texton.noise.colours import make_colour_map
    from warp_texton.noise.tiling import tiling_struct

    @wp.kernel
    def mapped(t: noise_tiling.Tiling, cmap: noise_colours.ColourMap, pts: wp.array(dtype=wp.vec2d),
               out: wp.array(dtype=wp.vec3)):
        k = wp.tid()
        out[k] = noise_colours.colour_value(cmap, noise_tiling.tiling_value(t, pts[k]))

    rng = np.random.default_rng(5)
    pts = np.stack([rng.uniform(-1e4, 1e4, 500), rng.uniform(-1e4, 1e4, 500)], 1)
    out = wp.empty(500, dtype=wp.vec3, device="cpu")
    wp.launch(mapped, dim=500, device="cpu",
              inputs=[tiling_struct(model, 6, "cpu"), make_colour_map(model, "cpu"),
                      wp.array(pts, dtype=wp.vec2d, device="cpu"), out])
    assert np.array_equal(out.numpy(), evaluate(model, pts, seed=6, device="cpu"))


def test_every_unfiltered_output_path_maps_the_tables(model, example):
    # periodic rasters and points, and supersampled footprints (each sample mapped, then averaged), stay in
    # the example's colours: without the tables the Gaussianised values reach about ±3
    lo, hi = example.min(axis=(0, 1)) - 1e-6, example.max(axis=(0, 1)) + 1e-6
    per = synthesize(model, (40, 48), seed=2, period=(48, 40), device="cpu")
    assert np.all((per >= lo) & (per <= hi))
    pts = np.array([[0.5, 0.5], [10.5, 3.5], [47.5, 39.5]])  # pixel centres
    np.testing.assert_array_equal(evaluate(model, pts, seed=2, period=(48, 40), device="cpu"),
                                  per[(pts[:, 1] - 0.5).astype(int), (pts[:, 0] - 0.5).astype(int)])
    sup = synthesize(model, (16, 16), seed=2, scale=0.5, filter="supersample", device="cpu")
    assert np.all((sup >= lo) & (sup <= hi))


@pytest.mark.parametrize("kind", ["mip", "anisotropic"])
def test_footprint_filters_are_refused_without_prefiltered_tables(model, kind):
    with pytest.raises(TextonError, match="histogram-preserving tiling model.*supersample"):
        synthesize(model, (16, 16), seed=2, scale=0.25, filter=kind, device="cpu")
