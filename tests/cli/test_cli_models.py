"""The subcommands that take a model file, with a tiling model: ``info`` describes either kind; those
that cannot take a tiling model say so in one line (exit 2)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from warp_texton import analyze
from warp_texton.cli import main


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("models")
    rng = np.random.default_rng(3)
    u = rng.gamma(2.0, 0.15, (64, 80, 3)).astype(np.float32)
    analyze(u, method="tiling", side=12, histogram="preserve").save(d / "tiling.exr")
    analyze(u[..., 0], size=16, seed=0).save(d / "texton.exr")
    return d


def test_info_describes_a_tiling_model(files, capsys):
    assert main(["info", str(files / "tiling.exr")]) == 0
    out = capsys.readouterr().out
    assert "tiling model (method 'tiling') of a 80x64 RGB example, histogram preserved" in out
    assert "side 12 texels, sharpness 16, variance blend" in out
    assert main(["info", str(files / "tiling.exr"), "--json"]) == 0
    s = json.loads(capsys.readouterr().out)
    assert (s["kind"], s["example"], s["side"], s["blend"], s["histogram"]) == ("tiling", [80, 64], 12.0,
                                                                                 "variance", "preserve")


def test_info_describes_a_texton(files, capsys):
    assert main(["info", str(files / "texton.exr"), "--json"]) == 0
    s = json.loads(capsys.readouterr().out)
    assert (s["kind"], s["size"], s["order"], s["channels"]) == ("texton", [16, 16], 1, 1)
    assert main(["info", str(files / "texton.exr")]) == 0
    assert "texton (method 'texton') of 16x16, order 1, grey" in capsys.readouterr().out


def test_info_names_the_histogram_judges_choice(tmp_path, capsys):
    """A histogram-preserving texton says which family the judges kept (docs/histogram.md)."""
    rng = np.random.default_rng(5)
    u = rng.gamma(2.0, 0.15, (64, 64, 3)).astype(np.float32)
    t = analyze(u, size=16, seed=0, histogram="preserve")
    t.save(tmp_path / "c.exr")
    assert main(["info", str(tmp_path / "c.exr")]) == 0
    out = capsys.readouterr().out
    kept = "zero-sum (no power at frequency 0)" if t.metadata["zero_sum"] else "plain"
    assert f"histogram judge: kept the {kept} texton" in out
    if "histogram_marginal_errors" in t.metadata:
        assert f"{t.metadata['histogram_marginal_errors'][0]:.4g} (plain)" in out
    else:
        assert "zero-sum: its spectrum past its bound" in out


@pytest.mark.parametrize("argv, words", [
    (["mix", "{m}", "{m}", "-o", "{d}/x.png"], "cannot be mixed"),
    (["gaussian", "{m}", "-o", "{d}/g.png"], "is a tiling model file, not an image"),
    (["analyze", "{m}", "-o", "{d}/a.exr"], "is a tiling model file, not an image"),
    (["info", "{d}/none.exr"], "no such file"),
])
def test_what_cannot_take_a_tiling_model_says_so_in_one_line(files, capsys, argv, words):
    argv = [a.format(m=files / "tiling.exr", d=files) for a in argv]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and words in err and err.startswith("warp-texton: error:")


def test_render_plane_takes_a_tiling_model_file(files, tmp_path, capsys):
    # the CLI's view of the plane is render_plane of the loaded model (supersample: a histogram model's filter)
    from warp_texton import load_texton, read_image, render_plane

    out = tmp_path / "plane.exr"
    assert main(["render-plane", str(files / "tiling.exr"), "-o", str(out), "--width", "24", "--height", "16",
                 "--seed", "5", "--filter", "supersample"]) == 0
    assert "24x16 plane, filter supersample, tiling model" in capsys.readouterr().out
    want = render_plane(load_texton(files / "tiling.exr"), (16, 24), seed=5, filter="supersample", device="cpu")
    np.testing.assert_array_equal(read_image(out), want)
