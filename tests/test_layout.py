"""The rooms' faces and the module paths of 0.2 (docs/architecture.md, "Paths of 0.2").

The 0.2 spellings are tested from one table, ``tests/data/modules_0_2.json``: every module of
0.2's flat layout and the public names it defined, read from git at the last commit of that
layout (``python tests/test_layout.py`` writes it again; a test checks it against git where the
history is there). Each module imports, each name resolves, each module is an attribute of its
package, and a moved one says where it went with one DeprecationWarning.
"""

from __future__ import annotations

import ast
import importlib
import importlib.util
import json
import re
import shutil
import subprocess
import sys
import types
import warnings
from pathlib import Path

import pytest

import warp_texton

ROOMS = ["core", "files", "model", "noise", "surface", "runtimes", "view", "blender", "cli"]


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


@pytest.mark.parametrize("old, new, name", [("warp_texton.view.images", "warp_texton.view.pictures", "to_8bit"),
                                           ("warp_texton.cli.images", "warp_texton.cli.image_commands", "SYNTHESIZE")])
def test_the_images_modules_of_0_3_import_with_a_warning(old, new, name, forget):
    """0.3's view.images and cli.images are named for what they hold now (files.images keeps its name)."""
    forget(old)
    with pytest.warns(DeprecationWarning, match=rf"{old} moved to {new};"):
        module = importlib.import_module(old)
    assert getattr(module, name) is getattr(importlib.import_module(new), name)


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


# ------------------------------------------------------------------ every spelling of 0.2
ROOT = Path(__file__).resolve().parents[1]
TABLE_PATH = ROOT / "tests" / "data" / "modules_0_2.json"
#: The last commit of 0.2's flat layout (version 0.2.0; the next one made the rooms). It holds
#: every module of the 0.2.0 release (RELEASE_0_2, whose CHANGELOG entry is "0.2.0 — 2026-12-01")
#: and those added under that version before the rooms (atlas_worker, device, shader, tiling, ...).
FLAT_0_2 = "44a5c3aa7c47cd094c51aa64aa4085877d66f548"
RELEASE_0_2 = "b1ac8dea98b841383bbbb331db36ef9cc2655258"


def modules_at(commit: str, root: Path = ROOT) -> dict[str, list[str]]:
    """{module: its public names} of ``warp_texton/`` and ``kernels/`` at ``commit``: ``__all__``
    where a module defines it, else its top-level functions, classes and assignments not
    starting with ``_``."""
    ls = subprocess.run(["git", "-C", str(root), "ls-tree", "-r", "--name-only", commit, "--", "warp_texton",
                         "kernels"], capture_output=True, text=True, check=True).stdout.split()
    out: dict[str, list[str]] = {}
    for path in ls:
        if not path.endswith(".py"):
            continue
        name = path[:-3].replace("/", ".").removesuffix(".__init__")
        name = "warp_texton." + name if name.startswith("kernels") else name
        src = subprocess.run(["git", "-C", str(root), "show", f"{commit}:{path}"], capture_output=True, text=True,
                             check=True).stdout
        names, listed = set(), None
        for node in ast.parse(src).body:
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
                names.add(node.name)
            elif isinstance(node, (ast.Assign, ast.AnnAssign)):
                for target in node.targets if isinstance(node, ast.Assign) else [node.target]:
                    if isinstance(target, ast.Name):
                        names.add(target.id)
                        if target.id == "__all__":
                            listed = ast.literal_eval(node.value)
        out[name] = sorted(listed) if listed is not None else sorted(n for n in names if not n.startswith("_"))
    return out


TABLE = json.loads(TABLE_PATH.read_text()) if TABLE_PATH.exists() else {"commit": None, "modules": {}}
MODULES_0_2: dict[str, list[str]] = TABLE["modules"]


def _has_commits(*commits: str) -> bool:
    if shutil.which("git") is None:
        return False
    return all(subprocess.run(["git", "-C", str(ROOT), "cat-file", "-e", f"{c}^{{commit}}"],
                              capture_output=True).returncode == 0 for c in commits)


@pytest.mark.skipif(not _has_commits(FLAT_0_2, RELEASE_0_2), reason="the repository's history is not here")
def test_the_table_is_what_0_2_had():
    assert TABLE["commit"] == FLAT_0_2 and MODULES_0_2 == modules_at(FLAT_0_2)
    assert set(modules_at(RELEASE_0_2)) <= set(MODULES_0_2)  # the release's modules, every one


def _is_moved(old: str) -> bool:
    """An old path that no file holds now (the rooms ``noise``, ``surface``, ``view``, ``cli`` do)."""
    spec = importlib.util.find_spec(old)
    return spec is not None and spec.origin is None


@pytest.fixture
def forget():
    """``forget(old)``: drop an old path's alias (``sys.modules`` and its package's attribute), so that
    the next import of it is a first one. Afterwards the packages' own attributes are put back."""
    packages = [warp_texton, importlib.import_module("warp_texton.kernels")]
    saved = [dict(vars(p)) for p in packages]

    def drop(old: str) -> None:
        sys.modules.pop(old, None)
        package, _, short = old.rpartition(".")
        holder = sys.modules.get(package)
        value = vars(holder).get(short) if holder is not None else None
        if isinstance(value, types.ModuleType) and value.__name__ == old:
            del vars(holder)[short]

    yield drop
    for package, before in zip(packages, saved):
        now = vars(package)
        for key in list(now):
            if key not in before and isinstance(now[key], types.ModuleType) and _is_moved(now[key].__name__):
                del now[key]
        now.update(before)


def _targets(new) -> tuple[str, ...]:
    """The modules a MOVED_MODULES entry maps to, in the order names are searched."""
    return (new,) if isinstance(new, str) else tuple(new)


def _holder(new, name: str):
    """The first module of a MOVED_MODULES entry that holds ``name`` (the first module if none does)."""
    modules = [importlib.import_module(p) for p in _targets(new)]
    return next((m for m in modules if hasattr(m, name)), modules[0])


def _deprecations(caught) -> list[str]:
    return [str(w.message) for w in caught if issubclass(w.category, DeprecationWarning)]


@pytest.mark.parametrize("old", sorted(MODULES_0_2))
def test_every_module_of_0_2_imports_with_its_names(old, forget):
    moved = _is_moved(old)
    new = warp_texton.MOVED_MODULES.get(old, old)
    if moved:
        forget(old)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        module = importlib.import_module(old)
    if moved:
        assert _deprecations(caught) == [f"{old} moved to {' and '.join(_targets(new))}; the old path goes in "
                                         "the next release"]
    else:
        assert _deprecations(caught) == [], old
    face = getattr(module, "_LAZY", {})
    for name in MODULES_0_2[old]:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            value = getattr(module, name)
        if moved or old == new or name in face:
            assert _deprecations(caught) == [], (old, name)
        else:  # a room now (0.2's warp_texton.noise was its engine): the name says where it lives
            assert _deprecations(caught) == [f"{old}.{name} moved to {new}.{name}; the old path goes in the next "
                                             "release"], (old, name)
        assert value is getattr(_holder(new, name), name) or name in face, (old, name)


@pytest.mark.parametrize("old", sorted(m for m in MODULES_0_2 if m.count(".") == 1
                                       or m.startswith("warp_texton.kernels.")))
def test_every_module_of_0_2_is_an_attribute_of_its_package(old, forget):
    """``import warp_texton as wt; wt.limits.set_memory_budget(...)``: 0.2's modules are attributes too."""
    package, _, short = old.rpartition(".")
    holder = importlib.import_module(package)
    if package == "warp_texton" and short in warp_texton.__all__:  # dsn: the public function, as in 0.2
        assert getattr(holder, short) is getattr(_holder(warp_texton.MOVED_MODULES[old], short), short)
        return
    moved = _is_moved(old)
    if moved:
        forget(old)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        value = getattr(holder, short)
    assert isinstance(value, types.ModuleType) and value is sys.modules[old]
    assert len(_deprecations(caught)) == (1 if moved else 0), _deprecations(caught)
    for name in MODULES_0_2[old][:3]:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", DeprecationWarning)
            assert getattr(value, name) is getattr(_holder(warp_texton.MOVED_MODULES.get(old, old), name), name)


def test_the_old_dsn_module_leaves_the_public_function(forget):
    """0.2's module ``warp_texton.dsn`` and the function ``warp_texton.dsn``: importing the old path
    (which binds a submodule on its package) does not hide the public name, in any order."""
    function = importlib.import_module("warp_texton.model.spot_noise").dsn
    for first_the_function in (True, False):
        forget("warp_texton.dsn")
        if first_the_function:
            assert warp_texton.dsn is function
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", DeprecationWarning)
            from warp_texton.dsn import dsn as old  # the old path's names
        assert old is function and warp_texton.dsn is function
        from warp_texton import dsn

        assert dsn is function


@pytest.mark.parametrize("old", sorted(m for m in MODULES_0_2 if _is_moved(m)))
def test_dir_of_a_moved_module_lists_its_names(old):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        module = importlib.import_module(old)
    assert set(MODULES_0_2[old]) <= set(dir(module)), old


def test_the_warnings_point_at_the_users_line():
    """Shown by Python's default filters, which show DeprecationWarnings of ``__main__`` only."""
    code = ("import warp_texton.dsn\nimport warp_texton as wt\nwt.limits.memory_budget()\nwt.noise.noise_setup\n"
            "import warp_texton.kernels as k\nk.noise2d\n")
    err = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120).stderr
    assert "<string>:1: DeprecationWarning: warp_texton.dsn moved to warp_texton.model.spot_noise" in err, err
    assert "<string>:3: DeprecationWarning: warp_texton.limits moved to warp_texton.core.limits" in err, err
    assert ("<string>:4: DeprecationWarning: warp_texton.noise.noise_setup moved to "
            "warp_texton.noise.engine.noise_setup") in err, err
    assert "<string>:6: DeprecationWarning: warp_texton.kernels.noise2d moved to warp_texton.kernels.noise_raster" \
        in err, err


def test_the_architecture_page_lists_every_moved_path():
    text = (ROOT / "docs" / "architecture.md").read_text()
    rows: dict[str, list[str]] = {}
    for old, new in re.findall(r"^\| `(warp_texton[\w.]*)`[^|]* \| `(warp_texton[\w.]*)` \|$", text, re.M):
        rows.setdefault(old, []).append(new)
    for old, new in warp_texton.MOVED_MODULES.items():
        assert rows.get(old) == list(_targets(new)), old


if __name__ == "__main__":  # python tests/test_layout.py: the table of 0.2's modules, from git
    found = modules_at(FLAT_0_2)
    rows = ",\n".join(f"  {json.dumps(name)}: {json.dumps(names)}" for name, names in sorted(found.items()))
    TABLE_PATH.write_text(f'{{"commit": "{FLAT_0_2}", "release": "{RELEASE_0_2}", "modules": {{\n{rows}\n}}}}\n')
    print(f"{TABLE_PATH}: {len(found)} modules")
