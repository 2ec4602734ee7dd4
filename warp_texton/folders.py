"""Folders written atomically: built under a temporary name beside the target and
renamed into place when complete, so a failed or interrupted write leaves nothing
half-written, and an existing folder is replaced only when asked to and only if
this package wrote it (Zarr stores, shader exports)."""

from __future__ import annotations

import contextlib
import os
import shutil
import tempfile
from collections.abc import Callable
from pathlib import Path

from .errors import TextonError


def check_replaceable(path: Path, overwrite: bool, is_ours: Callable[[Path], bool], what: str) -> None:
    """An existing ``path`` may be replaced only with ``overwrite`` and only if ``is_ours(path)``
    (``what`` names such folders: "a Zarr store"): --overwrite must not delete a folder of
    anything else."""
    if not (path.exists() or path.is_symlink()):
        return
    if not overwrite:
        raise TextonError(f"{path}: exists; replace it with overwrite", mentions=("overwrite",))
    try:
        ours = path.is_dir() and not path.is_symlink() and is_ours(path)
    except (OSError, ValueError, AttributeError):
        ours = False
    if not ours:
        raise TextonError(f"{path}: exists and is not {what} written by warp-texton; --overwrite replaces "
                          "only those: remove it yourself or choose another name", param="overwrite")


@contextlib.contextmanager
def atomic_folder(path: Path, replaceable: Callable[[Path], None]):
    """Yield a temporary folder beside ``path``; on success it replaces ``path`` (an
    existing folder, which ``replaceable(path)`` must accept first, is removed only
    then), on failure it is removed."""
    parent = path.parent if str(path.parent) else Path(".")
    if not parent.is_dir():
        raise TextonError(f"{path}: the output folder {parent} does not exist")
    replaceable(path)
    tmp = Path(tempfile.mkdtemp(dir=parent, prefix=f".{path.name}.", suffix=".part"))
    try:
        # mkdtemp makes it private (0700): the finished folder gets the user's umask, as
        # os.mkdir would, so that a web server can serve a shader export
        mask = os.umask(0o022)
        os.umask(mask)
        os.chmod(tmp, 0o777 & ~mask)
        yield tmp
        old = None
        if path.exists():
            old = Path(tempfile.mkdtemp(dir=parent, prefix=f".{path.name}.", suffix=".old"))
            os.replace(path, old / "store")
        os.replace(tmp, path)
        if old is not None:
            shutil.rmtree(old, ignore_errors=True)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
