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

#: The layers of docs/architecture.md: a module may import modules of lower layers only.
LAYERS = {
    "errors": 0, "_version": 0, "bspline": 0, "atlas_worker": 0,
    "limits": 1, "progress": 1,
    "_checks": 2, "image_readers": 2, "atlas": 2, "_runtime": 2,
    "io": 3, "filter_options": 3, "noise_options": 3, "folders": 3, "histogram": 3, "example_checks": 3,
    "texton": 4, "analysis_options": 4,
    "tiling": 3.5, "tiling_noise": 9,
    "gaussian": 5, "dsn": 5, "view_query": 5, "view_cache": 5, "view_images": 5, "colours": 5,
    "analysis": 6, "view_inputs": 6,
    "view_commands": 7,
    "noise": 8, "canvas": 8, "frames": 8, "blocks": 8,
    "filtering": 9, "raster": 9,
    "synthesis": 10, "plane": 10,
    "mixing": 11, "surface": 11, "dask": 11, "batches": 11,
    "mesh": 12, "shader_glsl": 12, "shader_osl": 12, "device": 12,
    "render": 13, "mesh_files": 13, "shader": 13, "view_webgl": 13,
    "bake": 14, "demo": 14, "view_core": 14, "cli_options": 14,
    "jobs": 15, "view": 15,
    "cli_images": 16, "cli_surface": 16, "cli_view": 16, "cli_shader": 16,
    "cli": 17,
    "__init__": 18,
}


def host_modules() -> dict[str, ast.Module]:
    return {p.stem: ast.parse(p.read_text(), str(p)) for p in PACKAGE.glob("*.py")}


def package_imports(name: str, tree: ast.Module):
    """(imported module, imported names) for every relative import of a package module."""
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.level == 1:
            target = (node.module or "").split(".")[0]
            if target == "kernels":
                continue
            if target:
                yield target, [a.name for a in node.names]
            else:  # from . import x
                for a in node.names:
                    yield a.name, []


def is_private(name: str) -> bool:
    return name.startswith("_") and not name.startswith("__")


def test_every_module_has_a_layer():
    assert set(host_modules()) == set(LAYERS), "add new modules to LAYERS and to docs/architecture.md"


def test_imports_go_down_the_layers():
    wrong = [f"{name} (layer {LAYERS[name]}) imports {target} (layer {LAYERS[target]})"
             for name, tree in host_modules().items() for target, _ in package_imports(name, tree)
             if LAYERS[target] >= LAYERS[name]]
    assert not wrong, wrong


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
    wrong = {name: list(_private_uses(tree, name)) for name, tree in host_modules().items()}
    assert not {k: v for k, v in wrong.items() if v}


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
    from warp_texton._runtime import init_warp

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
    assert {"noise2d", "filter2d", "surface", "blocks", "render"} <= set(compiled)
