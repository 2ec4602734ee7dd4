"""Batch surface texturing: ``warp-texton surface`` and :mod:`warp_texton.surface.jobs`.

Small real meshes (trimesh icospheres and a torus) are written to a temporary folder
with one broken file beside them. The command runs in-process through
``warp_texton.cli.parser.main``; the same jobs also run on a local Dask cluster (an optional
extra, skipped when absent) and must give the same files as the thread pool.
"""

from __future__ import annotations

import os
import pickle
import re
import sys
import warnings
from concurrent.futures import Executor, Future
from pathlib import Path

import numpy as np
import pytest
import trimesh
from PIL import Image

from warp_texton import Texton, TextonError, texture_mesh
from warp_texton.surface.jobs import JobResult, SurfaceJob, expand_meshes, resolve_up, run_jobs, run_surface_job
from warp_texton.surface.mesh_files import gltf_rotation
from helpers import parts, run_cli

MEAN = (0.3, 0.5, 0.7)
SUMMARY = re.compile(r"^(\d+) done, (\d+) skipped, (\d+) failed$")
OLD = 1_000_000_000  # an mtime (2001) that no run of the tests can produce


def linear_to_srgb(v) -> np.ndarray:
    """The sRGB encoding (IEC 61966-2-1), inverse of warp_texton.surface.mesh.srgb_to_linear."""
    v = np.clip(np.asarray(v, dtype=np.float64), 0.0, None)
    return np.where(v <= 0.0031308, v * 12.92, 1.055 * v ** (1 / 2.4) - 0.055)


@pytest.fixture
def texton_path(tmp_path):
    """An 8 × 8 RGB texton of order 1; its noise has sd ≈ 0.08 around MEAN."""
    a = np.random.default_rng(3).standard_normal((8, 8, 3))
    t = Texton(a, MEAN, 1)
    t = Texton(a * 0.08 / np.sqrt(np.diag(t.covariance()))[None, None, :], MEAN, 1)
    path = tmp_path / "wood.exr"
    t.save(path)
    return path


@pytest.fixture
def mesh_dir(tmp_path):
    """ball.ply (icosphere, 2 subdivisions), ring.obj (torus) and bad.ply (broken)."""
    d = tmp_path / "in"
    d.mkdir()
    trimesh.creation.icosphere(subdivisions=2).export(d / "ball.ply")
    trimesh.creation.torus(1.0, 0.3, major_sections=24, minor_sections=12).export(d / "ring.obj")
    (d / "bad.ply").write_text("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nend_header\n1 2\n")
    return d


#: A temporary file's name in a message: ``.NAME.PID-HOST.RANDOM.part`` (io.atomic_path).
TEMP_NAME = re.compile(r"\.part\b|\.\d+-[0-9a-f]{4}\.\w{8}\b")


def assert_usage_error(status: int, captured, out: Path, match: str) -> None:
    """One ``warp-texton: error:`` line matching ``match``, exit status 2, no traceback, no output."""
    assert status == 2
    lines = captured.err.splitlines()
    assert len(lines) == 1, captured.err
    assert "Traceback" not in captured.err + captured.out
    assert re.match(r"^warp-texton(?: surface)?: error: \S", lines[0]), lines[0]
    assert re.search(match, lines[0]), lines[0]
    assert not out.exists() or list(out.iterdir()) == []


class Tee:
    """A text stream that writes to ``stream`` and keeps a copy (what the user saw)."""

    def __init__(self, stream):
        self.stream, self.seen = stream, []

    def write(self, text):
        self.seen.append(text)
        return self.stream.write(text)

    def __getattr__(self, name):
        return getattr(self.stream, name)


def surface(mesh_dir, texton_path, out, *meshes, extra=()):
    """``warp-texton surface`` on the meshes; what it prints (stdout, stderr, the warnings and
    the progress bar, from every thread) must never name a temporary file."""
    names = meshes or ("ball.ply", "ring.obj")
    tees = Tee(sys.stdout), Tee(sys.stderr)
    sys.stdout, sys.stderr = tees
    try:
        # the command's warnings (pytest records them instead of letting them reach stderr)
        with warnings.catch_warnings(record=True) as caught:
            status = run_cli(["surface", *(mesh_dir / m for m in names), "--texton", texton_path, "--out-dir", out,
                              "--device", "cpu", *extra])
    finally:
        sys.stdout, sys.stderr = tees[0].stream, tees[1].stream
    WARNINGS[:] = [str(w.message) for w in caught]
    printed = "".join(tees[0].seen + tees[1].seen) + "\n".join(WARNINGS)
    assert not TEMP_NAME.search(printed), f"a temporary file name in the output: {printed}"
    return status


#: The warnings of the last ``surface`` run.
WARNINGS: list[str] = []


def summary(err: str):
    last = err.strip().splitlines()[-1]
    m = SUMMARY.match(last)
    assert m, f"no summary line at the end of stderr: {last!r}"
    return tuple(int(v) for v in m.groups())


def load(path) -> trimesh.Trimesh:
    return trimesh.load(str(path), force="mesh", process=False)


def expected_colours(mesh_path, texton_path, seed=0, mni=60.0, linear=False, up=None):
    """What a job computes: texel = bounding-box diagonal / 256, then texture_mesh
    (linear colours for glTF's COLOR_0) with the format's up axis (``--up auto``)."""
    from warp_texton.surface.jobs import resolve_up

    from warp_texton import load_texton

    mesh = load(mesh_path)
    lo, hi = mesh.bounds
    texel = float(np.linalg.norm(hi - lo)) / 256.0
    out = texture_mesh(mesh, load_texton(texton_path), texel, mni=mni, seed=seed, device="cpu", linear=linear,
                       warn=False, up=up or resolve_up("auto", str(mesh_path)))
    return np.asarray(out.visual.vertex_colors)


# --------------------------------------------------------------------------- #
# expand_meshes                                                               #
# --------------------------------------------------------------------------- #
class TestExpandMeshes:
    def test_plain_paths_keep_order_without_duplicates(self):
        assert expand_meshes(["b.ply", "a.ply", "b.ply", "c.obj", "a.ply"]) == ["b.ply", "a.ply", "c.obj"]

    def test_globs_are_sorted_and_unmatched_patterns_kept(self, tmp_path):
        for name in ("c.ply", "a.ply", "b.obj", "sub/d.ply"):
            (tmp_path / name).parent.mkdir(exist_ok=True)
            (tmp_path / name).write_text("x")
        got = expand_meshes([str(tmp_path / "*.ply"), str(tmp_path / "none*.ply"), str(tmp_path / "a.ply")])
        assert got == [str(tmp_path / "a.ply"), str(tmp_path / "c.ply"), str(tmp_path / "none*.ply")]
        got = expand_meshes([str(tmp_path / "**" / "*.ply")])
        assert got == sorted(str(tmp_path / n) for n in ("a.ply", "c.ply", "sub/d.ply"))

    def test_list_files(self, tmp_path):
        for name in ("x.ply", "y.ply", "z.obj"):
            (tmp_path / name).write_text("x")
        inner = tmp_path / "inner.txt"
        inner.write_text(f"{tmp_path / 'z.obj'}\n")
        listing = tmp_path / "list.txt"
        listing.write_text(
            "# meshes to texture\n"
            "\n"
            f"  {tmp_path / 'y.ply'}  \n"
            f"{tmp_path / '*.ply'}\n"
            "   # an indented comment\n"
            f"@{inner}\n"
            "missing.ply\n"
        )
        got = expand_meshes([f"@{listing}", str(tmp_path / "x.ply")])
        assert got == [str(tmp_path / "y.ply"), str(tmp_path / "x.ply"), str(tmp_path / "z.obj"), "missing.ply"]

    def test_missing_list_file(self, tmp_path):
        with pytest.raises(TextonError, match=r"nolist\.txt: cannot read the mesh list"):
            expand_meshes([f"@{tmp_path / 'nolist.txt'}"])


# --------------------------------------------------------------------------- #
# Jobs                                                                        #
# --------------------------------------------------------------------------- #
class TestJobs:
    def test_outputs_are_named_after_the_stem(self):
        job = SurfaceJob("scans/bunny.ply", "wood.exr", "out")
        assert job.outputs() == [Path("out/bunny.ply")]
        job = SurfaceJob("scans/bunny.obj", "wood.exr", "out", render=(16, 24), fmt="glb")
        assert job.outputs() == [Path("out/bunny.glb"), Path("out/bunny.png")]

    def test_job_is_picklable(self):
        # jobs travel to process pools and cluster workers
        job = SurfaceJob("a.ply", "t.exr", "out", texel_size=0.1, render=(8, 8), fmt="obj", device="cpu")
        assert pickle.loads(pickle.dumps(job)) == job
        res = JobResult("a.ply", "failed", "why")
        assert pickle.loads(pickle.dumps(res)) == res

    def test_done_skipped_overwrite(self, tmp_path, mesh_dir, texton_path):
        out = tmp_path / "out"
        job = SurfaceJob(str(mesh_dir / "ball.ply"), str(texton_path), str(out), render=(12, 20), device="cpu")
        res = run_surface_job(job)
        assert res.status == "done" and res.message == ""
        assert res.outputs == [str(out / "ball.ply"), str(out / "ball.png")]
        with Image.open(out / "ball.png") as im:
            assert im.size == (20, 12)
        mesh_bytes = (out / "ball.ply").read_bytes()
        for p in job.outputs():
            os.utime(p, (OLD, OLD))
        res = run_surface_job(job)
        assert res.status == "skipped" and "--overwrite" in res.message
        assert all(p.stat().st_mtime == OLD for p in job.outputs())
        res = run_surface_job(SurfaceJob(**{**job.__dict__, "overwrite": True}))
        assert res.status == "done"
        assert all(p.stat().st_mtime != OLD for p in job.outputs())
        assert (out / "ball.ply").read_bytes() == mesh_bytes  # same seed, same file
        assert parts(out) == []

    def test_missing_render_is_redone(self, tmp_path, mesh_dir, texton_path):
        out = tmp_path / "out"
        job = SurfaceJob(str(mesh_dir / "ball.ply"), str(texton_path), str(out), device="cpu")
        assert run_surface_job(job).status == "done"
        # asking for a render too: the PNG is missing, so the job runs again
        assert run_surface_job(SurfaceJob(**{**job.__dict__, "render": (8, 8)})).status == "done"
        assert (out / "ball.png").is_file()

    @pytest.mark.parametrize(
        "name, content, match",
        [
            ("missing.ply", None, r"missing\.ply: no such file"),
            ("bad.ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nend_header\n1 2\n",
             r"bad\.ply: not a mesh that trimesh can read"),
            ("cloud.ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                          "property float z\nend_header\n0 0 0\n1 0 0\n0 1 0\n", r"cloud\.ply: .*no triangles"),
            ("empty.obj", "", r"empty\.obj: "),
            ("folder.ply", "DIR", r"folder\.ply: no such file"),
        ],
    )
    def test_bad_meshes_fail_without_output(self, tmp_path, texton_path, name, content, match):
        path = tmp_path / name
        if content == "DIR":
            path.mkdir()
        elif content is not None:
            path.write_text(content)
        out = tmp_path / "out"
        job = SurfaceJob(str(path), str(texton_path), str(out), render=(8, 8), device="cpu")
        res = run_surface_job(job)
        assert res.status == "failed" and res.outputs == []
        assert re.search(match, res.message), res.message
        assert "\n" not in res.message
        assert not any(p.exists() for p in job.outputs())
        assert parts(tmp_path) == []

    def test_bad_texton_fails_the_job(self, tmp_path, mesh_dir):
        (tmp_path / "t.texton").write_text("NOT A TEXTON\n")
        res = run_surface_job(SurfaceJob(str(mesh_dir / "ball.ply"), str(tmp_path / "t.texton"), str(tmp_path / "o")))
        assert res.status == "failed" and "t.texton" in res.message

    def test_failed_overwrite_keeps_the_previous_output(self, tmp_path, mesh_dir, texton_path):
        out = tmp_path / "out"
        job = SurfaceJob(str(mesh_dir / "ball.ply"), str(texton_path), str(out), overwrite=True, device="cpu")
        assert run_surface_job(job).status == "done"
        before = (out / "ball.ply").read_bytes()
        (mesh_dir / "ball.ply").write_text("ply\ngarbage\n")
        res = run_surface_job(job)
        assert res.status == "failed"
        assert (out / "ball.ply").read_bytes() == before
        assert parts(out) == []


class TestRunBatch:
    def test_results_in_job_order_and_parallel_equals_serial(self, tmp_path, mesh_dir, texton_path):
        names = ("ring.obj", "bad.ply", "ball.ply")

        def jobs(out):
            return [SurfaceJob(str(mesh_dir / n), str(texton_path), str(tmp_path / out), device="cpu") for n in names]

        serial = run_jobs(jobs("serial"))
        parallel = run_jobs(jobs("parallel"), jobs_in_parallel=3)
        for res in (serial, parallel):
            assert [r.mesh for r in res] == [str(mesh_dir / n) for n in names]
            assert [r.status for r in res] == ["done", "failed", "done"]
        for stem in ("ring", "ball"):
            a = (tmp_path / "serial" / f"{stem}.ply").read_bytes()
            assert a == (tmp_path / "parallel" / f"{stem}.ply").read_bytes()

    def test_an_executor_failure_is_a_failed_result(self, tmp_path, mesh_dir, texton_path):
        class LostWorkers(Executor):
            def submit(self, fn, *args, **kwargs):
                f = Future()
                f.set_exception(RuntimeError("worker lost"))
                return f

        jobs = [SurfaceJob(str(mesh_dir / "ball.ply"), str(texton_path), str(tmp_path / "o"))]
        (res,) = run_jobs(jobs, executor=LostWorkers())
        assert res.status == "failed" and res.message == f"{jobs[0].mesh}: RuntimeError: worker lost"
        assert res.mesh == str(mesh_dir / "ball.ply")


# --------------------------------------------------------------------------- #
# The command line                                                            #
# --------------------------------------------------------------------------- #
class TestCli:
    @pytest.mark.parametrize("fmt", ["ply", "obj", "glb"])
    def test_outputs_in_each_format(self, tmp_path, mesh_dir, texton_path, capsys, fmt):
        out = tmp_path / "out"
        status = surface(mesh_dir, texton_path, out, extra=["--format", fmt, "-q"])
        captured = capsys.readouterr()
        assert status == 0, captured.err
        assert summary(captured.err) == (2, 0, 0)
        assert sorted(p.name for p in out.iterdir()) == sorted([f"ball.{fmt}", f"ring.{fmt}"])
        for stem, src in (("ball", "ball.ply"), ("ring", "ring.obj")):
            # a GLB's white material (COLOR_0 multiplies it) set aside: trimesh then reads the colours
            # as vertex colours (with it, as a vertex attribute of a textured visual)
            mesh = trimesh.load(str(out / f"{stem}.{fmt}"), force="mesh", process=False, skip_materials=True)
            source = load(mesh_dir / src)
            assert mesh.visual.kind == "vertex"
            c = np.asarray(mesh.visual.vertex_colors)
            # a vertex per normal: the ring's rows meet at 30.25°, past the default crease angle (30°),
            # so its vertices split in two (432 of 288), the ball's do not
            assert c.shape == (len(mesh.vertices), 4)
            assert len(mesh.vertices) == {"ball": 162, "ring": 432}[stem]
            # a GLB is Y-up: the Z-up PLY turned to +Y, the Y-up OBJ as it is; PLY and OBJ keep the axes
            turn = gltf_rotation(resolve_up("auto", src)) if fmt == "glb" else np.eye(3)
            np.testing.assert_allclose(mesh.vertices[mesh.faces], source.vertices[source.faces] @ turn.T, atol=1e-6)
            np.testing.assert_array_equal(c, expected_colours(mesh_dir / src, texton_path, linear=fmt == "glb"))
            # the texton's mean colour: 162 (ball) or 288 (ring) positions ≥ 20 texels apart
            # (independent), sd 0.08 each: 5 sd of the mean ≤ 0.032 ≪ the 0.2 between channels.
            # glTF's COLOR_0 is linear: decoded back to sRGB, its 8-bit steps reach 0.5/255 × 3.1
            # at the darkest channel (linear 0.07, where d sRGB / d linear ≈ 3.1)
            g = c[:, :3] / 255
            if fmt == "glb":
                g = linear_to_srgb(g)
            step = 0.5 / 255 * (3.1 if fmt == "glb" else 1.0)
            # vertices split at one position count as one: sd of the mean ≤ 0.08 √(Σ n_p²) / N
            _, n_p = np.unique(np.round(mesh.vertices, 6), axis=0, return_counts=True)
            assert np.all(np.abs(g.mean(axis=0) - MEAN) < 5 * 0.08 * np.sqrt(np.sum(n_p ** 2)) / len(c) + step)
        assert parts(out) == []

    def test_render_has_the_asked_size(self, tmp_path, mesh_dir, texton_path, capsys):
        out = tmp_path / "out"
        assert surface(mesh_dir, texton_path, out, extra=["--render", "24x16", "-q"]) == 0
        for stem in ("ball", "ring"):
            with Image.open(out / f"{stem}.png") as im:
                assert im.size == (24, 16) and im.mode == "RGB"
                px = np.asarray(im)
            assert np.all(px[0, 0] == round(0.92 * 255))  # background in the corner
            assert np.any(np.any(px != round(0.92 * 255), axis=2))  # and the mesh somewhere
        assert summary(capsys.readouterr().err) == (2, 0, 0)

    def test_one_bad_mesh_others_finish(self, tmp_path, mesh_dir, texton_path, capsys):
        out = tmp_path / "out"
        status = surface(mesh_dir, texton_path, out, "ball.ply", "bad.ply", "ring.obj", extra=["-q"])
        captured = capsys.readouterr()
        assert status == 1
        assert summary(captured.err) == (2, 0, 1)
        errors = [ln for ln in captured.err.splitlines() if ln.startswith("warp-texton: error:")]
        assert len(errors) == 1 and "bad.ply" in errors[0], captured.err
        assert "Traceback" not in captured.err + captured.out
        assert sorted(p.name for p in out.iterdir()) == ["ball.ply", "ring.ply"]
        assert parts(out) == []

    def test_rerun_skips_and_overwrite_redoes(self, tmp_path, mesh_dir, texton_path, capsys):
        out = tmp_path / "out"
        assert surface(mesh_dir, texton_path, out, extra=["-q", "--render", "8x8"]) == 0
        capsys.readouterr()
        files = sorted(out.iterdir())
        assert len(files) == 4
        content = {p: p.read_bytes() for p in files}
        for p in files:
            os.utime(p, (OLD, OLD))
        assert surface(mesh_dir, texton_path, out, extra=["-q", "--render", "8x8"]) == 0
        assert summary(capsys.readouterr().err) == (0, 2, 0)
        assert all(p.stat().st_mtime == OLD for p in files)
        assert surface(mesh_dir, texton_path, out, extra=["-q", "--render", "8x8", "--overwrite"]) == 0
        assert summary(capsys.readouterr().err) == (2, 0, 0)
        assert all(p.stat().st_mtime != OLD for p in files)
        assert all(p.read_bytes() == content[p] for p in files)  # deterministic
        assert parts(out) == []

    def test_list_files_and_globs(self, tmp_path, mesh_dir, texton_path, capsys):
        listing = tmp_path / "meshes.txt"
        listing.write_text(f"# two meshes\n{mesh_dir / 'ball.ply'}\n\n{mesh_dir / 'ring.*'}\n{mesh_dir / 'ball.ply'}\n")
        out = tmp_path / "out"
        status = run_cli(["surface", f"@{listing}", str(mesh_dir / "*.obj"), str(mesh_dir / "nothing*.ply"),
                      "--texton", texton_path, "--out-dir", out, "--device", "cpu", "-q"])
        captured = capsys.readouterr()
        assert status == 1  # the unmatched pattern is reported as a missing file
        assert summary(captured.err) == (2, 0, 1)
        assert re.search(r"error: .*nothing\*\.ply: no such file", captured.err), captured.err
        assert sorted(p.name for p in out.iterdir()) == ["ball.ply", "ring.ply"]

    def test_progress_bar_and_summary(self, tmp_path, mesh_dir, texton_path, capsys, monkeypatch):
        monkeypatch.setattr("warp_texton.core.progress.PROGRESS_DELAY", 0.0)
        monkeypatch.setattr("warp_texton.core.progress.terminal", lambda: True)  # capsys is no terminal
        assert surface(mesh_dir, texton_path, tmp_path / "out") == 0
        err = capsys.readouterr().err
        assert "surface" in err and "2/2" in err  # the bar counts meshes
        assert summary(err) == (2, 0, 0)

    def test_options_reach_the_jobs(self, tmp_path, mesh_dir, texton_path, capsys):
        a, b, c = tmp_path / "a", tmp_path / "b", tmp_path / "c"
        assert surface(mesh_dir, texton_path, a, "ball.ply", extra=["-q", "--seed", "1"]) == 0
        assert surface(mesh_dir, texton_path, b, "ball.ply", extra=["-q", "--seed", "2", "--jobs", "2"]) == 0
        ca, cb = (np.asarray(load(d / "ball.ply").visual.vertex_colors) for d in (a, b))
        np.testing.assert_array_equal(ca, expected_colours(mesh_dir / "ball.ply", texton_path, seed=1))
        assert np.mean(ca != cb) > 0.5
        assert surface(mesh_dir, texton_path, c, "ball.ply",
                       extra=["-q", "--texel-size", "0.01", "--max-edge", "8", "--mni", "40"]) == 0
        mesh = load(c / "ball.ply")
        v, f = np.asarray(mesh.vertices), np.asarray(mesh.faces)
        assert len(v) > 162 and np.linalg.norm(v[f[:, [1, 2, 0]]] - v[f], axis=2).max() <= 0.08 * (1 + 1e-6)

    def test_jobs_in_parallel_give_the_same_files(self, tmp_path, mesh_dir, texton_path, capsys):
        one, two = tmp_path / "one", tmp_path / "two"
        assert surface(mesh_dir, texton_path, one, extra=["-q"]) == 0
        assert surface(mesh_dir, texton_path, two, extra=["-q", "--jobs", "2"]) == 0
        for name in ("ball.ply", "ring.ply"):
            assert (one / name).read_bytes() == (two / name).read_bytes()

    @pytest.mark.parametrize(
        "extra, match",
        [
            (["--render", "abc"], r"--render must be WIDTHxHEIGHT"),
            (["--render", "16"], r"--render must be WIDTHxHEIGHT"),
            (["--render", "16x16x2"], r"--render must be WIDTHxHEIGHT"),
            (["--jobs", "0"], r"--jobs must be at least 1"),
            (["--texel-size", "0"], r"--texel-size must be a finite number > 0"),
            (["--texel-size", "nan"], r"--texel-size must be a finite number > 0"),
            (["--format", "stl"], r"invalid choice: 'stl'"),
            (["--jobs", "two"], r"invalid int value"),
            (["--device", "tpu"], r"device"),
        ],
    )
    def test_usage_errors(self, tmp_path, mesh_dir, texton_path, capsys, extra, match):
        out = tmp_path / "out"
        status = surface(mesh_dir, texton_path, out, extra=extra)
        assert_usage_error(status, capsys.readouterr(), out, match)

    @pytest.mark.parametrize("texton", ["missing.exr", "broken.texton", "image.png"])
    def test_bad_texton_is_one_error(self, tmp_path, mesh_dir, capsys, texton):
        (tmp_path / "broken.texton").write_text("TEXTON\n1\n")
        Image.fromarray(np.zeros((4, 4), np.uint8)).save(tmp_path / "image.png")
        out = tmp_path / "out"
        status = surface(mesh_dir, tmp_path / texton, out)
        captured = capsys.readouterr()
        assert status == 2
        lines = captured.err.splitlines()
        assert len(lines) == 1 and lines[0].startswith("warp-texton: error: ") and texton in lines[0], captured.err
        assert not out.exists()

    def test_missing_list_is_one_error(self, tmp_path, texton_path, capsys):
        out = tmp_path / "out"
        status = run_cli(["surface", f"@{tmp_path / 'nolist.txt'}", "--texton", texton_path, "--out-dir", out])
        err = capsys.readouterr().err
        assert status == 2 and err.count("\n") == 1 and "cannot read the mesh list" in err
        assert not out.exists()

    @pytest.mark.parametrize("size", ["0x16", "16x-4"])
    def test_non_positive_render_size_is_a_usage_error(self, tmp_path, mesh_dir, texton_path, capsys, size):
        out = tmp_path / "out"
        status = surface(mesh_dir, texton_path, out, "ball.ply", extra=["--render", size, "-q"])
        err = capsys.readouterr().err
        assert status == 2 and "--render" in err, err
        assert not (out / "ball.ply").exists()

    def test_error_lines_go_to_stderr_with_the_progress_bar(self, tmp_path, mesh_dir, texton_path, capsys,
                                                             monkeypatch):
        monkeypatch.setattr("warp_texton.core.progress.PROGRESS_DELAY", 0.0)
        monkeypatch.setattr("warp_texton.core.progress.terminal", lambda: True)
        status = surface(mesh_dir, texton_path, tmp_path / "out", "ball.ply", "bad.ply")
        captured = capsys.readouterr()
        assert status == 1
        assert "warp-texton: error:" not in captured.out, captured.out
        # the bar is cleared with a carriage return before the line: a terminal shows it at column 0
        assert re.search(r"(^|\r)warp-texton: error: .*bad\.ply", captured.err, re.M), captured.err


# --------------------------------------------------------------------------- #
# Dask                                                                        #
# --------------------------------------------------------------------------- #
@pytest.fixture
def dask_client():
    distributed = pytest.importorskip("dask.distributed")
    with distributed.LocalCluster(n_workers=1, threads_per_worker=2, processes=False,
                                  dashboard_address=None) as cluster, distributed.Client(cluster) as client:
        yield client


def test_dask_cluster_gives_the_same_files(tmp_path, mesh_dir, texton_path, dask_client):
    names = ("ball.ply", "bad.ply", "ring.obj")

    def jobs(out):
        return [SurfaceJob(str(mesh_dir / n), str(texton_path), str(tmp_path / out), render=(12, 12),
                           device="cpu") for n in names]

    local = run_jobs(jobs("threads"), jobs_in_parallel=2)
    remote = run_jobs(jobs("dask"), executor=dask_client.get_executor())
    assert [(r.mesh, r.status, r.message) for r in remote] == [(r.mesh, r.status, r.message) for r in local]
    assert [r.status for r in remote] == ["done", "failed", "done"]
    assert [r.outputs for r in remote] == [[o.replace("threads", "dask") for o in r.outputs] for r in local]
    files = sorted(p.name for p in (tmp_path / "threads").iterdir())
    assert files == sorted(p.name for p in (tmp_path / "dask").iterdir()) == [
        "ball.ply", "ball.png", "ring.ply", "ring.png"]
    for name in files:
        assert (tmp_path / "threads" / name).read_bytes() == (tmp_path / "dask" / name).read_bytes()
    assert parts(tmp_path) == []


def test_dask_reruns_a_job_whose_input_changed(tmp_path, mesh_dir, texton_path, dask_client):
    out = tmp_path / "out"
    job = SurfaceJob(str(mesh_dir / "ball.ply"), str(texton_path), str(out), overwrite=True, device="cpu")
    # a result of this very job still alive on the cluster, e.g. from an earlier batch in the same client
    held = dask_client.submit(run_surface_job, job)
    assert held.result().status == "done"
    os.utime(out / "ball.ply", (OLD, OLD))
    trimesh.creation.icosphere(subdivisions=3).export(mesh_dir / "ball.ply")  # the input changes
    (res,) = run_jobs([job], executor=dask_client.get_executor())
    assert res.status == "done"
    assert (out / "ball.ply").stat().st_mtime != OLD, "the job was not run: the output is stale"
    assert len(load(out / "ball.ply").vertices) == 642


# --------------------------------------------------------------------------- #
# Baked textures, up axes, textons from images, Ctrl-C, a cluster             #
# --------------------------------------------------------------------------- #
def err_lines(err: str) -> list[str]:
    return [ln for ln in err.splitlines() if ln.startswith("warp-texton: error:")]


class TestBakeCli:
    def test_bake_writes_glb_with_a_texture(self, tmp_path, mesh_dir, texton_path, capsys):
        pytest.importorskip("xatlas")
        out = tmp_path / "out"
        status = surface(mesh_dir, texton_path, out, extra=["--bake", "64"])
        captured = capsys.readouterr()
        assert status == 0, captured.err
        assert summary(captured.err) == (2, 0, 0)
        assert sorted(p.name for p in out.iterdir()) == ["ball.glb", "ring.glb"]
        for stem in ("ball", "ring"):
            (mesh,) = trimesh.load(out / f"{stem}.glb", process=False).geometry.values()
            assert isinstance(mesh.visual, trimesh.visual.TextureVisuals)
            assert mesh.visual.material.baseColorTexture.size == (64, 64)
            # the note tells how fine the texture is
            assert re.search(rf"note: .*{stem}\.\w+: 64x64 texture, [\d.]+ texels per texton texel", captured.err)
        assert parts(out) == []

    def test_bake_obj_texture_and_render_then_skip(self, tmp_path, mesh_dir, texton_path, capsys):
        pytest.importorskip("xatlas")
        out = tmp_path / "out"
        extra = ["--bake", "32", "--format", "obj", "--texture", "exr", "--render", "16x12", "-q"]
        assert surface(mesh_dir, texton_path, out, "ball.ply", extra=extra) == 0
        names = ["ball.mtl", "ball.obj", "ball.png", "ball_render.png", "ball_texture.exr"]
        assert sorted(p.name for p in out.iterdir()) == names
        with Image.open(out / "ball_render.png") as im:
            assert im.size == (16, 12)
        capsys.readouterr()
        assert surface(mesh_dir, texton_path, out, "ball.ply", extra=extra) == 0
        assert summary(capsys.readouterr().err) == (0, 1, 0)

    @pytest.mark.parametrize(
        "extra, match",
        [
            (["--bake", "0"], r"--bake must be at least 1"),
            (["--bake", "20000"], r"--bake must be at most 16384"),
            (["--bake", "x"], r"invalid int value"),
            (["--bake", "32", "--format", "ply"], r"--bake writes --format glb or obj"),
            (["--bake", "32", "--max-edge", "2"], r"--max-edge subdivides for vertex colours"),
            (["--texture", "png"], r"--texture applies to baked textures: add --bake RES"),
            (["--uv", "atlas"], r"--uv applies to baked textures"),
            (["--bake", "32", "--exr-linear"], r"--exr-linear applies to --texture exr"),
            (["--bake", "32", "--supersample", "0"], r"--supersample must be at least 1"),
            (["--orbit", "30"], r"--orbit must be AZIMUTH,ELEVATION"),
            (["--orbit", "30,95"], r"--orbit: orbit elevation must be finite and strictly between -90 and 90"),
            (["--fov", "200"], r"--fov must be below 180"),
            (["--up", "w"], r"invalid choice: 'w'"),
        ],
    )
    def test_usage_errors(self, tmp_path, mesh_dir, texton_path, capsys, extra, match):
        out = tmp_path / "out"
        status = surface(mesh_dir, texton_path, out, extra=extra)
        assert_usage_error(status, capsys.readouterr(), out, match)

    def test_missing_xatlas_fails_each_mesh_with_the_reason(self, tmp_path, mesh_dir, texton_path, capsys,
                                                             monkeypatch):
        monkeypatch.setitem(sys.modules, "xatlas", None)  # as if not installed
        out = tmp_path / "out"
        status = surface(mesh_dir, texton_path, out, extra=["--bake", "32", "-q"])
        captured = capsys.readouterr()
        assert status == 1 and summary(captured.err) == (0, 0, 2)
        lines = err_lines(captured.err)
        assert len(lines) == 2
        for line, name in zip(lines, ("ball.ply", "ring.obj")):
            assert re.match(rf"warp-texton: error: \S*{re.escape(name)}: making a UV atlas needs the xatlas package: "
                            r"pip install 'warp-texton\[mesh\]'", line), line
        assert list(out.iterdir()) == []

    def test_bad_meshes_are_named_in_the_package_words(self, tmp_path, mesh_dir, texton_path, capsys):
        header = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n" \
                 "element face 1\nproperty list uchar int vertex_indices\nend_header\n"
        (mesh_dir / "nan.ply").write_text(header + "0 0 0\n1 0 nan\n0 1 0\n3 0 1 2\n")
        (mesh_dir / "index.ply").write_text(header + "0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n")
        far = trimesh.creation.icosphere(subdivisions=1)
        far.apply_translation((1e12, 0, 0))
        far.export(mesh_dir / "far.ply")
        out = tmp_path / "out"
        status = surface(mesh_dir, texton_path, out, "nan.ply", "index.ply", "far.ply", "ball.ply",
                         extra=["--texel-size", "0.01", "-q"])
        captured = capsys.readouterr()
        assert status == 1 and summary(captured.err) == (1, 0, 3)
        lines = err_lines(captured.err)
        assert re.search(r"nan\.ply: 1 vertices have NaN or infinite coordinates$", lines[0]), lines[0]
        assert re.search(r"index\.ply: faces index vertices that do not exist \(indices up to 7, 3 vertices\)$",
                         lines[1]), lines[1]
        assert re.search(r"far\.ply: the mesh's vertices lie too far from the origin for this texel_size: "
                         r"1e\+14 texels", lines[2]), lines[2]
        assert "Traceback" not in captured.err
        assert sorted(p.name for p in out.iterdir()) == ["ball.ply"]

    def test_vertex_spacing_warning_names_each_mesh_once(self, tmp_path, mesh_dir, texton_path, capsys):
        status = surface(mesh_dir, texton_path, tmp_path / "out", extra=["-q"])
        captured = capsys.readouterr()
        assert status == 0
        warns = [ln for ln in captured.err.splitlines() if ln.startswith("warp-texton: warning:")]
        assert len(warns) == 2
        for line, name in zip(warns, ("ball.ply", "ring.obj")):
            assert re.search(rf"{re.escape(name)}: vertices are [\d.]+ texels apart .*--bake RES.*--max-edge 1",
                             line), line


class TestMessagesNameTheOutputs:
    @pytest.fixture
    def bright_texton(self, tmp_path):
        """A texton whose mean lies above 1 (1.1, sd 0.3): 8-bit images clip most of it."""
        a = np.random.default_rng(3).standard_normal((8, 8, 1))
        t = Texton(a, [1.1], 1)
        t = Texton(a * 0.3 / np.sqrt(t.covariance()[0, 0]), [1.1], 1)
        path = tmp_path / "bright.exr"
        t.save(path)
        return path

    @pytest.mark.parametrize("fmt, images", [("glb", ["ball.glb", "ball_texture.png"]),
                                             ("obj", ["ball.png", "ball_texture.png"])])
    def test_one_clipping_warning_per_8bit_output_by_its_name(self, tmp_path, mesh_dir, bright_texton, capsys,
                                                               fmt, images):
        """Every 8-bit texture written (the texture alone, the one embedded in the GLB, the OBJ's PNG)
        follows one rule and is reported once, by its final name; the render (shaded darker than 1)
        clips nothing here."""
        pytest.importorskip("xatlas")
        out = tmp_path / "out"
        status = surface(mesh_dir, bright_texton, out, "ball.ply",
                         extra=["--bake", "32", "--format", fmt, "--texture", "png", "--render", "16x12", "-q"])
        err = capsys.readouterr().err
        assert status == 0, err
        warns = [w for w in WARNINGS if "clipped for uint8" in w]
        named = sorted(Path(w.split(": ")[0]).name for w in warns)
        assert named == sorted(images), WARNINGS
        assert all(w.startswith(f"{out}{os.sep}ball") for w in warns), WARNINGS
        assert parts(out) == []

    def test_a_failed_write_names_the_output(self, tmp_path, mesh_dir, texton_path, capsys):
        """The texture file cannot be written (a folder of its name): the error names it, and nothing
        of that mesh is written."""
        pytest.importorskip("xatlas")
        out = tmp_path / "out"
        (out / "ball_texture.exr").mkdir(parents=True)
        status = surface(mesh_dir, texton_path, out, "ball.ply", extra=["--bake", "16", "--texture", "exr", "-q"])
        err = capsys.readouterr().err
        assert status == 1
        (line,) = err_lines(err)
        assert f"{out / 'ball_texture.exr'}" in line, line
        assert sorted(p.name for p in out.iterdir()) == ["ball_texture.exr"] and parts(out) == []

    @pytest.mark.parametrize("extra", [[], ["--bake", "16"], ["--render", "8x8", "--format", "glb"]])
    def test_a_degenerate_mesh_is_one_line_and_the_batch_continues(self, tmp_path, mesh_dir, texton_path, capsys,
                                                                    extra):
        """A mesh without area (all points on a line, or at one point) has no up axis to honour."""
        trimesh.Trimesh([[0, 0, 0], [1, 1, 1], [2, 2, 2], [3, 3, 3]], [[0, 1, 2], [1, 2, 3]],
                        process=False).export(mesh_dir / "line.ply")
        trimesh.Trimesh(np.zeros((3, 3)), [[0, 1, 2]], process=False).export(mesh_dir / "dot.ply")
        if extra[:1] == ["--bake"]:
            pytest.importorskip("xatlas")
        out = tmp_path / "out"
        status = surface(mesh_dir, texton_path, out, "line.ply", "ball.ply", "dot.ply", extra=[*extra, "-q"])
        err = capsys.readouterr().err
        assert status == 1 and summary(err) == (1, 0, 2)
        lines = err_lines(err)
        assert len(lines) == 2, err
        for line, name, where in zip(lines, ("line.ply", "dot.ply"), ("on a line", "at one point")):
            assert re.match(rf"warp-texton: error: \S*{name}: degenerate mesh: its triangles have no area \(the "
                            rf"vertices lie {where}\), so it has no normals and no up axis to honour$", line), line
        assert all(p.name.startswith("ball") for p in out.iterdir()) and parts(out) == []


class TestUpAxisJobs:
    def test_auto_up_by_format(self):
        from warp_texton.surface.jobs import resolve_up

        assert resolve_up("auto", "a/b.GLB") == "y" and resolve_up("auto", "x.gltf") == "y"
        assert resolve_up("auto", "x.obj") == "y" and resolve_up("auto", "x.OBJ") == "y"  # Blender, Maya
        assert resolve_up("auto", "x.ply") == "z" and resolve_up("auto", "x.stl") == "z"
        assert resolve_up("auto", "x.off") == "z" and resolve_up("auto", "noext") == "z"
        assert resolve_up("x", "x.glb") == "x"
        with pytest.raises(TextonError, match="up must be one of auto, x, y, z"):
            resolve_up("w", "x.ply")

    def test_the_cli_names_the_axis_of_each_mesh(self, tmp_path, mesh_dir, texton_path, capsys):
        """A sideways render says what to change: each done mesh's note names its up axis and why."""
        assert surface(mesh_dir, texton_path, tmp_path / "a") == 0
        err = capsys.readouterr().err
        for name, why in (("ball.ply", "up z, auto for .ply"), ("ring.obj", "up y, auto for .obj")):
            lines = [ln for ln in err.splitlines() if ln.startswith("warp-texton: note: done ")]
            assert any(ln.endswith(f"{name} ({why})") for ln in lines), err
        assert surface(mesh_dir, texton_path, tmp_path / "b", extra=["--up", "x"]) == 0
        err = capsys.readouterr().err
        assert len(re.findall(r"^warp-texton: note: done \S+ \(up x, given\)$", err, re.M)) == 2, err
        assert surface(mesh_dir, texton_path, tmp_path / "c", extra=["-q"]) == 0
        assert "note:" not in capsys.readouterr().err  # -q: no notes

    def test_an_obj_is_y_up_by_default(self, tmp_path, mesh_dir, texton_path):
        """The OBJ's render and colours use Y up (Blender's and Maya's export): the same as --up y."""
        from warp_texton import load_texton, render_mesh

        job = SurfaceJob(str(mesh_dir / "ring.obj"), str(texton_path), str(tmp_path / "out"), render=(20, 24),
                         device="cpu")
        result = run_surface_job(job)
        assert result.status == "done" and result.up == "y, auto for .obj"
        mesh = load(mesh_dir / "ring.obj")
        texel = float(np.linalg.norm(mesh.bounds[1] - mesh.bounds[0])) / 256
        want = render_mesh(mesh, load_texton(texton_path), (20, 24), texel_size=texel, up="y", device="cpu")
        got = np.asarray(Image.open(tmp_path / "out" / "ring.png"), np.float32) / 255
        np.testing.assert_allclose(got, want, atol=0.5 / 255 + 1e-6)
        np.testing.assert_array_equal(np.asarray(load(tmp_path / "out" / "ring.ply").visual.vertex_colors),
                                      expected_colours(mesh_dir / "ring.obj", texton_path, up="y"))

    def test_the_job_renders_with_its_up_view_and_fov(self, tmp_path, mesh_dir, texton_path):
        from warp_texton import load_texton, render_mesh

        box = trimesh.creation.box(extents=(1.0, 3.0, 1.0))
        box.export(tmp_path / "tall.glb")
        job = SurfaceJob(str(tmp_path / "tall.glb"), str(texton_path), str(tmp_path / "out"), render=(24, 24),
                         orbit=(-30.0, 15.0), fov=50.0, device="cpu")
        assert run_surface_job(job).status == "done"
        mesh = load(tmp_path / "tall.glb")
        lo, hi = mesh.bounds
        texel = float(np.linalg.norm(hi - lo)) / 256
        want = render_mesh(mesh, load_texton(texton_path), (24, 24), texel_size=texel, up="y", orbit=(-30.0, 15.0), fov=50.0,
                           device="cpu")
        got = np.asarray(Image.open(tmp_path / "out" / "tall.png"), np.float32) / 255
        np.testing.assert_allclose(got, want, atol=0.5 / 255 + 1e-6)


class TestTextonImage:
    def test_an_image_is_analysed_once_for_the_batch(self, tmp_path, mesh_dir, capsys, monkeypatch):
        import warp_texton.model.analysis as analysis
        from warp_texton import analyze, read_image

        rng = np.random.default_rng(0)
        img = (0.5 + 0.1 * rng.standard_normal((48, 48, 3))).clip(0, 1)
        Image.fromarray((img * 255).round().astype(np.uint8)).save(tmp_path / "wood.png")
        calls = []
        real = analysis.analyze

        def counting(*a, **k):
            calls.append(1)
            return real(*a, **k)

        monkeypatch.setattr(analysis, "analyze", counting)
        out = tmp_path / "out"
        status = surface(mesh_dir, tmp_path / "wood.png", out, extra=["--size", "8", "--seed", "3", "-q"])
        assert status == 0, capsys.readouterr().err
        assert len(calls) == 1
        # the same files as with the texton of that image saved first
        texton = real(read_image(tmp_path / "wood.png"), size=8, seed=3)
        texton.save(tmp_path / "wood.exr")
        assert surface(mesh_dir, tmp_path / "wood.exr", tmp_path / "ref", extra=["--seed", "3", "-q"]) == 0
        for name in ("ball.ply", "ring.ply"):
            assert (out / name).read_bytes() == (tmp_path / "ref" / name).read_bytes()
        assert analyze is not None


class TestInterrupt:
    def test_ctrl_c_cancels_the_queue_and_exits_130(self, tmp_path, mesh_dir, texton_path, capsys, monkeypatch):
        import _thread
        import threading
        import time

        import warp_texton.surface.jobs as batch

        for k in range(4):
            trimesh.creation.icosphere(subdivisions=2).export(mesh_dir / f"m{k}.ply")
        real = batch.run_surface_job

        def slow(job, token=None):
            time.sleep(0.4)
            return real(job, token)

        monkeypatch.setattr(batch, "run_surface_job", slow)
        out = tmp_path / "out"

        def interrupt_after_the_first_mesh():
            deadline = time.monotonic() + 20
            while not (out / "m0.ply").exists() and time.monotonic() < deadline:
                time.sleep(0.01)
            _thread.interrupt_main()

        threading.Thread(target=interrupt_after_the_first_mesh, daemon=True).start()
        status = surface(mesh_dir, texton_path, out, *(f"m{k}.ply" for k in range(4)), extra=["-q", "--jobs", "1"])
        captured = capsys.readouterr()
        assert status == 130
        assert "Traceback" not in captured.err + captured.out
        last = captured.err.strip().splitlines()[-1]
        m = re.match(r"^warp-texton: interrupted: (\d+) done, 0 skipped, 0 failed, (\d+) cancelled$", last)
        assert m, captured.err
        done, cancelled = int(m.group(1)), int(m.group(2))
        assert done >= 1 and cancelled >= 1 and done + cancelled == 4
        written = sorted(p.name for p in out.iterdir())
        assert len(written) == done and parts(out) == []
        for name in written:
            assert len(load(out / name).vertices) == 162  # whole files only


@pytest.mark.slow
def test_cli_scheduler_runs_on_a_dask_cluster(tmp_path, mesh_dir, texton_path, capsys):
    distributed = pytest.importorskip("dask.distributed")
    with distributed.LocalCluster(n_workers=1, threads_per_worker=2, processes=False,
                                  dashboard_address=None) as cluster:
        status = surface(mesh_dir, texton_path, tmp_path / "dask", extra=["--scheduler", cluster.scheduler_address,
                                                                         "-q"])
        captured = capsys.readouterr()
        assert status == 0, captured.err
        assert summary(captured.err) == (2, 0, 0)
    assert surface(mesh_dir, texton_path, tmp_path / "threads", extra=["-q"]) == 0
    for name in ("ball.ply", "ring.ply"):
        assert (tmp_path / "dask" / name).read_bytes() == (tmp_path / "threads" / name).read_bytes()


def test_cli_scheduler_that_cannot_be_reached(tmp_path, mesh_dir, texton_path, capsys):
    pytest.importorskip("dask.distributed")
    status = surface(mesh_dir, texton_path, tmp_path / "out", extra=["--scheduler", "tcp://127.0.0.1:9", "-q"])
    captured = capsys.readouterr()
    assert status == 2 and len(captured.err.splitlines()) == 1
    assert re.match(r"warp-texton: error: --scheduler tcp://127\.0\.0\.1:9: cannot connect", captured.err)


class TestAllOrNone:
    """A mesh's files (mesh, MTL, PNG texture, texture alone, render) appear together or not at all."""

    @pytest.mark.parametrize("kw", [
        dict(render=(8, 8)),
        dict(render=(8, 8), bake=16, fmt="obj", texture="exr"),
        dict(render=(8, 8), bake=16, fmt="glb"),
    ])
    def test_a_failing_render_write_leaves_nothing(self, tmp_path, mesh_dir, texton_path, monkeypatch, kw):
        import errno

        import warp_texton.files.images

        def full(path, *a, **k):
            raise OSError(errno.ENOSPC, "No space left on device", str(path))

        monkeypatch.setattr(warp_texton.files.images, "write_image", full)
        out = tmp_path / "out"
        job = SurfaceJob(str(mesh_dir / "ball.ply"), str(texton_path), str(out), device="cpu", **kw)
        res = run_surface_job(job)
        assert res.status == "failed" and "No space left" in res.message, res
        assert ".part" not in res.message
        assert os.listdir(out) == []

    def test_a_failing_rename_removes_the_renamed(self, tmp_path, monkeypatch):
        """Should a rename fail after others succeeded, the renamed files go again."""
        import warp_texton.files.images
        from warp_texton.surface.mesh_files import write_set

        real, calls = os.replace, []

        def flaky(src, dst):
            calls.append(dst)
            if len(calls) == 2:
                raise OSError(5, "Input/output error")
            real(src, dst)

        monkeypatch.setattr(warp_texton.files.images.os, "replace", flaky)
        with pytest.raises(OSError):
            write_set({tmp_path / "a.obj": b"o", tmp_path / "a.mtl": b"m", tmp_path / "a.png": b"p"})
        assert os.listdir(tmp_path) == []

    def test_long_names_are_refused_before_any_work(self, tmp_path, mesh_dir, texton_path, monkeypatch):
        """A 246-character stem fits its .obj but not its _render.png (257 bytes): refused before the bake."""
        import warp_texton.surface.bake

        monkeypatch.setattr(warp_texton.surface.bake, "bake_mesh", lambda *a, **k: pytest.fail("baked"))
        stem = "m" * 246
        (mesh_dir / f"{stem}.ply").write_bytes((mesh_dir / "ball.ply").read_bytes())
        out = tmp_path / "out"
        job = SurfaceJob(str(mesh_dir / f"{stem}.ply"), str(texton_path), str(out), device="cpu", bake=16,
                         fmt="obj", render=(8, 8))
        res = run_surface_job(job)
        assert res.status == "failed" and "_render.png" in res.message and "257 bytes long" in res.message, res.message
        assert os.listdir(out) == []

    @pytest.mark.parametrize("kw", [dict(fmt="stl"), dict(fmt="ply", bake=16), dict(fmt=3), dict(fmt="GLB")])
    def test_undocumented_formats_are_refused(self, kw):
        with pytest.raises(TextonError, match=r"fmt must be one of") as info:
            SurfaceJob("a.ply", "t.exr", "out", **kw)
        assert info.value.param == "fmt"


def test_names_at_the_limit_are_written(tmp_path, mesh_dir, texton_path):
    """A 243-byte stem: its .obj, .mtl, .png, _render.png and the 255-byte _texture.exr fit, and so do the
    temporary names they are written under."""
    stem = "m" * 243  # 243 + len("_texture.exr") = 255
    (mesh_dir / f"{stem}.ply").write_bytes((mesh_dir / "ball.ply").read_bytes())
    out = tmp_path / "out"
    job = SurfaceJob(str(mesh_dir / f"{stem}.ply"), str(texton_path), str(out), device="cpu", bake=16, fmt="obj",
                     texture="exr", render=(8, 8))
    res = run_surface_job(job)
    assert res.status == "done", res.message
    assert sorted(os.listdir(out)) == sorted(p.name for p in job.outputs())
