"""The translation process (``warp_texton.model.translation``) and the translation fit.

* The Hermite series of known monotone maps against Monte-Carlo correlations of T(X), T(Y)
  for Gaussian pairs of known correlation, within 4 standard errors (per channel and across
  channels); its inverse returns the correlation it was given, and clamps outside the range.
* Synthetic truth: a Gaussian field of a known spectrum pushed through a known map (the
  exponential): the inverted kernel's spectrum is the Gaussian field's, not the mapped
  field's.
* ``analyze(..., histogram="preserve")`` with the translation fit: deterministic, its
  metadata says what the inverse changed.
"""

from __future__ import annotations

import numpy as np
import pytest

from warp_texton.model import analysis
from warp_texton.model.histogram import HistogramTransform, gauss_grid
from warp_texton.model.translation import TranslationSeries, half_plane_covariance, translated_kernel

GRID = gauss_grid(1024)
MAPS = {
    "exp": lambda g: np.exp(0.8 * g),
    "two-level": lambda g: np.tanh(2.0 * (g - 0.3)) + 0.05 * g,  # two plateaus, still increasing
    "cube": lambda g: g ** 3 + g,
}


def monte_carlo(fa, fb, rho: float, rng, count: int = 400_000, batches: int = 20) -> tuple[float, float]:
    """(correlation, standard error) of fa(X), fb(Y) for standard Gaussians of correlation ρ,
    over ``batches`` independent batches."""
    out = []
    for _ in range(batches):
        x = rng.standard_normal(count // batches)
        y = rho * x + np.sqrt(1.0 - rho * rho) * rng.standard_normal(x.size)
        out.append(np.corrcoef(fa(x), fb(y))[0, 1])
    return float(np.mean(out)), float(np.std(out, ddof=1) / np.sqrt(batches))


@pytest.mark.parametrize("name", sorted(MAPS))
def test_series_matches_monte_carlo(name):
    rng = np.random.default_rng(7)
    f = MAPS[name]
    series = TranslationSeries(f(GRID)[None], GRID)
    for rho in (-0.8, -0.3, 0.2, 0.6, 0.95):
        want, se = monte_carlo(f, f, rho, rng)
        got = float(series(np.array(rho)[None, None])[0, 0])
        assert abs(got - want) < 4 * se + 2e-3, (name, rho, got, want, se)
    lo, hi = series.range()
    assert hi[0, 0] == pytest.approx(1.0, abs=1e-6) and -1.0 <= lo[0, 0] < 0.0


def test_cross_channel_series_matches_monte_carlo():
    rng = np.random.default_rng(8)
    fa, fb = MAPS["exp"], MAPS["two-level"]
    series = TranslationSeries(np.stack([fa(GRID), fb(GRID)]), GRID)
    for rho in (-0.5, 0.4, 0.9):
        want, se = monte_carlo(fa, fb, rho, rng)
        got = float(series(np.full((2, 2), rho)[..., None])[0, 1, 0])
        assert abs(got - want) < 4 * se + 2e-3, (rho, got, want, se)


def test_inverse_round_trip_and_clamp():
    tables = np.stack([MAPS["exp"](GRID), MAPS["cube"](GRID)])
    series = TranslationSeries(tables, GRID)
    rho = np.linspace(-0.9, 0.99, 40)
    kappa = series(np.broadcast_to(rho, (2, 2, rho.size)))
    back, clamped = series.inverse(kappa)
    np.testing.assert_allclose(back, np.broadcast_to(rho, back.shape), atol=2e-4)
    assert clamped == 0.0
    lo, _ = series.range()
    below = lo[..., None] - 0.05  # no Gaussian correlation maps there
    got, clamped = series.inverse(below)
    assert clamped == 1.0 and got[0, 0, 0] == pytest.approx(-1.0, abs=1e-3)


def gaussian_field(side: int, width: float, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    fy, fx = np.meshgrid(np.fft.fftfreq(side), np.fft.fftfreq(side), indexing="ij")
    amp = np.exp(-0.5 * (fy ** 2 + fx ** 2) / width ** 2)
    g = np.fft.ifft2(np.fft.fft2(rng.standard_normal((side, side))) * amp).real
    return g / g.std()


def ring_power(field: np.ndarray, rings: int = 12, periodogram: bool = True) -> np.ndarray:
    """Ring averages of a field's periodogram (or of a spectrum given on the FFT grid, with
    ``periodogram=False``), radius up to 0.12 cycle per texel, the DC left out."""
    p = np.abs(np.fft.fft2(field - field.mean())) ** 2 if periodogram else field
    fy, fx = np.meshgrid(np.fft.fftfreq(field.shape[0]), np.fft.fftfreq(field.shape[1]), indexing="ij")
    r = np.hypot(fy, fx)
    edges = np.linspace(0, 0.12, rings + 1)
    return np.array([p[(r > a) & (r <= b)].mean() for a, b in zip(edges[:-1], edges[1:])])


def windowed(power: np.ndarray, window: int) -> np.ndarray:
    """The spectrum seen through the triangular lag window of ``translated_kernel`` (lags
    |τ| < window, the texton's side: a texton cannot make longer correlations)."""
    r = np.fft.ifft2(power).real
    d = np.minimum(np.arange(power.shape[0]), power.shape[0] - np.arange(power.shape[0]))
    w = np.clip(1.0 - d / window, 0.0, None)
    return np.maximum(np.fft.fft2(r * np.outer(w, w)).real, 0.0)


def test_synthetic_truth_recovers_the_gaussian_spectrum():
    """u = exp(0.8 G), G Gaussian of spectrum exp(−|ξ|²/w²), w = 0.05 cycles per texel: the
    inverted kernel's spectrum is G's (through the 64-lag window), not u's. The kernel whose
    phases the result keeps is another field of another spectrum, so only the inverse of u's
    covariances can give G's. Ring averages over 12 rings of a 512² periodogram hold hundreds
    to thousands of frequencies, a relative sampling error of a few per cent: the recovered
    spectrum must be within 10 % of G's on average (measured: 5 %), u's own being off by more
    than twice that (measured: 24 %)."""
    side, width, window = 512, 0.05, 64
    g = gaussian_field(side, width, 3)
    u = np.exp(0.8 * g)[..., None]
    tr = HistogramTransform.fit(u, axes="rgb")
    other = gaussian_field(side, 0.1, 4)[..., None]
    t = (other - other.mean()) / np.sqrt(side * side)
    tz = (u - u.mean()) / np.sqrt(side * side)
    g_hat, meta = translated_kernel(t, tz, tr.lut, gauss_grid(tr.lut.shape[1]), window)
    k = np.fft.irfft2(g_hat[..., 0], s=(side, side))
    fy, fx = np.meshgrid(np.fft.fftfreq(side), np.fft.fftfreq(side), indexing="ij")
    truth = ring_power(windowed(np.exp(-(fy ** 2 + fx ** 2) / width ** 2), window), periodogram=False)
    mapped = ring_power(windowed(np.abs(np.fft.fft2(tz[..., 0])) ** 2, window), periodogram=False)

    def error(p: np.ndarray) -> float:
        return float(np.mean(np.abs(np.log((p / p.sum()) / (truth / truth.sum())))))

    err_got, err_mapped = error(ring_power(k)), error(mapped)
    assert err_got < 0.10 and err_mapped > 2 * err_got, (err_got, err_mapped)
    assert meta["translation_clamped"] < 0.01
    # the kernel keeps unit variance (the Gaussian field's), as the texton fit expects
    assert half_plane_covariance(g_hat, side)[0, 0] == pytest.approx(1.0, rel=0.05)


def test_translation_fit_in_analyze(monkeypatch):
    rng = np.random.default_rng(1)
    u = np.stack([np.exp(0.7 * gaussian_field(96, 0.08, s)) for s in (1, 2, 3)], axis=-1)
    u = (u / u.max() + 0.02 * rng.random(u.shape)).astype(np.float32)
    monkeypatch.setattr(analysis, "PRESERVE_FIT", "translation")
    a = analysis.analyze(u, size=16, seed=0, histogram="preserve")
    b = analysis.analyze(u, size=16, seed=0, histogram="preserve")
    np.testing.assert_array_equal(a.coeffs, b.coeffs)
    assert a.metadata["histogram_fit"] == "translation" and a.histogram is not None
    assert 0.0 <= a.metadata["translation_clamped"] <= 1.0 and 0.0 <= a.metadata["translation_psd_removed"] <= 1.0
    monkeypatch.setattr(analysis, "PRESERVE_FIT", "judges")
    c = analysis.analyze(u, size=16, seed=0, histogram="preserve")
    assert "histogram_fit" not in c.metadata and not np.array_equal(a.coeffs, c.coeffs)


@pytest.mark.parametrize("fit", analysis.PRESERVE_FITS)
def test_preserve_analysis_shows_its_stages(fit, monkeypatch, capsys):
    """``progress=True``: one bar over the stages of the preserve analysis (tables, texton, judges),
    for each fit; none without it."""
    monkeypatch.setattr("warp_texton.core.progress.PROGRESS_DELAY", 0.0)
    monkeypatch.setattr(analysis, "PRESERVE_FIT", fit)
    u = np.exp(0.7 * gaussian_field(64, 0.1, 5))[..., None].astype(np.float32)
    analysis.analyze(u, size=8, seed=0, histogram="preserve", iterations=5)
    assert capsys.readouterr().err == ""
    analysis.analyze(u, size=8, seed=0, histogram="preserve", iterations=5, progress=True)
    err = capsys.readouterr().err
    # the stages' bar (not the projections' "it" bar); its last draw may be skipped by tqdm's
    # minimum interval, so the stage names seen depend on timing
    assert "analyze: tables" in err and "/3 [" in err and "it/s" not in err, err[-300:]
