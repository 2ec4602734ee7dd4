"""Regression tests of the third hardening round (issue 31): one group per class it lists.

1. texton files whose histogram tables or centre hold huge, non-finite or decreasing
   values: refused on load, one line on the command line;
2. the device API's ``filtered_value`` against the filtered ``synthesize`` on odd and
   extreme texton shapes: identical wherever the raster is filtered, and the raster
   path's rounding bounded where it is not;
3. shader exports written over an earlier export: only the export's files change, a
   malformed marker is not an export, bad names and a ``--html`` page inside the
   export are refused before anything is written;
4. bakes on the mesh's own UVs: bad shapes refused, UVs without area refused, faces
   laid flat and small overlaps warned;
5. positive-real arguments whose float32 copy or reciprocal leaves float32: refused;
6. a bake priced from the command's options alone, before any mesh is read.

The property suite (tests/test_properties.py, with the device packers and
``export_shader`` in tests/property_api.py) searches the same ground at random.
"""

from __future__ import annotations

import json
import math
import os
import sys
from pathlib import Path

import numpy as np
import pytest
import trimesh
import warp as wp
from hypothesis import given, settings
from hypothesis import strategies as st

import device_kernels as user
from helpers import parts, random_texton, run_cli
from warp_texton import Texton, TextonError, analyze, bake_mesh, evaluate, export_shader, load_texton, synthesize
from warp_texton.core import limits
from warp_texton.runtimes import warp_api as td
from warp_texton.core.checks import MAX_POSITIVE, MIN_POSITIVE, check_positive
from warp_texton.surface.bake import check_bake_arguments
from warp_texton import FilterOptions
from warp_texton.noise.filtering import RasterPixels, needs_filtering
from warp_texton.model.histogram import MAX_CENTRE, MAX_TABLE_VALUE, HistogramTransform, gauss_grid
from warp_texton.files.images import write_exr
from warp_texton.noise.engine import noise_setup
from warp_texton.noise.raster import raster_geometry
from warp_texton.runtimes.export import EXPORT_FILES
from warp_texton.model.texton import EXR_TEXTON_VERSION

EPS32 = float(np.finfo(np.float32).eps)


@pytest.fixture(autouse=True)
def fresh_budgets(monkeypatch):
    for env in (limits.BUDGET_ENV, limits.WORK_ENV):
        monkeypatch.delenv(env, raising=False)
    limits.set_memory_budget(None)
    limits.set_work_budget(None)
    yield
    limits.set_memory_budget(None)
    limits.set_work_budget(None)


def error_lines(capsys) -> list[str]:
    return [line for line in capsys.readouterr().err.splitlines() if line.strip()]


def listing(folder: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir()) if p.is_file()}


# ------------------------------------------------------- 1. histogram tables
@pytest.fixture(scope="module")
def preserving_texton() -> Texton:
    u = np.random.default_rng(0).gamma(2.0, 0.1, size=(32, 32, 3))
    return analyze(u, size=8, histogram="preserve")


def write_with_histogram(path: Path, texton: Texton, transform: dict) -> Path:
    """A texton EXR whose histogram attribute is ``transform`` as written (NaN allowed)."""
    write_exr(path, texton.coeffs, texton_version=EXR_TEXTON_VERSION, texton_order=texton.order,
              texton_mean=[float(v) for v in texton.mean], texton_metadata="{}",
              texton_histogram=json.dumps(transform))
    return path


def corrupted(texton: Texton, case: str) -> dict:
    d = json.loads(texton.histogram.to_json())
    lut, centre = d["lut"], d["centre"]
    if case == "lut huge":
        lut[0][-1] = 1e300
    elif case == "lut -huge":
        lut[1][0] = -1e300
    elif case == "lut past float32":
        lut[2][-1] = 1e39
    elif case == "lut just over the bound":
        lut[0][-1] = 1.01 * MAX_TABLE_VALUE
    elif case == "lut all huge, monotone":
        d["lut"] = [[1e300 * (k - 512) for k in range(1024)]] * 3
    elif case == "lut two huge entries":
        d["lut"] = [[-1e308, 1e308]] * 3
    elif case == "lut NaN":
        lut[0][5] = float("nan")
    elif case == "lut decreasing":
        lut[1] = lut[1][::-1]
    elif case == "centre huge":
        centre[0] = 1e300
    elif case == "centre just over the bound":
        centre[2] = -1.01 * MAX_CENTRE
    elif case == "centre infinite":
        centre[1] = float("inf")
    elif case == "matrix huge":
        d["matrix"] = (np.array(d["matrix"]) * 1e200).tolist()
    else:
        raise AssertionError(case)
    return d


TABLE_CASES = ["lut huge", "lut -huge", "lut past float32", "lut just over the bound", "lut all huge, monotone",
               "lut two huge entries", "lut NaN", "lut decreasing", "centre huge", "centre just over the bound",
               "centre infinite", "matrix huge"]


@pytest.mark.parametrize("case", TABLE_CASES)
def test_bad_histogram_tables_refused_on_load(tmp_path, preserving_texton, case):
    path = write_with_histogram(tmp_path / "bad.exr", preserving_texton, corrupted(preserving_texton, case))
    with _no_warnings():
        with pytest.raises(TextonError, match="malformed histogram transform") as info:
            load_texton(path)
    assert "\n" not in str(info.value) and str(path) in str(info.value)


class _no_warnings:
    """No warning (a NumPy overflow, say) on the way to the refusal."""

    def __enter__(self):
        import warnings

        self._ctx = warnings.catch_warnings()
        self._ctx.__enter__()
        warnings.simplefilter("error")

    def __exit__(self, *exc):
        return self._ctx.__exit__(*exc)


@pytest.mark.parametrize("case", ["lut huge", "centre huge", "matrix huge", "lut two huge entries"])
def test_shader_command_prints_one_line(tmp_path, preserving_texton, case, capsys):
    path = write_with_histogram(tmp_path / "bad.exr", preserving_texton, corrupted(preserving_texton, case))
    assert run_cli(["shader", path, "--lang", "glsl", "-o", tmp_path / "out"]) == 2
    lines = error_lines(capsys)
    assert len(lines) == 1 and lines[0].startswith("warp-texton: error: ") and "histogram" in lines[0], lines
    assert not (tmp_path / "out").exists() and parts(tmp_path) == []


def test_tables_at_the_bound_are_accepted_and_stay_finite(preserving_texton, device):
    """A table reaching the bound (an example of values near ±10¹⁰) still gives finite colours."""
    tr = preserving_texton.histogram
    lut = np.array(tr.lut)
    lut[:, -1] = MAX_TABLE_VALUE
    lut[:, 0] = -MAX_TABLE_VALUE
    extreme = HistogramTransform(tr.matrix, np.full(3, MAX_CENTRE), lut)
    t = Texton(preserving_texton.coeffs, preserving_texton.mean, histogram=extreme)
    out = synthesize(t, (16, 16), seed=1, device=device)
    assert np.isfinite(out).all()


@settings(max_examples=200)
@given(value=st.floats(allow_nan=True, allow_infinity=True), where=st.sampled_from(["lut", "centre"]),
       index=st.integers(0, 1023))
def test_transform_values_are_finite_and_bounded_or_refused(value, where, index):
    """Any value placed in a grey transform's table or centre: a TextonError, or a transform whose
    colours are finite float32 (no value past the bounds is ever accepted)."""
    lut = gauss_grid(1024)[None, :] * 0.1
    centre = np.array([0.5])
    if where == "lut":
        lut = lut.copy()
        lut[0, index] = value
    else:
        centre = np.array([value])
    bound = MAX_TABLE_VALUE if where == "lut" else MAX_CENTRE
    try:
        tr = HistogramTransform(np.eye(1), centre, lut)
    except TextonError as exc:
        assert "\n" not in str(exc)
        ok = math.isfinite(value) and abs(value) <= bound and (where == "centre" or np.all(np.diff(lut) >= 0))
        assert not ok, f"refused a valid {where} value {value}: {exc}"
        return
    assert math.isfinite(value) and abs(value) <= bound
    colours = tr.to_colours(np.linspace(-6, 6, 97)[:, None]).astype(np.float32)
    assert np.isfinite(colours).all()


# --------------------------------------------- 2. filtered_value and synthesize
def device_pixels(texton, shape, scale, offset, options, seed, device):
    """(synthesize's raster, filtered_value at its pixels' centres and footprints, their centres)."""
    h, w = shape
    raster = synthesize(texton, shape, scale=scale, offset=offset, filter=options, seed=seed, device=device)
    origin, step = raster_geometry(shape, scale, 0.0, offset)
    centres = RasterPixels(shape, origin, step, step).centres(0, h * w)
    J = np.broadcast_to(step.astype(np.float32), (h * w, 2, 2)).copy()
    noise = td.pack_filtered(texton, filter=options, seed=seed, device=device)
    out = wp.zeros(h * w, dtype=wp.vec3, device=device)
    wp.launch(user.filtered_at, dim=h * w, inputs=[noise, wp.array(centres, dtype=wp.vec2d, device=device),
                                                   wp.array(J, dtype=wp.mat22, device=device)],
              outputs=[out], device=device)
    got = out.numpy()[:, :texton.channels].reshape(h, w, texton.channels)
    return raster, got, centres


EXTREME_SHAPES = [(1, 4096), (4096, 1), (1, 1), (7, 3), (1, 2), (3, 1000), (257, 5)]


def extreme_texton(shape, order=1, seed=0, gain=3.0):
    coeffs = np.random.default_rng(seed).standard_normal(shape + (1,)) * gain / np.sqrt(max(shape))
    return Texton(coeffs, [0.5], order=order)


@pytest.mark.parametrize("shape", EXTREME_SHAPES)
@pytest.mark.parametrize("options", ["mip", "anisotropic"])
@pytest.mark.parametrize("scale", [0.3, 0.04])
def test_filtered_value_is_the_filtered_raster_on_extreme_textons(shape, options, scale, device):
    texton = extreme_texton(shape, order=1 if shape[0] % 2 else 3)
    raster, got, _ = device_pixels(texton, (12, 10), scale, (5.0e5, -3.0), options, 2, device)
    assert np.array_equal(got, raster)


@settings(max_examples=25, deadline=None)
@given(rows=st.sampled_from([1, 2, 3, 5, 31, 64, 1000, 4096]), cols=st.sampled_from([1, 2, 3, 7, 64, 999, 4096]),
       scale=st.floats(0.01, 0.7), order=st.sampled_from([0, 1, 3]), options=st.sampled_from(["mip", "anisotropic"]),
       seed=st.integers(0, 2**32 - 1))
def test_filtered_value_identity_property(rows, cols, scale, order, options, seed):
    """Any texton shape, order and zoomed-out scale: the device API's filtered pixels are the
    filtered raster's bit for bit where the raster is filtered, and evaluate's bit for bit
    where no pixel needs filtering (CPU)."""
    if rows * cols > 1 << 20:
        rows = 1
    texton = extreme_texton((rows, cols), order=order, seed=seed % 1000)
    raster, got, centres = device_pixels(texton, (6, 7), scale, (-20.0, 1.0e4), options, seed, "cpu")
    step = raster_geometry((6, 7), scale, 0.0, (0.0, 0.0))[1]
    if needs_filtering(step, FilterOptions.of(options)):
        assert np.array_equal(got, raster)
    else:
        assert np.array_equal(got, evaluate(texton, centres, seed=seed, device="cpu").reshape(got.shape))


@pytest.mark.parametrize("shape", [(1, 4096), (4096, 1), (1000, 1000), (1, 1), (16, 16)])
@pytest.mark.parametrize("scale", [1.0, 3.0])
def test_unfiltered_rasters_take_the_raster_path_within_its_rounding(shape, scale, device):
    """Where no pixel needs filtering (one lookup of level 0), the filtered synthesize is the
    unfiltered raster and filtered_value is plane_value (evaluate): both exactly; the two
    differ by the raster path's float32 rounding, within the documented bound
    4 ε (r + s) S / √λ, S the sum of |h| over the impacts and λ ∫|h| (docs/renderers.md)."""
    texton = extreme_texton(shape)
    raster, got, centres = device_pixels(texton, (12, 16), scale, (0.0, 0.0), "mip", 1, device)
    h, w, c = raster.shape
    assert np.array_equal(raster, synthesize(texton, (h, w), scale=scale, seed=1, device=device))
    assert np.array_equal(got, evaluate(texton, centres, seed=1, device=device).reshape(h, w, c))
    absolute = Texton(np.abs(texton.coeffs), [0.0], order=texton.order)  # |h| ≤ h of |α|: ψ ≥ 0
    lam = noise_setup(texton, 30.0, None, 0.6).lam
    s = evaluate(absolute, centres, seed=1, device=device).reshape(h, w, c) * math.sqrt(lam) \
        + lam * absolute.integral[0]
    bound = 4.0 * EPS32 * (shape[0] + shape[1]) * s / math.sqrt(lam)
    assert np.all(np.abs(got - raster) <= bound)


# ---------------------------------------------------------------- 3. exports
@pytest.fixture
def grey_texton():
    return random_texton((8, 8), seed=3)


def test_overwrite_replaces_only_the_exports_files(tmp_path, grey_texton, preserving_texton):
    out = tmp_path / "export"
    export_shader(preserving_texton, "glsl", out)  # with colour tables
    assert {"texton_colours.f32", "texton_shares.f32"} <= set(os.listdir(out))
    (out / "notes.txt").write_text("mine")
    (out / "mine").mkdir()
    (out / "mine" / "a.glsl").write_text("kept")
    before = listing(out)
    export_shader(grey_texton, "glsl", out, overwrite=True, seed=5)
    names = set(os.listdir(out))
    assert (out / "notes.txt").read_text() == "mine" and (out / "mine" / "a.glsl").read_text() == "kept"
    assert "texton_colours.f32" not in names and "texton_shares.f32" not in names  # the earlier export's, removed
    assert before["texton_noise.json"] != (out / "texton_noise.json").read_bytes()
    assert json.loads((out / "texton_noise.json").read_text())["warp_texton"]
    assert parts(tmp_path) == [] and [p.name for p in tmp_path.iterdir()] == ["export"]
    # an OSL export over it: the GLSL files go, the user's stay
    export_shader(grey_texton, "osl", out, overwrite=True)
    assert set(os.listdir(out)) == {"notes.txt", "mine", "texton_surface.osl", "texton_plane.osl",
                                    "texton_noise_osl.json"}


def test_every_file_an_export_writes_is_listed(tmp_path, grey_texton, preserving_texton):
    written = set()
    from warp_texton.model.tiling import TilingModel

    from warp_texton import analyze

    example = np.random.default_rng(0).random((40, 40, 3)).astype(np.float32)
    tiling = TilingModel(example, 8.0)
    preserving_tiling = analyze(example, method="tiling", side=8, histogram="preserve")  # + its tables' file
    from tests.helpers import running_bond
    from warp_texton.model.lattice import Lattice

    wall = running_bond((64, 64))  # + the lattice-periodic mean's texture
    lattice = TilingModel(wall, 16.0, wrap=(True, True),
                          lattice=Lattice.from_vectors([(16, 16), (16, -16)], wall.shape, (True, True)))
    for k, texton in enumerate((grey_texton, preserving_texton, tiling, preserving_tiling, lattice)):
        for lang in ("glsl", "osl"):
            written |= set(os.listdir(export_shader(texton, lang, tmp_path / f"{lang}{k}")))
    assert written == EXPORT_FILES


DEEP = "[" * 100_000 + "]" * 100_000


@pytest.mark.parametrize("marker", ["5", "null", "true", '"warp_texton"', '["warp_texton"]', DEEP, "{bad",
                                    b"\xff\xfe{", '{"warp": 1}'], ids=["number", "null", "true", "string", "list",
                                                                      "deep", "broken", "not-utf8", "other-key"])
def test_a_malformed_marker_is_not_an_export(tmp_path, grey_texton, marker, capsys):
    out = tmp_path / "folder"
    out.mkdir()
    meta = out / "texton_noise.json"
    meta.write_bytes(marker if isinstance(marker, bytes) else marker.encode())
    (out / "texton_noise.glsl").write_text("the user's own")
    before = listing(out)
    with pytest.raises(TextonError, match="not a shader export written by warp-texton") as info:
        export_shader(grey_texton, "glsl", out, overwrite=True)
    assert "\n" not in str(info.value)
    assert listing(out) == before and parts(tmp_path) == []
    texton = tmp_path / "t.exr"
    grey_texton.save(texton)
    assert run_cli(["shader", texton, "--lang", "glsl", "-o", out, "--overwrite"]) == 2
    lines = error_lines(capsys)
    assert len(lines) == 1 and "not a shader export" in lines[0], lines
    assert listing(out) == before


@pytest.mark.parametrize("name", ["x" * 300, "a\x00b"])
@pytest.mark.parametrize("as_path", [False, True])
def test_bad_export_names_refused(tmp_path, grey_texton, name, as_path):
    target = tmp_path / name if as_path else str(tmp_path) + "/" + name
    with pytest.raises(TextonError, match="out_dir|file name") as info:
        export_shader(grey_texton, "glsl", target)
    assert "\n" not in str(info.value) and list(tmp_path.iterdir()) == []


def test_names_at_the_limit_work(tmp_path, grey_texton):
    out = export_shader(grey_texton, "glsl", tmp_path / ("n" * 255))
    assert (out / "texton_noise.json").is_file()
    export_shader(grey_texton, "glsl", out, overwrite=True, seed=2)
    assert [p.name for p in tmp_path.iterdir()] == ["n" * 255]


def test_html_inside_the_export_folder_refused(tmp_path, grey_texton, capsys):
    texton = tmp_path / "t.exr"
    grey_texton.save(texton)
    out = tmp_path / "out"
    export_shader(grey_texton, "glsl", out)
    before = listing(out)
    for page in (out / "page.html", out / "preview.html", tmp_path / "x" / ".." / "out" / "p.html"):
        assert run_cli(["shader", texton, "--lang", "glsl", "-o", out, "--overwrite", "--seed", "4",
                        "--html", page]) == 2
        lines = error_lines(capsys)
        assert len(lines) == 1 and "--html" in lines[0], lines
        assert listing(out) == before
    # a page whose folder is missing: refused before the export is written
    fresh = tmp_path / "fresh"
    assert run_cli(["shader", texton, "--lang", "glsl", "-o", fresh, "--html", tmp_path / "no" / "p.html"]) == 2
    assert not fresh.exists() and parts(tmp_path) == []
    assert run_cli(["shader", texton, "--lang", "glsl", "-o", fresh, "--html", tmp_path / "p.html", "-q"]) == 0
    assert (tmp_path / "p.html").is_file() and (fresh / "texton_noise.glsl").is_file()


def test_a_failed_write_into_an_export_changes_nothing(tmp_path, grey_texton, monkeypatch):
    out = tmp_path / "out"
    export_shader(grey_texton, "glsl", out)
    (out / "notes.txt").write_text("mine")
    before = listing(out)
    calls = []
    real = Path.write_bytes

    def failing(self, data):
        calls.append(self.name)
        if len(calls) == 3:
            raise OSError(28, "No space left on device", str(self))
        return real(self, data)

    monkeypatch.setattr(Path, "write_bytes", failing)
    with pytest.raises(OSError):
        export_shader(grey_texton, "glsl", out, overwrite=True, seed=9)
    monkeypatch.undo()
    assert listing(out) == before and parts(tmp_path) == []


def test_a_folder_where_the_export_writes_a_file_is_refused(tmp_path, grey_texton):
    out = export_shader(grey_texton, "glsl", tmp_path / "out")
    (out / "preview.html").unlink()
    (out / "preview.html").mkdir()
    before = listing(out)
    with pytest.raises(TextonError, match="is a folder"):
        export_shader(grey_texton, "glsl", out, overwrite=True)
    assert listing(out) == before and parts(tmp_path) == []


# ----------------------------------------------------------- 4. mesh UVs
QUAD_V = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], float)
QUAD_F = np.array([[0, 1, 2], [0, 2, 3]])


def uv_mesh(uv, vertices=QUAD_V, faces=QUAD_F):
    mesh = trimesh.Trimesh(vertices, faces, process=False)
    mesh.visual = trimesh.visual.TextureVisuals(uv=uv)
    return mesh


def bake(mesh, **kw):
    t = random_texton((4, 4), seed=1)
    return bake_mesh(mesh, t, 1 / 32, resolution=32, device="cpu", name="m.obj", **kw)


@pytest.mark.parametrize("uv, match", [
    (np.array([[0.2, 0.3]]), r"shape \(1, 2\)"), (np.array([0.2, 0.3, 0.4, 0.5]), r"shape \(4,\)"),
    (np.random.default_rng(0).random((4, 3)), r"shape \(4, 3\)"), (np.zeros((0, 2)), r"shape \(0, 2\)"),
    (np.array([[0, 0], [2, 0], [2, 2], [0, 2]], float), "outside"),
    (np.array([[0, 0], [1, 0], [1, 1], [1, 0]], float), "overlap"),
    (np.full((4, 2), 0.5), "no area"), (np.array([[0, 0], [1, 1], [0.5, 0.5], [0.25, 0.25]]), "no area")],
    ids=["one-row", "1-D", "3-columns", "empty", "outside", "full-overlap", "one-point", "one-line"])
def test_unusable_mesh_uvs_refused(uv, match):
    with pytest.raises(TextonError, match=match) as info:
        bake(uv_mesh(uv))
    message = str(info.value)
    assert message.startswith("m.obj: ") and "uv='atlas'" in message and "\n" not in message


@pytest.mark.parametrize("uv", [np.array([[0.2, 0.3]]), np.zeros((4, 2)), [[0, 0]] * 4, None, 1, "MESH"])
def test_uv_is_a_choice(uv):
    with pytest.raises(TextonError, match="uv must be one of") as info:
        bake(uv_mesh(np.array([[0, 0], [1, 0], [1, 1], [0, 1]], float)), uv=uv)
    assert "\n" not in str(info.value)


def test_faces_laid_flat_are_warned():
    # two quads; the second's UV triangles are lines
    v = np.concatenate([QUAD_V, QUAD_V + [2, 0, 0]])
    f = np.concatenate([QUAD_F, QUAD_F + 4])
    uv = np.array([[0, 0], [0.5, 0], [0.5, 1], [0, 1], [0.7, 0.2], [0.8, 0.2], [0.9, 0.2], [0.7, 0.2]], float)
    with pytest.warns(UserWarning, match=r"m.obj: 2 of 4 faces \(50 % of the surface\) have UV triangles without"):
        baked = bake(uv_mesh(uv, v, f))
    assert baked.uv_source == "mesh"


def test_small_overlaps_are_warned():
    # two quads side by side in UV space, the second shifted onto the first by 1/256
    v = np.concatenate([QUAD_V, QUAD_V + [2, 0, 0]])
    f = np.concatenate([QUAD_F, QUAD_F + 4])
    uv = np.array([[0, 0], [0.5, 0], [0.5, 1], [0, 1], [0.5, 0], [1, 0], [1, 1], [0.5, 1]], float)
    uv[4:, 0] -= 1 / 256
    t = random_texton((4, 4), seed=1)
    with pytest.warns(UserWarning, match=r"m.obj: its UVs overlap \(0\.[0-9]+ % .*--uv atlas"):
        baked = bake_mesh(uv_mesh(uv, v, f), t, 1 / 64, resolution=256, device="cpu", name="m.obj")
    assert baked.uv_source == "mesh"


def test_clean_uvs_bake_without_warnings(recwarn):
    bake(uv_mesh(np.array([[0, 0], [1, 0], [1, 1], [0, 1]], float)))
    assert not [w for w in recwarn if "UV" in str(w.message)]


@settings(max_examples=40, deadline=None)
@given(shape=st.sampled_from([(1,), (4,), (8,), (1, 2), (3, 2), (5, 2), (4, 1), (4, 3), (2, 4), (4, 2, 1)]),
       scale=st.sampled_from([1.0, 3.0, -1.0, 1e-9]))
def test_any_uv_array_bakes_or_is_refused(shape, scale):
    """Any UV array on the quad: a bake, or one TextonError naming the mesh; never an IndexError."""
    uv = np.random.default_rng(len(shape) * 7 + shape[0]).random(shape) * scale
    try:
        mesh = uv_mesh(uv)
    except (ValueError, IndexError):
        return  # trimesh itself refuses to hold it
    try:
        bake(mesh)
    except TextonError as exc:
        assert str(exc).startswith("m.obj: ") and "\n" not in str(exc)


# ------------------------------------------------------ 5. positive reals
OUT_OF_FLOAT32 = [5e-324, 1e-320, 1e-45, 1e-39, 1e38, 3.4e38, 1e39, 1e300]


@pytest.mark.parametrize("value", OUT_OF_FLOAT32)
@pytest.mark.parametrize("call, param", [
    (lambda t, v: td.pack_surface(t, 0.01, cell_factor=v, device="cpu"), "cell_factor"),
    (lambda t, v: td.pack_surface(t, v, device="cpu"), "texel_size"),
    (lambda t, v: td.pack_surface(t, 0.01, mni=v, device="cpu"), "mni"),
    (lambda t, v: td.pack_plane(t, cell_factor=v, device="cpu"), "cell_factor"),
    (lambda t, v: td.pack_plane(t, period=(v, 64.0), device="cpu"), "period[0]"),
    (lambda t, v: td.pack_filtered(t, cell_factor=v, device="cpu"), "cell_factor"),
    (lambda t, v: evaluate(t, [[0.5, 0.5]], cell_factor=v, device="cpu"), "cell_factor"),
    (lambda t, v: synthesize(t, (4, 4), scale=v, device="cpu"), "scale")],
    ids=["pack_surface-cell", "pack_surface-texel", "pack_surface-mni", "pack_plane-cell", "pack_plane-period",
         "pack_filtered-cell", "evaluate-cell", "synthesize-scale"])
def test_positive_reals_past_float32_refused(call, param, value):
    import warnings

    t = random_texton((8, 8), seed=2)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no overflow warning on the way
        with pytest.raises(TextonError, match="fit float32|must be") as info:
            call(t, value)
    assert info.value.param == param and "\n" not in str(info.value)


@given(st.floats(allow_nan=True, allow_infinity=True) | st.integers(-10**400, 10**400))
def test_check_positive_keeps_the_value_and_its_reciprocal_in_float32(value):
    try:
        got = check_positive(value, "x")
    except TextonError as exc:
        assert exc.param == "x"
        assert not (isinstance(value, float) and math.isfinite(value) and MIN_POSITIVE <= value <= MAX_POSITIVE)
        return
    assert got > 0 and MIN_POSITIVE <= got <= MAX_POSITIVE
    f, r = np.float32(got), np.float32(1.0 / got)
    assert np.isfinite(f) and np.isfinite(r) and f >= np.finfo(np.float32).tiny and r >= np.finfo(np.float32).tiny


# ------------------------------------------------------------ 6. bake prices
@pytest.fixture
def surface_inputs(tmp_path):
    texton = tmp_path / "t.exr"
    random_texton((8, 8), seed=1).save(texton)
    mesh = tmp_path / "sphere.ply"
    trimesh.creation.icosphere(subdivisions=2).export(mesh)
    return texton, mesh


@pytest.mark.parametrize("budget, extra", [("1e9", []), ("5e9", ["--uv", "atlas"])])
def test_bake_priced_before_the_batch(surface_inputs, tmp_path, monkeypatch, capsys, budget, extra):
    texton, mesh = surface_inputs
    monkeypatch.setenv(limits.WORK_ENV, budget)
    out = tmp_path / "out"
    status = run_cli(["surface", mesh, "--texton", texton, "--out-dir", out, "--bake", "1024", "--supersample", "64",
                      *extra])
    err = capsys.readouterr().err
    lines = [line for line in err.splitlines() if line.strip()]
    assert status == 2
    assert len(lines) == 1 and "work budget" in lines[0] and "--supersample" in lines[0] and "--bake" in lines[0]
    assert "surface:" not in err and "failed" not in err  # no batch, no progress bar
    assert not out.exists()


def test_bakes_within_the_price_still_run(surface_inputs, tmp_path, monkeypatch):
    texton, mesh = surface_inputs
    monkeypatch.setenv(limits.WORK_ENV, "1e9")
    assert run_cli(["surface", mesh, "--texton", texton, "--out-dir", tmp_path / "out", "--bake", "32", "-q"]) == 0
    assert (tmp_path / "out" / "sphere.glb").is_file()


def test_check_bake_arguments():
    t = random_texton((8, 8), seed=1)
    limits.set_work_budget(1e9)
    with pytest.raises(TextonError, match="work budget") as info:
        check_bake_arguments(t, 1024, supersample=64)
    assert info.value.param == "supersample" and {"resolution", "mni"} <= set(info.value.mentions)
    with pytest.raises(TextonError, match="work budget"):
        check_bake_arguments(t, 256, supersample=32, uv="atlas")  # 256² / 4 texels of 32² samples
    check_bake_arguments(t, 256, supersample=32)  # the mesh's UVs may cover little: priced per mesh
    for bad, match in (({"uv": "box"}, "uv must be"), ({"supersample": 0}, "supersample"),
                       ({"resolution": 10**6}, "resolution")):
        kw = {"resolution": 64, **bad}
        with pytest.raises(TextonError, match=match):
            check_bake_arguments(t, kw.pop("resolution"), **kw)
    limits.set_memory_budget("64M")
    with pytest.raises(TextonError, match="memory budget"):
        check_bake_arguments(t, 4096)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(pytest.main([__file__, "-q"]))
