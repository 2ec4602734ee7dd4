"""The tiling model (method "tiling"): window invariance, points = pixels, the blend's mean, files, errors."""

import numpy as np
import pytest

from warp_texton import TextonError, analyze, evaluate, load_texton, synthesize
from warp_texton.model.tiling import TilingModel


@pytest.fixture(scope="module")
def model():
    rng = np.random.default_rng(0)
    u = rng.random((96, 80, 3)).astype(np.float32)
    return analyze(u, method="tiling", side=16)


def test_any_window_is_the_same_noise(model):
    whole = synthesize(model, (64, 72), seed=3, offset=(5.25, -7.5), scale=1.5, rotation=20.0, device="cpu")
    part = synthesize(model, (20, 30), seed=3, offset=(5.25, -7.5), scale=1.5, rotation=20.0,
                      pixel_offset=(17, 11), device="cpu")
    assert np.array_equal(part, whole[17:37, 11:41])


def test_evaluate_equals_the_pixels(model):
    raster = synthesize(model, (40, 50), seed=7, device="cpu")
    jj, ii = np.meshgrid(np.arange(50) + 0.5, np.arange(40) + 0.5)
    points = evaluate(model, np.stack([jj.ravel(), ii.ravel()], 1), seed=7, device="cpu")
    assert np.array_equal(points.reshape(40, 50, 3), raster)


def test_blend_keeps_the_mean():
    # each patch is a translate of the example at a uniform random texel, so E[value] is the mean of the
    # example's interior; over many independent vertices the sample mean matches within its sampling error
    rng = np.random.default_rng(1)
    u = rng.random((64, 64, 1)).astype(np.float32)
    m = TilingModel(u, side=8.0, sharpness=4)
    inner = u[m.margin:64 - m.margin, m.margin:64 - m.margin, 0]
    pts = np.stack([rng.uniform(-1e5, 1e5, 20000), rng.uniform(-1e5, 1e5, 20000)], 1)
    v = evaluate(m, pts, seed=2, device="cpu")[:, 0]
    # points are far apart (independent vertices); a blend of uniform texels has variance ≤ that of one
    err = 4.0 * inner.std() / np.sqrt(v.size)
    assert abs(v.mean() - inner.mean()) < err + 1e-3


def test_save_load_round_trip(model, tmp_path):
    path = tmp_path / "m.exr"
    model.save(path)
    back = load_texton(path)
    assert isinstance(back, TilingModel)
    assert np.array_equal(back.example, model.example)
    assert (back.side, back.sharpness, back.guide_weight) == (model.side, model.sharpness, model.guide_weight)
    assert np.array_equal(synthesize(back, (16, 16), seed=1, device="cpu"),
                          synthesize(model, (16, 16), seed=1, device="cpu"))


def test_texton_method_is_the_default():
    u = np.random.default_rng(2).random((64, 64)).astype(np.float32)
    a, b = analyze(u, size=16, seed=0), analyze(u, size=16, seed=0, method="texton")
    assert np.array_equal(a.coeffs, b.coeffs)


def test_structure_score_separates_bricks_from_noise():
    from skimage import data

    from warp_texton.model.tiling import phase_randomised, structure_score

    brick = data.brick().astype(np.float32)[:256, :256] / 255.0
    gaussian = phase_randomised(brick, seed=5).astype(np.float32)
    assert structure_score(brick) > 1.6 > structure_score(gaussian)


@pytest.mark.parametrize("call, param", [
    (lambda m: synthesize(m, (8, 8), mni=10, device="cpu"), "mni"),
    (lambda m: synthesize(m, (8, 8), cell_factor=0.5, device="cpu"), "cell_factor"),
    (lambda m: synthesize(m, (8, 8), filter="box", device="cpu"), "filter"),
    (lambda m: evaluate(m, [[0.0, 0.0]], poisson="gaussian", device="cpu"), "poisson"),
    (lambda m: TilingModel(m.example, side=200.0), "side"),
    (lambda m: TilingModel(m.example, side=8.0, sharpness=3), "sharpness"),
    (lambda m: TilingModel(m.example, side=8.0, blend="hpg"), "blend"),
    (lambda m: TilingModel(m.example[..., :2], side=8.0), "example"),
    (lambda m: analyze(m.example, method="tiles"), "method"),
    (lambda m: analyze(m.example, method="tiling", order=3), "order"),
])
def test_bad_models_and_options(model, call, param):
    with pytest.raises(TextonError) as info:
        call(model)
    assert info.value.param == param


def test_variance_preserving_blend_keeps_mean_and_variance():
    # the variance-preserving blend of independent patches keeps the example's mean and variance (HPG 2018 eq. 4);
    # the linear blend lowers the variance in blend zones
    rng = np.random.default_rng(3)
    u = rng.random((64, 64, 1)).astype(np.float32)
    # texel centres, so that the bilinear lookups read single texels (interpolation would lower the variance)
    pts = rng.integers(-100000, 100000, (40000, 2)) + 0.5
    vp = TilingModel(u, side=8.0, sharpness=1, blend="variance")
    lin = TilingModel(u, side=8.0, sharpness=1)
    inner = u[vp.margin:64 - vp.margin, vp.margin:64 - vp.margin, 0].astype(np.float64)
    a = evaluate(vp, pts, seed=4, device="cpu")[:, 0].astype(np.float64)
    b = evaluate(lin, pts, seed=4, device="cpu")[:, 0].astype(np.float64)
    # the example's mean over all texels (the blend's centre) vs its interior's: both within sampling error
    n = a.size
    var = inner.var()
    assert abs(a.mean() - inner.mean()) < 4 * np.sqrt(var / n) + abs(u.mean() - inner.mean())
    # sample variance: relative standard error √(2/n) for near-Gaussian blends; uniform values, so 4 · √(2/n) suffices
    assert abs(a.var() / var - 1.0) < 4 * np.sqrt(2.0 / n) + 0.02
    assert b.var() < 0.9 * var


def test_cli_analyze_and_synthesize_a_tiling_model(tmp_path, capsys):
    from skimage import data

    from warp_texton.cli.parser import main
    from warp_texton.files.images import read_image, write_image

    src = tmp_path / "brick.png"
    write_image(src, data.brick()[:128, :128].astype(np.float32)[..., None] / 255.0)
    model = tmp_path / "m.exr"
    assert main(["analyze", str(src), "--method", "tiling", "-o", str(model)]) in (0, None)
    printed = capsys.readouterr().out
    assert "structure score" in printed and "method" in printed
    out = tmp_path / "out.exr"
    assert main(["synthesize", str(model), "-o", str(out), "--width", "40", "--height", "30", "--seed", "2"]) in (0, None)
    expected = synthesize(load_texton(model), (30, 40), seed=2, device="cpu")
    assert np.allclose(read_image(out), expected, atol=1e-6)
