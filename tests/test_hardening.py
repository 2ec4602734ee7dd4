"""Regression tests of the hardening issue: one per class of failure it lists.

Silent wrong output (periods past int32 cells, integer arrays, texton files read
as images, values that overflow float32, the largest texton), bounded memory and
work (the budgets, applied before allocating), interrupts and disks (SIGTERM,
Ctrl-C, leftovers of killed writers, a full disk, long names), and one error type
with messages that name the parameter (the CLI option on the command line).
The property suite (test_properties.py) searches the same ground at random.
Failures in functions another issue owns are kept here as xfail tests that
name the owner, for the hand-over.
"""

from __future__ import annotations

import errno
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from warp_texton import (FilterOptions, Texton, TextonError, analyze, dsn, evaluate, gaussian_texture,
                         mix_textons, model_error, periodic_component, read_image, render_plane, synthesize,
                         synthesize_mixed, write_image)
from warp_texton.core import limits
from warp_texton.core.checks import MAX_VALUE, MIN_MNI
from warp_texton.files.images import atomic_path, remove_leftovers
from warp_texton.noise.engine import MAX_CELL_INDEX, noise_setup
from warp_texton.model.texton import MAX_TEXTON_SIDE
from helpers import assert_nothing_written, ctrl_c_default, parts, random_texton, raw_exr, run_cli

@pytest.fixture(autouse=True)
def fresh_budgets(monkeypatch):
    for env in (limits.BUDGET_ENV, limits.WORK_ENV):
        monkeypatch.delenv(env, raising=False)
    limits.set_memory_budget(None)
    limits.set_work_budget(None)
    yield
    limits.set_memory_budget(None)
    limits.set_work_budget(None)


@pytest.fixture
def image():
    """A 48 × 40 grey texture in [0, 1] with some structure (float64)."""
    rng = np.random.default_rng(3)
    u = rng.random((48, 40))
    return 0.5 * u + 0.25 * np.roll(u, 1, 0) + 0.25 * np.roll(u, 1, 1)


@pytest.fixture
def png(tmp_path, image):
    path = tmp_path / "in.png"
    Image.fromarray(np.round(image * 255).astype(np.uint8)).save(path)
    return path


@pytest.fixture
def texton_exr(tmp_path):
    path = tmp_path / "t.exr"
    random_texton((8, 8), seed=1).save(path)
    return path


def one_error(capsys) -> str:
    err = capsys.readouterr().err
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("warp-texton: error: "), err
    assert "Traceback" not in err
    return lines[0]


# ============================================================== silent wrong output
class TestPeriods:
    """A period is honoured or refused with its limit, in synthesize and evaluate alike."""

    T = random_texton((8, 8), seed=2)

    @pytest.mark.parametrize("period", [(167503724661.0, 167503724661.0), (2**31 * 5.4, 10.0), (10.0, 2**32 * 5.4)])
    def test_beyond_int32_cells_refused(self, period, device):
        for call in (lambda: synthesize(self.T, (8, 8), period=period, device=device),
                     lambda: evaluate(self.T, [[0.5, 0.5]], period=period, device=device)):
            with pytest.raises(TextonError, match=r"period \(.*\) texels spans .* at most 2\*\*30 cells"):
                call()

    def test_largest_period_is_honoured(self, device):
        setup = noise_setup(self.T, 30.0)
        side = setup.cell[0] / 1.0  # cells of the default grid, 0.6 of the support side
        big = (MAX_CELL_INDEX - 1) * side * 0.999  # just inside the limit
        s = noise_setup(self.T, 30.0, (big, big))
        assert s.period_cells[0] <= MAX_CELL_INDEX
        # the noise repeats after one period (within the noise's domain, ±2**30 cells)
        px = s.period_cells[0] * s.cell[0]
        pts = np.array([[0.5, 0.5], [-1000.25, 77.5]])
        a = evaluate(self.T, pts, period=(big, big), device=device)
        b = evaluate(self.T, pts - [px / 2, 0.0] + [px / 2, 0.0], period=(big, big), device=device)
        np.testing.assert_array_equal(a, b)
        c = evaluate(self.T, pts + [0.0, s.period_cells[1] * s.cell[1] / 4], period=(big, big), device=device)
        assert not np.allclose(a, c)  # not a small period in disguise

    def test_cli_period(self, tmp_path, texton_exr, capsys):
        out = tmp_path / "n.png"
        assert run_cli(["synthesize", texton_exr, "-o", out, "--width", 16, "--height", 16,
                        "--period", 167503724661, 167503724661, "--device", "cpu", "-q"]) == 2
        assert "--period (" in one_error(capsys)
        assert_nothing_written(out)


class TestIntegerImages:
    """Integer arrays are scaled by their dtype's range, as image files are, in every entry point."""

    @pytest.mark.parametrize("dtype", [np.uint8, np.uint16, np.int16, np.int32])
    def test_scaled_like_the_float_image(self, image, dtype):
        top = np.iinfo(dtype).max
        ints = np.round(image * top).astype(dtype)
        floats = ints / top  # what a file of these values reads as
        ta, tb = analyze(ints, size=8, iterations=3), analyze(floats, size=8, iterations=3)
        np.testing.assert_allclose(ta.coeffs, tb.coeffs, rtol=1e-4, atol=1e-6)
        np.testing.assert_allclose(ta.mean, tb.mean, rtol=1e-6)
        assert 0.0 <= float(ta.mean[0]) <= 1.0
        assert model_error(ints, ta) == pytest.approx(model_error(floats, ta), rel=1e-5)
        np.testing.assert_allclose(periodic_component(ints), periodic_component(floats), atol=1e-5)
        np.testing.assert_allclose(gaussian_texture(ints, (20, 24), seed=1), gaussian_texture(floats, (20, 24), seed=1),
                                   atol=1e-5)
        ma = mix_textons(ints, floats[::-1], [0.5], size=8, iterations=2)[0]
        mb = mix_textons(floats, floats[::-1], [0.5], size=8, iterations=2)[0]
        np.testing.assert_allclose(ma.coeffs, mb.coeffs, rtol=1e-4, atol=1e-6)

    def test_gravel_uint8_gives_a_texton_in_range(self):
        data = pytest.importorskip("skimage.data")
        t = analyze(data.gravel(), size=32, iterations=10)
        assert 0.0 < float(t.mean[0]) < 1.0  # was 126.5: the uint8 values taken as floats
        noise = synthesize(t, (64, 64), device="cpu")
        assert 0.0 < float(np.median(noise)) < 1.0 and noise.std() < 0.5

    def test_signed_and_boolean(self):
        b = np.zeros((16, 16), bool)
        b[::2] = True
        np.testing.assert_array_equal(periodic_component(b), periodic_component(b.astype(np.float32)))
        s = np.full((16, 16), -32767, np.int16)
        s[::3] = 32767
        p = periodic_component(s)
        assert p.min() >= -1.0 - 1e-6 and p.max() <= 1.0 + 1e-6  # scaled to about [-1, 1]

    def test_write_image_scales_integers_too(self, tmp_path, image):
        ints = np.round(image * 255).astype(np.uint8)
        write_image(tmp_path / "a.png", ints)
        write_image(tmp_path / "b.png", ints / 255.0)
        np.testing.assert_array_equal(read_image(tmp_path / "a.png"), read_image(tmp_path / "b.png"))
        np.testing.assert_array_equal(np.asarray(Image.open(tmp_path / "a.png")), ints)


class TestTextonFilesAreNotImages:
    def test_read_image_refuses_a_texton_exr(self, texton_exr):
        with pytest.raises(TextonError, match=r"t.exr: is a texton file, not an image; .*load_texton"):
            read_image(texton_exr)

    def test_read_image_refuses_a_texton_text_file(self, tmp_path):
        path = tmp_path / "t.texton"
        random_texton((4, 4), seed=3).save(path)
        with pytest.raises(TextonError, match=r"is a texton file, not an image"):
            read_image(path)

    @pytest.mark.parametrize("command", [["gaussian"], ["analyze"], ["synthesize-map"]])
    def test_cli_refuses_texton_where_an_image_is_expected(self, tmp_path, texton_exr, png, capsys, command):
        out = tmp_path / "g.png"
        if command == ["synthesize-map"]:
            argv = ["mix", png, png, "-o", out, "--map", texton_exr, "--size", 8, "-q"]
        elif command == ["analyze"]:
            out = tmp_path / "t2.exr"
            argv = ["analyze", texton_exr, "-o", out, "-q"]
        else:
            argv = ["gaussian", texton_exr, "-o", out]
        assert run_cli(argv) == 2
        assert "t.exr: is a texton file, not an image" in one_error(capsys)
        assert_nothing_written(out)

    def test_commands_that_document_textons_take_them(self, tmp_path, texton_exr):
        out = tmp_path / "n.png"
        assert run_cli(["synthesize", texton_exr, "-o", out, "--width", 8, "--height", 8, "--device", "cpu",
                        "-q"]) == 0


class TestValueRange:
    """Values whose arithmetic would overflow float32 are refused, naming the range;
    values at the limit give finite results everywhere."""

    @pytest.mark.parametrize("scale", [1e11, 1e20, 1e38])
    def test_huge_images_refused(self, image, scale):
        with pytest.raises(TextonError, match=r"u: pixels range from .*accepted: within ±1e\+10"):
            analyze(image * scale, size=8)

    def test_huge_coefficients_refused(self):
        with pytest.raises(TextonError, match=r"texton coefficients: values range .*within ±1e\+10"):
            Texton(np.full((4, 4), 1e38), [0.5])
        with pytest.raises(TextonError, match=r"texton mean: values range"):
            Texton(np.ones((4, 4)), [1e11])

    def test_values_at_the_limit_stay_finite(self, image, device):
        u = (image - 0.5) * 2 * MAX_VALUE
        t = analyze(u, size=16, iterations=5, order=5)
        assert np.isfinite(t.coeffs).all() and 0.0 < t.metadata["model_error"] < 1.0
        coeffs = np.random.default_rng(4).choice([-MAX_VALUE, MAX_VALUE], (16, 16, 3))
        big = Texton(coeffs, [MAX_VALUE] * 3, 3)
        for out in (synthesize(big, (24, 24), mni=200, device=device),
                    synthesize(big, (24, 24), mni=200, scale=0.05, filter="anisotropic", device=device),
                    evaluate(big, [[0.5, 0.5], [1e6, 3.0]], mni=200, device=device),
                    render_plane(big, (16, 16), mni=200, device=device),
                    dsn(big, (16, 16), mni=200),
                    synthesize_mixed([big, big], "strips", (16, 16), mni=200, device=device)):
            assert np.isfinite(out).all()

    def test_smallest_mni(self, device):
        t = random_texton((64, 64), seed=5)
        with pytest.raises(TextonError, match=r"mni must be at least 0.001"):
            synthesize(t, (8, 8), mni=1e-300, device=device)
        assert np.isfinite(synthesize(t, (32, 32), mni=MIN_MNI, device=device)).all()
        assert np.isfinite(evaluate(t, [[1.0, 2.0]], mni=MIN_MNI, device=device)).all()


class TestTextonSize:
    def test_up_to_the_image(self, image):
        t = analyze(image, size=40, iterations=3)  # the image is 48 x 40
        assert t.size == (40, 40)
        with pytest.raises(TextonError, match=r"too small for size 41.*size <= 40"):
            analyze(image, size=41)
        assert mix_textons(image, image[::-1], [0.5], size=40, iterations=2)[0].size == (40, 40)

    def test_cli(self, tmp_path, png, capsys):
        out = tmp_path / "t.exr"
        assert run_cli(["analyze", png, "-o", out, "--size", 40, "--iterations", 2, "-q"]) == 0
        assert run_cli(["analyze", png, "-o", tmp_path / "u.exr", "--size", 41, "-q"]) == 2
        assert "in.png: the image (40x48) is too small for --size 41" in one_error(capsys)


# ============================================================== memory and work
class TestBudgets:
    """Requests are priced before anything is allocated or computed, and refused with
    the estimate, the budget and what to change."""

    def test_large_texton_exr_refused_from_its_header(self, tmp_path):
        path = tmp_path / "big.exr"
        raw_exr(path, {"Y": np.zeros((MAX_TEXTON_SIDE + 1, 2), np.float32)}, texton_order=1, texton_mean=[0.5])
        from warp_texton import load_texton

        with pytest.raises(TextonError, match=r"a 2x4097 EXR texton; at most 4096 texels per side"):
            load_texton(path)

    def test_image_files_priced_from_their_header(self, tmp_path):
        exr, png = tmp_path / "a.exr", tmp_path / "a.png"
        raw_exr(exr, {"RGB": np.zeros((300, 400, 3), np.float32)})
        Image.new("RGB", (400, 300)).save(png)
        limits.set_memory_budget("1M")
        for path in (exr, png):
            with pytest.raises(TextonError, match=rf"{path.name}: a 400x300 image .* over the memory budget of 1 MiB"):
                read_image(path)
        limits.set_memory_budget(None)
        assert read_image(exr).shape == (300, 400, 3)

    @pytest.mark.parametrize("call, match", [
        (lambda u, t: analyze(u, size=10**9), r"size must be at most 4096"),
        (lambda u, t: analyze(u, size=16, iterations=10**9), r"work budget"),
        (lambda u, t: synthesize(t, (16384, 16384), mni=16000, device="cpu"), r"16384x16384 raster at MNI 16000"),
        (lambda u, t: synthesize(t, (4096, 4096), mni=30000, device="cpu"), r"work budget"),
        (lambda u, t: render_plane(t, (16384, 16384), device="cpu"), r"16384x16384 plane view .* budget"),
        (lambda u, t: dsn(t, (512, 512), mni=1e9), r"discrete spot noise .* memory budget"),
        (lambda u, t: mix_textons(u, u, np.linspace(0, 1, 100_000), size=8), r"mixing 100000 textons .* budget"),
        (lambda u, t: gaussian_texture(u, (16384, 16384)), r"Gaussian texture .* budget"),
        (lambda u, t: evaluate(t, np.broadcast_to(np.float32(0), (10**9, 2)), device="cpu"), r"points: .* budget"),
        (lambda u, t: synthesize(t, (64, 64), scale=0.25, filter=FilterOptions("supersample", supersample=64),
                                 mni=3000, device="cpu"), r"filter 'supersample' .* work budget"),
    ], ids=["analyze-size", "analyze-iterations", "synthesize-16384-mni16000", "synthesize-4096-mni30000",
            "render-plane-16384", "dsn-mni1e9", "mix-100000-steps", "gaussian-16384", "evaluate-1e8",
            "supersample"])
    def test_refused_at_once(self, image, call, match):
        t = random_texton((64, 64), seed=6)
        limits.set_memory_budget("4G")  # the same on every machine
        t0 = time.perf_counter()
        with pytest.raises(TextonError, match=match) as err:
            call(image, t)
        assert time.perf_counter() - t0 < 5.0  # priced, not attempted
        assert "\n" not in str(err.value)

    def test_budgets_are_configurable(self, image, monkeypatch):
        monkeypatch.setenv(limits.WORK_ENV, "1e5")
        with pytest.raises(TextonError, match=r"over the work budget of 1e\+05; .*WARP_TEXTON_WORK_BUDGET=1e"):
            analyze(image, size=8, iterations=50)
        monkeypatch.delenv(limits.WORK_ENV)
        analyze(image, size=8, iterations=2)
        limits.set_work_budget("1K")
        with pytest.raises(TextonError, match="work budget of 1e\\+03"):
            synthesize(random_texton(), (64, 64), device="cpu")

    def test_every_entry_point_prices_its_work(self, image, tmp_path):
        """Each computation that grows with its arguments checks the work budget (work_log)."""
        t = random_texton((8, 8), seed=7)
        calls = {
            "analyze": lambda: analyze(image, size=8, iterations=2),
            "mix_textons": lambda: mix_textons(image, image[::-1], [0.0, 1.0], size=8, iterations=2),
            "gaussian_texture": lambda: gaussian_texture(image, (20, 20)),
            "dsn": lambda: dsn(t, (16, 16)),
            "synthesize": lambda: synthesize(t, (16, 16), device="cpu"),
            "synthesize filtered": lambda: synthesize(t, (16, 16), scale=0.1, filter="mip", device="cpu"),
            "evaluate": lambda: evaluate(t, [[0.0, 0.0]], device="cpu"),
            "render_plane": lambda: render_plane(t, (8, 8), texel_size=0.05, device="cpu"),
            "synthesize_mixed": lambda: synthesize_mixed([t, t], "strips", (8, 8), device="cpu"),
        }
        for name, call in calls.items():
            with limits.work_log() as log:
                call()
            assert log and all(ops > 0 for _, ops in log), name

    def test_cli_refusals_name_the_options(self, tmp_path, png, texton_exr, capsys):
        out = tmp_path / "o.png"
        assert run_cli(["mix", png, png, "-o", out, "--steps", 100000, "--size", 8, "-q"]) == 2
        line = one_error(capsys)
        assert "work budget" in line and "fewer --steps" in line and "fewer --iterations" in line
        assert run_cli(["synthesize", texton_exr, "-o", out, "--width", 4096, "--height", 4096, "--mni", 30000,
                        "--device", "cpu", "-q"]) == 2
        assert "a lower --mni" in one_error(capsys)
        assert run_cli(["analyze", png, "-o", tmp_path / "t.exr", "--size", 1000000000, "-q"]) == 2
        assert "--size must be at most 4096" in one_error(capsys)
        assert_nothing_written(out)


# ============================================================== interrupts, disks and files
SLOW_WRITE = textwrap.dedent("""
    import sys, time
    import warp_texton.files.images as io
    def slow(path, img, **attributes):  # a write that takes its time, as a large EXR does
        with io.atomic_path(path) as tmp:
            with open(tmp, "wb") as f:
                f.write(b"x" * 4096)
            print("writing", flush=True)
            time.sleep(60)
    io.write_exr = slow
    from warp_texton.cli.parser import main
    sys.exit(main(sys.argv[1:]))
""")


def _interrupted(tmp_path, texton_exr, sig):
    out = tmp_path / "n.exr"
    proc = subprocess.Popen([sys.executable, "-c", SLOW_WRITE, "synthesize", str(texton_exr), "-o", str(out),
                             "--width", "32", "--height", "32", "--device", "cpu", "-q"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, preexec_fn=ctrl_c_default)
    try:
        assert proc.stdout.readline().strip() == "writing"
        assert parts(tmp_path), "the temporary file is there while writing"
        proc.send_signal(sig)
        _, err = proc.communicate(timeout=60)
    finally:
        proc.kill()
    return proc.returncode, err, out


class TestInterrupts:
    def test_sigterm_removes_the_temporary_file(self, tmp_path, texton_exr):
        status, err, out = _interrupted(tmp_path, texton_exr, signal.SIGTERM)
        assert status == 128 + signal.SIGTERM, err
        assert err.strip() == "warp-texton: terminated; nothing written"  # one line, as for Ctrl-C
        assert_nothing_written(out)

    def test_ctrl_c_is_one_line_and_status_130(self, tmp_path, texton_exr):
        status, err, out = _interrupted(tmp_path, texton_exr, signal.SIGINT)
        assert status == 130, err
        assert err.strip() == "warp-texton: interrupted; nothing written"
        assert_nothing_written(out)

    def test_leftovers_of_killed_writers_are_removed_by_the_next_write(self, tmp_path):
        out = tmp_path / "n.png"
        dead = subprocess.Popen([sys.executable, "-c", "pass"])
        dead.wait()
        from warp_texton.files.images import host_tag

        host = host_tag()
        killed = tmp_path / f".n.png.{dead.pid}-{host}.abcd1234.part"
        alive = tmp_path / f".n.png.{os.getpid()}-{host}.efgh5678.part"
        other = tmp_path / f".m.png.{dead.pid}-{host}.ijkl9012.part"
        for p in (killed, alive, other):
            p.write_bytes(b"partial")
        write_image(out, np.zeros((4, 4)))
        assert out.is_file() and not killed.exists()
        assert alive.exists() and other.exists()  # a live writer's, and another path's, stay
        assert remove_leftovers(tmp_path / "m.png") == [other]

    def test_sigkill_leaves_a_recognisable_file_the_next_run_removes(self, tmp_path, texton_exr):
        out = tmp_path / "n.exr"
        proc = subprocess.Popen([sys.executable, "-c", SLOW_WRITE, "synthesize", str(texton_exr), "-o", str(out),
                                 "--width", "16", "--height", "16", "--device", "cpu", "-q"],
                                stdout=subprocess.PIPE, text=True)
        assert proc.stdout.readline().strip() == "writing"
        proc.kill()
        proc.wait()
        left = parts(tmp_path)
        assert len(left) == 1 and left[0].startswith(f".n.exr.{proc.pid}-")
        assert run_cli(["synthesize", texton_exr, "-o", out, "--width", 16, "--height", 16, "--device", "cpu",
                        "-q"]) == 0
        assert out.is_file() and parts(tmp_path) == []


class TestDisks:
    def test_disk_full_png_names_the_file(self, tmp_path, texton_exr, capsys, monkeypatch):
        def full(self, fp, *a, **k):
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

        monkeypatch.setattr(Image.Image, "save", full)
        out = tmp_path / "n.png"
        assert run_cli(["synthesize", texton_exr, "-o", out, "--width", 8, "--height", 8, "--device", "cpu",
                        "-q"]) == 2
        assert one_error(capsys) == f"warp-texton: error: {out}: No space left on device"
        assert_nothing_written(out)

    def test_disk_full_exr_names_the_file(self, tmp_path, png, capsys, monkeypatch):
        import OpenEXR

        class Full:  # OpenEXR reports a failed write as a RuntimeError
            def __init__(self, *a, **k):
                pass

            def write(self, name):
                Path(name).write_bytes(b"x" * 10)
                raise RuntimeError(f'Failed to write pixel data to image file "{name}". No space left on device.')

        monkeypatch.setattr(OpenEXR, "File", Full)
        for command in (["analyze", png, "-o", tmp_path / "t.exr", "--size", 8, "--iterations", 2, "-q"],
                        ["gaussian", png, "-o", tmp_path / "g.exr"]):
            assert run_cli(command) == 2
            assert one_error(capsys) == f"warp-texton: error: {command[3]}: No space left on device"
            assert_nothing_written(command[3])
        with pytest.raises(OSError) as err:
            write_image(tmp_path / "w.exr", np.zeros((4, 4)))
        assert err.value.errno == errno.ENOSPC and err.value.filename == str(tmp_path / "w.exr")

    def test_a_real_full_disk(self, tmp_path, png, capsys):
        mount = tmp_path / "full"
        mount.mkdir()
        if subprocess.run(["mount", "-t", "tmpfs", "-o", "size=64k", "tmpfs", str(mount)],
                          capture_output=True).returncode != 0:
            pytest.skip("cannot mount a small tmpfs here (needs root); the simulated tests above cover it")
        try:
            for name in ("g.exr", "g.png"):
                out = mount / name
                assert run_cli(["gaussian", png, "-o", out, "--width", 512, "--height", 512]) == 2
                assert one_error(capsys) == f"warp-texton: error: {out}: No space left on device"
                assert_nothing_written(out)
        finally:
            subprocess.run(["umount", str(mount)], check=False)

    def test_names_near_the_limit(self, tmp_path):
        long = tmp_path / ("a" * 249 + ".png")  # 253 bytes: its temporary name had to be shortened
        write_image(long, np.zeros((4, 4)))
        assert long.is_file() and parts(tmp_path) == []
        too_long = tmp_path / ("b" * 252 + ".png")
        with pytest.raises(TextonError, match=r"the file name is 256 bytes long; the file system allows at most 255"):
            write_image(too_long, np.zeros((4, 4)))
        with pytest.raises(TextonError, match="256 bytes long"):
            random_texton().save(tmp_path / ("c" * 252 + ".exr"))

    def test_too_long_name_fails_before_the_work(self, tmp_path, texton_exr, capsys):
        out = tmp_path / ("n" * 300 + ".png")
        t0 = time.perf_counter()
        assert run_cli(["synthesize", texton_exr, "-o", out, "--device", "cpu", "-q"]) == 2
        assert "bytes long; the file system allows at most" in one_error(capsys)
        assert time.perf_counter() - t0 < 5.0

    def test_atomic_path_cleans_up_on_any_exception(self, tmp_path):
        for exc in (KeyboardInterrupt, SystemExit, ValueError):
            with pytest.raises(exc):
                with atomic_path(tmp_path / "x.bin") as tmp:
                    Path(tmp).write_bytes(b"1")
                    raise exc()
            assert_nothing_written(tmp_path / "x.bin")


# ============================================================== one error
class TestOneError:
    """Bad input raises TextonError naming the parameter; strings are not numbers."""

    T = random_texton((6, 6), seed=8)

    @pytest.mark.parametrize("call, match", [
        (lambda t: Texton(np.ones((4, 4)), mean="x"), r"texton mean must be one number per channel"),
        (lambda t: Texton(np.ones((4, 4)), [0.5], metadata=[1, 2]), r"texton metadata must be a dict"),
        (lambda t: Texton(np.ones((4, 4)), [0.5], order="1"), r"texton order must be one of"),
        (lambda t: Texton([["a", "b"]], [0.5]), r"texton coefficients must be"),
        (lambda t: read_image(None), r"path must be a file name"),
        (lambda t: write_image(None, np.zeros((2, 2))), r"path must be a file name"),
        (lambda t: FilterOptions("mip", fade_energy="0.1"), r"fade_energy must be a number"),
        (lambda t: FilterOptions("mip", lod_bias=1e300), r"lod_bias must be a number in \[-64, 64\]"),
        (lambda t: synthesize(t, (8, 8), rotation="30", device="cpu"), r"rotation must be a number, got '30'"),
        (lambda t: synthesize(t, (8, 8), offset=("1", "2"), device="cpu"), r"offset\[0\] must be a number"),
        (lambda t: synthesize(t, (8, 8), scale=1e9, device="cpu"), r"scale must be at most 10000"),
        (lambda t: synthesize(t, (8, 8), jacobian=[["1", "0"], ["0", "1"]], filter="mip", device="cpu"),
         r"jacobian must be an array"),
        (lambda t: synthesize(t, (8, 8), cell_factor=1e-300, device="cpu"), r"cell_factor must be between .* got 1e-300"),
        (lambda t: evaluate(t, [["1", "2"]], device="cpu"), r"points must be an array of shape \(N, 2\) of numbers"),
        (lambda t: render_plane(t, (8, 8), tilt="30", device="cpu"), r"tilt must be a number"),
        (lambda t: mix_textons(np.random.rand(16, 16), np.random.rand(16, 16), ["0.5"], size=4),
         r"rhos must be numbers in \[0, 1\]"),
        (lambda t: mix_textons(np.random.rand(16, 16), np.random.rand(16, 16), [0.5], size=4, periodic="no"),
         r"periodic must be True or False"),
        (lambda t: synthesize_mixed([t, t], [["0.5"] * 8] * 8, (8, 8), device="cpu"), r"weights must be"),
        (lambda t: analyze(np.random.rand(16, 16), size=4, color_correction=1), r"color_correction must be True"),
        (lambda t: gaussian_texture("img.png"), r"u: expected a numeric image array, got str"),
        (lambda t: t.save(Path("/nonexistent-folder/t.exr")), r"output folder .* does not exist"),
    ], ids=lambda v: None if callable(v) else v[:30])
    def test_texton_error(self, call, match):
        with pytest.raises(TextonError, match=match):
            call(self.T)

    @pytest.mark.parametrize("call, param", [
        (lambda t: synthesize(t, (8, 8), mni=0, device="cpu"), "mni"),
        (lambda t: synthesize(t, (8, 0), device="cpu"), "shape[1] (width)"),
        (lambda t: synthesize(t, (8, 8), offset=(np.nan, 0), device="cpu"), "offset[0]"),
        (lambda t: synthesize(t, (8, 8), seed=-1, device="cpu"), "seed"),
        (lambda t: render_plane(t, (8, 8), height=0, device="cpu"), "height (the camera's height above the plane)"),
        (lambda t: FilterOptions("mip", max_aniso=0), "max_aniso"),
        (lambda t: FilterOptions("bilinear"), "filter"),
        (lambda t: analyze(np.random.rand(16, 16), size=40), "u"),
        (lambda t: gaussian_texture(np.zeros((8, 8))), "u"),
    ], ids=["mni", "width", "offset", "seed", "camera height", "max_aniso", "filter", "size", "constant"])
    def test_error_names_its_parameter(self, call, param):
        """The error's param is the argument its message starts with; it survives pickling
        (errors cross process pools)."""
        import pickle

        with pytest.raises(TextonError) as info:
            call(self.T)
        err = info.value
        assert err.param == param and str(err).startswith(param), (err.param, str(err))
        copy = pickle.loads(pickle.dumps(err))
        assert (type(copy), str(copy), copy.param, copy.mentions) == (TextonError, str(err), err.param, err.mentions)

    def test_errors_list_the_arguments_their_advice_names(self):
        with pytest.raises(TextonError, match="too small for size 40") as info:
            analyze(np.random.rand(16, 16), size=40)
        assert info.value.mentions == ("size",)
        limits.set_work_budget("1K")  # the autouse fixture restores it
        with pytest.raises(TextonError, match="a lower mni") as info:
            synthesize(self.T, (64, 64), device="cpu")
        assert "mni" in info.value.mentions

    def test_texton_save_with_numpy_metadata(self, tmp_path):
        from warp_texton import load_texton

        t = Texton(np.ones((3, 3)), [0.5], metadata={"n": np.int64(3), "a": np.arange(2), "f": np.float32(0.5)})
        t.save(tmp_path / "t.exr")
        assert load_texton(tmp_path / "t.exr").metadata["a"] == [0, 1]
        t.metadata["bad"] = object()  # metadata stays a mutable dict
        with pytest.raises(TextonError, match=r"metadata\['bad'\]"):
            t.save(tmp_path / "u.exr")
        assert_nothing_written(tmp_path / "u.exr")

    @pytest.mark.parametrize("argv, message", [
        (["synthesize", "T", "--mni", "0"], "--mni must be a finite number > 0, got 0.0"),
        (["synthesize", "T", "--scale", "nan"], "--scale must be a finite number > 0"),
        (["synthesize", "T", "--rotation", "nan"], "--rotation must be a finite number, got nan"),
        (["synthesize", "T", "--offset", "nan", "0"], "--offset X must be a finite number"),
        (["synthesize", "T", "--period", "0", "5"], "--period PX must be a finite number > 0"),
        (["synthesize", "T", "--width", "0"], "--width must be at least 1"),
        (["render-plane", "T", "--camera-height", "0"], "--camera-height must be a finite number > 0"),
        (["render-plane", "T", "--texel-size", "-1"], "--texel-size must be a finite number > 0"),
        (["synthesize", "IMG", "--size", "100"], "in.png: the image (40x48) is too small for --size 100"),
        (["analyze", "FLAT", "--size", "8"], "flat.png: the image is constant"),
        (["mix", "IMG", "FLAT", "--size", "8"], "flat.png: the image is constant"),
        (["synthesize", "T", "--device", "tpu"], "--device: unknown device"),
    ])
    def test_cli_messages_name_options_and_files(self, tmp_path, png, texton_exr, capsys, argv, message):
        flat = tmp_path / "flat.png"
        Image.new("L", (32, 32), 128).save(flat)
        files = {"T": texton_exr, "IMG": png, "FLAT": flat}
        command, *rest = argv
        inputs = [files.get(a, a) for a in rest]
        out = tmp_path / ("o.exr" if command == "analyze" else "o.png")
        if command == "mix":
            argv = [command, *inputs[:2], "-o", out, *inputs[2:], "-q"]
        else:
            argv = [command, inputs[0], "-o", out, *inputs[1:], "-q"]
        assert run_cli(argv) == 2
        line = one_error(capsys)
        assert message in line, line
        assert " u:" not in line and "u, v" not in line


# ============================================================== meshes
@pytest.mark.parametrize("content", [b"\x89PNG\r\n\x1a\n\x00\xff\xfe", "SELF"])
def test_mesh_lists_binary_or_self_including(tmp_path, content):
    from warp_texton.surface.jobs import expand_meshes

    listing = tmp_path / "list.txt"
    listing.write_bytes(f"@{listing}\n".encode() if content == "SELF" else content)
    with pytest.raises(TextonError, match="list"):
        expand_meshes([f"@{listing}"])


@pytest.mark.parametrize("call", ["surface_noise-up", "texture_mesh-max_faces", "expand_meshes-None",
                                  "render_mesh-texel_size"])
def test_mesh_functions_raise_texton_error(call):
    import trimesh

    from warp_texton import render_mesh, surface_noise, texture_mesh
    from warp_texton.surface.jobs import expand_meshes

    t = random_texton((4, 4), seed=9)
    mesh = trimesh.creation.icosphere(0)
    calls = {
        "surface_noise-up": lambda: surface_noise(t, [[0, 0, 0]], [[0, 0, 1]], 0.1, up="abc", device="cpu"),
        "texture_mesh-max_faces": lambda: texture_mesh(mesh, t, 0.1, max_edge=0.5, max_faces="x", device="cpu"),
        "expand_meshes-None": lambda: expand_meshes([None]),
        "render_mesh-texel_size": lambda: render_mesh(mesh, t, (8, 8), texel_size=1e-300, device="cpu"),
    }
    with pytest.raises(TextonError):
        calls[call]()
