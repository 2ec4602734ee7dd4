"""Bombs of issue 22 on the work paths: batches, surface noise and bakes, mix, Zarr planning
and mesh outputs. Each runs in a child process (tests/bombs.py) with a 2 GiB address space
and a 60 s time-out and must end in one clean refusal, leaving nothing behind, within 10 CPU
seconds: the work done, which a loaded machine does not stretch as it does the wall clock."""

from __future__ import annotations

import pytest

from bombs import ADDRESS_SPACE, api_bomb, assert_refused, run_bomb

pytestmark = pytest.mark.slow

TEXTON = "t = wt.Texton(np.full((8, 8, 1), 0.1), [0.5])"


def _refused(code: str, match: str = ""):
    out = run_bomb(code)
    assert_refused(out, match, within=10.0)
    assert out.peak_bytes is not None and out.peak_bytes < ADDRESS_SPACE // 2
    return out


@pytest.mark.parametrize("count, shape, mni", [(200, (256, 256), 2000), (2000, (64, 64), 2000)])
def test_batch_priced_whole(count, shape, mni):
    setup = TEXTON + "\nfrom warp_texton.core.limits import set_work_budget\nset_work_budget(1e10)"
    _refused(api_bomb(f"wt.synthesize_batch(t, {count}, {shape}, mni={mni}, device='cpu')", setup),
             rf"a batch of {count} .* over the work budget")


@pytest.mark.parametrize("count", [1_000_000, 10**8])
def test_batch_of_tiny_items(count):
    _refused(api_bomb(f"wt.synthesize_batch(t, {count}, (1, 1), device='cpu')", TEXTON),
             rf"a batch of {count} 1x1 rasters .* over the (work|memory) budget")


@pytest.mark.parametrize("count, mni", [(200_000, 50_000), (2_000_000, 6000)])
def test_surface_noise_priced(count, mni):
    setup = TEXTON + f"\nrng = np.random.default_rng(0)\npts = rng.uniform(-10, 10, ({count}, 3))"
    _refused(api_bomb(f"wt.surface_noise(t, pts, pts + 1, 0.1, mni={mni}, device='cpu')", setup),
             rf"surface noise at {count} points at MNI {mni} .* over the work budget")


_SURFACE = (
    "import sys, trimesh, numpy as np, warp_texton as wt\n"
    "from warp_texton.cli.parser import main\n"
    "trimesh.creation.icosphere(subdivisions=3).export(sys.argv[1] + '/sphere.ply')\n"
    "wt.Texton(np.full((8, 8, 3), 0.1), [0.5, 0.5, 0.5]).save(sys.argv[1] + '/t.exr')\n"
    "sys.exit(main(['surface', sys.argv[1] + '/sphere.ply', '--texton', sys.argv[1] + '/t.exr', '--out-dir',"
    " sys.argv[1] + '/out', *sys.argv[2:], '--quiet']))\n"
)


def _surface_refused(tmp_path, *args: str) -> str:
    """The surface command on a sphere with ``args``: the mesh fails in seconds with one
    error line, nothing is written; returns its stderr."""
    out = run_bomb(_SURFACE, str(tmp_path), *args)
    assert out.returncode == 1 and out.cpu_seconds < 10, (out.returncode, out.stderr[-500:])
    assert "Traceback" not in out.stderr and out.peak_bytes < ADDRESS_SPACE // 2
    assert [line for line in out.error_lines if "error:" in line] == out.error_lines[:1]
    assert not (tmp_path / "out").exists() or not any((tmp_path / "out").iterdir())
    return out.stderr


@pytest.mark.parametrize("res, supersample", [(512, 64), (1024, 32), (2048, 16)])
def test_bake_priced(tmp_path, res, supersample):
    """The CLI's bake is refused before the atlas and sampling."""
    err = _surface_refused(tmp_path, "--bake", str(res), "--supersample", str(supersample))
    assert "over the work budget" in err and "a smaller --supersample or a lower --mni" in err


@pytest.mark.parametrize("render, mni", [("8192x8192", "5000"), ("2048x2048", "200000")])
def test_render_priced(tmp_path, render, mni):
    """A render no path could afford is refused before the ray cast (the code before this
    pricing ran over 10 min and 3.6 GB on the first)."""
    err = _surface_refused(tmp_path, "--render", render, "--mni", mni)
    assert f"a {render} render at MNI {mni} needs about" in err and "use a smaller --render or a lower --mni" in err


_MIX = (
    "import sys, numpy as np, warp_texton as wt\n"
    "from warp_texton.cli.parser import main\n"
    "wt.write_image(sys.argv[1] + '/a.png', np.full((64, 64, 3), 0.5, np.float32))\n"
    "sys.exit(main(['mix', sys.argv[1] + '/a.png', sys.argv[1] + '/a.png', '-o', sys.argv[1] + '/m.png', *sys.argv[2:]]))\n"
)


@pytest.mark.parametrize("args, match", [
    (["--steps", "400000000", "--size", "8"], r"mixing 400000000 textons of 8x8 needs about"),
    (["--steps", "100000000", "--size", "2"], r"mixing 100000000 textons of 2x2 needs about"),
    (["--steps", "21", "--width", "1073741824", "--height", "1073741824"], r"too large"),
])
def test_mix_priced_before_analysis(tmp_path, args, match):
    out = run_bomb(_MIX, str(tmp_path), *args)
    assert_refused(out, match, within=10.0)
    assert out.peak_bytes < ADDRESS_SPACE // 2 and not (tmp_path / "m.png").exists()


_SYNTH = (
    "import sys, numpy as np, warp_texton as wt\n"
    "from warp_texton.cli.parser import main\n"
    "wt.Texton(np.full((8, 8, 1), 0.1), [0.5]).save(sys.argv[1] + '/t.exr')\n"
    "sys.exit(main(['synthesize', sys.argv[1] + '/t.exr', '-o', sys.argv[1] + '/z.zarr', *sys.argv[2:]]))\n"
)


@pytest.mark.parametrize("args, match", [
    (["--width", "1073741824", "--height", "1073741824"], r"blocks of 4096x4096 .* use larger --chunk"),
    (["--width", "65536", "--height", "65536", "--chunk", "16"], r"blocks of 16x16 .* use larger --chunk"),
    (["--width", "1048576", "--height", "1048576", "--chunk", "65536"], r"over the (work|memory) budget"),
])
def test_zarr_planning_priced(tmp_path, args, match):
    pytest.importorskip("zarr")
    out = run_bomb(_SYNTH, str(tmp_path), *args)
    assert_refused(out, match, within=10.0)
    assert out.peak_bytes < ADDRESS_SPACE // 2
    assert sorted(p.name for p in tmp_path.iterdir()) == ["t.exr"]


def test_overwrite_keeps_a_foreign_folder(tmp_path):
    pytest.importorskip("zarr")
    (tmp_path / "z.zarr").mkdir()
    (tmp_path / "z.zarr" / "notes.txt").write_text("keep me")
    out = run_bomb(_SYNTH, str(tmp_path), "--width", "8", "--height", "8", "--overwrite")
    assert_refused(out, r"not a Zarr store written by warp-texton", within=10.0)
    assert (tmp_path / "z.zarr" / "notes.txt").read_text() == "keep me"


@pytest.mark.parametrize("extra", [["--bake", "64", "--format", "obj", "--render", "32x32"],
                                   ["--bake", "64", "--texture", "png", "--render", "32x32"]])
def test_long_mesh_names_leave_nothing(tmp_path, extra):
    """A 246-character stem: the names of its render (257 bytes with _render.png) or its texture
    (258 with _texture.png; 255 at most) are checked before any work, and no file of the set is left."""
    stem = "m" * 246
    code = (
        "import sys, trimesh, numpy as np, warp_texton as wt\n"
        "from warp_texton.cli.parser import main\n"
        f"trimesh.creation.icosphere(subdivisions=2).export(sys.argv[1] + '/{stem}.ply')\n"
        "wt.Texton(np.full((8, 8, 3), 0.1), [0.5, 0.5, 0.5]).save(sys.argv[1] + '/t.exr')\n"
        f"sys.exit(main(['surface', sys.argv[1] + '/{stem}.ply', '--texton', sys.argv[1] + '/t.exr',"
        " '--out-dir', sys.argv[1] + '/out', '--quiet', *sys.argv[2:]]))\n"
    )
    out = run_bomb(code, str(tmp_path), *extra)
    assert out.returncode == 1 and out.cpu_seconds < 15 and "Traceback" not in out.stderr, out.stderr[-500:]
    assert "bytes long" in out.stderr
    assert not list((tmp_path / "out").iterdir())
