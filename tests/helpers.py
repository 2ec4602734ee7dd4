"""Test helpers shared by the test modules: textons, comparisons, CLI runs, files, devices.

The device the property tests run on comes from ``pytest --device`` (see
conftest.py) through the ``device`` fixture; helpers here take it as an argument.
"""

from __future__ import annotations

import shutil
import sys
from pathlib import Path

import numpy as np
import OpenEXR

from warp_texton import Texton

#: Mixes white channels into correlated ones with a full-rank lag-0 covariance, as in a photograph.
CHANNEL_MIX = np.array([[1.0, 0.0, 0.0], [0.8, 0.6, 0.0], [0.5, 0.3, 0.8]])


def random_texton(shape=(8, 8), channels=1, order=1, seed=0, *, gain=0.15, offset=0.03, mean=0.5,
                  correlated=True, metadata=None) -> Texton:
    """White coefficients ``gain`` · N(0, 1) plus a constant ``offset``.

    A non-zero offset makes ∫h = Σα clearly non-zero, so that mean tests see the
    λ ∫h subtraction; white coefficients keep the spectrum's dynamic range
    moderate. RGB channels are mixed by CHANNEL_MIX unless ``correlated`` is
    False. ``seed`` is an int or a NumPy Generator; ``mean=None`` draws the mean
    colour from it after the coefficients.
    """
    rng = np.random.default_rng(seed)
    a = gain * rng.standard_normal((*shape, channels))
    if channels == 3 and correlated:
        a = a @ CHANNEL_MIX.T
    m = rng.random(channels) if mean is None else np.broadcast_to(np.asarray(mean, np.float64), (channels,))
    return Texton(a + offset, m, order, metadata or {})


def anisotropic_texton(shape=(8, 12), order=1, seed=4, mean=0.5) -> Texton:
    """Coefficients smoothed along x (σ = 0.8): a spectrum elongated along ξ_y.

    σ = 0.8 keeps the power at the x-Nyquist frequency at exp(−4π²σ²/4) ≈ 2 % of
    the peak, well above the rectangular window's leakage (~1e-4 at 32 bins).
    """
    import scipy.ndimage as ndi

    a = np.random.default_rng(seed).standard_normal((*shape, 1))
    a = ndi.gaussian_filter1d(a, 0.8, axis=1, mode="constant")
    return Texton(0.3 * a + 0.02, [mean], order)


def running_bond(shape=(128, 128), channels=3, seed=0) -> np.ndarray:
    """A seamless running-bond brick wall, float32 (H, W, C): bricks 32 × 16 texels, every second course
    shifted by 16, 2-texel mortar, a tone per brick and a periodic grain (H, W multiples of 32), so that
    its lattice is (16, 16), (16, −16) (dy, dx) and its courses (16, 0)."""
    h, w = shape
    rng = np.random.default_rng(seed)
    y, x = np.mgrid[0:h, 0:w]
    course = y // 16
    xs = x + 16 * (course % 2)
    mortar = ((y % 16) < 2) | ((xs % 32) < 2)
    brick = course * (w // 32) + (xs // 32) % (w // 32)
    tone = rng.uniform(0.45, 0.8, (h // 16) * (w // 32))[brick]
    grain = np.real(np.fft.ifft2(np.fft.fft2(rng.standard_normal((h, w)))
                                 * np.exp(-(np.fft.fftfreq(h)[:, None] ** 2 + np.fft.fftfreq(w) ** 2) / 0.02)))
    g = np.where(mortar, 0.25, tone) + 0.4 * grain / grain.std() * 0.1
    if channels == 1:
        return g[..., None].astype(np.float32)
    return np.stack([g, 0.8 * g + 0.1, 0.6 * g + 0.05 * np.roll(grain, 9, axis=1)], axis=-1).astype(np.float32)


def noise_sd(texton: Texton) -> float:
    """The noise's standard deviation, averaged over channels."""
    return float(np.sqrt(np.diag(texton.covariance()).mean()))


def assert_same_noise(a, b, texton, rtol=1e-4, max_flips=0.0):
    """a == b up to float error, relative to the noise standard deviation.

    Order 0 is discontinuous: a pixel whose offset to an impact lies within float
    rounding (~1e-5 texel) of a half-integer may fall on either side in two evaluation
    paths, so a few such pixels (probability ~ 2 × 2 × MNI × 1e-5 per pixel ≈ 0.2 %) are
    allowed to differ there; ``max_flips`` bounds their fraction.
    """
    a = np.asarray(a, np.float64)
    b = np.asarray(b, np.float64)
    assert a.shape == b.shape
    bad = np.any(np.abs(a - b) > rtol * noise_sd(texton), axis=-1)
    assert bad.mean() <= max_flips, (
        f"{bad.sum()} of {bad.size} pixels differ by more than {rtol} std "
        f"(max {np.abs(a - b).max() / noise_sd(texton):.3g} std)"
    )


def run_cli(argv):
    """``warp-texton`` with ``argv`` -> exit status, whether it returns or exits through argparse."""
    from warp_texton.cli.parser import main

    try:
        return main([str(a) for a in argv])
    except SystemExit as exc:
        return exc.code


def cli_script() -> str | None:
    """The installed ``warp-texton`` command of the interpreter running the tests, or None.

    It is looked up beside ``sys.executable`` first (a virtual environment's ``bin/``, which
    is on PATH only when the environment is activated), then on PATH.
    """
    here = Path(sys.executable).parent
    return shutil.which("warp-texton", path=str(here)) or shutil.which("warp-texton")


def ctrl_c_default() -> None:
    """``preexec_fn`` of a child a test presses Ctrl-C on: SIGINT back to its default. A suite started
    in the background (``pytest &``) ignores SIGINT, and an ignored signal stays ignored across exec,
    so the child (Python, which installs its KeyboardInterrupt handler only where SIGINT is not
    ignored) would never see it."""
    import signal

    signal.signal(signal.SIGINT, signal.SIG_DFL)


def parts(folder) -> list[str]:
    """Temporary files an atomic write may leave behind, anywhere below ``folder``."""
    return sorted(p.name for p in Path(folder).rglob("*") if ".part" in p.name)


def assert_nothing_written(path):
    path = Path(path)
    assert not path.exists()
    assert parts(path.parent) == []


def raw_exr(path, channels, **attributes):
    """Write an EXR directly with OpenEXR (bypassing the package's writer)."""
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage, **attributes}
    OpenEXR.File(header, channels).write(str(path))


def cuda_devices() -> list[str]:
    """The CUDA devices Warp sees (initialised quietly, as the package does)."""
    from warp_texton.core.runtime import init_warp

    return [str(d) for d in init_warp().get_devices() if str(d).startswith("cuda")]
