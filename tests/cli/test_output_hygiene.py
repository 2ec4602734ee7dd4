"""What the command line writes besides its outputs (issue 33): progress bars only on a
terminal and after 2 s, the bake bar's named steps, folders with the user's umask, sizes as
width x height, the summary of ``gaussian``, options rather than Python arguments in
messages, and the aliasing warning of ``synthesize --scale``."""

from __future__ import annotations

import io
import os
import re
import stat

import numpy as np
import pytest

import warp_texton
from warp_texton import Texton, TextonError, analyze, write_image
from warp_texton.core.checks import check_shape
from warp_texton.demo import demo_texture_path
from helpers import run_cli

ESCAPES = re.compile("[\r\x1b]")


@pytest.fixture
def texton_path(tmp_path):
    path = tmp_path / "t.exr"
    Texton(np.full((8, 8, 1), 0.1, np.float32), [0.5]).save(path)
    return path


def long_raster(monkeypatch):
    """A synthesize call cut into 8 strips, so that it has a bar to draw, at once."""
    monkeypatch.setattr("warp_texton.core.progress.PROGRESS_DELAY", 0.0)
    monkeypatch.setattr(warp_texton.noise.canvas, "STRIP_WORK", 64 * 8)


class TestProgress:
    def test_no_bar_when_stderr_is_not_a_terminal(self, tmp_path, texton_path, capsys, monkeypatch):
        long_raster(monkeypatch)
        out = tmp_path / "p.exr"
        argv = ["synthesize", texton_path, "-o", out, "--width", 64, "--height", 64, "--device", "cpu"]
        assert run_cli(argv) == 0
        err = capsys.readouterr().err
        assert err == "" and not ESCAPES.search(err)
        # the same call on a terminal draws one (the test above would pass with no bar at all)
        monkeypatch.setattr("warp_texton.core.progress.terminal", lambda: True)
        assert run_cli(argv) == 0
        assert "synthesize" in capsys.readouterr().err

    def test_short_work_draws_no_bar_on_a_terminal(self, tmp_path, capsys, monkeypatch):
        """The documented 2 s: an analysis of well under a second prints nothing."""
        monkeypatch.setattr("warp_texton.core.progress.terminal", lambda: True)
        assert run_cli(["analyze", demo_texture_path(), "-o", tmp_path / "t.exr", "--size", 16,
                        "--iterations", 3]) == 0
        # (the example's own warnings may reach stderr, depending on the warning filters in force)
        assert "analyze:" not in capsys.readouterr().err
        monkeypatch.setattr("warp_texton.core.progress.PROGRESS_DELAY", 0.0)
        assert run_cli(["analyze", demo_texture_path(), "-o", tmp_path / "t.exr", "--size", 16,
                        "--iterations", 3]) == 0
        assert "analyze:" in capsys.readouterr().err  # the bar: "analyze:   0%|"

    def test_bake_bar_names_its_steps_with_a_fixed_total(self, monkeypatch):
        pytest.importorskip("xatlas")
        import trimesh
        from tqdm import tqdm

        from warp_texton import bake_mesh

        stream = io.StringIO()
        monkeypatch.setattr("warp_texton.core.progress.PROGRESS_DELAY", 0.0)
        original = tqdm.__init__

        def to_stream(self, *a, **k):
            k.update(file=stream, mininterval=0, miniters=0)
            original(self, *a, **k)

        monkeypatch.setattr(tqdm, "__init__", to_stream)
        bake_mesh(trimesh.creation.icosphere(subdivisions=2), Texton(np.full((4, 4, 1), 0.1, np.float32), [0.5]),
                  0.05, resolution=64, supersample=2, device="cpu", progress=True)
        text = stream.getvalue()
        counts = re.findall(r"\| (\d+)/(\d+) \[", text)
        assert counts and {total for _, total in counts} == {"3"}, text
        assert [int(n) for n, _ in counts] == sorted(int(n) for n, _ in counts)
        for step in ("charts", "packing", "sampling"):
            assert f"bake: {step}" in text, text


def test_shader_folder_has_the_users_umask(tmp_path):
    texton = Texton(np.full((4, 4, 1), 0.1, np.float32), [0.5])
    old = os.umask(0o022)
    try:
        warp_texton.export_shader(texton, "glsl", tmp_path / "a", mni=10, seed=1)
        os.umask(0o027)
        warp_texton.export_shader(texton, "glsl", tmp_path / "b", mni=10, seed=1)
    finally:
        os.umask(old)
    assert stat.S_IMODE((tmp_path / "a").stat().st_mode) == 0o755
    assert stat.S_IMODE((tmp_path / "b").stat().st_mode) == 0o750


def test_sizes_are_width_by_height():
    with pytest.raises(TextonError, match=r"\(40x20\) is too small for size 30"):
        analyze(np.random.default_rng(0).random((20, 40)), size=30)
    with pytest.raises(TextonError, match=r"shape \(3000, 5000\), a 5000x3000 raster, is too large"):
        check_shape((3000, 5000), "shape", max_pixels=1000)
    assert repr(Texton(np.ones((2, 3, 1), np.float32), [0.5])).startswith("Texton(3x2,")


class TestGaussian:
    def test_summary_and_quiet(self, tmp_path, capsys):
        out = tmp_path / "g.exr"
        assert run_cli(["gaussian", demo_texture_path(), "-o", out, "--width", 40, "--height", 30]) == 0
        text = capsys.readouterr().out
        assert re.fullmatch(rf"{re.escape(str(out))}: 40x30 Gaussian texture of a 256x256 example "
                            r"\(\d+\.\d\d s(, \d+\.\d\d s wall)?\)\n", text), text
        assert run_cli(["gaussian", demo_texture_path(), "-o", out, "--width", 40, "--height", 30, "-q"]) == 0
        assert capsys.readouterr().out == ""


def test_errors_name_options_not_python_arguments(tmp_path, texton_path, capsys):
    texton = Texton(np.full((4, 4, 1), 0.1, np.float32), [0.5])
    warp_texton.export_shader(texton, "glsl", tmp_path / "ex", mni=10, seed=1)
    assert run_cli(["shader", texton_path, "--lang", "glsl", "-o", tmp_path / "ex"]) == 2
    err = capsys.readouterr().err
    assert "--overwrite" in err and "=True" not in err and "overwrite=" not in err
    with pytest.raises(TextonError, match="replace it with overwrite"):
        warp_texton.export_shader(texton, "glsl", tmp_path / "ex", mni=10, seed=1)


class TestAliasing:
    def argv(self, tmp_path, texton_path, *extra):
        return ["synthesize", texton_path, "-o", tmp_path / "o.exr", "--width", 16, "--height", 16,
                "--device", "cpu", "-q", *extra]

    def test_zoomed_out_without_a_filter_warns(self, tmp_path, texton_path):
        with pytest.warns(UserWarning, match=r"--scale 0.1 puts 10 texels in a pixel .* --filter anisotropic"):
            assert run_cli(self.argv(tmp_path, texton_path, "--scale", 0.1)) == 0

    @pytest.mark.parametrize("extra", [["--scale", "0.5"], ["--scale", "0.1", "--filter", "none"],
                                       ["--scale", "0.1", "--filter", "mip"]])
    def test_no_warning_when_chosen_or_close(self, tmp_path, texton_path, extra, recwarn):
        assert run_cli(self.argv(tmp_path, texton_path, *extra)) == 0
        assert not [w for w in recwarn if "aliases" in str(w.message)]

    def test_outputs_unchanged(self, tmp_path, texton_path):
        """The default is still no filter: the same pixels as --filter none and the API's default."""
        texton = warp_texton.load_texton(texton_path)
        with pytest.warns(UserWarning, match="aliases"):
            assert run_cli(self.argv(tmp_path, texton_path, "--scale", 0.1)) == 0
        expected = warp_texton.synthesize(texton, shape=(16, 16), scale=0.1, device="cpu")
        np.testing.assert_array_equal(warp_texton.read_image(tmp_path / "o.exr"), expected)


def test_cli_warns_of_a_texton_as_large_as_the_image(tmp_path):
    """docs/limits.md: at most half the image; the command line says so in its words."""
    import subprocess
    import sys

    src = tmp_path / "small.png"
    write_image(src, warp_texton.read_image(demo_texture_path())[:40, :40])
    script = "import sys; from warp_texton.cli.parser import main; sys.exit(main())"
    done = subprocess.run([sys.executable, "-c", script, "analyze", str(src), "-o", str(tmp_path / "t.exr"),
                           "--size", "40", "--iterations", "2", "-q"], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert done.stderr.startswith("warp-texton: warning: --size 40 is more than half the 40x40 example"), done.stderr
    assert "use --size <= 20" in done.stderr
