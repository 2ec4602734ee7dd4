"""NoiseOptions and AnalysisOptions: frozen, checked option values that the front ends,
the command line and the viewer pass instead of keyword lists.

Each value is checked once when made (an error names the field), cannot be changed,
and gives through ``noise=`` / ``options=`` bit for bit what the 0.2 keywords give.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from helpers import random_texton, run_cli
from warp_texton import (AnalysisOptions, NoiseOptions, TextonError, analyze, evaluate, export_shader, mix_textons,
                         surface_noise, synthesize)

NOISE_BAD = [
    ("mni", {"mni": 0}), ("mni", {"mni": float("nan")}), ("mni", {"mni": 1e-4}), ("mni", {"mni": "30"}),
    ("seed", {"seed": -1}), ("seed", {"seed": 2**32}), ("seed", {"seed": 1.5}), ("seed", {"seed": True}),
    ("period", {"period": (64,)}), ("period", {"period": "ab"}), ("period[0]", {"period": (0, 64)}),
    ("period[1]", {"period": (64, float("inf"))}),
    ("poisson", {"poisson": "fast"}), ("poisson", {"poisson": None}),
    ("cell_factor", {"cell_factor": 0}), ("cell_factor", {"cell_factor": -0.6}), ("cell_factor", {"cell_factor": "x"}),
]
ANALYSIS_BAD = [
    ("size", {"size": 1}), ("size", {"size": 4097}), ("size", {"size": 32.0}),
    ("order", {"order": 2}), ("order", {"order": "1"}),
    ("iterations", {"iterations": 0}), ("seed", {"seed": -1}),
    ("periodic", {"periodic": 1}), ("color_correction", {"color_correction": "no"}),
    ("support", {"support": "circle"}), ("histogram", {"histogram": "uniform"}),
]


@pytest.fixture(scope="module")
def example():
    """A small grey example image (a smoothed white noise: a Gaussian texture)."""
    import scipy.ndimage as ndi

    u = ndi.gaussian_filter(np.random.default_rng(5).standard_normal((48, 56)), 1.5)
    return (0.5 + 0.1 * u / u.std()).astype(np.float32)


# ------------------------------------------------------------------ the values
class TestNoiseOptions:
    @pytest.mark.parametrize("field, kwargs", NOISE_BAD, ids=[f"{f}-{k}" for f, k in NOISE_BAD])
    def test_error_names_the_field(self, field, kwargs):
        with pytest.raises(TextonError) as info:
            NoiseOptions(**kwargs)
        assert info.value.param == field and field.split("[")[0] in str(info.value)

    def test_values_are_normalised_and_equal_by_value(self):
        a = NoiseOptions(mni=40, seed=np.uint32(3), period=[256, 128])
        assert (a.mni, a.seed, a.period) == (40.0, 3, (256.0, 128.0))
        assert type(a.mni) is float and type(a.seed) is int and type(a.period[0]) is float
        assert a == NoiseOptions(mni=40.0, seed=3, period=(256.0, 128.0)) and hash(a) == hash(NoiseOptions(
            mni=40.0, seed=3, period=(256.0, 128.0)))
        assert a != a.replace(seed=4) and a.replace(seed=4).seed == 4 and a.seed == 3

    def test_frozen(self):
        a = NoiseOptions()
        with pytest.raises(dataclasses.FrozenInstanceError):
            a.mni = 10.0  # type: ignore[misc]
        with pytest.raises(TextonError, match="poisson"):
            a.replace(poisson="fast")  # a changed copy is checked again


class TestAnalysisOptions:
    @pytest.mark.parametrize("field, kwargs", ANALYSIS_BAD, ids=[f"{f}-{k}" for f, k in ANALYSIS_BAD])
    def test_error_names_the_field(self, field, kwargs):
        with pytest.raises(TextonError) as info:
            AnalysisOptions(**kwargs)
        assert info.value.param == field and field in str(info.value)

    def test_frozen_and_equal_by_value(self):
        a = AnalysisOptions(size=np.int64(32), periodic=np.bool_(False))
        assert type(a.size) is int and a.periodic is False
        assert a == AnalysisOptions(size=32, periodic=False) and a != AnalysisOptions(size=32)
        with pytest.raises(dataclasses.FrozenInstanceError):
            a.size = 16  # type: ignore[misc]

    def test_analyze_refuses_what_the_options_refuse(self, example):
        """analyze's keywords go through AnalysisOptions: the same errors, naming the argument."""
        for field, kwargs in ANALYSIS_BAD:
            with pytest.raises(TextonError) as info:
                analyze(example, **kwargs)
            assert info.value.param == field


# ------------------------------------------------------------------ keywords or one value
class TestSameResults:
    """Through ``noise=`` / ``options=`` every front end gives what its keywords give, bit for bit."""

    NOISE = dict(mni=17.0, seed=12345, period=(96.0, 80.0), poisson="gaussian", cell_factor=0.8)

    def test_synthesize_and_evaluate(self):
        t = random_texton((6, 7), channels=3, seed=4)
        opts = NoiseOptions(**self.NOISE)
        for kw in ({}, {"scale": 0.6, "rotation": 20.0, "offset": (5.0, -3.0)}, {"filter": "mip", "scale": 0.3}):
            a = synthesize(t, (40, 48), device="cpu", **self.NOISE, **kw)
            b = synthesize(t, (40, 48), device="cpu", noise=opts, **kw)
            assert np.array_equal(a, b)
        # a different option changes the noise: the value is not ignored
        assert not np.array_equal(b, synthesize(t, (40, 48), device="cpu", noise=opts.replace(seed=1), **kw))
        pts = np.random.default_rng(0).uniform(-200, 200, (300, 2))
        assert np.array_equal(evaluate(t, pts, device="cpu", **self.NOISE), evaluate(t, pts, device="cpu", noise=opts))

    def test_surface_noise(self):
        t = random_texton((6, 6), channels=1, seed=2)
        rng = np.random.default_rng(1)
        p, n = rng.normal(size=(200, 3)), rng.normal(size=(200, 3))
        kw = dict(mni=45.0, seed=9, poisson="gaussian", cell_factor=0.7)
        a = surface_noise(t, p, n, 0.05, device="cpu", **kw)
        assert np.array_equal(a, surface_noise(t, p, n, 0.05, device="cpu", noise=NoiseOptions(**kw)))
        # the surface default is MNI 60, not the plane's 30
        assert np.array_equal(surface_noise(t, p, n, 0.05, device="cpu"),
                              surface_noise(t, p, n, 0.05, device="cpu", noise=NoiseOptions(mni=60.0)))
        with pytest.raises(TextonError, match="surface noise has no period") as info:
            surface_noise(t, p, n, 0.05, device="cpu", noise=NoiseOptions(period=(10, 10)))
        assert info.value.param == "period"

    def test_device_packers(self):
        from warp_texton.runtimes.warp_api import pack_filtered, pack_plane, pack_surface

        t = random_texton((5, 5), channels=1, seed=3)
        opts = NoiseOptions(**self.NOISE)

        def record(struct):  # every field of the kernels' parameters, and the coefficients
            return repr(struct.params), struct.coeffs.numpy().tobytes() if hasattr(struct, "coeffs") else None

        assert record(pack_plane(t, device="cpu", **self.NOISE)) == record(pack_plane(t, device="cpu", noise=opts))
        assert record(pack_plane(t, device="cpu", **self.NOISE)) != record(pack_plane(t, device="cpu"))
        assert record(pack_filtered(t, device="cpu", **self.NOISE)) == record(
            pack_filtered(t, device="cpu", noise=opts))
        kw = dict(mni=50.0, seed=8, poisson="gaussian", cell_factor=0.9)
        assert record(pack_surface(t, 0.1, device="cpu", **kw)) == record(
            pack_surface(t, 0.1, device="cpu", noise=NoiseOptions(**kw)))

    def test_shader_exports(self, tmp_path):
        from warp_texton.runtimes.glsl.texton import preview_html
        from warp_texton.runtimes.osl.texton import osl_files

        t = random_texton((5, 6), channels=3, seed=6)
        opts = NoiseOptions(**self.NOISE)
        for lang in ("glsl", "osl"):
            a = export_shader(t, lang, tmp_path / f"{lang}_kw", **self.NOISE)
            b = export_shader(t, lang, tmp_path / f"{lang}_opts", noise=opts)
            names = sorted(p.name for p in a.iterdir())
            assert names == sorted(p.name for p in b.iterdir())
            for name in names:
                assert (a / name).read_bytes() == (b / name).read_bytes(), name
        assert osl_files(t, **self.NOISE) == osl_files(t, noise=opts)
        assert preview_html(t, (32, 32), **self.NOISE) == preview_html(t, (32, 32), noise=opts)

    def test_dask(self):
        pytest.importorskip("dask")
        from warp_texton.noise.dask_arrays import synthesize_dask

        t = random_texton((6, 6), channels=1, seed=7)
        a = synthesize_dask(t, (50, 60), chunks=32, device="cpu", **self.NOISE)
        b = synthesize_dask(t, (50, 60), chunks=32, device="cpu", noise=NoiseOptions(**self.NOISE))
        assert np.array_equal(a.compute(), b.compute())
        assert np.array_equal(b.compute(), synthesize(t, (50, 60), device="cpu", **self.NOISE))

    def test_analyze_and_mix(self, example):
        kw = dict(size=12, order=3, iterations=7, seed=4, periodic=False, color_correction=False, support="disk")
        a = analyze(example, **kw)
        b = analyze(example, options=AnalysisOptions(**kw))
        assert np.array_equal(a.coeffs, b.coeffs) and np.array_equal(a.mean, b.mean) and a.metadata == b.metadata
        assert not np.array_equal(a.coeffs, analyze(example, options=AnalysisOptions(**{**kw, "seed": 5})).coeffs)
        v = example[::-1, ::-1].copy()
        ma = mix_textons(example, v, [0.0, 0.5], **kw)
        mb = mix_textons(example, v, [0.0, 0.5], options=AnalysisOptions(**kw))
        assert all(np.array_equal(x.coeffs, y.coeffs) for x, y in zip(ma, mb))
        with pytest.raises(TextonError, match="histogram") as info:
            mix_textons(example, v, [0.5], options=AnalysisOptions(histogram="preserve"))
        assert info.value.param == "histogram"


class TestOnePlace:
    """A setting given both as a keyword and in the value is refused, naming the keyword."""

    def test_noise_and_keyword(self):
        t = random_texton((4, 4), seed=1)
        with pytest.raises(TextonError, match="seed is given both") as info:
            synthesize(t, (8, 8), seed=3, noise=NoiseOptions(seed=3), device="cpu")
        assert info.value.param == "seed"
        with pytest.raises(TextonError) as info:
            evaluate(t, [[0.5, 0.5]], period=(8, 8), noise=NoiseOptions(), device="cpu")
        assert info.value.param == "period"
        # keywords at their defaults beside the value: the value holds
        assert np.array_equal(synthesize(t, (8, 8), mni=30.0, seed=0, noise=NoiseOptions(seed=2), device="cpu"),
                              synthesize(t, (8, 8), seed=2, device="cpu"))

    def test_wrong_type(self, example):
        t = random_texton((4, 4), seed=1)
        with pytest.raises(TextonError, match="noise must be a NoiseOptions") as info:
            synthesize(t, (8, 8), noise={"mni": 30.0}, device="cpu")
        assert info.value.param == "noise"
        with pytest.raises(TextonError, match="options must be an AnalysisOptions") as info:
            analyze(example, options=NoiseOptions())
        assert info.value.param == "options"
        with pytest.raises(TextonError, match="size is given both") as info:
            analyze(example, size=16, options=AnalysisOptions(size=16))
        assert info.value.param == "size"


# ------------------------------------------------------------------ the command line and the viewer
def test_cli_synthesize_is_the_api(tmp_path):
    """The CLI makes one NoiseOptions of --mni, --seed and --period: its EXR is synthesize's."""
    from warp_texton import read_image

    t = random_texton((6, 6), channels=3, seed=11)
    t.save(tmp_path / "t.exr")
    out = tmp_path / "n.exr"
    assert run_cli(["synthesize", tmp_path / "t.exr", "-o", out, "--width", 40, "--height", 32, "--mni", 21,
                    "--seed", 6, "--period", 64, 48, "--device", "cpu", "-q"]) == 0
    want = synthesize(t, (32, 40), noise=NoiseOptions(mni=21, seed=6, period=(64, 48)), device="cpu")
    assert np.array_equal(read_image(out), want)


def test_cli_bad_option_names_the_flag(tmp_path, capsys):
    t = random_texton((6, 6), seed=11)
    t.save(tmp_path / "t.exr")
    assert run_cli(["synthesize", tmp_path / "t.exr", "-o", tmp_path / "n.exr", "--period", 0, 48, "-q"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--period" in err[0], err
    assert not (tmp_path / "n.exr").exists()


def test_viewer_controls_make_the_values():
    from warp_texton.view.queries import ANALYSIS_SEED, Analysis, Noise

    assert Noise(seed=4, mni=12.5).options() == NoiseOptions(mni=12.5, seed=4)
    assert Analysis(size=32, order=0, color_correction=False).options() == AnalysisOptions(
        size=32, order=0, seed=ANALYSIS_SEED, color_correction=False)
