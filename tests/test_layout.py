"""The rooms' faces and the module paths of 0.2 (docs/architecture.md, "Paths of 0.2")."""

from __future__ import annotations

import importlib
import subprocess
import sys
import warnings

import pytest

import warp_texton

ROOMS = ["core", "files", "model", "noise", "surface", "runtimes", "view", "cli"]


@pytest.mark.parametrize("room", ROOMS)
def test_every_name_of_a_face_resolves_to_its_module(room):
    face = importlib.import_module(f"warp_texton.{room}")
    assert face.__all__, room
    for name in face.__all__:
        value = getattr(face, name)
        module = importlib.import_module(f"warp_texton.{room}.{face._LAZY[name]}")
        assert value is getattr(module, name)
    with pytest.raises(AttributeError):
        face.no_such_name  # noqa: B018


def test_public_api_names_are_those_of_the_rooms():
    for name in warp_texton.__all__:
        assert getattr(warp_texton, name) is not None, name
    assert warp_texton.synthesize is importlib.import_module("warp_texton.noise.synthesis").synthesize
    assert warp_texton.surface_noise is importlib.import_module("warp_texton.surface").surface_noise


@pytest.mark.parametrize("old", sorted(warp_texton.MOVED_MODULES))
def test_a_path_of_0_2_imports_the_moved_module_with_a_warning(old):
    paths = warp_texton.MOVED_MODULES[old]
    paths = (paths,) if isinstance(paths, str) else paths
    news = [importlib.import_module(p) for p in paths]
    sys.modules.pop(old, None)
    with pytest.warns(DeprecationWarning, match=" and ".join(p.replace(".", r"\.") for p in paths)):
        alias = importlib.import_module(old)
    seen: set[str] = set()
    for new in news:  # a name resolves in the first module that holds it
        public = [n for n in vars(new) if not n.startswith("_") and n not in seen]
        assert public, (old, new.__name__)
        for name in public[:5] + public[-5:]:
            assert getattr(alias, name) is getattr(new, name)
        seen.update(vars(new))
    with pytest.raises(AttributeError):
        alias.no_such_name  # noqa: B018


def test_the_tiling_shaders_of_0_3_resolve_in_each_language():
    """0.3's runtimes.tiling_shaders held both languages: its names resolve in the port that holds them now."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        from warp_texton.runtimes import tiling_shaders as old
    from warp_texton.runtimes.glsl import tiling as glsl_tiling
    from warp_texton.runtimes.osl import tiling as osl_tiling
    from warp_texton.runtimes import shared

    assert old.glsl_source is glsl_tiling.glsl_source and old.tiling_anchor is glsl_tiling.tiling_anchor
    assert old.tiling_osl_files is osl_tiling.tiling_osl_files and old.MAX_OSL_FLOATS == 512 * 512 * 3
    assert old.refuse_texton_options is shared.refuse_texton_options and old.GLSL_FILE == "tiling_noise.glsl"


@pytest.mark.parametrize("face, name", [("glsl", "glsl_noise"), ("glsl", "preview_html"), ("glsl", "GLSL_FILE"),
                                        ("osl", "osl_files"), ("osl", "i32"), ("osl", "PLANE_FILE")])
def test_names_of_a_module_that_became_a_language_package_warn(face, name):
    """0.3's runtimes.glsl and runtimes.osl were texton noise's modules; they are each language's port now,
    and the old names resolve for a release from the texton module, with a warning naming it."""
    port = importlib.import_module(f"warp_texton.runtimes.{face}")
    texton = importlib.import_module(f"warp_texton.runtimes.{face}.texton")
    with pytest.warns(DeprecationWarning, match=rf"runtimes\.{face}\.texton\.{name}"):
        value = getattr(port, name)
    assert value is getattr(texton, name)
    with pytest.raises(AttributeError):
        port.no_such_name  # noqa: B018


def test_from_import_of_an_old_path_gives_the_same_objects():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        from warp_texton.kernels.noise2d import plane_value
        from warp_texton.limits import check_memory
    from warp_texton.core.limits import check_memory as new_check
    from warp_texton.kernels.noise_raster import plane_value as new_value

    assert check_memory is new_check and plane_value is new_value


def test_an_unknown_old_path_is_still_an_import_error():
    with pytest.raises(ModuleNotFoundError):
        importlib.import_module("warp_texton.no_such_module")


def test_the_console_script_entry_point_resolves():
    code = "import warp_texton.cli as c; import sys; sys.exit(0 if callable(c.main) else 1)"
    assert subprocess.run([sys.executable, "-c", code], timeout=120).returncode == 0


def test_importing_a_room_does_not_start_warp():
    code = ("import sys, warp_texton.noise, warp_texton.surface, warp_texton.cli.parser; "
            "sys.exit(1 if 'warp' in sys.modules else 0)")
    assert subprocess.run([sys.executable, "-c", code], timeout=120).returncode == 0
