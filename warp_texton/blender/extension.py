"""``build_extension``: the Blender extension zip (manifest, add-on, wheels)."""

from __future__ import annotations

import tempfile
import zipfile
from collections.abc import Callable
from pathlib import Path

from ..core.errors import TextonError
from ..files.images import atomic_path, check_output_name
from .manifest import check_platforms, manifest_text
from .wheels import extension_wheels

#: The add-on's files (``warp_texton/blender/addon/``), copied to the top of the zip.
ADDON = Path(__file__).resolve().parent / "addon"
ADDON_FILES = ("__init__.py",)
MANIFEST = "blender_manifest.toml"


def _check_output(out, overwrite: bool) -> Path:
    path = check_output_name(out, "out")
    if path.suffix.lower() != ".zip":
        raise TextonError(f"out: {out} is not a .zip file; Blender installs an extension from a .zip", param="out")
    if path.is_dir():
        raise TextonError(f"out: {out} is a folder; give the .zip file to write", param="out")
    if (path.exists() or path.is_symlink()) and not overwrite:
        raise TextonError(f"out: {out} exists; replace it with overwrite", param="out",
                          mentions=("overwrite",))
    parent = path.parent if str(path.parent) else Path(".")
    if not parent.is_dir():
        raise TextonError(f"out: the folder {parent} does not exist", param="out")
    return path


def build_extension(out, *, platforms=None, wheels_dir=None, overwrite: bool = False,
                    progress: Callable[[str], None] | None = None) -> Path:
    """Write the Blender extension of the package to ``out`` (a .zip).

    Parameters
    ----------
    out : path
        The zip to write (atomically; an existing file only with ``overwrite``).
    platforms : str or sequence of str, optional
        Blender's platforms the extension is for (:data:`~warp_texton.blender.manifest.PLATFORMS`:
        ``"linux-x64"``, ``"windows-x64"``, ``"macos-arm64"``); default: this
        machine's. The zip holds the wheels of each; Blender installs those of the platform it runs on.
    wheels_dir : path, optional
        A folder of wheels downloaded before: the dependencies are taken from it, none fetched.
    overwrite : bool
        Replace an existing ``out``.
    progress : callable, optional
        Called with a line before each step.

    Returns
    -------
    Path
        ``out``.

    Raises
    ------
    TextonError
        For an ``out`` that is not a new .zip in an existing folder, an unknown platform, a
        ``wheels_dir`` that is not a folder, and a wheel pip cannot find (the message is pip's).

    Notes
    -----
    The zip holds ``blender_manifest.toml`` (schema 1.0.0), the add-on's ``__init__.py`` and
    ``wheels/``: the package's own wheel and its dependencies' for Blender's Python, NumPy
    excepted (Blender's). docs/blender.md says what the add-on does.
    """
    path = _check_output(out, overwrite)
    names = check_platforms(platforms)
    folder = None
    if wheels_dir is not None:
        folder = Path(wheels_dir)
        if not folder.is_dir():
            raise TextonError(f"wheels_dir: {wheels_dir} is not a folder", param="wheels_dir")
    say = progress or (lambda line: None)
    with tempfile.TemporaryDirectory(prefix="warp-texton-extension-") as tmp:
        say(f"gathering the wheels for {', '.join(names)}")
        wheels = extension_wheels(names, Path(tmp), folder)
        manifest = manifest_text(names, [f"./wheels/{w.name}" for w in wheels])
        say(f"writing {path} ({len(wheels)} wheels)")
        with atomic_path(path) as part, zipfile.ZipFile(part, "w") as z:
            z.writestr(MANIFEST, manifest, zipfile.ZIP_DEFLATED)
            for name in ADDON_FILES:
                z.write(ADDON / name, name, zipfile.ZIP_DEFLATED)
            for wheel in wheels:  # wheels are zips already
                z.write(wheel, f"wheels/{wheel.name}", zipfile.ZIP_STORED)
    return path
