"""Folders written atomically: built under a temporary name beside the target and
renamed into place when complete, so a failed or interrupted write leaves nothing
half-written, and an existing folder is replaced only when asked to and only if
this package wrote it (Zarr stores, shader exports)."""

from __future__ import annotations

import contextlib
import hashlib
import os
import shutil
import tempfile
from collections.abc import Callable, Collection
from pathlib import Path

from ..core.errors import TextonError


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
    except (OSError, ValueError, TypeError, AttributeError, RecursionError):  # an unreadable marker: not ours
        ours = False
    if not ours:
        raise TextonError(f"{path}: exists and is not {what} written by warp-texton; --overwrite replaces "
                          "only those: remove it yourself or choose another name", param="overwrite")


#: Longest temporary-name prefix taken whole from the target's name: with the random part
#: and the suffix it stays under the usual 255-byte name limit.
PREFIX_BYTES = 200


def temp_prefix(name: str) -> str:
    """``.NAME.`` for the temporary sibling of ``name``, shortened with a hash of the full
    name when ``name`` is near the file system's limit (the target itself fits)."""
    raw = os.fsencode(name)
    if len(raw) + 2 <= PREFIX_BYTES:
        return f".{name}."
    head = raw[:PREFIX_BYTES // 2].decode("utf-8", "ignore")
    return f".{head}.{hashlib.sha256(raw).hexdigest()[:16]}."


def _parent_of(path: Path) -> Path:
    parent = path.parent if str(path.parent) else Path(".")
    if not parent.is_dir():
        raise TextonError(f"{path}: the output folder {parent} does not exist")
    return parent


def _public(tmp: Path) -> None:
    """mkdtemp makes a folder private (0700): a finished folder gets the user's umask, as
    os.mkdir would, so that a web server can serve a shader export."""
    mask = os.umask(0o022)
    os.umask(mask)
    os.chmod(tmp, 0o777 & ~mask)


@contextlib.contextmanager
def atomic_folder(path: Path, replaceable: Callable[[Path], None]):
    """Yield a temporary folder beside ``path``; on success it replaces ``path`` (an
    existing folder, which ``replaceable(path)`` must accept first, is removed only
    then), on failure it is removed."""
    parent = _parent_of(path)
    replaceable(path)
    tmp = Path(tempfile.mkdtemp(dir=parent, prefix=temp_prefix(path.name), suffix=".part"))
    try:
        _public(tmp)
        yield tmp
        old = None
        if path.exists():
            old = Path(tempfile.mkdtemp(dir=parent, prefix=temp_prefix(path.name), suffix=".old"))
            os.replace(path, old / "store")
        os.replace(tmp, path)
        if old is not None:
            shutil.rmtree(old, ignore_errors=True)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise


@contextlib.contextmanager
def atomic_files(path: Path, replaceable: Callable[[Path], None], owned: Collection[str]):
    """Yield a temporary folder beside ``path`` to write files into; on success a new
    ``path`` is that folder renamed into place, and an existing one (which
    ``replaceable(path)`` must accept first) gets each written file renamed over its
    namesake, loses the files named in ``owned`` that this write did not make (an
    earlier write's), and keeps every other file. On failure nothing in ``path`` changes.
    """
    parent = _parent_of(path)
    replaceable(path)
    tmp = Path(tempfile.mkdtemp(dir=parent, prefix=temp_prefix(path.name), suffix=".part"))
    try:
        _public(tmp)
        yield tmp
        if not (path.exists() or path.is_symlink()):
            os.replace(tmp, path)
            return
        replaceable(path)
        written = sorted(p.name for p in tmp.iterdir())
        blocked = [n for n in written if (path / n).is_dir() and not (path / n).is_symlink()]
        if blocked:
            raise TextonError(f"{path / blocked[0]}: is a folder where the export writes a file; remove it or "
                              "choose another name", param="overwrite")
        for name in written:  # each file replaced atomically
            os.replace(tmp / name, path / name)
        for name in set(owned) - set(written):
            stale = path / name
            if stale.is_file() or stale.is_symlink():
                stale.unlink()
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
