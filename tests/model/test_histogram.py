"""Histogram-preserving texton noise: ``analyze(..., histogram="preserve")``.

* The transform: Gaussianised channels, tables that undo it, prefiltered tables
  whose share-0 row gives the example's mean; the default analysis unchanged.
* Every output path maps the noise through the transform: each equals
  ``synthesize``/``evaluate`` (or the surface noise) of the same texton without
  transform, mapped (``colours.to_colours``), at the same points.
* Far views (filtered) converge to the example's mean colour; unfiltered tables
  would give the median instead.
* On real photographs: the clipped fraction, the marginal W1 distance and the
  spectrum distance against Gaussian texton noise, asserted with tolerances
  from the sampling error over seeds.
* Files and bad input: the EXR holds the transform exactly; ``.texton``
  refuses it; a NaN or decreasing table in a file, an unknown ``histogram``,
  and mixing what cannot be mixed raise one clear TextonError each.
"""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest

from warp_texton import (FilterOptions, Texton, TextonError, analyze, bake_mesh, evaluate, load_texton, mix_textons,
                         read_image, render_plane, surface_noise, synthesize, synthesize_batch, synthesize_mixed,
                         texture_mesh)
from warp_texton.noise.colours import mean_colour, to_colours
from warp_texton.demo import demo_texture_path
from warp_texton.model.histogram import HistogramTransform
from warp_texton.files.images import read_exr_header, write_exr

from helpers import run_cli


@pytest.fixture(scope="module")
def grass() -> np.ndarray:
    return read_image(demo_texture_path())


@pytest.fixture(scope="module")
def texton(grass) -> Texton:
    return analyze(grass, size=32, seed=0, histogram="preserve")


def plain(t: Texton) -> Texton:
    """The same noise without the transform."""
    return Texton(t.coeffs, t.mean, t.order, t.metadata)


def coloured(t: Texton, values: np.ndarray, share=None) -> np.ndarray:
    """``values`` (..., C) of the noise of ``plain(t)`` mapped as every output path maps them."""
    flat = np.array(values, np.float32).reshape(-1, values.shape[-1])
    to_colours(flat, t, share)
    return flat.reshape(values.shape)


# ---------------------------------------------------------------- the transform


def test_default_analysis_is_unchanged(grass):
    a = analyze(grass, size=16, iterations=5, seed=0)
    b = analyze(grass, size=16, iterations=5, seed=0, histogram="gaussian")
    assert a.histogram is None and b.histogram is None
    np.testing.assert_array_equal(a.coeffs, b.coeffs)


def test_transform_gaussianises_and_undoes_it(grass):
    tr = HistogramTransform.fit(grass)
    g = tr.to_gaussian(grass).reshape(-1)
    assert abs(g.mean()) < 1e-3 and abs(g.std() - 1.0) < 1e-9
    assert abs(np.mean(g ** 3)) < 0.05  # symmetric, where the example is skewed:
    z = tr.decorrelate(grass).reshape(-1)
    assert abs(np.mean(((z - z.mean()) / z.std()) ** 3)) > 0.2
    assert np.all(np.diff(tr.lut, axis=1) >= 0)
    back = tr.to_colours(g[:, None]).reshape(grass.shape)
    assert np.median(np.abs(back - grass)) < 1e-3  # to the tables' resolution
    tables = tr.prefiltered
    np.testing.assert_array_equal(tables[-1], tr.lut)
    # a share 0 of the variance: the table averaged over a whole Gaussian, the mean
    assert abs(float(tr.to_colours(np.zeros((1, 1)), 0.0)[0, 0]) - grass.mean()) < 1e-4
    assert abs(float(tr.to_colours(np.zeros((1, 1)))[0, 0]) - np.median(grass)) < 2e-3  # the table alone: median


def test_texton_noise_of_the_gaussianised_example_is_standard(texton):
    assert texton.histogram is not None and texton.metadata["histogram"] == "preserve"
    assert abs(float(texton.mean[0])) < 1e-3
    assert abs(float(texton.covariance()[0, 0]) - 1.0) < 0.05


# ---------------------------------------------------------------- every path


def test_synthesize_evaluate_batch_and_dask_map_the_noise(texton):
    shape = (40, 56)
    out = synthesize(texton, shape, seed=3, device="cpu")
    np.testing.assert_array_equal(out, coloured(texton, synthesize(plain(texton), shape, seed=3, device="cpu")))
    jj, ii = np.meshgrid(np.arange(shape[1]), np.arange(shape[0]))
    pts = np.stack([jj.ravel() + 0.5, ii.ravel() + 0.5], axis=1)
    np.testing.assert_allclose(evaluate(texton, pts, seed=3, device="cpu"), out.reshape(-1, 1), atol=1e-4)
    images, params = synthesize_batch([texton, plain(texton)], 4, shape, seed=np.arange(1, 5), texton_index=[0, 1, 0, 1],
                                      device="cpu")
    for k in range(4):
        t = [texton, plain(texton)][params.texton[k]]
        np.testing.assert_array_equal(images[k], synthesize(t, shape, **params.item(k), device="cpu"))
    from warp_texton.noise.dask_arrays import synthesize_dask

    lazy = synthesize_dask(texton, shape, chunks=24, seed=3, device="cpu")
    np.testing.assert_array_equal(lazy.compute(), out)


def test_filtered_rasters_use_the_prefiltered_tables(texton):
    opts = FilterOptions("anisotropic")
    out = synthesize(texton, (32, 32), seed=2, scale=0.25, filter=opts, device="cpu")
    raw = synthesize(plain(texton), (32, 32), seed=2, scale=0.25, filter=opts, device="cpu")
    from warp_texton.noise.colours import footprint_shares

    share = footprint_shares(texton, np.diag([4.0, 4.0]), opts)
    assert 0.05 < share < 0.9
    np.testing.assert_array_equal(out, coloured(texton, raw, share))


def test_plane_views_map_the_noise(texton):
    from warp_texton.noise.ground_plane import PlaneCamera, plane_pixels

    camera = PlaneCamera((48, 64), height=1.0, tilt=75.0, fov=40.0, texel_size=0.02)
    img = render_plane(texton, (48, 64), tilt=75.0, texel_size=0.02, seed=4, filter="none", device="cpu")
    ii, jj = np.divmod(np.arange(48 * 64), 64)
    centre = camera.texels(ii + 0.5, jj + 0.5)
    hit = np.isfinite(centre).all(axis=1)
    assert 0 < hit.sum() < hit.size  # ground and sky
    flat = img.reshape(-1, 1)
    np.testing.assert_allclose(flat[hit], evaluate(texton, centre[hit], seed=4, device="cpu"), atol=1e-4)
    np.testing.assert_array_equal(flat[~hit], np.broadcast_to(mean_colour(texton), (int((~hit).sum()), 1)))
    aniso = render_plane(texton, (48, 64), tilt=75.0, texel_size=0.02, seed=4, device="cpu")
    keys = np.array([0, 1500, 48 * 64 - 1])
    np.testing.assert_array_equal(plane_pixels(texton, camera, keys, seed=4, device="cpu"), aniso.reshape(-1, 1)[keys])


def test_surfaces_meshes_and_bakes_map_the_noise(texton):
    import trimesh

    sphere = trimesh.creation.icosphere(subdivisions=2)
    pts, nrm = sphere.vertices, sphere.vertex_normals
    values = surface_noise(texton, pts, nrm, 0.05, seed=1, device="cpu")
    np.testing.assert_array_equal(values, coloured(texton, surface_noise(plain(texton), pts, nrm, 0.05, seed=1,
                                                                         device="cpu")))
    mesh = texture_mesh(sphere, texton, 0.05, seed=1, device="cpu", warn=False)
    expect = np.round(np.clip(surface_noise(texton, mesh.vertices, mesh.vertex_normals, 0.05, seed=1, device="cpu"),
                              0, 1) * 255)
    np.testing.assert_array_equal(mesh.visual.vertex_colors[:, 0], expect[:, 0])
    baked = bake_mesh(sphere, texton, 0.05, resolution=32, supersample=1, seed=1, device="cpu")
    raw = bake_mesh(sphere, plain(texton), 0.05, resolution=32, supersample=1, seed=1, device="cpu")
    cov = baked.coverage
    assert cov.any() and not cov.all()
    np.testing.assert_allclose(baked.texture[cov], coloured(texton, raw.texture[cov]), atol=1e-6)
    # outside the charts and their gutters (where the plain bake shows its mean): the mean colour
    # (the far view's), not the Gaussian mean
    background = ~cov & np.all(raw.texture == plain(texton).mean.astype(np.float32), axis=-1)
    assert background.any()
    np.testing.assert_array_equal(baked.texture[background][:, 0], mean_colour(texton)[0])
    assert mean_colour(texton)[0] != np.float32(plain(texton).mean[0])


def test_the_viewer_maps_the_noise(texton, tmp_path):
    from warp_texton.view.viewer import Viewer
    from warp_texton.view.queries import Analysis, Noise, Tile, tile_window

    path = tmp_path / "preserve.exr"
    texton.save(path)
    viewer = Viewer(str(path), device="cpu")
    tile, noise = Tile(0, 1, 0, size=32), Noise(seed=2, filter="none")
    w = tile_window(tile, noise)
    want = synthesize(load_texton(path), w.shape, seed=2, scale=w.scale, rotation=w.rotation, offset=w.offset,
                      device="cpu")
    np.testing.assert_array_equal(viewer.tile(tile, Analysis(), noise), want)


# ---------------------------------------------------------------- filtering


def test_far_views_converge_to_the_example_mean(grass, texton):
    """A pixel covering ~100 × 100 texels keeps ~1 % of the variance: prefiltered
    tables give the example's mean; the unfiltered table would give its median."""
    opts = FilterOptions("anisotropic")
    seeds = range(1, 7)
    far = np.array([synthesize(texton, (32, 32), seed=s, scale=0.01, filter=opts, device="cpu").mean()
                    for s in seeds])
    naive = np.array([coloured(texton, synthesize(plain(texton), (32, 32), seed=s, scale=0.01, filter=opts,
                                                  device="cpu")).mean() for s in seeds])
    # sampling error of the mean over seeds, plus the tables' resolution (1e-4 of the range)
    tol = 4.0 * far.std(ddof=1) / np.sqrt(len(far)) + 1e-4
    assert abs(far.mean() - grass.mean()) < tol
    assert abs(naive.mean() - grass.mean()) > 20 * tol  # the shift prefiltering removes
    # a plane view with the anisotropic filter: the ground, near to far, averages to the mean
    views = [render_plane(texton, (96, 96), tilt=80.0, texel_size=0.01, seed=s, device="cpu") for s in seeds]
    bands = np.array([[v[r0:r0 + 8].mean() for r0 in (40, 48, 56)] for v in views])  # far rows, shares 0.05–0.2
    se = bands.std(axis=0, ddof=1) / np.sqrt(len(seeds))
    assert np.all(np.abs(bands.mean(axis=0) - grass.mean()) < 4 * se + 1e-3), (bands.mean(axis=0), se)


# ---------------------------------------------------------------- real photographs


def photographs():
    """The README's grass and two stone photographs of GIMP's patterns (Debian's gimp-data)."""
    from benchmarks.common import GIMP_PATTERNS, read_gpat

    out = [pytest.param(lambda: read_image(demo_texture_path()), id="grass")]
    for name, path in (("marble", "Stone/marble1.pat"), ("moonfoot", "Stone/Moonfoot.pat")):
        out.append(pytest.param(lambda path=path: read_gpat(GIMP_PATTERNS / path), id=name,
                                marks=pytest.mark.skipif(not (GIMP_PATTERNS / path).is_file(),
                                                         reason="Debian's gimp-data is not installed")))
    return out


def pooled_w1(outs, u, resamples: int = 30) -> tuple[float, float]:
    """W1 of the outputs' pooled histogram against u's, and its standard error from
    resampling the outputs (seeds) with replacement."""
    from benchmarks.bench_quality import marginal_w1

    rng = np.random.default_rng(0)
    boot = [np.mean(marginal_w1(np.concatenate([outs[i] for i in rng.integers(0, len(outs), len(outs))]), u))
            for _ in range(resamples)]
    return float(np.mean(marginal_w1(np.concatenate(outs), u))), float(np.std(boot, ddof=1))


@pytest.mark.slow
@pytest.mark.parametrize("load", photographs())
def test_preserve_keeps_the_histogram_and_the_spectrum(load):
    """Eight 256² outputs per method: the clipped fraction, W1 of their pooled
    histogram, the spectrum distances paired by seed. Clipping stays below 1 %
    by three standard errors (over the seeds); W1 is below a third of the
    Gaussian noise's by two standard errors of the difference (resampling the
    seeds); the spectrum distance exceeds 1.1 times the Gaussian noise's by
    less than two standard errors of the paired differences."""
    from benchmarks.bench_quality import clipped_fraction, spectrum_distance

    u = load()
    seeds = range(1, 9)
    stats = {}
    for mode in ("gaussian", "preserve"):
        t = analyze(u, size=min(64, *u.shape[:2]), seed=0, histogram=mode)
        outs = [synthesize(t, (256, 256), mni=30, seed=s, device="cpu") for s in seeds]
        stats[mode] = {"clipped": np.array([clipped_fraction(o) for o in outs]), "w1": pooled_w1(outs, u),
                       "spectrum": np.array([spectrum_distance(o, u) for o in outs])}
    g, p = stats["gaussian"], stats["preserve"]

    def se(a):
        return a.std(ddof=1) / np.sqrt(len(a))

    assert p["clipped"].mean() + 3 * se(p["clipped"]) < 0.01, p["clipped"]
    (w1_p, se_p), (w1_g, se_g) = p["w1"], g["w1"]
    assert w1_g / 3 - w1_p > 2 * np.hypot(se_g / 3, se_p), (p["w1"], g["w1"])
    excess = p["spectrum"] - 1.10 * g["spectrum"]  # paired by seed
    assert excess.mean() < 2 * se(excess), (p["spectrum"].mean(), g["spectrum"].mean())


# ---------------------------------------------------------------- colour examples


def _field(rng, side: int, sigma: float) -> np.ndarray:
    from scipy import ndimage

    g = ndimage.gaussian_filter(rng.standard_normal((side, side)), sigma, mode="wrap")
    g = g / g.std() + 0.35 * rng.standard_normal((side, side))  # a fine grain, as photographs have
    return g / g.std()


def colour_example(kind: str) -> np.ndarray:
    """RGB examples whose histograms Gaussian noise cannot keep: "dark" (blue at 0 on
    about 40 % of the pixels), "saturated" (red at 1 on about 22 %), "low" (a strong
    component at a scale of 6 pixels' blur under the grain, through exponentials)."""
    rng = np.random.default_rng(0)
    side = 256 if kind == "low" else 128
    a, b = _field(rng, side, 1.5), _field(rng, side, 3.0)
    if kind == "dark":
        u = [0.45 + 0.12 * a, 0.35 + 0.1 * (0.8 * a + 0.6 * b), 0.06 * (b + 0.4 * a) + 0.02]
    elif kind == "saturated":
        u = [0.88 + 0.15 * a, 0.5 + 0.12 * np.tanh(a + 0.5 * b), 0.25 + 0.08 * b]
    else:
        v = _field(rng, side, 6.0) + 0.5 * a
        u = [0.15 * np.exp(0.5 * v), 0.25 + 0.1 * v, 0.2 * np.exp(0.3 * (v + b))]
    return np.clip(np.stack(u, -1), 0.0, 1.0).astype(np.float32)


@pytest.mark.slow
@pytest.mark.parametrize("kind", ["dark", "saturated", "low"])
def test_colour_examples_keep_their_colours_and_their_spectrum(kind):
    """Issue 29's bounds over six 256² outputs (seeds 1–6), against Gaussian texton noise
    of the same example: clipped pixels below 1 % by three standard errors; W1 of the
    pooled histogram above a third of the Gaussian noise's by less than two standard
    errors of the difference (resampling the seeds); the spectrum distance above 1.15
    times the Gaussian noise's + 0.02 by less than two standard errors of the paired
    differences. The strong low-frequency example, whose steep tables show texton
    noise's own skewness most, is held to a third too: the tables are fitted to the
    noise's marginal (docs/histogram.md)."""
    from benchmarks.bench_quality import clipped_fraction, spectrum_distance

    u = colour_example(kind)
    assert u[..., 2].min() == 0.0 if kind == "dark" else True
    assert (u[..., 0] == 1.0).mean() > 0.1 if kind == "saturated" else True
    stats = {}
    for mode in ("gaussian", "preserve"):
        t = analyze(u, size=32, seed=0, histogram=mode)
        outs = [synthesize(t, (256, 256), mni=30, seed=s, device="cpu") for s in range(1, 7)]
        stats[mode] = {"clipped": np.array([clipped_fraction(o) for o in outs]), "w1": pooled_w1(outs, u),
                       "spectrum": np.array([spectrum_distance(o, u) for o in outs])}
    g, p = stats["gaussian"], stats["preserve"]

    def se(x):
        return x.std(ddof=1) / np.sqrt(len(x))

    assert g["clipped"].mean() > 0.03  # the example is one that Gaussian noise clips
    assert p["clipped"].mean() + 3 * se(p["clipped"]) < 0.01, p["clipped"]
    (w1_p, se_p), (w1_g, se_g) = p["w1"], g["w1"]
    assert w1_p - w1_g / 3 < 2 * np.hypot(se_g / 3, se_p), (p["w1"], g["w1"])
    excess = p["spectrum"] - (1.15 * g["spectrum"] + 0.02)
    assert excess.mean() < 2 * se(excess), (p["spectrum"], g["spectrum"])


def test_colour_tables_are_the_rgb_channels():
    """analyze's colour transform has one table per RGB channel (identity axes, centre 0):
    the tables stay within each channel's extreme values (their ends within a
    pixel's interpolation of them), so no output leaves them."""
    u = colour_example("dark")
    tr = analyze(u, size=16, histogram="preserve").histogram
    np.testing.assert_array_equal(tr.matrix, np.eye(3))
    np.testing.assert_array_equal(tr.centre, np.zeros(3))
    lo, hi = u.min(axis=(0, 1)), u.max(axis=(0, 1))
    assert np.all(tr.lut >= lo[:, None]) and np.all(tr.lut <= hi[:, None])
    assert np.all(tr.gaussian_lut >= lo[:, None]) and np.all(tr.gaussian_lut <= hi[:, None])
    np.testing.assert_allclose(tr.lut[:, 0], lo, atol=1e-4)
    np.testing.assert_allclose(tr.gaussian_lut[:, -1], hi, atol=1e-4)
    # the noise's right tail is longer than a Gaussian's: its table reaches the maximum past g = 5
    assert np.all(tr.lut[:, -1] <= tr.gaussian_lut[:, -1]) and np.all(tr.lut[:, -1] >= np.quantile(
        u.reshape(-1, 3), 0.999, axis=0))


@pytest.mark.parametrize("order, size", [(1, 32), (0, 16), (3, 24)])
def test_noise_cdf_is_the_noise_marginal(grass, order, size):
    """noise_cdf (compound Poisson by FFT) against 60 000 independent values of the noise
    (points 300 texels apart): the Kolmogorov–Smirnov distance stays within the 0.1 %
    critical value 1.95 / √n, while the Gaussian CDF's exceeds it (skewness ~0.2)."""
    from scipy.special import ndtr

    from warp_texton.model.analysis import noise_cdf
    from warp_texton.noise.colours import noise_moments

    t = analyze(grass, size=size, order=order, seed=0, iterations=10)
    n = 60_000
    rng = np.random.default_rng(1)
    points = (np.stack([np.arange(n) % 300, np.arange(n) // 300], 1) * 300.0 + rng.uniform(0, 300, (n, 2)))
    m, s = noise_moments(t)
    g = np.sort(((evaluate(t, points.astype(np.float32), mni=30, seed=3, device="cpu") - m) / s)[:, 0])
    emp_hi, emp_lo = np.arange(1, n + 1) / n, np.arange(n) / n
    crit = 1.95 / np.sqrt(n)

    def ks(cdf):
        return max(np.max(emp_hi - cdf), np.max(cdf - emp_lo))

    assert ks(noise_cdf(t, 30.0, g)[0]) < crit
    assert ks(ndtr(g)) > crit


# ---------------------------------------------------------------- mixing


def test_mixing_interpolates_the_colour_maps(grass, texton):
    v = np.clip(0.5 * np.rot90(grass) ** 2 + 0.4, 0, 1)
    other = analyze(v, size=32, seed=0, histogram="preserve")
    mids = mix_textons(texton, other, [0.0, 0.5, 1.0], size=32, iterations=20)
    np.testing.assert_allclose(mids[0].histogram.lut, texton.histogram.lut)
    np.testing.assert_allclose(mids[1].histogram.centre, (texton.histogram.centre + other.histogram.centre) / 2)
    # strips: the left columns take the first texture's colours, the right ones the last's
    out = synthesize_mixed(mids, "strips", (128, 384), seed=1, device="cpu")
    left, right = out[:, :64].ravel(), out[:, -64:].ravel()
    assert abs(np.median(left) - np.median(grass)) < 0.03 and abs(np.median(right) - np.median(v)) < 0.03
    assert out.min() >= min(grass.min(), v.min()) - 1e-6 and out.max() <= max(grass.max(), v.max()) + 1e-6


def test_mixing_refuses_what_it_does_not_define(grass, texton):
    with pytest.raises(TextonError, match="needs another one"):
        mix_textons(texton, grass, [0.5], size=32)
    rgb = np.random.default_rng(0).uniform(size=(64, 64, 3)).astype(np.float32)
    rgb[..., 1] = rgb[..., 0] ** 2
    # analyze's RGB tables share their axes (the identity); transforms fitted on principal
    # axes (tiling and blending's, and files written before) may not
    a = analyze(rgb, size=16, histogram="preserve")
    b = analyze(rgb[:, :, ::-1].copy(), size=16, histogram="preserve")
    assert mix_textons(a, b, [0.5], size=16)[0].histogram is not None
    a = replace(a, histogram=HistogramTransform.fit(rgb))
    b = replace(b, histogram=HistogramTransform.fit(rgb[:, :, ::-1]))
    with pytest.raises(TextonError, match="different colour axes"):
        mix_textons(a, b, [0.5], size=16)
    with pytest.raises(TextonError, match="all or none"):
        synthesize_mixed([texton, plain(texton)], "strips", (32, 32), device="cpu")


# ---------------------------------------------------------------- files and bad input


def test_exr_holds_the_transform_exactly(texton, tmp_path):
    texton.save(tmp_path / "t.exr")
    back = load_texton(tmp_path / "t.exr")
    for name in ("matrix", "centre", "lut"):
        np.testing.assert_array_equal(getattr(back.histogram, name), getattr(texton.histogram, name))
    np.testing.assert_array_equal(synthesize(back, (16, 16), device="cpu"), synthesize(texton, (16, 16), device="cpu"))


def test_exr_holds_rgb_tables_and_older_principal_axes(tmp_path):
    """The RGB tables (identity axes) and the principal axes that colour textons held
    before both round-trip through the EXR file and map as in memory."""
    u = colour_example("dark")
    rgb = analyze(u, size=16, histogram="preserve")
    older = replace(rgb, histogram=HistogramTransform.fit(u))  # a file written before
    for n, t in enumerate((rgb, older)):
        t.save(tmp_path / f"{n}.exr")
        back = load_texton(tmp_path / f"{n}.exr")
        for name in ("matrix", "centre", "lut"):
            np.testing.assert_array_equal(getattr(back.histogram, name), getattr(t.histogram, name))
        if t.histogram.gaussian_lut is None:
            assert back.histogram.gaussian_lut is None
        else:
            np.testing.assert_array_equal(back.histogram.gaussian_lut, t.histogram.gaussian_lut)
        np.testing.assert_array_equal(back.histogram.prefiltered, t.histogram.prefiltered)
        np.testing.assert_array_equal(synthesize(back, (16, 16), device="cpu"), synthesize(t, (16, 16), device="cpu"))
    assert not np.allclose(older.histogram.matrix, np.eye(3))
    assert rgb.histogram.gaussian_lut is not None and not np.allclose(rgb.histogram.lut, rgb.histogram.gaussian_lut)


def test_noise_tables_keep_the_mean_and_fade_with_filtering():
    """The tables fitted to the noise's marginal: the last prefiltered row is ``lut``;
    the share-0 row is the Gaussian table averaged over a standard Gaussian, the
    example's mean (the far-view limit), as for tables without a noise fit; rows
    in between stay non-decreasing."""
    from scipy.special import ndtr

    from warp_texton.model.histogram import gauss_grid

    u = colour_example("low")
    tr = analyze(u, size=16, histogram="preserve").histogram
    rows = tr.prefiltered
    np.testing.assert_array_equal(rows[-1], tr.lut)
    k = tr.lut.shape[1] // 2  # g = 0 lies between entries k − 1 and k
    np.testing.assert_allclose(rows[0][:, k - 1:k + 1].mean(axis=1), u.reshape(-1, 3).mean(axis=0), atol=1e-3)
    assert np.all(np.diff(rows, axis=2) >= -1e-12)
    # without the noise fit the applied table is the Gaussian one; with it, its median is higher
    # (texton noise's right tail is longer: its median standardised value is below 0)
    plain_tr = HistogramTransform(tr.matrix, tr.centre, tr.gaussian_lut)
    np.testing.assert_allclose(plain_tr.prefiltered[0], rows[0], atol=1e-12)
    assert np.all(tr.lut[:, k] >= tr.gaussian_lut[:, k]), ndtr(gauss_grid()[k])


def test_numpy_noise_sample_has_the_noise_statistics(grass):
    """noise_sample (the analysis's judge of candidate textons) is texton noise: standardised
    mean 0 and variance 1, and its one-point distribution is noise_cdf's (KS within the
    0.1 % critical value for the sample's effective size, a point per 16 × 16 texels)."""
    from warp_texton.model.analysis import noise_cdf, noise_sample

    t = analyze(grass, size=16, seed=0, iterations=10)
    g = noise_sample(t, 30.0, (512, 512), seed=4)[::16, ::16, 0].ravel()
    n = g.size
    assert abs(g.mean()) < 4 / np.sqrt(n) and abs(g.var() - 1) < 4 * np.sqrt(2 / n)
    g = np.sort(g)
    cdf = noise_cdf(t, 30.0, g)[0]
    assert max(np.max(np.arange(1, n + 1) / n - cdf), np.max(cdf - np.arange(n) / n)) < 1.95 / np.sqrt(n)


def test_texton_format_refuses_the_transform(texton, tmp_path):
    with pytest.raises(TextonError, match="cannot hold a histogram transform"):
        texton.save(tmp_path / "t.texton")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("edit, match", [
    (lambda d: d["lut"][0].__setitem__(5, float("nan")), "NaN"),
    (lambda d: d["lut"][0].__setitem__(5, d["lut"][0][4] - 1.0), "decreases"),
    (lambda d: d.__setitem__("matrix", [[2.0]]), "orthonormal"),
    (lambda d: d.pop("lut"), "arrays of numbers"),
])
def test_malformed_tables_in_a_file_are_refused(texton, tmp_path, edit, match):
    texton.save(tmp_path / "t.exr")
    header = read_exr_header(tmp_path / "t.exr")
    d = json.loads(header["texton_histogram"])
    edit(d)
    write_exr(tmp_path / "bad.exr", np.asarray(texton.coeffs),
              **{k: header[k] for k in ("texton_version", "texton_order", "texton_mean", "texton_metadata")},
              texton_histogram=json.dumps(d))
    with pytest.raises(TextonError, match=f"malformed histogram transform.*{match}"):
        load_texton(tmp_path / "bad.exr")


def test_unknown_histogram_is_refused(grass):
    with pytest.raises(TextonError, match="histogram must be one of gaussian, preserve"):
        analyze(grass, size=16, histogram="uniform")


def test_cli_analyze_preserve(tmp_path, capsys):
    out = tmp_path / "t.exr"
    assert run_cli(["analyze", demo_texture_path(), "-o", out, "--size", "16", "--histogram", "preserve", "-q"]) == 0
    assert load_texton(out).histogram is not None
    capsys.readouterr()
    assert run_cli(["analyze", demo_texture_path(), "-o", tmp_path / "t.texton", "--size", "16",
                    "--histogram", "preserve"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "cannot hold a histogram transform" in err[0], err
    assert not (tmp_path / "t.texton").exists()
    assert run_cli(["analyze", demo_texture_path(), "-o", tmp_path / "u.exr", "--histogram", "uniform"]) == 2


def test_colour_refits_are_judged_and_bounded(monkeypatch):
    """A colour analysis judges two families of three candidates (a first texton and
    two refits; plain and zero-sum), their errors and the Gaussian texton's
    reference in its metadata, and keeps what the rule says: the plain family's
    best, or the zero-sum family's where its spectrum error is within the slack
    of the reference and its marginals are closer (judged only then). An
    example above REFINE_MAX_PIXELS gets no refits but still tables fitted to its
    noise."""
    import warp_texton.model.analysis as analysis
    import warp_texton.model.judges as judges

    u = colour_example("saturated")
    t = analyze(u, size=16, seed=0, histogram="preserve")
    md = t.metadata
    errors, free = md["histogram_spectrum_errors"], md["histogram_zero_sum_spectrum_errors"]
    assert len(errors) == 3 and len(free) == 3 and all(e > 0 for e in errors + free)
    reference = md["histogram_reference_spectrum_error"]
    assert reference > 0
    admissible = min(free) <= 1.15 * reference + 0.02
    assert ("histogram_marginal_errors" in md) == admissible
    marginal = md.get("histogram_marginal_errors", [0.0, 1.0])
    assert md["zero_sum"] == (admissible and marginal[1] < marginal[0])
    if md["zero_sum"]:
        np.testing.assert_allclose(t.coeffs.sum(axis=(0, 1)), 0.0, atol=1e-5 * np.abs(t.coeffs).sum())
    # the rule on both sides: no slack keeps the plain family unjudged, any slack judges the marginals
    monkeypatch.setattr(judges, "ZERO_SUM_SPECTRUM_SLACK", 0.0)
    monkeypatch.setattr(judges, "ZERO_SUM_SPECTRUM_MARGIN", 0.0)
    plain = analyze(u, size=16, seed=0, histogram="preserve")
    assert plain.metadata["zero_sum"] is False and "histogram_marginal_errors" not in plain.metadata
    monkeypatch.setattr(judges, "ZERO_SUM_SPECTRUM_MARGIN", 1e9)
    loose = analyze(u, size=16, seed=0, histogram="preserve")
    w_plain, w_free = loose.metadata["histogram_marginal_errors"]
    assert w_plain > 0 and w_free > 0 and loose.metadata["zero_sum"] == (w_free < w_plain)
    monkeypatch.setattr(analysis, "REFINE_MAX_PIXELS", u.shape[0] * u.shape[1] - 1)
    first = analyze(u, size=16, seed=0, histogram="preserve")
    assert "histogram_spectrum_errors" not in first.metadata and "zero_sum" not in first.metadata
    assert first.histogram.gaussian_lut is not None
    # the plain texton kept is the first one exactly when the first was judged best
    assert np.array_equal(first.coeffs, plain.coeffs) == (min(errors) == errors[0])


def test_the_marginal_judge_sees_the_mean_drift():
    """On an example with a strong low-frequency component the zero-sum texton's
    samples are judged closer to the example's marginals than the plain one's
    (eight samples: the plain texton's outputs drift with its power at frequency
    0), and its real outputs are too: the mean W1 of twelve 256² outputs is lower."""
    import warp_texton.model.judges as judges
    from benchmarks.bench_quality import marginal_w1

    u = colour_example("low")
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(judges, "ZERO_SUM_SPECTRUM_MARGIN", 1e9)  # judge the marginals whatever the spectrum
        t = analyze(u, size=32, seed=0, histogram="preserve")
        mp.setattr(judges, "ZERO_SUM_SPECTRUM_MARGIN", -1e9)  # the plain texton
        p = analyze(u, size=32, seed=0, histogram="preserve")
    w_plain, w_free = t.metadata["histogram_marginal_errors"]
    assert t.metadata["zero_sum"] and w_free < w_plain
    outs = {k: [np.mean(marginal_w1(synthesize(x, (256, 256), mni=30, seed=s, device="cpu"), u)) for s in range(12)]
            for k, x in (("free", t), ("plain", p))}
    # lower by more than two standard errors of the difference (measured: 0.0033 against 0.0084, SE 0.0016)
    se = np.hypot(*(np.std(outs[k], ddof=1) / np.sqrt(12) for k in outs))
    assert np.mean(outs["free"]) + 2 * se < np.mean(outs["plain"]), outs


def test_zero_sum_textons_hold_the_mean():
    """The zero-sum fit (no power at frequency 0, as the model, t̂_u(0) = 0, has
    none) sums to 0 per channel, and its outputs' means stray far less from the
    texton's mean than the plain fit's: over 12 seeds of 128² outputs the
    variance of the mean is below a quarter of the plain fit's (an F(11, 11)
    ratio falls below 0.25 by chance with probability 0.015 when the variances
    are equal; measured 0.02–0.035 on the strong low-frequency example)."""
    import scipy.fft as sfft

    from warp_texton.model.analysis import texton_from_spectrum
    from warp_texton.model.gaussian import normalized_kernel

    u = colour_example("low")
    mean, t = normalized_kernel(u)
    t_hat = sfft.rfft2(t, axes=(0, 1))
    flat = t.reshape(-1, 3)
    fits = {zs: texton_from_spectrum(t_hat, u.shape[1], mean, 16, 1, 50, 0, covariance=flat.T @ flat,
                                     zero_sum=zs) for zs in (False, True)}
    free = fits[True]
    assert free.metadata["zero_sum"] is True and "zero_sum" not in fits[False].metadata
    np.testing.assert_allclose(free.coeffs.sum(axis=(0, 1)), 0.0, atol=1e-5 * np.abs(free.coeffs).sum())
    assert np.all(np.abs(fits[False].coeffs.sum(axis=(0, 1))) > 1e-3 * np.abs(fits[False].coeffs).sum(axis=(0, 1)))
    spread = {zs: np.var([synthesize(tx, (128, 128), mni=30, seed=s, device="cpu").mean(axis=(0, 1))
                          for s in range(12)], axis=0, ddof=1) for zs, tx in fits.items()}
    assert np.all(spread[True] < 0.25 * spread[False]), spread


def test_zero_sum_colour_far_views_converge_to_the_mean_colour():
    """A zero-sum colour texton (the strong low-frequency example's, which the judges
    keep) filtered at scale 0.01 gives each channel the example's mean, not its
    median (the prefiltered tables do not depend on the texton's sum)."""
    u = colour_example("low")
    t = analyze(u, size=32, seed=0, histogram="preserve")
    assert t.metadata["zero_sum"]
    far = np.array([synthesize(t, (32, 32), seed=s, scale=0.01, filter=FilterOptions("anisotropic"),
                               device="cpu").mean(axis=(0, 1)) for s in range(1, 7)])
    mean, median = u.mean(axis=(0, 1)), np.median(u.reshape(-1, 3), axis=0)
    tol = 4.0 * far.std(axis=0, ddof=1) / np.sqrt(len(far)) + 1e-4  # sampling error + the tables' resolution
    assert np.all(np.abs(far.mean(axis=0) - mean) < tol), (far.mean(axis=0), mean, tol)
    assert np.all(np.abs(median - mean) > 10 * tol)  # the median would fail it


def test_grey_examples_are_judged_too(grass):
    """A grey example (its first texton from the per-frequency correction) gets the same
    judges as colour: both families' errors and the reference in its metadata, the
    rule applied, and a zero-sum texton that sums to 0 where it is kept."""
    t = analyze(grass, size=32, seed=0, histogram="preserve")
    md = t.metadata
    assert len(md["histogram_spectrum_errors"]) == 3 and len(md["histogram_zero_sum_spectrum_errors"]) == 3
    admissible = min(md["histogram_zero_sum_spectrum_errors"]) <= 1.15 * md["histogram_reference_spectrum_error"] + 0.02
    marginal = md.get("histogram_marginal_errors", [0.0, 1.0])
    assert md["zero_sum"] == (admissible and marginal[1] < marginal[0])
    if md["zero_sum"]:
        np.testing.assert_allclose(t.coeffs.sum(), 0.0, atol=1e-5 * np.abs(t.coeffs).sum())
    assert t.histogram.matrix.shape == (1, 1)
