"""The wheels an extension bundles: the package's own and its run-time dependencies Blender lacks.

Blender ships NumPy (1.26 in 4.2 to 5.0) and installs an extension's wheels beside it, without a
resolver: every dependency must be in the zip, for each platform the manifest names, built for
Blender's Python. The package's wheel is built from its source (``pip wheel --no-deps``); the
dependencies are those of its metadata (and the ``mesh`` extra's, for EEVEE's atlases), NumPy left
out, downloaded by ``pip download`` for each platform, or taken from a folder of wheels downloaded
before (``wheels_dir``: no dependency is fetched then).
"""

from __future__ import annotations

import re
import subprocess
import sys
from importlib import metadata
from pathlib import Path

from .._version import __version__
from ..core.errors import TextonError
from .manifest import BLENDER_PYTHON, PLATFORMS

#: The distribution whose wheel the extension carries.
DISTRIBUTION = "warp-texton"
#: Dependencies Blender ships itself: never bundled (a second NumPy would shadow Blender's).
BLENDER_SHIPS = {"numpy"}
#: The extras whose dependencies the extension also needs (``mesh``: xatlas, the UV atlas of EEVEE bakes).
EXTRAS = ("mesh",)


def _name(requirement: str) -> str:
    """The normalised project name of a requirement string (PEP 503)."""
    match = re.match(r"\s*([A-Za-z0-9][A-Za-z0-9._-]*)", requirement)
    return re.sub(r"[-_.]+", "-", match.group(1)).lower() if match else ""


def requirements() -> list[str]:
    """The requirement strings of the package's dependencies that the extension bundles
    (its run-time dependencies and those of :data:`EXTRAS`, less :data:`BLENDER_SHIPS`),
    markers dropped.

    >>> reqs = requirements()
    >>> [r for r in reqs if r.startswith(("warp-lang", "xatlas"))], any(r.startswith("numpy") for r in reqs)
    (['warp-lang>=1.15', 'xatlas>=0.0.9'], False)
    """
    try:
        declared = metadata.requires(DISTRIBUTION) or []
    except metadata.PackageNotFoundError:  # pragma: no cover - the package runs installed
        raise TextonError(f"{DISTRIBUTION} is not installed (pip install .): its dependencies are read from its "
                          "metadata") from None
    out = []
    for req in declared:
        spec, _, marker = req.partition(";")
        extra = re.search(r"extra\s*==\s*['\"]([^'\"]+)['\"]", marker)
        if (marker.strip() and not (extra and extra.group(1) in EXTRAS)) or _name(spec) in BLENDER_SHIPS:
            continue
        out.append(spec.strip())
    return list(dict.fromkeys(out))


def _pip(args: list[str], what: str) -> None:
    proc = subprocess.run([sys.executable, "-m", "pip", *args], capture_output=True, text=True)
    if proc.returncode != 0:
        lines = [ln.strip() for ln in (proc.stderr + proc.stdout).splitlines()
                 if ln.strip() and "is ignored" not in ln]
        errors = [ln for ln in lines if ln.startswith("ERROR")] or lines or ["pip failed"]
        raise TextonError(f"{what}: {errors[0].removeprefix('ERROR: ')}")


def own_wheel(dest: Path, wheels_dir: Path | None) -> Path:
    """The package's wheel of this version: built from the source tree the package runs from (a
    checkout or an editable install; ``wheels_dir`` lends the build backend off line), else taken
    from ``wheels_dir``."""
    pattern = f"warp_texton-{__version__}-*.whl"
    source = Path(__file__).resolve().parents[2]
    if not (source / "pyproject.toml").is_file():
        if wheels_dir is not None and (found := sorted(wheels_dir.glob(pattern))):
            return found[-1]
        raise TextonError(f"wheels_dir: the package does not run from its source tree (where its wheel would be "
                          f"built), so the folder must hold its wheel, {pattern}", param="wheels_dir")
    args = ["wheel", "--no-deps", "-q", "-w", str(dest), str(source)]
    if wheels_dir is not None:
        args += ["--find-links", str(wheels_dir)]
    _pip(args, "the package's wheel")
    found = sorted(dest.glob(pattern))
    if not found:  # pragma: no cover - pip said it succeeded
        raise TextonError("the package's wheel: pip wheel wrote none")
    return found[-1]


def dependency_wheels(platform: str, dest: Path, wheels_dir: Path | None) -> None:
    """Download (or copy from ``wheels_dir``) the dependencies' wheels for one Blender platform into ``dest``."""
    args = ["download", "--no-deps", "-q", "--only-binary=:all:", "--python-version", BLENDER_PYTHON,
            "--implementation", "cp", "--abi", "cp" + BLENDER_PYTHON.replace(".", ""), "--abi", "abi3",
            "--abi", "none", "-d", str(dest)]
    for tag in PLATFORMS[platform]:
        args += ["--platform", tag]
    if wheels_dir is not None:
        args += ["--no-index", "--find-links", str(wheels_dir)]
    where = f" in {wheels_dir}" if wheels_dir is not None else ""
    _pip(args + requirements(), f"the dependencies' wheels for {platform} (Python {BLENDER_PYTHON}){where}")


def extension_wheels(platforms, dest: Path, wheels_dir: Path | None = None) -> list[Path]:
    """Every wheel the extension bundles for ``platforms``, gathered in ``dest``: the package's own
    first, then its dependencies' (one file each, a pure-Python wheel once for all platforms)."""
    deps = dest / "deps"
    deps.mkdir(parents=True, exist_ok=True)
    for platform in platforms:
        dependency_wheels(platform, deps, wheels_dir)
    return [own_wheel(dest, wheels_dir), *sorted(deps.glob("*.whl"))]
