"""The ``warp-texton`` command line, run in-process (and once as the installed script)."""

from __future__ import annotations

import re
import subprocess
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from warp_texton import load_texton, read_image
from helpers import cli_script, parts, run_cli

# User errors print one line. Errors found by warp-texton say "warp-texton: error:";
# argparse usage errors of a subcommand name it ("warp-texton analyze: error:").
ERROR_LINE = re.compile(r"^warp-texton(?: (?:analyze|gaussian|demo))?: error: \S")


@pytest.fixture
def texture(tmp_path):
    """A 32 x 32 grey PNG with some texture."""
    rng = np.random.default_rng(5)
    u = rng.random((32, 32))
    u = 0.5 * u + 0.25 * np.roll(u, 1, axis=0) + 0.25 * np.roll(u, 1, axis=1)
    path = tmp_path / "in.png"
    Image.fromarray(np.round(u * 255).astype(np.uint8)).save(path)
    return path


@pytest.fixture
def colour_texture(tmp_path):
    rng = np.random.default_rng(6)
    path = tmp_path / "rgb.png"
    Image.fromarray(rng.integers(0, 256, (32, 32, 3), dtype=np.uint8)).save(path)
    return path


def assert_user_error(capsys, argv, match, *outputs):
    """Exit 2, one 'error:' line on stderr, no traceback, nothing written."""
    status = run_cli(argv)
    captured = capsys.readouterr()
    assert status == 2
    lines = captured.err.splitlines()
    assert len(lines) == 1, captured.err
    assert ERROR_LINE.match(lines[0]), lines[0]
    assert re.search(match, lines[0]), lines[0]
    assert "Traceback" not in captured.err + captured.out
    for out in outputs:
        out = Path(out)
        assert not out.exists()
        if out.parent.is_dir():
            assert parts(out.parent) == []
    return lines[0]


# ------------------------------------------------------------------ analyze
class TestAnalyze:
    @pytest.mark.parametrize("ext, order", [(".exr", 3), (".texton", 0), (".texton", 1)])
    def test_writes_texton_of_requested_size_and_order(self, tmp_path, texture, capsys, ext, order):
        out = tmp_path / f"t{ext}"
        status = run_cli(["analyze", texture, "-o", out, "--size", 8, "--order", order, "--iterations", 3, "-q"])
        captured = capsys.readouterr()
        assert status == 0, captured.err
        assert captured.out == ""  # -q: no summary
        t = load_texton(out)
        assert t.size == (8, 8)
        assert t.order == order
        assert t.channels == 1
        assert np.abs(t.coeffs).max() > 0
        np.testing.assert_allclose(t.mean, read_image(texture).mean(), rtol=1e-5)
        assert t.metadata["source"] == "in.png"
        assert parts(tmp_path) == []

    def test_texton_file_names_the_source(self, tmp_path, texture, capsys):
        out = tmp_path / "t.texton"
        assert run_cli(["analyze", texture, "-o", out, "--size", 8, "--iterations", 3, "-q"]) == 0
        assert out.read_text().splitlines()[-1] == "Original image: in.png (32 x 32)"

    def test_colour_texton(self, tmp_path, colour_texture, capsys):
        out = tmp_path / "c.exr"
        assert run_cli(["analyze", colour_texture, "-o", out, "--size", 6, "--iterations", 3, "-q"]) == 0
        t = load_texton(out)
        assert t.size == (6, 6) and t.channels == 3 and t.order == 1

    def test_same_seed_same_texton(self, tmp_path, texture, capsys):
        args = ["--size", 8, "--iterations", 3, "--seed", 11, "-q"]
        assert run_cli(["analyze", texture, "-o", tmp_path / "a.exr", *args]) == 0
        assert run_cli(["analyze", texture, "-o", tmp_path / "b.exr", *args]) == 0
        np.testing.assert_array_equal(load_texton(tmp_path / "a.exr").coeffs,
                                      load_texton(tmp_path / "b.exr").coeffs)

    def test_options_reach_the_analysis(self, tmp_path, texture, capsys):
        out = tmp_path / "d.exr"
        assert run_cli(["analyze", texture, "-o", out, "--size", 9, "--iterations", 2, "--seed", 4,
                    "--support", "disk", "--no-periodic", "--no-color-correction", "-q"]) == 0
        t = load_texton(out)
        meta = t.metadata
        assert (meta["size"], meta["iterations"], meta["seed"]) == (9, 2, 4)
        assert meta["support"] == "disk"
        assert meta["periodic"] is False and meta["color_correction"] is False
        assert t.coeffs[0, 0, 0] == 0.0  # corners lie outside the disk

    def test_summary_without_quiet(self, tmp_path, texture, capsys):
        out = tmp_path / "t.exr"
        assert run_cli(["analyze", texture, "-o", out, "--size", 8, "--iterations", 3]) == 0
        summary = capsys.readouterr().out
        assert f"{out}: 8x8 texton, order 1, model error" in summary


# ------------------------------------------------------------------ gaussian
class TestGaussian:
    @pytest.mark.parametrize("ext", [".png", ".exr", ".jpg"])
    def test_writes_requested_size(self, tmp_path, texture, capsys, ext):
        out = tmp_path / f"g{ext}"
        assert run_cli(["gaussian", texture, "-o", out, "--width", 40, "--height", 24, "--seed", 3]) == 0
        img = read_image(out)
        assert img.shape == (24, 40, 1)
        assert img.std() > 0.01  # a texture, not a constant
        assert parts(tmp_path) == []

    def test_default_size_is_the_input(self, tmp_path, colour_texture, capsys):
        out = tmp_path / "g.exr"
        assert run_cli(["gaussian", colour_texture, "-o", out]) == 0
        assert read_image(out).shape == (32, 32, 3)

    def test_one_dimension_given(self, tmp_path, texture, capsys):
        out = tmp_path / "g.exr"
        assert run_cli(["gaussian", texture, "-o", out, "--width", 50]) == 0
        assert read_image(out).shape == (32, 50, 1)

    def test_seed_changes_the_sample(self, tmp_path, texture, capsys):
        for seed in (1, 2):
            assert run_cli(["gaussian", texture, "-o", tmp_path / f"s{seed}.exr", "--seed", seed]) == 0
        a, b = read_image(tmp_path / "s1.exr"), read_image(tmp_path / "s2.exr")
        assert not np.array_equal(a, b)


# ------------------------------------------------------------------ help
class TestHelp:
    def test_version(self, capsys):
        """One version: the package's, the installed metadata's (read from it) and the CLI's."""
        from importlib.metadata import version

        import warp_texton

        assert run_cli(["--version"]) == 0
        assert capsys.readouterr().out.strip() == f"warp-texton {warp_texton.__version__}"
        assert version("warp-texton") == warp_texton.__version__

    @pytest.mark.parametrize(
        "command, options",
        [
            ([], ["analyze", "gaussian", "demo"]),
            (["analyze"], ["--output", "--size", "--order", "--iterations", "--seed", "--support",
                           "--no-periodic", "examples:"]),
            (["gaussian"], ["--output", "--width", "--height", "--seed", "examples:"]),
            (["demo"], ["--out-dir", "--seed", "--quiet"]),
        ],
    )
    def test_help(self, capsys, command, options):
        assert run_cli([*command, "--help"]) == 0
        out = capsys.readouterr().out
        assert out.startswith("usage: warp-texton")
        for option in options:
            assert option in out

    def test_no_command_prints_help_and_fails(self, capsys):
        assert run_cli([]) == 2
        assert "usage: warp-texton" in capsys.readouterr().out

    @pytest.mark.slow
    def test_installed_console_script(self, tmp_path):
        script = cli_script()
        if script is None:
            pytest.skip("the warp-texton console script is not installed")
        done = subprocess.run([script, "--help"], capture_output=True, text=True, timeout=60)
        assert done.returncode == 0, done.stderr
        assert "analyze" in done.stdout and "gaussian" in done.stdout
        # the script's exit status is main()'s return value
        done = subprocess.run([script, "analyze", str(tmp_path / "none.png"), "-o", str(tmp_path / "t.exr")],
                              capture_output=True, text=True, timeout=60)
        assert done.returncode == 2
        assert done.stderr.splitlines() == [f"warp-texton: error: {tmp_path / 'none.png'}: no such file"]


# ------------------------------------------------------------------ user errors
class TestUserErrors:
    def test_missing_input(self, tmp_path, capsys):
        out = tmp_path / "t.exr"
        assert_user_error(capsys, ["analyze", tmp_path / "none.png", "-o", out], "none.png: no such file", out)
        out = tmp_path / "g.png"
        assert_user_error(capsys, ["gaussian", tmp_path / "none.png", "-o", out], "no such file", out)

    def test_not_an_image(self, tmp_path, capsys):
        bad = tmp_path / "notes.png"
        bad.write_text("hello\n")
        out = tmp_path / "t.exr"
        assert_user_error(capsys, ["analyze", bad, "-o", out], "not an image that can be read", out)
        out = tmp_path / "g.exr"
        assert_user_error(capsys, ["gaussian", bad, "-o", out], "not an image that can be read", out)

    @pytest.mark.parametrize("order", ["2", "7", "x"])
    def test_bad_order(self, tmp_path, texture, capsys, order):
        out = tmp_path / "t.exr"
        assert_user_error(capsys, ["analyze", texture, "-o", out, "--order", order],
                          "argument --order: invalid", out)

    def test_size_too_large(self, tmp_path, texture, capsys):
        out = tmp_path / "t.exr"
        assert_user_error(capsys, ["analyze", texture, "-o", out, "--size", 33, "--iterations", 3, "-q"],
                          r"in.png: the image \(32x32\) is too small for --size 33.*choose --size <= 32", out)

    @pytest.mark.parametrize("flag, value, match", [("--size", 1, "error: --size must be at least 2"),
                                                    ("--iterations", 0, "error: --iterations must be at least 1"),
                                                    ("--seed", -1, "error: --seed must be an integer in")])
    def test_bad_numbers(self, tmp_path, texture, capsys, flag, value, match):
        out = tmp_path / "t.exr"
        assert_user_error(capsys, ["analyze", texture, "-o", out, flag, value, "-q"], match, out)

    def test_unsupported_output_extension(self, tmp_path, texture, capsys):
        out = tmp_path / "t.png"
        assert_user_error(capsys, ["analyze", texture, "-o", out, "--size", 8, "-q"],
                          r"unsupported texton extension '\.png'", out)
        out = tmp_path / "g.bmp"
        assert_user_error(capsys, ["gaussian", texture, "-o", out], r"unsupported extension '\.bmp'", out)

    def test_output_folder_missing(self, tmp_path, texture, capsys):
        out = tmp_path / "missing" / "t.exr"
        assert_user_error(capsys, ["analyze", texture, "-o", out, "--size", 8, "--iterations", 3, "-q"],
                          "does not exist", out)
        out = tmp_path / "missing" / "g.png"
        assert_user_error(capsys, ["gaussian", texture, "-o", out], "does not exist", out)
        assert not (tmp_path / "missing").exists()

    def test_constant_image(self, tmp_path, capsys):
        flat = tmp_path / "flat.png"
        Image.new("L", (32, 32), 128).save(flat)
        out = tmp_path / "t.texton"
        assert_user_error(capsys, ["analyze", flat, "-o", out, "--size", 8, "--iterations", 3, "-q"],
                          "constant", out)
        out = tmp_path / "g.png"
        assert_user_error(capsys, ["gaussian", flat, "-o", out], "constant", out)

    def test_bad_gaussian_size(self, tmp_path, texture, capsys):
        out = tmp_path / "g.png"
        assert_user_error(capsys, ["gaussian", texture, "-o", out, "--width", -5], r"error: --width must be at least 1, got -5",
                          out)

    def test_failed_run_keeps_existing_output(self, tmp_path, texture, capsys):
        out = tmp_path / "t.exr"
        assert run_cli(["analyze", texture, "-o", out, "--size", 8, "--iterations", 3, "-q"]) == 0
        before = out.read_bytes()
        flat = tmp_path / "flat.png"
        Image.new("L", (32, 32), 7).save(flat)
        assert run_cli(["analyze", flat, "-o", out, "--size", 8, "--iterations", 3, "-q"]) == 2
        assert out.read_bytes() == before
        assert parts(tmp_path) == []

    @pytest.mark.parametrize("argv, match", [
        (["analyze", "in.png"], "the following arguments are required: -o/--output"),
        (["nope"], "invalid choice: 'nope'"),
        (["gaussian", "in.png", "-o", "g.png", "--width", "wide"], "argument --width: invalid int value"),
    ])
    def test_usage_errors(self, tmp_path, capsys, argv, match):
        assert_user_error(capsys, argv, match)


# ------------------------------------------------------------------ demo
@pytest.mark.slow
def test_demo_writes_everything(tmp_path, capsys):
    out = tmp_path / "demo"
    assert run_cli(["demo", "-o", out, "-q"]) == 0
    # -q: the written paths are not listed (Warp may print its own start-up banner)
    assert str(out) not in capsys.readouterr().out
    names = {p.name for p in out.iterdir()}
    expected = {f"{n}{e}" for n in ("input", "gaussian", "texton_preview") for e in (".png", ".exr")}
    expected |= {"texton.exr", "texton.texton"}
    assert expected <= names
    assert not any(n.endswith(".part") for n in names)
    u = read_image(out / "input.exr")
    np.testing.assert_array_equal(read_image(out / "gaussian.png").shape, u.shape)
    np.testing.assert_allclose(read_image(out / "input.png"), u, atol=0.5 / 255 + 1e-6)
    t_exr, t_txt = load_texton(out / "texton.exr"), load_texton(out / "texton.texton")
    assert t_exr.size == (64, 64) and t_exr.order == 1
    np.testing.assert_array_equal(t_exr.coeffs, t_txt.coeffs)
    np.testing.assert_array_equal(t_exr.mean, t_txt.mean)
    assert read_image(out / "texton_preview.exr").shape == (64, 64, u.shape[2])
    if "noise.exr" in names:  # written when the synthesis kernels are part of the build
        assert read_image(out / "noise.exr").shape == (512, 512, u.shape[2])
        plane = read_image(out / "plane.exr")
        assert plane.shape == (512, 512, u.shape[2])
        # filtered towards the horizon: the far rows vary far less than the near ones
        assert plane[:64].var() < 0.2 * plane[-64:].var()


@pytest.mark.slow
def test_demo_lists_what_it_writes(tmp_path, capsys):
    out = tmp_path / "demo"
    assert run_cli(["demo", "-o", out]) == 0
    listed = {Path(line).name for line in capsys.readouterr().out.splitlines() if line.startswith(str(out))}
    assert listed == {p.name for p in out.iterdir()}


# ------------------------------------------------------------------ the library's words
class TestCommandLineWords:
    """Errors name the options and files that set the arguments they carry (param, mentions)."""

    NAMES = {"mni": "--mni", "size": "--size", "u": "wood.png", "offset[0]": "--offset X", "offset": "--offset"}

    @pytest.mark.parametrize("message, param, mentions, expected", [
        ("mni must be at least 0.001, got 0", "mni", (), "--mni must be at least 0.001, got 0"),
        ("u: the image (8x8) is too small for size 9 (choose size <= 8)", "u", ("size",),
         "wood.png: the image (8x8) is too small for --size 9 (choose --size <= 8)"),
        ("offset[0] must be a finite number, got nan", "offset[0]", (), "--offset X must be a finite number, got nan"),
        # only the names the error carries, and only where they stand alone
        ("size must be at least 2; the mni is fine", "size", (), "--size must be at least 2; the mni is fine"),
        ("needs 1e12 operations at MNI 30; use a lower mni.", None, ("mni",),
         "needs 1e12 operations at MNI 30; use a lower --mni."),
        ("omni mni_x --mni 'mni' mni[0]: use a lower mni", None, ("mni",),
         "omni mni_x --mni 'mni' mni[0]: use a lower --mni"),
        ("mnis must be given", "mni", (), "mnis must be given"),
        ("cell_factor 1e-300 is too small", "cell_factor", (), "cell_factor 1e-300 is too small"),
    ])
    def test_in_words(self, message, param, mentions, expected):
        from warp_texton import TextonError

        assert TextonError(message, param, mentions=mentions).in_words(self.NAMES) == expected

    def test_every_command_names_only_its_own_options(self, capsys):
        """A command's names map library arguments to options the command has."""
        from warp_texton.cli.parser import COMMANDS

        for name, command in COMMANDS.items():
            assert run_cli([name, "--help"]) == 0
            words = set(capsys.readouterr().out.replace(",", " ").replace("[", " ").split())
            for option in command.names.values():
                assert all(part.split()[0] in words for part in option.split("/")), (name, option)

    def test_filters_come_from_the_registry(self, capsys):
        from warp_texton.noise.filter_options import FILTERS

        assert run_cli(["synthesize", "--help"]) == 0
        text = " ".join(capsys.readouterr().out.split())
        for kind in FILTERS.values():
            assert f"{kind.name}: {kind.description}" in text
        assert run_cli(["view", "--help"]) == 0
        text = " ".join(capsys.readouterr().out.split())
        assert "{none,mip,anisotropic}" in text and "supersample:" not in text
