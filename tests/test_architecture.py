"""The package keeps the shape docs/architecture.md describes.

* Host modules form one-way layers: each imports only modules of lower layers,
  so the import graph has no cycle, and no module imports a private name
  (``_name``) of another, nor reaches one as an attribute.
* Tests, benchmarks and the docs' scripts use public or documented names too.
* Device code lives in ``kernels/``: host modules define no ``@wp.kernel`` or
  ``@wp.func``, and kernels read no files and parse no options.
* Every kernel module compiles for CUDA (sm_75, sm_86, sm_90) through NVRTC,
  which works without a GPU, so a kernel that breaks on CUDA fails here.
"""

from __future__ import annotations

import ast
import importlib
import pkgutil
import tempfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "warp_texton"
KERNELS = ROOT / "kernels"

#: The rooms of docs/architecture.md, lowest first: a module imports modules of lower rooms, and of
#: lower layers of its own room (ROOM_LAYERS), only. Top-level modules are rooms of their own.
ROOMS = ["_version", "core", "files", "model", "noise", "surface", "runtimes", "view", "demo", "blender", "cli", "__init__"]
#: The layers inside each room (a room's ``__init__``, its face, sits above them all).
ROOM_LAYERS = {
    "core": {"errors": 0, "progress": 0, "lazy": 0, "limits": 1, "checks": 2, "runtime": 3},
    "files": {"readers": 0, "folders": 0, "images": 1},
    "model": {"bspline": 0, "histogram": 0, "example_checks": 0, "analysis_options": 1, "gaussian": 2,
              "lattice": 3, "structure": 3, "tiling": 4, "lattice_detection": 4, "texton": 5, "tiling_fit": 5, "spot_noise": 6, "analysis": 7,
              "translation": 1, "judges": 6, "noise_tables": 6},
    "noise": {"filter_options": 0, "noise_options": 0, "tiling": 2, "engine": 1, "colours": 1, "canvas": 2, "filtering": 3, "raster": 3,
              "tiling_filtering": 4, "synthesis": 5, "ground_plane": 5, "mixing": 5, "dask_arrays": 6, "batches": 6,
              "relief": 6},
    "surface": {"frames": 0, "atlas": 0, "atlas_worker": 0, "blocks": 0, "tiling": 1, "points": 2, "mesh": 3,
                "mesh_files": 4, "render": 4, "bake": 5, "jobs": 6, "relief": 5},
    "runtimes": {"warp_api": 0, "shared": 0, "glsl.page": 1, "glsl.texton": 2, "glsl.tiling": 2, "glsl": 3,
                 "osl.texton": 1, "osl.tiling": 2, "osl": 3, "languages": 4, "export": 5},
    "view": {"static": 0, "queries": 0, "cache": 0, "pictures": 0, "webgl": 0, "inputs": 1, "commands": 2,
             "viewer": 3, "server": 4},
    "blender": {"manifest": 0, "wheels": 1, "materials": 0, "extension": 2},
    "cli": {"options": 0, "info": 1, "image_commands": 2, "surface": 2, "shader": 2, "view": 2, "blender": 2, "parser": 3},
}
#: Package data with an ``__init__`` (no code): outside the rooms' order.
DATA_PACKAGES = {"data", "view.static", "blender.addon"}
TOP_LEVEL_LIMIT = 8
ROOM_SIZE = (3, 16)


def module_name(path: Path) -> str:
    """``core.limits`` for warp_texton/core/limits.py, ``core`` for its __init__, ``demo`` for demo.py."""
    parts = list(path.relative_to(PACKAGE).with_suffix("").parts)
    if parts[-1] == "__init__" and len(parts) > 1:
        parts = parts[:-1]
    return ".".join(parts)


def host_modules() -> dict[str, ast.Module]:
    return {module_name(p): ast.parse(p.read_text(), str(p)) for p in sorted(PACKAGE.rglob("*.py"))
            if module_name(p) not in DATA_PACKAGES}


def is_package(name: str) -> bool:
    return name == "__init__" or (PACKAGE / name.replace(".", "/") / "__init__.py").is_file()


def rank(name: str) -> tuple[int, int]:
    """(room, layer in the room) of a module; a room's face (its __init__) above its layers."""
    room, _, leaf = name.partition(".")
    layers = ROOM_LAYERS.get(room, {})
    return ROOMS.index(room), (layers[leaf] if leaf else max(layers.values(), default=0) + 1)


def package_imports(name: str, tree: ast.Module):
    """(imported module, imported names) for every relative import of a package module."""
    here = [] if name == "__init__" else name.split(".")
    if not is_package(name):
        here = here[:-1]
    for node in ast.walk(tree):
        if not (isinstance(node, ast.ImportFrom) and node.level >= 1):
            continue
        base = here[: len(here) - (node.level - 1)]
        target = ".".join(base + ([node.module] if node.module else []))
        if target.split(".")[0] == "kernels":
            continue
        if node.module:
            yield _module_of(target), [a.name for a in node.names]
        else:  # from . import x
            for a in node.names:
                yield _module_of(".".join(base + [a.name])), []


def _module_of(dotted: str) -> str:
    """The module a dotted path names: itself, or its package when the tail is a name inside it."""
    parts = dotted.split(".")
    while parts and not ((PACKAGE / "/".join(parts)).with_suffix(".py").is_file() or is_package(".".join(parts))):
        parts.pop()
    return ".".join(parts) or "__init__"


def is_private(name: str) -> bool:
    return name.startswith("_") and not name.startswith("__")


def test_every_module_has_a_room_and_a_layer():
    missing = []
    for name in host_modules():
        room, _, leaf = name.partition(".")
        if room not in ROOMS or (leaf and leaf not in ROOM_LAYERS.get(room, {})):
            missing.append(name)
    assert not missing, f"add {missing} to ROOMS/ROOM_LAYERS and to docs/architecture.md"


def test_rooms_have_the_documented_sizes():
    top = sorted(p.stem for p in PACKAGE.glob("*.py"))
    assert len(top) <= TOP_LEVEL_LIMIT, top
    for room in ROOM_LAYERS:
        # a room's modules, those of its folders (a language of runtimes) included, package data not
        modules = [module_name(p) for p in (PACKAGE / room).rglob("*.py")]
        modules = [m for m in modules if m != room and m not in DATA_PACKAGES]
        assert ROOM_SIZE[0] <= len(modules) <= ROOM_SIZE[1], (room, sorted(modules))


#: The most lines a module holds (docs/architecture.md, "Sizes"): a host module, a kernel module.
HOST_LINES = 650
KERNEL_LINES = 700


@pytest.mark.parametrize("folder, limit", [(PACKAGE, HOST_LINES), (KERNELS, KERNEL_LINES)], ids=["host", "kernels"])
def test_modules_stay_within_their_size(folder, limit):
    sizes = {str(p.relative_to(ROOT)): len(p.read_text().splitlines()) for p in sorted(folder.rglob("*.py"))}
    over = {path: n for path, n in sizes.items() if n > limit}
    assert not over, f"over {limit} lines (split by idea, docs/architecture.md): {over}"


def test_imports_go_down_the_rooms_and_layers():
    wrong = []
    for name, tree in host_modules().items():
        for target, _ in package_imports(name, tree):
            if target == name or target in DATA_PACKAGES:
                continue
            inside_face = is_package(name) and target.startswith(name + ".")  # a room's face imports its rooms
            if not inside_face and rank(target) >= rank(name):
                wrong.append(f"{name} {rank(name)} imports {target} {rank(target)}")
    assert not wrong, wrong


def test_the_rule_sees_an_import_that_runs_back_up():
    """The check above catches a low module importing a higher one: it is not vacuous."""
    tree = ast.parse("from ..noise.synthesis import synthesize\nfrom .limits import check_work")
    targets = [t for t, _ in package_imports("core.errors", tree)]
    assert targets == ["noise.synthesis", "core.limits"]
    assert all(rank(t) > rank("core.errors") for t in targets)


def _private_uses(tree: ast.Module, own: str | None = None):
    """Private names taken from another module of the package: imported, or reached as attributes."""
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            source = node.module or ""
            inside = node.level >= 1 or source.startswith("warp_texton")
            if inside and source.split(".")[-1] != own:
                yield from (f"from {source} import {a.name}" for a in node.names if is_private(a.name))
        elif isinstance(node, ast.Attribute) and is_private(node.attr):
            base = node.value
            while isinstance(base, ast.Attribute):
                base = base.value
            if isinstance(base, ast.Name) and base.id in ("warp_texton", "wt"):
                yield f"{ast.unparse(node)}"


def test_no_private_names_across_package_modules():
    wrong = {name: list(_private_uses(tree, name.split(".")[-1])) for name, tree in host_modules().items()}
    assert not {k: v for k, v in wrong.items() if v}


def test_no_private_names_across_kernel_modules():
    # kernels/ share device code by public names too (kernels/native_simd.VECTOR, not a copied or imported _VECTOR)
    trees = {p.stem: ast.parse(p.read_text(), str(p)) for p in sorted(KERNELS.glob("*.py"))}
    wrong = {name: uses for name, tree in trees.items() if (uses := list(_private_uses(tree, name)))}
    assert not wrong


def test_the_private_name_rule_sees_a_kernel_import():
    tree = ast.parse("from .surface_native import _VECTOR\nfrom .impacts import avalanche")
    assert list(_private_uses(tree, "noise_tiling_native")) == ["from surface_native import _VECTOR"]


@pytest.mark.parametrize("folder", ["tests", "benchmarks", "docs"])
def test_tests_benchmarks_and_docs_use_public_names(folder):
    wrong = {str(p.relative_to(ROOT)): uses for p in sorted((ROOT / folder).rglob("*.py"))
             if (uses := list(_private_uses(ast.parse(p.read_text()))))}
    assert not wrong


def test_device_code_lives_in_kernels():
    for name, tree in host_modules().items():
        for node in ast.walk(tree):
            if isinstance(node, (ast.FunctionDef, ast.ClassDef)):
                decorators = [ast.unparse(d) for d in node.decorator_list]
                assert not any(d.startswith(("wp.kernel", "wp.func", "wp.struct")) for d in decorators), \
                    f"{name}.{node.name} is device code: move it to kernels/"
    for path in KERNELS.glob("*.py"):
        src = path.read_text()
        for banned in ("open(", "argparse", "Path(", "np.load", "read_image"):
            assert banned not in src, f"kernels/{path.name} uses {banned}: kernels read no files, parse no options"


#: Warp's allocators: without ``device=`` they use Warp's default device, which is "cuda:0" on a GPU machine.
ALLOCATORS = {"array", "empty", "zeros", "full", "ones", "clone", "empty_like", "zeros_like"}


def unscoped_allocations(tree) -> list[int]:
    """Lines of ``wp.<allocator>(...)`` calls that give no ``device=`` and are not inside
    ``with wp.ScopedDevice(...)``, nor in a function whose docstring says it works "on the current device"."""
    found: list[int] = []

    def visit(node, scoped):
        if isinstance(node, ast.With) and any(isinstance(i.context_expr, ast.Call)
                                              and getattr(i.context_expr.func, "attr", "") == "ScopedDevice"
                                              for i in node.items):
            scoped = True
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)) and "current device" in (ast.get_docstring(node) or ""):
            scoped = True
        if (isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) and node.func.attr in ALLOCATORS
                and isinstance(node.func.value, ast.Name) and node.func.value.id == "wp"
                and not scoped and not any(k.arg == "device" for k in node.keywords)):
            found.append(node.lineno)
        for child in ast.iter_child_nodes(node):
            visit(child, scoped)

    visit(tree, False)
    return found


def test_every_warp_allocation_names_its_device():
    # the last GPU pass crashed a CPU launch whose output array went to Warp's default device (cuda:0)
    for name, tree in host_modules().items():
        assert not unscoped_allocations(tree), f"{name}: lines {unscoped_allocations(tree)} allocate on Warp's default device"


def test_the_allocation_rule_sees_a_missing_device():
    bad = ast.parse("def f(x, device):\n    return wp.array(x, dtype=float)\n")
    good = ast.parse("def f(x, device):\n    with wp.ScopedDevice(device):\n        return wp.array(x)\n"
                     "def g(x, device):\n    return wp.empty(3, device=device)\n")
    assert unscoped_allocations(bad) == [2] and unscoped_allocations(good) == []


def kernel_modules():
    import warp_texton.kernels as pkg

    return [importlib.import_module(f"{pkg.__name__}.{m.name}") for m in pkgutil.iter_modules(pkg.__path__)]


def _has_kernels(module) -> bool:
    import warp as wp

    return any(isinstance(v, wp.Kernel) for v in vars(module).values())


@pytest.mark.slow
@pytest.mark.parametrize("arch", [75, 86, 90])
def test_kernels_compile_for_cuda(arch):
    """Every kernel module compiles for this CUDA architecture (NVRTC, no GPU needed).

    Modules of functions only (kernels/impacts.py) are compiled inside the
    modules that call them.
    """
    from warp_texton.core.runtime import init_warp

    wp = init_warp()
    if arch not in wp.get_cuda_supported_archs():
        pytest.skip(f"this Warp build's NVRTC cannot compile for sm_{arch} here "
                    f"(supported: {wp.get_cuda_supported_archs() or 'none'})")
    compiled = []
    for module in kernel_modules():
        if not _has_kernels(module):
            continue
        with tempfile.TemporaryDirectory() as d:
            files = wp.compile_aot_module(module, arch=arch, module_dir=d)
            if files is None:  # Warp before 1.19 returns nothing: look for what it wrote
                files = [str(f) for f in Path(d).glob(f"*.sm{arch}.cubin")]
            assert files and all(Path(f).is_file() and Path(f).stat().st_size > 0 for f in files), module.__name__
            compiled.append(module.__name__.rsplit(".", 1)[-1])
    assert {"noise_raster", "noise_filter", "surface_points", "surface_blocks", "surface_render"} <= set(compiled)
