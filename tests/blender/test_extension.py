"""The Blender extension (issue 43, item 4): ``warp-texton blender-extension`` writes a zip whose
manifest is complete and that Blender's validator accepts; it installs into Blender (``bpy``, a user
folder of its own) and its operator gives the default cube a material that Cycles renders with
texture, from the OSL node and from the EEVEE branch's bake, against the same cube with a flat colour.

The zip is built once per session with ``wheels_dir`` (the dependencies downloaded once by
``pip download``, which reaches PyPI in CI); the Blender side is tests/blender_extension.py.
"""

from __future__ import annotations

import json
import zipfile
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from clients import has_bpy, require, run_blender
from helpers import parts, run_cli
from warp_texton import TextonError
from warp_texton.blender import PLATFORMS, build_extension
from warp_texton.blender.extension import MANIFEST
from warp_texton.blender.manifest import EXTENSION_ID, PERMISSIONS, manifest_text, this_platform
from warp_texton.blender.wheels import dependency_wheels, requirements
from warp_texton.demo import demo_texture_path

tomllib = pytest.importorskip("tomllib")  # Python 3.11+, as Blender's

SCRIPT = Path(__file__).resolve().parents[1] / "blender_extension.py"
#: Every field schema 1.0.0 requires (Blender's validator: bl_pkg/cli/blender_ext.py, PkgManifest).
REQUIRED = ("schema_version", "id", "version", "name", "tagline", "maintainer", "type", "blender_version_min",
            "license")
SIZE = 96
#: An 8-bit step: the smallest pixel difference a PNG holds.
STEP = 1.0


# ------------------------------------------------------------------ the manifest and the wheels, no Blender
def test_manifest_has_every_required_field_and_declares_permissions():
    wheels = ["./wheels/a-1.0-py3-none-any.whl", "./wheels/b-2.0-cp311-cp311-win_amd64.whl"]
    m = tomllib.loads(manifest_text(["linux-x64", "windows-x64"], wheels))
    assert all(m.get(k) for k in REQUIRED), [k for k in REQUIRED if not m.get(k)]
    assert m["schema_version"] == "1.0.0" and m["type"] == "add-on" and m["id"] == EXTENSION_ID
    assert m["license"] == ["SPDX:MIT"] and m["platforms"] == ["linux-x64", "windows-x64"]
    assert m["wheels"] == wheels
    assert m["permissions"] == PERMISSIONS and "files" in m["permissions"]
    # Blender's terse descriptions: at most 64 characters, no final punctuation
    for text in (m["tagline"], *m["permissions"].values()):
        assert len(text) <= 64 and text[-1].isalnum(), text


def test_the_bundled_requirements_leave_numpy_to_blender():
    names = {r.split(">")[0].split("=")[0].split("<")[0].strip().lower() for r in requirements()}
    assert {"warp-lang", "scipy", "openexr", "pillow", "tqdm", "trimesh", "xatlas"} <= names
    assert "numpy" not in names
    assert not any(n in names for n in ("dask", "zarr", "pytest", "mkdocs"))  # extras Blender's add-on never uses


@pytest.mark.parametrize("args, match", [
    (["--platform", "amiga-68k"], "amiga-68k"),
    (["--platform", "linux-x64", "--wheels-dir", "no_such_folder"], "no_such_folder is not a folder"),
])
def test_bad_options_exit_2_in_one_line_and_write_nothing(tmp_path, capsys, monkeypatch, args, match):
    monkeypatch.chdir(tmp_path)
    assert run_cli(["blender-extension", "-o", "ext.zip", *args]) == 2
    err = capsys.readouterr().err
    assert match in err and err.count("\n") == 1 and err.startswith("warp-texton: error: ")
    assert sorted(p.name for p in tmp_path.iterdir()) == []


@pytest.mark.parametrize("name, match", [("ext.zip", "exists; replace it with --overwrite"), ("ext.tar", "not a .zip")])
def test_an_existing_or_misnamed_output_is_refused(tmp_path, capsys, name, match):
    out = tmp_path / name
    out.write_bytes(b"old")
    assert run_cli(["blender-extension", "-o", out, "--platform", "linux-x64"]) == 2
    err = capsys.readouterr().err
    assert match in err and err.count("\n") == 1
    assert out.read_bytes() == b"old"


def test_the_api_names_the_argument(tmp_path):
    with pytest.raises(TextonError, match="platforms: windows-x86; Blender platforms"):
        build_extension(tmp_path / "x.zip", platforms=["windows-x86"])
    (tmp_path / "folder.zip").mkdir()
    with pytest.raises(TextonError, match="out: .*folder.zip is a folder"):
        build_extension(tmp_path / "folder.zip", platforms=["linux-x64"])
    assert [p.name for p in tmp_path.iterdir()] == ["folder.zip"]


# ------------------------------------------------------------------ the zip, built once
@pytest.fixture(scope="session")
def extension_zip(tmp_path_factory):
    """(zip path, wheels folder): the dependencies downloaded once for this platform, the zip built from them."""
    platform = this_platform()
    if platform not in PLATFORMS:
        pytest.skip(f"no wheels of the dependencies for {platform}")
    wheels = tmp_path_factory.mktemp("wheels")
    dependency_wheels(platform, wheels, None)
    out = tmp_path_factory.mktemp("extension") / "warp_texton.zip"
    assert build_extension(out, wheels_dir=wheels) == out
    return out, wheels


@pytest.mark.slow
def test_the_zip_holds_the_manifest_the_addon_and_every_wheel(extension_zip):
    out, wheels = extension_zip
    with zipfile.ZipFile(out) as z:
        names = set(z.namelist())
        manifest = tomllib.loads(z.read(MANIFEST).decode())
        addon = z.read("__init__.py").decode()
    assert all(manifest.get(k) for k in REQUIRED)
    assert manifest["platforms"] == [this_platform()]
    listed = {w.removeprefix("./") for w in manifest["wheels"]}
    assert listed == {n for n in names if n.startswith("wheels/")}
    assert names == listed | {MANIFEST, "__init__.py"}
    bundled = {Path(w).name.split("-")[0].lower() for w in listed}
    assert {"warp_texton", "warp_lang", "scipy", "openexr", "pillow", "tqdm", "trimesh", "xatlas"} <= bundled
    assert "numpy" not in bundled
    # every downloaded wheel is in the zip, and the package's own wheel is this version's
    assert {p.name for p in wheels.glob("*.whl")} <= {Path(w).name for w in listed}
    from warp_texton import __version__
    assert f"wheels/warp_texton-{__version__}-py3-none-any.whl" in names
    assert "def register():" in addon and '"warp_texton.material_from_image"' in addon


@pytest.mark.slow
def test_overwrite_replaces_the_zip_atomically(extension_zip, tmp_path):
    _, wheels = extension_zip
    out = tmp_path / "again.zip"
    out.write_bytes(b"old")
    assert run_cli(["blender-extension", "-o", out, "--wheels-dir", wheels, "--overwrite", "-q"]) == 0
    assert zipfile.is_zipfile(out) and not parts(tmp_path)


# ------------------------------------------------------------------ in Blender
def object_pixels(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """(luminance, mask of the object's pixels) of an RGBA render on a transparent film."""
    a = np.asarray(Image.open(path), np.float64)
    return a[..., :3].mean(axis=2), a[..., 3] == 255


def texture_contrast(path: Path) -> float:
    """The median absolute difference of horizontally adjacent pixels on the object: the shading of a
    flat-coloured cube changes only across its few edges (and by render noise), a texture everywhere."""
    lum, on = object_pixels(path)
    both = on[:, 1:] & on[:, :-1]
    return float(np.median(np.abs(np.diff(lum, axis=1))[both]))


@pytest.fixture(scope="module")
def blender_run(extension_zip, tmp_path_factory):
    """Blender's report and its folder: the operator run twice on the default cube, first as a user
    would (method "auto", the tiling model for the demo photograph, with the bake), then with the
    texton model (the OSL surface shader) and no bake."""
    require(has_bpy(), "Blender's bpy module")
    out, _ = extension_zip
    d = tmp_path_factory.mktemp("blender")
    (d / "user").mkdir()

    def job(name, branch, engine="CYCLES"):
        return {"out": str(d / f"{name}.png"), "branch": branch, "width": SIZE, "height": SIZE, "samples": 8,
                "engine": engine}

    (d / "not_an_image.png").write_bytes(b"not a png")
    # the photograph upscaled 4 times: too smooth for a texton of 64 (SmoothExampleWarning, docs/photographs.md)
    grass = Image.open(demo_texture_path()).crop((0, 0, 128, 128))
    grass.resize((512, 512), Image.BILINEAR).save(d / "smooth.png")
    cycles = [job(b, b) for b in ("material", "baked", "flat")]
    # EEVEE renders the bake: at 128² its texels are about the pixels' size on the cube's faces here (a finer
    # bake is minified through mipmaps, which smooth the neighbouring pixels this test compares)
    eevee = [job("eevee", "material", "EEVEE"), job("eevee_flat", "flat", "EEVEE")]
    runs = [{"operator": {"resolution": 128}, "renders": cycles + eevee},
            {"operator": {"method": "texton", "bake": False}, "renders": [job("texton", "material")]},
            {"object": "sphere without UVs", "operator": {"method": "texton", "resolution": 64}},
            {"operator": {"filepath": str(d / "not_an_image.png")}},
            {"operator": {"filepath": str(d / "smooth.png"), "method": "texton", "bake": False}}]
    spec = {"zip": str(out), "image": str(demo_texture_path()), "runs": runs, "report": str(d / "report.json")}
    (d / "spec.json").write_text(json.dumps(spec))
    # a user folder of its own, and a working folder outside the checkout (whose warp_texton would shadow the wheel's)
    proc = run_blender(SCRIPT, d / "spec.json", timeout=900, cwd=d, env={"BLENDER_USER_RESOURCES": str(d / "user")})
    report = json.loads((d / "report.json").read_text())
    report["stdout"] = proc.stdout  # the operator's reports, as background mode prints them
    return report, d


@pytest.mark.slow
def test_blenders_validator_accepts_the_zip(blender_run):
    report, _ = blender_run
    assert report["validate"]["returncode"] == 0, report["validate"]["output"]


@pytest.mark.slow
def test_the_extension_installs_and_its_package_comes_from_its_wheels(blender_run):
    report, d = blender_run
    assert report["install"] == ["FINISHED"]
    assert report["addons"] == [f"bl_ext.user_default.{EXTENSION_ID}"]
    # its panel: the Shader editor's sidebar, tab "Warp Texton"
    assert report["panel"] == {"bl_space_type": "NODE_EDITOR", "bl_region_type": "UI", "bl_category": "Warp Texton"}
    for run in report["runs"][:3]:  # those that finished
        assert Path(run["package"]).is_relative_to(d / "user" / "extensions"), run["package"]


@pytest.mark.slow
def test_the_operator_gives_the_cube_an_osl_and_a_baked_material(blender_run):
    run = blender_run[0]["runs"][0]
    assert run["operator"] == ["FINISHED"] and run["osl"]
    mat = run["material"]
    assert sorted(mat["outputs"].values()) == ["CYCLES", "EEVEE"]
    assert mat["scripts"] == ["tiling_plane.osl"] * 3  # the demo photograph's model: tiling, on three planes
    assert {"ShaderNodeNormalMap", "ShaderNodeBump", "ShaderNodeTexImage"} <= set(mat["node_types"])
    spaces = sorted(i["colorspace"] for i in mat["images"].values())
    assert spaces == ["Non-Color", "sRGB"]
    assert all(i["size"] == [128, 128] and i["packed"] for i in mat["images"].values())


@pytest.mark.slow
def test_a_texton_material_is_one_surface_shader_without_a_bake(blender_run):
    run = blender_run[0]["runs"][1]
    assert run["operator"] == ["FINISHED"]
    mat = run["material"]
    assert mat["scripts"] == ["texton_surface.osl"] and not mat["images"]
    assert list(mat["outputs"].values()) == ["ALL"]
    assert "ShaderNodeTexCoord" not in mat["node_types"] and "ShaderNodeUVMap" not in mat["node_types"]


@pytest.mark.slow
def test_an_object_without_uvs_gets_them_for_the_bake(blender_run):
    run = blender_run[0]["runs"][2]
    assert run["operator"] == ["FINISHED"], run.get("error")
    assert (run["uv_layers_before"], run["uv_layers_after"]) == (0, 1)
    assert all(i["size"] == [64, 64] for i in run["material"]["images"].values())
    assert len(run["material"]["images"]) == 2


@pytest.mark.slow
def test_an_unreadable_image_cancels_with_one_error_and_changes_nothing(blender_run):
    run = blender_run[0]["runs"][3]
    assert run["operator"] == ["CANCELLED"] and run["material_unchanged"]
    assert "Warp Texton: " in run["error"] and "not_an_image.png" in run["error"], run["error"]


@pytest.mark.slow
def test_the_analysis_warnings_are_the_operators_warnings(blender_run):
    report, _ = blender_run
    assert report["runs"][4]["operator"] == ["FINISHED"]
    warned = [line for line in report["stdout"].splitlines() if line.startswith("Warning: Warp Texton: ")]
    assert len(warned) == 1 and "smooth.png" in warned[0], warned
    # and the steps as information
    assert "Info: Warp Texton: analysing the image (texton or tiling, by the structure score)" in report["stdout"]


@pytest.mark.slow
@pytest.mark.parametrize("name, flat_name", [
    ("material", "flat"), ("baked", "flat"), ("texton", "flat"),  # Cycles: the OSL nodes, the bake, the texton
    ("eevee", "eevee_flat"),  # EEVEE: the bake and its normal map
])
def test_the_cube_renders_with_texture(blender_run, name, flat_name):
    _, d = blender_run
    lum, on = object_pixels(d / f"{name}.png")
    flat_lum, flat_on = object_pixels(d / f"{flat_name}.png")
    assert on.sum() > 0.05 * on.size and (on == flat_on).mean() > 0.99  # the same cube, in view
    textured, flat = texture_contrast(d / f"{name}.png"), texture_contrast(d / f"{flat_name}.png")
    assert textured > 3.0 * max(flat, STEP), (textured, flat)


# ------------------------------------------------------------------ several platforms, off line
def fake_wheel(folder: Path, name: str, version: str, tag: str) -> Path:
    """A minimal valid wheel (metadata only): what pip needs to pick it for a platform."""
    dist = name.replace("-", "_")
    path = folder / f"{dist}-{version}-{tag}.whl"
    info = f"{dist}-{version}.dist-info"
    with zipfile.ZipFile(path, "w") as z:
        z.writestr(f"{info}/METADATA", f"Metadata-Version: 2.1\nName: {name}\nVersion: {version}\n")
        z.writestr(f"{info}/WHEEL", f"Wheel-Version: 1.0\nGenerator: test\nRoot-Is-Purelib: true\nTag: {tag}\n")
        z.writestr(f"{info}/RECORD", "")
    return path


@pytest.mark.slow
def test_each_platform_gets_its_wheels_and_a_pure_wheel_comes_once(tmp_path):
    """Two platforms from a folder of wheels (nothing fetched): the binary dependencies of each, a
    pure-Python one once, the manifest naming both platforms; a platform the folder lacks is one error."""
    wheels = tmp_path / "wheels"
    wheels.mkdir()
    pure = {"tqdm", "trimesh"}
    tags = {"linux-x64": "cp311-cp311-manylinux_2_28_x86_64", "windows-x64": "cp311-cp311-win_amd64"}
    for req in requirements():
        name = req.split(">")[0].split("=")[0].strip()
        for tag in tags.values():
            fake_wheel(wheels, name, "99.0", "py3-none-any" if name in pure else tag)
    out = build_extension(tmp_path / "both.zip", platforms=["windows-x64", "linux-x64"], wheels_dir=wheels)
    with zipfile.ZipFile(out) as z:
        manifest = tomllib.loads(z.read(MANIFEST).decode())
        names = [n for n in z.namelist() if n.startswith("wheels/")]
    assert manifest["platforms"] == ["windows-x64", "linux-x64"]
    assert len(names) == len(set(names)) == 1 + len(pure) + 2 * (len(requirements()) - len(pure))
    for platform, tag in tags.items():
        assert sum(n.endswith(f"-{tag}.whl") for n in names) == len(requirements()) - len(pure), platform
    with pytest.raises(TextonError, match="macos-arm64"):
        build_extension(tmp_path / "mac.zip", platforms=["macos-arm64"], wheels_dir=wheels)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["both.zip", "wheels"]
