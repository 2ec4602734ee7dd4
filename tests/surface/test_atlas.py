"""UV atlases (warp_texton.surface.atlas): normal charts, xatlas in a worker process, its crashes and hangs."""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np
import pytest
import trimesh

import warp_texton.surface.atlas as atlas
from warp_texton import TextonError, Texton, bake_mesh, write_baked
from warp_texton.surface.jobs import SurfaceJob, run_jobs

pytest.importorskip("xatlas")


def _texton():
    return Texton(np.random.default_rng(0).standard_normal((8, 8, 1)) / 8, [0.5])


def _scan(seed=0):
    """A torus with noisy vertices (normals that scatter like a range scan's)."""
    torus = trimesh.creation.torus(1.0, 0.35, major_sections=48, minor_sections=24)
    v = np.asarray(torus.vertices) + np.random.default_rng(seed).normal(0, 0.01, torus.vertices.shape)
    return v, np.asarray(torus.faces, np.int64)


class TestNormalCharts:
    def test_every_face_faces_its_charts_direction_and_keeps_its_orientation(self):
        v, f = _scan()
        chart, direction = atlas.normal_charts(v, f)
        p = v[f]
        n = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
        n /= np.linalg.norm(n, axis=1)[:, None]
        cos = np.sum(n * atlas.DIRECTIONS[direction[chart]], axis=1)
        assert cos.min() >= atlas.MIN_COS - 1e-12
        vmap, faces, uv = atlas.project_charts(v, f, chart, direction)
        assert np.allclose(v[vmap][faces], v[f])  # the same triangles, in order
        a, b, c = uv[faces].transpose(1, 0, 2)
        signed = (b - a)[:, 0] * (c - a)[:, 1] - (b - a)[:, 1] * (c - a)[:, 0]
        assert (signed > 0).all()  # projected along the direction: no triangle is mirrored or folded

    def test_charts_are_connected_and_split_vertices_only_on_seams(self):
        v, f = _scan()
        chart, direction = atlas.normal_charts(v, f)
        vmap, faces, _ = atlas.project_charts(v, f, chart, direction)
        # each output vertex belongs to one chart
        owner = np.full(len(vmap), -1)
        owner[faces.ravel()] = np.repeat(chart, 3)
        assert all(len(set(owner[faces[chart == k].ravel()])) == 1 for k in range(len(direction)))
        assert len(direction) < len(f) / 50  # smoothed: charts of many faces, not a face each

    def test_a_soup_of_unmerged_vertices_charts_as_the_merged_mesh(self):
        v, f = _scan()
        soup_v, soup_f = v[f].reshape(-1, 3), np.arange(3 * len(f)).reshape(-1, 3)
        assert len(atlas.normal_charts(soup_v, soup_f)[1]) == len(atlas.normal_charts(v, f)[1])


class TestMakeAtlas:
    def test_an_atlas_of_normal_charts_lays_every_triangle_once(self):
        v, f = _scan()
        vmap, faces, uv, used = atlas.make_atlas(v, f, 256, 2)
        assert np.allclose(v[vmap][faces], v[f])
        assert uv.min() >= 0 and uv.max() <= 1 and 0 < used <= 1
        mesh = trimesh.Trimesh(v[vmap], faces, visual=trimesh.visual.TextureVisuals(uv=uv), process=False)
        # a bake on these UVs refuses UVs that overlap (more than 2 % of the texels twice)
        baked = bake_mesh(mesh, _texton(), 0.02, resolution=256, uv="mesh", device="cpu", gutter=0)
        assert baked.covered > 0.4

    def test_bake_reports_the_atlas_coverage(self):
        v, f = _scan()
        baked = bake_mesh(trimesh.Trimesh(v, f), _texton(), 0.02, resolution=128, device="cpu")
        assert baked.uv_source == "atlas" and baked.covered == pytest.approx(baked.coverage.mean())

    def test_bad_charts(self):
        v, f = _scan()
        with pytest.raises(TextonError, match="charts must be one of normals, xatlas"):
            bake_mesh(trimesh.Trimesh(v, f), _texton(), 0.02, resolution=64, device="cpu", charts="cube")

    def test_coordinates_beyond_float32_reach_xatlas_scaled(self):
        sphere = trimesh.creation.icosphere(2)
        v = np.asarray(sphere.vertices) * 1e39  # finite in float64, infinite in float32
        unit = atlas.unit_box(v, "huge.obj")
        assert unit.dtype == np.float32 and np.isfinite(unit).all() and np.abs(unit).max() <= 0.5
        vmap, faces, uv, _ = atlas.make_atlas(v, np.asarray(sphere.faces), 64, 2, name="huge.obj")
        assert np.isfinite(uv).all() and np.allclose(v[vmap][faces], v[np.asarray(sphere.faces)])

    def test_an_extent_beyond_float64_is_refused(self):
        v = np.array([[-1.7e308, 0, 0], [1.7e308, 0, 0], [0, 1, 0]])
        with pytest.raises(TextonError, match="m.ply: its vertices span more than float64 holds"):
            atlas.unit_box(v, "m.ply")

    def test_a_glb_cannot_hold_coordinates_beyond_float32(self, tmp_path):
        sphere = trimesh.creation.icosphere(2)
        huge = trimesh.Trimesh(np.asarray(sphere.vertices) * 1e39, sphere.faces, process=False)
        baked = bake_mesh(huge, _texton(), 1e37, resolution=32, device="cpu")
        with pytest.raises(TextonError, match="float32 positions of glTF"):
            write_baked(baked, tmp_path / "huge", fmt="glb")
        assert list(tmp_path.iterdir()) == []
        write_baked(baked, tmp_path / "huge", fmt="obj")  # OBJ writes decimal text: it holds them


def _fake_worker(tmp_path, body: str) -> Path:
    script = tmp_path / "worker.py"
    script.write_text("import os, signal, sys, time\nsys.stdin.buffer.read()\n" + body)
    return script


class TestWorker:
    def test_a_crash_is_one_error_naming_the_mesh(self, tmp_path, monkeypatch):
        monkeypatch.setattr(atlas, "WORKER", _fake_worker(tmp_path, "os.kill(os.getpid(), signal.SIGSEGV)\n"))
        v, f = _scan()
        with pytest.raises(TextonError, match=r"scan.ply: xatlas crashed making the UV atlas \(SIGSEGV\)"):
            atlas.make_atlas(v, f, 64, 2, name="scan.ply")

    def test_a_hang_that_ignores_sigterm_is_stopped_at_the_time_limit(self, tmp_path, monkeypatch):
        hang = "signal.signal(signal.SIGTERM, signal.SIG_IGN)\nsignal.signal(signal.SIGINT, signal.SIG_IGN)\n" \
               "time.sleep(600)\n"
        monkeypatch.setattr(atlas, "WORKER", _fake_worker(tmp_path, hang))
        monkeypatch.setattr(atlas, "WORKER_SECONDS", 1.0)
        monkeypatch.setattr(atlas, "WORKER_SECONDS_PER_FACE", 0.0)
        v, f = _scan()
        t0 = time.monotonic()
        with pytest.raises(TextonError, match=r"scan.ply: xatlas made no atlas within 1 s and was stopped"):
            atlas.make_atlas(v, f, 64, 2, name="scan.ply")
        assert time.monotonic() - t0 < 30

    def test_the_time_limit_is_an_option(self, tmp_path, monkeypatch):
        """WARP_TEXTON_ATLAS_SECONDS sets the base of the limit (a loaded machine may need more
        than 60 s); the share per face is added; a bad value is one error naming it."""
        monkeypatch.setenv(atlas.SECONDS_ENV, "1.5")
        assert atlas.worker_limits(1000, 64)[0] == pytest.approx(1.5 + 1000 * atlas.WORKER_SECONDS_PER_FACE)
        monkeypatch.setenv(atlas.SECONDS_ENV, "")
        assert atlas.worker_limits(0, 64)[0] == atlas.WORKER_SECONDS
        hang = "time.sleep(600)\n"
        monkeypatch.setattr(atlas, "WORKER", _fake_worker(tmp_path, hang))
        monkeypatch.setattr(atlas, "WORKER_SECONDS_PER_FACE", 0.0)
        monkeypatch.setenv(atlas.SECONDS_ENV, "1")
        v, f = _scan()
        with pytest.raises(TextonError, match=r"within 1 s and was stopped; .*WARP_TEXTON_ATLAS_SECONDS"):
            atlas.make_atlas(v, f, 64, 2, name="scan.ply")
        for bad in ("soon", "-3", "nan", "0"):
            monkeypatch.setenv(atlas.SECONDS_ENV, bad)
            with pytest.raises(TextonError, match=r"^WARP_TEXTON_ATLAS_SECONDS: .* seconds > 0"):
                atlas.worker_limits(10, 64)

    def test_the_memory_cap_holds_the_worker(self, monkeypatch):
        # a cap of one byte per face: xatlas cannot allocate its charts (nor start its threads)
        for name, value in (("WORKER_BASE_BYTES", 0), ("WORKER_BYTES_PER_THREAD", 0), ("WORKER_BYTES_PER_FACE", 1.0),
                            ("WORKER_BYTES_PER_TEXEL", 0.0)):
            monkeypatch.setattr(atlas, name, value)
        v, f = _scan()
        with pytest.raises(TextonError, match=r"scan.ply: xatlas failed making the UV atlas \(over its memory cap"):
            atlas.make_atlas(v, f, 64, 2, charts="xatlas", name="scan.ply")

    def test_the_worker_runs_without_warp(self):
        # started by path, it imports neither the package nor Warp (a fresh process starts fast)
        import subprocess

        code = (f"import runpy, sys; sys.argv = ['w']; mods = set(sys.modules)\n"
                f"runpy.run_path({str(atlas.WORKER)!r}, run_name='not_main')\n"
                "print(sorted(m for m in set(sys.modules) - mods if m.split('.')[0] in ('warp', 'warp_texton')))")
        out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
        assert out.strip() == "[]"


@pytest.mark.slow
def test_xatlas_crash_on_an_icosphere_fails_that_mesh_and_the_batch_goes_on(tmp_path):
    """xatlas's own charting crashes (SIGSEGV) on a subdivided icosphere (6 subdivisions, 81,920 faces):
    one failed job naming it, the next mesh done, nothing written for the first."""
    trimesh.creation.icosphere(6).export(tmp_path / "ico.ply")
    trimesh.creation.torus(1.0, 0.35).export(tmp_path / "torus.ply")
    jobs = [SurfaceJob(str(tmp_path / name), _texton(), str(tmp_path / "out"), 0.02, bake=64, charts="xatlas",
                       device="cpu") for name in ("ico.ply", "torus.ply")]
    ico, torus = run_jobs(jobs)
    if ico.status == "done":
        pytest.skip("this xatlas charts the icosphere without crashing")
    assert ico.status == "failed" and ico.message.startswith(f"{tmp_path / 'ico.ply'}: xatlas crashed")
    assert "\n" not in ico.message
    assert torus.status == "done"
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == ["torus.glb"]
    # the default charting makes its atlas
    assert run_jobs([SurfaceJob(str(tmp_path / "ico.ply"), _texton(), str(tmp_path / "out"), 0.02, bake=64,
                                device="cpu")])[0].status == "done"


def test_the_atlas_is_priced_by_what_its_worker_holds():
    # the budget prices the worker's resident peak (a small mesh fits a 256 MiB budget, as in
    # the property suite), not its address-space cap, which maps far more than it touches
    from warp_texton.core.limits import scoped_budget

    box = trimesh.creation.box()
    with scoped_budget(memory=256 << 20):
        uv = atlas.make_atlas(box.vertices, box.faces, 64, 2, name="box.ply")
    assert uv is not None
    _, cap = atlas.worker_limits(len(box.faces), 64)
    assert cap > 256 << 20  # the cap alone would have refused it
    with scoped_budget(memory=32 << 20), pytest.raises(TextonError, match=r"box.ply: a UV atlas of 12 faces needs"):
        atlas.make_atlas(box.vertices, box.faces, 64, 2, name="box.ply")
