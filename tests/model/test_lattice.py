"""The structure of an example (warp_texton.model.lattice): seams, lattices, the lattice-periodic mean, and
the lattice snap of the tiling model's draw (its NumPy twin against the kernels)."""

from __future__ import annotations

import numpy as np
import pytest

from benchmarks.synthetic_lattices import CASES, lattice_texture, same_lattice
from warp_texton import TextonError, analyze, evaluate, load_texton, synthesize
from warp_texton.model.lattice import Lattice, lattice_mean, seam_ratios
from warp_texton.model.lattice_detection import detect_lattices
from warp_texton.model.tiling import TilingModel
from warp_texton.model.tiling_fit import example_wrap, fit_tiling, snap_centres


def _gaussian_sample(shape, seed):
    rng = np.random.default_rng(seed)
    f = np.fft.fftfreq(shape[0])[:, None] ** 2 + np.fft.fftfreq(shape[1]) ** 2
    g = np.real(np.fft.ifft2(np.fft.fft2(rng.standard_normal(shape)) * np.exp(-f / 0.004)))
    return (0.5 + 0.1 * g / g.std()).astype(np.float32)


# ---------------------------------------------------------------- detection
@pytest.mark.parametrize("seamless", [True, False])
@pytest.mark.parametrize("kind", list(CASES))
def test_synthetic_lattices_are_found_within_half_a_texel(kind, seamless):
    # tiles, bonds, hexagons, rotated tiles (2-D) and courses (1-D), with noise, weathering and a colour
    # per tile, seamless or cropped: the strongest lattice of the true rank is the true one
    u, truth = lattice_texture(kind, seamless=seamless, seed=2)
    wrap, _ = example_wrap(u)
    found = detect_lattices(u, wrap)
    same_rank = [lat for lat in found if lat.rank == truth.rank]
    assert same_rank, f"no rank-{truth.rank} lattice found: {[lat.vectors for lat in found]}"
    assert same_lattice(same_rank[0].vectors, truth.vectors, tol=0.5), (same_rank[0].vectors, truth.vectors)
    assert same_rank[0].strength >= 0.03


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_stochastic_textures_have_no_lattice(seed):
    from skimage import data

    for u in (_gaussian_sample((256, 256), seed), data.grass()[::2, ::2] / 255.0, data.gravel()[::2, ::2] / 255.0):
        assert detect_lattices(u, seam_ratios(u).wrap) == []


@pytest.mark.parametrize("seed", [1, 2])
@pytest.mark.parametrize("kind", ["square", "running", "hexagonal", "rotated"])
def test_seamless_and_cropped_examples_are_told_apart(kind, seed):
    # the fit's reading: the seams, then whole cells of the lattice across each wrapped axis (a crop of
    # flat tiles can hide its seam inside a tile, not a fraction of a cell)
    for seamless in (True, False):
        m = fit_tiling(lattice_texture(kind, seamless=seamless, seed=seed)[0], side=48, lattice=None, score=False)
        assert m.wrap == (seamless, seamless)
    # a Gaussian sample made by FFT is periodic: seamless
    assert seam_ratios(_gaussian_sample((300, 300), 4)).wrap == (True, True)


def test_a_crop_of_a_photograph_is_not_seamless():
    from skimage import data

    for u in (data.brick(), data.grass(), data.gravel()):
        assert seam_ratios(u / 255.0).wrap == (False, False)


# ---------------------------------------------------------------- the Lattice value
def test_lattices_of_the_same_vectors_compare_equal_and_round_trip():
    a = Lattice.from_vectors([(32, 32), (32, -32)], (256, 256), (True, True))
    b = Lattice.from_vectors([(0, 64), (32, 32)], (256, 256), (True, True))  # another basis of it
    assert a == b and a.commensurate((256, 256)) and a.modulus == 256
    assert Lattice.from_json(a.to_json()) == a
    assert np.allclose(sorted(map(tuple, np.abs(a.vectors))), [(32, 32), (32, 32)])


@pytest.mark.parametrize("bad", [[(2, 0)], [(16, 16), (32, 32)], [(np.nan, 4)], "x", [(1, 2, 3)]])
def test_bad_lattices_are_refused(bad):
    with pytest.raises(TextonError):
        Lattice.from_vectors(bad, (128, 128))


# ---------------------------------------------------------------- the lattice-periodic mean
@pytest.mark.parametrize("kind,seamless", [("running", True), ("courses", True), ("square", False)])
def test_the_lattice_mean_is_invariant_under_the_lattice(kind, seamless):
    u, truth = lattice_texture(kind, seamless=seamless, seed=3)
    wrap = (seamless, seamless)
    lat = Lattice.from_vectors(truth.vectors, u.shape, wrap)
    m = lattice_mean(u, lat, wrap).astype(np.float64)
    assert np.allclose(m.mean(axis=(0, 1)), u.mean(axis=(0, 1)), atol=2e-3)
    for dy, dx in truth.vectors if truth.rank == 2 else truth.vectors:
        if float(dy).is_integer() and float(dx).is_integer():
            shifted = np.roll(m, (int(dy), int(dx)), axis=(0, 1))
            inner = (slice(40, -40), slice(40, -40))
            tol = 1e-4 if seamless else 0.02
            assert np.abs(shifted[inner] - m[inner]).max() < tol
    if truth.rank == 1:  # courses: the mean depends on the coordinate across them only
        assert np.abs(m - m.mean(axis=1, keepdims=True)).max() < 1e-3


# ---------------------------------------------------------------- the snap: NumPy twin = kernels
def test_the_snap_moves_each_centre_to_the_lattice_phase_of_its_vertex():
    rng = np.random.default_rng(0)
    for vectors, shape, wrap in (([(32, 32), (32, -32)], (256, 256), (True, True)),
                                 ([(23.27, 23.27), (23.27, -23.27)], (512, 512), (False, False)),
                                 ([(24, 0)], (240, 240), (True, True)), ([(17.3, 5.1)], (300, 200), (False, True))):
        lat = Lattice.from_vectors(vectors, shape, wrap)
        c = rng.integers(0, 200, (500, 2))
        p = rng.integers(-10 ** 6, 10 ** 6, (500, 2))
        s = snap_centres(c, p, lat)
        k = lat.dual_matrix[:, ::-1]  # (x, y)
        phase = ((s - p) @ k.T) / lat.modulus
        err = np.abs(phase - np.round(phase))  # in cycles; at most half a texel of rounding per axis
        assert np.all(err <= 0.5 * np.abs(k).sum(axis=1) / lat.modulus + 1e-12)
        ey, ex = lat.half_extent()
        assert np.all(np.abs(s - c) <= np.array([ex, ey]))


def _lattice_model(blend="variance", channels=3, lattice=((16, 16), (16, -16)), wrap=(True, True), side=40):
    from tests.helpers import running_bond

    u = running_bond((128, 128), channels=channels)
    return TilingModel(u, side, 16, 0.0, {}, blend, None, wrap, Lattice.from_vectors(lattice, u.shape, wrap))


def test_lattice_models_keep_the_bricks_aligned_across_the_plane():
    # the output's mean over the lattice's translations is the example's lattice-periodic mean, at the
    # plane's phase: every vertex's patch shows the example at the same lattice phase
    m = _lattice_model()
    out = synthesize(m, (256, 256), seed=3).astype(np.float64)
    shifted = lattice_mean(out, m.lattice, (True, True))
    want = np.tile(m.mean_image, (2, 2, 1))  # phase 0 at the plane's origin, as at the example's
    assert np.abs(shifted - want).mean() < 0.01
    plain = TilingModel(m.example, m.side, 16, 0.0, {}, "variance", None, (True, True))
    off = lattice_mean(synthesize(plain, (256, 256), seed=3).astype(np.float64), m.lattice, (True, True))
    assert np.abs(off - want).mean() > 3 * np.abs(shifted - want).mean()


@pytest.mark.parametrize("lattice", [((16, 16), (16, -16)), ((16, 0),)])
def test_the_blend_keeps_the_residual_variance(lattice):
    # the variance-preserving blend of the residuals around the lattice-periodic mean keeps their variance
    # (over many seeds: the standard error of the variance ratio is a few per cent)
    m = _lattice_model(lattice=lattice)
    resid = (m.example - m.mean_image).astype(np.float64)
    want = resid.var(axis=(0, 1))
    ratios = []
    for seed in range(12):
        out = synthesize(m, (256, 256), seed=seed).astype(np.float64)
        mean = np.tile(m.mean_image, (2, 2, 1))
        ratios.append((out - mean).var(axis=(0, 1)) / want)
    r = np.array(ratios)
    se = r.std(axis=0) / np.sqrt(len(r))
    assert np.all(np.abs(r.mean(axis=0) - 1.0) < 4 * se + 0.08), (r.mean(axis=0), se)


@pytest.mark.parametrize("wrap,lattice", [((True, True), ((16, 16), (16, -16))), ((True, False), ((16, 0),)),
                                          ((False, False), ((16, 16), (16, -16))), ((True, True), None)])
def test_wrapped_and_lattice_models_evaluate_their_pixels(wrap, lattice):
    u = lattice_model_example()
    lat = None if lattice is None else Lattice.from_vectors(lattice, u.shape, wrap)
    for blend in ("linear", "variance"):
        m = TilingModel(u, 24, 8, 0.0, {}, blend, None, wrap, lat)
        r = synthesize(m, (40, 56), seed=5, offset=(-1000.0, 3000.0))
        jj, ii = np.meshgrid(np.arange(56) + 0.5 - 1000.0, np.arange(40) + 0.5 + 3000.0)
        pts = evaluate(m, np.stack([jj.ravel(), ii.ravel()], 1), seed=5)
        assert np.array_equal(pts.reshape(r.shape), r)
        # windows are the big raster
        big = synthesize(m, (64, 64), seed=5)
        win = synthesize(m, (20, 24), seed=5, pixel_offset=(10, 30))
        assert np.array_equal(big[10:30, 30:54], win)


def lattice_model_example():
    from tests.helpers import running_bond

    return running_bond((128, 128), channels=1)


def test_the_numpy_probe_is_a_statistical_twin_of_the_kernels():
    # the probe (another stream of centres, the same draw and blend) has the kernels' statistics
    m = _lattice_model()
    out = np.stack([synthesize(m, (256, 256), seed=s) for s in range(4)]).astype(np.float64)
    from warp_texton.model.tiling_fit import probe

    twin = np.stack([probe(m, (256, 256), s) for s in range(4)]).astype(np.float64)
    assert np.allclose(out.mean(axis=(0, 1, 2)), twin.mean(axis=(0, 1, 2)), atol=0.01)
    assert np.allclose(out.std(axis=(0, 1, 2)), twin.std(axis=(0, 1, 2)), rtol=0.05)
    # and the lattice phase of both is the plane's
    for img in (out[0], twin[0]):
        assert np.abs(lattice_mean(img, m.lattice, (True, True)) - np.tile(m.mean_image, (2, 2, 1))).mean() < 0.01


# ---------------------------------------------------------------- the fit and its files
def test_the_fit_reads_a_seamless_regular_example_wrapped_with_its_lattice(tmp_path):
    u, truth = lattice_texture("running", seed=5)
    m = fit_tiling(u)
    assert m.wrap == (True, True)
    assert m.lattice is not None and same_lattice(m.lattice.vectors, truth.vectors)
    fit = m.metadata["fit"]
    assert fit["wrap"] == [1, 1] and len(fit["candidates"]) >= 3
    assert m.side >= 64  # a wrapped example takes patches larger than a quarter of it
    m.save(tmp_path / "m.exr")
    back = load_texton(tmp_path / "m.exr")
    assert back.wrap == m.wrap and back.lattice == m.lattice and back.side == m.side
    assert np.array_equal(synthesize(back, (64, 64), seed=2), synthesize(m, (64, 64), seed=2))


def test_the_fit_of_a_crop_does_not_wrap_and_keeps_its_centres_inside():
    from skimage import data

    m = analyze(data.brick(), method="tiling")
    assert m.wrap == (False, False)
    (lx, nx), (ly, ny) = m.centre_box
    assert lx >= m.margin and ly >= m.margin and lx + nx <= 512 - m.margin and ly + ny <= 512 - m.margin


def test_options_of_the_fit():
    u, truth = lattice_texture("square", seed=1)
    assert fit_tiling(u, lattice=None).lattice is None
    assert fit_tiling(u, periodic=False, lattice=None).wrap == (False, False)
    given = fit_tiling(u, lattice=[(32, 0), (0, 32)], side=64)
    assert given.side == 64 and same_lattice(given.lattice.vectors, truth.vectors, tol=1e-6)
    # a small seamless example takes a side as large as itself
    small = lattice_texture("square", seed=1)[0][:96, :96]
    assert fit_tiling(small, side=96, periodic=True, lattice=None).side == 96
    for bad in ({"periodic": "yes"}, {"lattice": "grid"}, {"lattice": [(1, 1)]}):
        with pytest.raises(TextonError):
            fit_tiling(u, **bad)
    with pytest.raises(TextonError, match="lattice applies to method 'tiling' only"):
        analyze(u, lattice=None)


def test_old_files_load_unchanged(tmp_path):
    # a model file without the new header attributes is read as before: clamped, no lattice
    u = lattice_model_example()
    m = TilingModel(u, 20, 8)
    m.save(tmp_path / "old.exr")
    back = load_texton(tmp_path / "old.exr")
    assert back.wrap == (False, False) and back.lattice is None
    assert np.array_equal(synthesize(back, (32, 32), seed=1), synthesize(m, (32, 32), seed=1))


def test_bad_wrap_and_lattice_arguments_are_refused():
    u = lattice_model_example()
    for kwargs in ({"wrap": (1, 0)}, {"wrap": True}, {"wrap": (True,)}, {"lattice": ((16, 0),)}):
        with pytest.raises(TextonError):
            TilingModel(u, 20, **kwargs)
    with pytest.raises(TextonError, match="larger than the wrapped example"):
        TilingModel(u, 200, wrap=(True, True))
    TilingModel(u, 128, wrap=(True, True))  # as large as the example: fine
