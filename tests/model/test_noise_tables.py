"""Histogram tables for the MNI in use (``warp_texton.model.noise_tables``).

* The tables of MNI m derived from the Gaussian tables equal the analysis's own route
  (the example's quantiles at the noise's CDF at m), to the tables' resolution.
* The fitted MNI, textons without tables, tables of a Gaussian input and tiling models
  are returned as they are (outputs at the default MNI bit-identical).
* At MNI 10 the tables of MNI 10 bring the outputs' marginal closer to the example's
  than the analysis's MNI-30 tables (paired seeds, beyond twice the standard error).
* Every output path maps with the tables of its MNI: rasters and points, batches, the
  device API (``pack_colours(mni=...)``), the GLSL and OSL plane exports.
"""

from __future__ import annotations

import numpy as np
import pytest

from warp_texton import Texton, TextonError, analyze, evaluate, synthesize, synthesize_batch
from warp_texton.model.histogram import gauss_grid
from warp_texton.model.noise_tables import at_mni, fitted_mni
from warp_texton.model.translation import noise_cdf
from warp_texton.noise.colours import make_colour_map


def skewed_example(seed: int = 0, side: int = 192) -> np.ndarray:
    """A grey example of a strongly right-skewed marginal (the exponential of a smooth
    Gaussian field), where the noise's skewness at low MNI matters."""
    rng = np.random.default_rng(seed)
    g = rng.standard_normal((side, side))
    f = np.fft.fft2(g) * np.exp(-0.5 * (np.hypot(*np.meshgrid(np.fft.fftfreq(side), np.fft.fftfreq(side))) / 0.15) ** 2)
    field = np.fft.ifft2(f).real
    field /= field.std()
    u = np.exp(0.9 * field)
    return ((u - u.min()) / np.ptp(u)).astype(np.float32)[..., None]


@pytest.fixture(scope="module")
def example() -> np.ndarray:
    return skewed_example()


@pytest.fixture(scope="module")
def texton(example) -> Texton:
    return analyze(example, size=16, seed=0, histogram="preserve")


def test_tables_equal_the_analysis_route(example, texton):
    """F_u⁻¹ ∘ F_m from the Gaussian tables equals the example's own quantiles at F_m."""
    assert fitted_mni(texton) == 30.0
    for mni in (10.0, 120.0):
        t = at_mni(texton, mni)
        assert t.metadata["histogram_mni"] == mni and t.metadata["size"] == texton.metadata["size"]
        np.testing.assert_array_equal(t.coeffs, texton.coeffs)
        np.testing.assert_array_equal(t.histogram.gaussian_lut, texton.histogram.gaussian_lut)
        direct = texton.histogram.for_noise(example, noise_cdf(texton, mni, gauss_grid(texton.histogram.lut.shape[1])))
        # the derived tables interpolate the Gaussian ones (1024 steps over ±5 σ): within a few
        # thousandths of the example's range, far below the tables' change from MNI 30
        err = np.abs(t.histogram.lut - direct.lut).max()
        change = np.abs(direct.lut - texton.histogram.lut).max()
        assert err < 4e-3 and change > 5 * err, (mni, err, change)


def test_unchanged_where_no_mni_applies(texton, example):
    assert at_mni(texton, 30.0) is texton  # the fitted MNI: the analysis's own tables, bit for bit
    assert at_mni(texton, 10.0) is at_mni(texton, 10.0)  # cached: one colour map per MNI
    gaussian = analyze(example, size=16, seed=0)
    assert at_mni(gaussian, 10.0) is gaussian
    tiling = analyze(example, method="tiling", histogram="preserve")
    assert at_mni(tiling, 10.0) is tiling
    np.testing.assert_array_equal(synthesize(texton, (32, 32), seed=1), synthesize(texton, (32, 32), mni=30.0, seed=1))


def w1(a: np.ndarray, ref_sorted: np.ndarray) -> float:
    q = np.sort(a.ravel().astype(np.float64))
    idx = np.linspace(0, len(ref_sorted) - 1, len(q)).round().astype(int)
    return float(np.mean(np.abs(q - ref_sorted[idx])))


def test_low_mni_outputs_keep_the_marginal_better(example, texton):
    """At MNI 10 the noise is more skewed than at 30: the tables of MNI 10 give outputs whose
    marginal is closer to the example's. Paired over 12 seeds (the same noise through both
    tables); the mean gain must exceed twice its standard error."""
    ref = np.sort(example.ravel().astype(np.float64))
    fitted = at_mni(texton, 30.0)
    ten = at_mni(texton, 10.0)
    # the same texton with the MNI-30 tables at MNI 10: what every call got before
    old = Texton(ten.coeffs, ten.mean, ten.order, {**ten.metadata, "histogram_mni": 10.0}, fitted.histogram)
    gains = []
    for seed in range(1, 13):
        new_w1 = w1(synthesize(texton, (256, 256), mni=10.0, seed=seed), ref)
        old_w1 = w1(synthesize(old, (256, 256), mni=10.0, seed=seed), ref)
        gains.append(old_w1 - new_w1)
    gains = np.array(gains)
    assert gains.mean() > 2.0 * gains.std(ddof=1) / np.sqrt(len(gains)), gains


def test_every_path_maps_with_the_tables_of_its_mni(texton):
    mni = 12.0
    t = at_mni(texton, mni)
    pts = np.random.default_rng(3).uniform(-40, 40, (64, 2))
    np.testing.assert_array_equal(evaluate(texton, pts, mni=mni, seed=2), evaluate(t, pts, mni=mni, seed=2))
    raster = synthesize(texton, (16, 24), mni=mni, seed=2)
    np.testing.assert_array_equal(raster, synthesize(t, (16, 24), mni=mni, seed=2))
    assert not np.array_equal(raster, synthesize(Texton(t.coeffs, t.mean, t.order, t.metadata, texton.histogram),
                                                 (16, 24), mni=mni, seed=2))  # the tables changed the values
    batch = synthesize_batch([texton], 1, (16, 24), mni=mni, seed=2)
    np.testing.assert_array_equal(batch.images[0], synthesize_batch([t], 1, (16, 24), mni=mni, seed=2).images[0])
    # the device API: pack_colours(mni=...) packs the same tables, its default those fitted
    from warp_texton.runtimes.warp_api import pack_colours

    np.testing.assert_array_equal(pack_colours(texton, mni=mni, device="cpu").tables.numpy(),
                                  make_colour_map(t).tables.numpy())
    np.testing.assert_array_equal(pack_colours(texton, device="cpu").tables.numpy(),
                                  make_colour_map(texton).tables.numpy())
    with pytest.raises(TextonError, match="mni"):
        pack_colours(texton, mni="ten", device="cpu")
    # the shader exports' plane tables
    from warp_texton.runtimes.glsl.texton import colour_textures, glsl_noise
    from warp_texton.runtimes.osl.texton import colour_map_code, osl_files

    g = glsl_noise(texton, mni=mni, seed=2)
    np.testing.assert_array_equal(g.textures["texton_colours"], colour_textures(t)["texton_colours"])
    plane = osl_files(texton, mni=mni, seed=2)["texton_plane.osl"].decode()
    assert colour_map_code(t, slopes=True) in plane and colour_map_code(texton, slopes=True) not in plane
