"""Real photographs (issue 33): the warnings of ``analyze`` about examples a texton learns
badly, ``downscale`` and ``--crop``/``--downscale``, and the command line's words for them."""

from __future__ import annotations

import re
import subprocess
import sys
import warnings

import numpy as np
import pytest

from warp_texton import ExampleWarning, TextonError, analyze, downscale, load_texton, read_image, write_image
from warp_texton.demo import demo_texture_path
from warp_texton.model.example_checks import (LargeExampleWarning, LargeTextonWarning, NonStationaryWarning,
                                        SmoothExampleWarning, low_frequency_share)
from helpers import run_cli


def example_warnings(u, **kw) -> list[type]:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        analyze(u, **{"iterations": 2, **kw})
    return [type(w.message) for w in caught if issubclass(w.category, ExampleWarning)]


def upscaled(u: np.ndarray, k: int) -> np.ndarray:
    """u enlarged k times by bilinear interpolation (a photo upscaled in an editor)."""
    m, n = u.shape[:2]
    y = (np.arange(m * k) + 0.5) / k - 0.5
    x = (np.arange(n * k) + 0.5) / k - 0.5
    y0 = np.clip(np.floor(y).astype(int), 0, m - 2)
    x0 = np.clip(np.floor(x).astype(int), 0, n - 2)
    fy = np.clip(y - y0, 0, 1)[:, None, None]
    fx = np.clip(x - x0, 0, 1)[None, :, None]
    a, b = u[y0][:, x0], u[y0][:, x0 + 1]
    c, d = u[y0 + 1][:, x0], u[y0 + 1][:, x0 + 1]
    return ((1 - fy) * ((1 - fx) * a + fx * b) + fy * ((1 - fx) * c + fx * d)).astype(np.float32)


@pytest.fixture(scope="module")
def grass():
    return read_image(demo_texture_path())  # 256², a Gaussian-like texture


def skimage_textures():
    data = pytest.importorskip("skimage.data")
    return {name: getattr(data, name)() for name in ("grass", "gravel", "brick")}


class TestWarnings:
    def test_textures_pass(self, grass):
        assert example_warnings(grass, size=64) == []
        for name, u in skimage_textures().items():
            assert example_warnings(u, size=64) == [], name

    def test_upscaled_photo_is_too_smooth(self, grass):
        up = upscaled(grass[:128, :128], 4)  # 512², features 4× larger than the example's
        assert example_warnings(up, size=64) == [SmoothExampleWarning]
        # what the warning stands on: most variance at wavelengths past half the texton
        from scipy.fft import rfft2

        from warp_texton.model.gaussian import normalized_kernel

        share = low_frequency_share(rfft2(normalized_kernel(up)[1], axes=(0, 1)), 512, 64)
        assert share > 0.55
        assert low_frequency_share(rfft2(normalized_kernel(grass)[1], axes=(0, 1)), 256, 64) < 0.2
        # shrinking it back passes
        assert example_warnings(downscale(up, 4), size=32) == []

    def test_uneven_lighting_is_not_stationary(self, grass):
        x = np.linspace(0.2, 1.0, grass.shape[1], dtype=np.float32)[None, :, None]
        assert example_warnings(grass * x, size=64) == [NonStationaryWarning]

    def test_a_scene_is_not_a_texture(self):
        data = pytest.importorskip("skimage.data")
        found = example_warnings(data.camera(), size=64)
        assert NonStationaryWarning in found and SmoothExampleWarning in found

    def test_large_example(self):
        rng = np.random.default_rng(0)
        assert example_warnings(rng.random((1025, 1024), np.float32), size=16, iterations=1) == [LargeExampleWarning]
        assert example_warnings(rng.random((1024, 1024), np.float32), size=16, iterations=1) == []

    def test_texton_past_half_the_example(self, grass):
        assert example_warnings(grass[:100, :100], size=51) == [LargeTextonWarning]
        assert example_warnings(grass[:100, :100], size=50) == []

    def test_warnings_do_not_change_the_texton(self, grass):
        with warnings.catch_warnings():
            warnings.simplefilter("error", ExampleWarning)
            a = analyze(grass, size=32, iterations=5)
        b = analyze(grass, size=32, iterations=5)
        assert np.array_equal(a.coeffs, b.coeffs)


class TestDownscale:
    def test_block_means(self):
        rng = np.random.default_rng(1)
        u = rng.random((10, 7, 3)).astype(np.float32)
        d = downscale(u, 3)
        assert d.shape == (3, 2, 3) and d.dtype == np.float32
        np.testing.assert_allclose(d[1, 1], u[3:6, 3:6].mean(axis=(0, 1)), rtol=1e-6)
        assert np.array_equal(downscale(u, 1), u)

    def test_integer_images_scaled(self):
        u = np.full((4, 4), 255, np.uint8)
        assert np.array_equal(downscale(u, 2), np.ones((2, 2, 1), np.float32))

    @pytest.mark.parametrize("factor", [0, -1, 5, 1.5, "2"])
    def test_bad_factor(self, factor):
        with pytest.raises(TextonError, match="factor"):
            downscale(np.zeros((4, 4)), factor)


class TestCommandLine:
    def test_crop_and_downscale_analyse_that_example(self, tmp_path, grass):
        src = tmp_path / "photo.exr"
        write_image(src, grass)
        out = tmp_path / "t.exr"
        assert run_cli(["analyze", src, "-o", out, "--size", 16, "--iterations", 3, "--crop", 10, 20, 200, 100,
                        "--downscale", 2, "-q"]) == 0
        expected = analyze(downscale(grass[20:120, 10:210], 2), size=16, iterations=3)
        assert np.array_equal(load_texton(out).coeffs, expected.coeffs)

    @pytest.mark.parametrize("args, match", [
        (["--crop", 0, 0, 300, 10], r"^warp-texton: error: --crop 300x10 at \(0, 0\) does not fit in the 256x256"),
        (["--crop", -1, 0, 10, 10], r"^warp-texton: error: --crop X must be"),
        (["--downscale", 0], r"^warp-texton: error: --downscale must be at least 1"),
    ])
    def test_bad_crop_or_factor(self, tmp_path, capsys, args, match):
        out = tmp_path / "t.exr"
        assert run_cli(["analyze", demo_texture_path(), "-o", out, *args]) == 2
        err = capsys.readouterr().err.splitlines()
        assert len(err) == 1 and re.search(match, err[0]), err
        assert not out.exists()

    def test_warning_in_the_command_lines_words(self, tmp_path, grass):
        """The program prints the warning on one line, with its options and the file given."""
        src = tmp_path / "zoomed.png"
        write_image(src, upscaled(grass[:128, :128], 4))
        script = "import sys; from warp_texton.cli.parser import main; sys.exit(main())"
        done = subprocess.run([sys.executable, "-c", script, "analyze", str(src), "-o", str(tmp_path / "t.exr"),
                               "--iterations", "2", "-q"], capture_output=True, text=True, timeout=300)
        assert done.returncode == 0, done.stderr
        lines = done.stderr.splitlines()
        assert len(lines) == 1, lines
        line = lines[0]
        assert line.startswith(f"warp-texton: warning: {src}: ")
        assert "--downscale" in line and "--size" in line
        assert "downscale(" not in line and " u:" not in line
