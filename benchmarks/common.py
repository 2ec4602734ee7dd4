"""Helpers shared by the benchmark scripts: machine description, git state,
atomic result files and the colour test texture."""

from __future__ import annotations

import os
import platform
import subprocess
import tempfile
from pathlib import Path

import numpy as np
import scipy

import warp_texton

HERE = Path(__file__).resolve().parent

# Channels of the test texture: grass, gravel and brick mixed so that they correlate.
MIX = np.array([
    [0.60, 0.30, 0.10],
    [0.35, 0.45, 0.20],
    [0.20, 0.30, 0.50],
])


def make_texture(side: int) -> np.ndarray:
    """A side × side RGB texture: grass, gravel and brick (CC0) mixed linearly."""
    from skimage import data

    sources = [getattr(data, name)() for name in ("grass", "gravel", "brick")]
    y0 = (sources[0].shape[0] - side) // 2
    x0 = (sources[0].shape[1] - side) // 2
    stack = np.stack([s[y0:y0 + side, x0:x0 + side] for s in sources], axis=-1) / 255.0
    return np.ascontiguousarray(stack @ MIX.T, dtype=np.float32)


def processor_name() -> str:
    name = platform.processor()
    try:
        with open("/proc/cpuinfo", encoding="ascii", errors="replace") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return name or "unknown"


def _git(*args: str) -> str | None:
    try:
        out = subprocess.run(["git", *args], cwd=HERE, capture_output=True,
                             text=True, timeout=10, check=True)
        return out.stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return None


def git_commit() -> str | None:
    """HEAD of the checkout, or None outside a git checkout."""
    return _git("rev-parse", "HEAD") or None


def git_dirty() -> bool | None:
    """Whether tracked files differ from HEAD (the commit alone does not say what ran)."""
    status = _git("status", "--porcelain", "--untracked-files=no")
    return None if status is None else bool(status)


def machine_info() -> dict:
    try:
        usable = len(os.sched_getaffinity(0))
    except AttributeError:
        usable = os.cpu_count()
    return {
        "platform": platform.platform(),
        "processor": processor_name(),
        "cpu_count": os.cpu_count(),
        "usable_cpus": usable,
        "python": platform.python_version(),
        "numpy": np.__version__,
        "scipy": scipy.__version__,
        "warp_texton": warp_texton.__version__,
    }


def write_atomic(path: Path, text: str) -> None:
    """Write ``text`` to ``path`` through a temporary file in the same folder."""
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as f:
            f.write(text)
        mask = os.umask(0o022)  # mkstemp creates 0600; give the usual mode
        os.umask(mask)
        os.chmod(tmp, 0o666 & ~mask)
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise
