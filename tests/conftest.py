"""Shared fixtures: the device under test, real example textures, and exact samples of
known Gaussian models.

``pytest --device cuda:0`` runs every test that takes the ``device`` fixture (the
statistical and exactness tests of the kernels) on that device; the default is
the CPU. The ADSN helper draws u = m + k ⊛ W on a circular grid (EUSIPCO §2.2),
so a test knows the true kernel k behind an image and can compare what the
analysis finds with the truth rather than with a single noisy periodogram.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import warnings
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, settings

# Profiles of the property suite (tests/test_properties.py). "ci", the default, is
# deterministic (derandomized, no example database) and bounded: each function gets
# 80 examples, about two minutes in all on two cores. "slow" draws at random
# and many more: python -m pytest tests/test_properties.py --hypothesis-profile slow
# (or HYPOTHESIS_PROFILE=slow).
_RELAXED = [HealthCheck.too_slow, HealthCheck.data_too_large, HealthCheck.filter_too_much,
            HealthCheck.function_scoped_fixture, HealthCheck.differing_executors]
settings.register_profile("ci", derandomize=True, database=None, max_examples=80, deadline=None,
                          suppress_health_check=_RELAXED, print_blob=True)
settings.register_profile("slow", max_examples=500, deadline=None, suppress_health_check=_RELAXED,
                          print_blob=True)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))


def pytest_addoption(parser):
    parser.addoption("--device", default="cpu",
                     help="Warp device for the device tests: cpu (default), cuda, cuda:N")


def pytest_configure(config):
    from warp_texton import TextonError
    from warp_texton.core.runtime import resolve_device

    try:
        config.device = resolve_device(config.getoption("--device"))
    except TextonError as exc:
        raise pytest.UsageError(f"--device: {exc}") from None


@pytest.fixture(scope="session")
def device(pytestconfig) -> str:
    """The Warp device the kernels' tests run on (``--device``, default "cpu")."""
    return pytestconfig.device


@pytest.fixture(scope="session")
def gpu(device) -> str:
    """The --device when it is not the CPU, for tests that compare it with the CPU."""
    if device == "cpu":
        pytest.skip("compares the --device with the CPU: run with --device cuda:0 on a GPU machine")
    return device


@pytest.fixture
def restore_warning_format(monkeypatch):
    """The CLI installs its own one-line warning format; keep it out of other tests."""
    monkeypatch.setattr(warnings, "formatwarning", warnings.formatwarning)


TEXTURE_NAMES = ("grass", "gravel", "brick")


def draw_adsn(kernel, shape, mean=0.5, seed=0) -> np.ndarray:
    """One sample of the circular ADSN m + k ⊛ W on an ``shape`` = (H, W) grid.

    ``kernel`` is (r, s) or (r, s, C), zero-padded to the grid; all channels are
    convolved with one shared standard white noise W (so the colour cross-spectra
    are k̂_c k̂_d*), and ``mean`` (scalar or per channel) is added. Returns float64
    (H, W, C); the exact spectrum of the model is |fft2(k, s=shape)|².
    """
    k = np.asarray(kernel, dtype=np.float64)
    if k.ndim == 2:
        k = k[:, :, None]
    w = np.random.default_rng(seed).standard_normal(shape)
    k_hat = np.fft.fft2(k, s=shape, axes=(0, 1))
    g = np.fft.ifft2(k_hat * np.fft.fft2(w)[:, :, None], axes=(0, 1)).real
    return g + np.broadcast_to(np.asarray(mean, dtype=np.float64), (k.shape[2],))


@pytest.fixture(scope="session")
def adsn_sampler():
    """The :func:`draw_adsn` helper, for tests that need samples of a known model."""
    return draw_adsn


def _skimage_texture(name: str) -> np.ndarray:
    data = pytest.importorskip("skimage.data")
    img = np.asarray(getattr(data, name)(), dtype=np.float32) / 255.0
    assert img.ndim == 2 and img.min() >= 0.0 and img.max() <= 1.0
    return img


@pytest.fixture(scope="session")
def grass_image() -> np.ndarray:
    """``skimage.data.grass()``: 512 × 512 grey float32 in [0, 1]."""
    return _skimage_texture("grass")


@pytest.fixture(scope="session")
def gravel_image() -> np.ndarray:
    """``skimage.data.gravel()``: 512 × 512 grey float32 in [0, 1]."""
    return _skimage_texture("gravel")


@pytest.fixture(scope="session")
def brick_image() -> np.ndarray:
    """``skimage.data.brick()``: 512 × 512 grey float32 in [0, 1]."""
    return _skimage_texture("brick")


@pytest.fixture(scope="session", params=TEXTURE_NAMES)
def real_texture(request):
    """Each real texture in turn, as ``(name, image)``."""
    return request.param, request.getfixturevalue(f"{request.param}_image")


@pytest.fixture(scope="session")
def grey_kernel() -> np.ndarray:
    """A known 8 × 8 grey ADSN kernel (white, scaled by 0.2), shape (8, 8, 1)."""
    return 0.2 * np.random.default_rng(1).standard_normal((8, 8, 1))


@pytest.fixture(scope="session")
def color_kernel() -> np.ndarray:
    """A known 8 × 8 RGB kernel whose channels are strongly correlated.

    Independent white kernels mixed by a lower-triangular matrix: the channels
    share most of their structure (as the channels of a photograph do) but the
    3 × 3 lag-0 covariance is full rank, and each channel has its own phases.
    """
    mix = np.array([[1.0, 0.0, 0.0], [0.8, 0.6, 0.0], [0.5, 0.3, 0.8]])
    return 0.2 * np.random.default_rng(2).standard_normal((8, 8, 3)) @ mix.T


#: The Khronos glTF validator (tests/node, ``npm ci``), run with node.
GLTF_VALIDATOR = Path(__file__).resolve().parent / "node"


@pytest.fixture(scope="session", autouse=True)
def every_glb_is_valid(tmp_path_factory):
    """After the session: the glTF validator on every GLB the tests wrote (the package's
    bakes, vertex-colour meshes, re-bakes, the CLI's outputs), 0 errors and 0 warnings.

    Files named ``broken*.glb`` are the validator's own negative test. Where node or
    the validator is missing this is skipped outside CI (tests/clients.py's rule:
    in CI the validator is installed and its test fails without it)."""
    yield
    base = tmp_path_factory.getbasetemp()
    glbs = sorted(p for p in base.rglob("*.glb") if not p.name.startswith("broken") and p.is_file())
    node = shutil.which("node")
    if not glbs or node is None or not (GLTF_VALIDATOR / "node_modules" / "gltf-validator").is_dir():
        return
    bad = {}
    for start in range(0, len(glbs), 50):
        chunk = glbs[start:start + 50]
        proc = subprocess.run([node, str(GLTF_VALIDATOR / "validate.js"), *map(str, chunk)], capture_output=True,
                              text=True, timeout=300)
        assert proc.returncode == 0, proc.stderr[-2000:]
        for path, report in json.loads(proc.stdout).items():
            if report["errors"] or report["warnings"]:
                bad[str(Path(path).relative_to(base))] = report["messages"][:5]
    print(f"\nglTF validator: {len(glbs)} GLB files the tests wrote, {len(bad)} with errors or warnings")
    assert not bad, f"the glTF validator finds errors or warnings in GLB files the tests wrote: {bad}"
