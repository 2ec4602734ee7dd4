"""The real clients the tests open outputs with: headless Chromium and Blender.

What a user opens, a client opens in the tests. Both clients install on the CI
machine (`.ci/run`: Debian's ``chromium``, and the ``bpy`` wheel in a virtual
environment of its own, ``.blender-venv``), so there their tests must run: :func:`require` skips only
outside CI (``CI`` unset), and fails in CI when the client is missing.

- :func:`chromium_browser` launches Debian's Chromium through Playwright
  (WebGL2 works headless through SwiftShader);
- :func:`run_blender` runs a Python script in a fresh interpreter that imports
  ``bpy`` (Blender 5 as a module; Cycles renders on the CPU).

Blender's interpreter is not the package's: the ``bpy`` wheel pins NumPy 1.26
while the package's dependencies (Zarr 3) need NumPy 2, so ``bpy`` lives in its
own virtual environment and the scripts it runs exchange files (meshes, EXR
renders, JSON) with the tests, never import ``warp_texton``. Its interpreter is
``$WARP_TEXTON_BLENDER_PYTHON``, else ``.blender-venv/bin/python`` at the
repository root (``python3 -m venv .blender-venv && .blender-venv/bin/pip
install bpy``, as `.ci/run` does).
"""

from __future__ import annotations

import contextlib
import functools
import importlib.util
import os
import shutil
import subprocess
from pathlib import Path

import pytest

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")


def require(available: bool, what: str) -> None:
    """Skip (outside CI) or fail (in CI) when a client is missing."""
    if available:
        return
    if os.environ.get("CI"):
        pytest.fail(f"{what} is missing on the CI machine; .ci/run installs it")
    pytest.skip(f"{what} is not installed")


ROOT = Path(__file__).resolve().parents[1]


def blender_python() -> str | None:
    """The interpreter that imports ``bpy``, or None."""
    env = os.environ.get("WARP_TEXTON_BLENDER_PYTHON")
    if env:
        return env
    local = ROOT / ".blender-venv" / "bin" / "python"
    return str(local) if local.exists() else None


@functools.cache
def has_bpy() -> bool:
    exe = blender_python()
    if exe is None:
        return False
    try:
        return subprocess.run([exe, "-c", "import bpy"], capture_output=True, timeout=120).returncode == 0
    except (OSError, subprocess.TimeoutExpired):
        return False


def has_playwright() -> bool:
    return importlib.util.find_spec("playwright") is not None


@contextlib.contextmanager
def chromium_browser():
    """A headless Chromium (Playwright's sync API) for the duration of the block."""
    require(CHROMIUM is not None, "Chromium (Debian: apt-get install chromium)")
    require(has_playwright(), "Playwright (pip install playwright)")
    from playwright.sync_api import sync_playwright

    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, args=["--no-sandbox"])
        try:
            yield browser
        finally:
            browser.close()


def run_blender(script: str | Path, *args: str, timeout: float = 300.0,
                cwd: str | Path | None = None, env: dict[str, str] | None = None) -> subprocess.CompletedProcess:
    """Run ``script`` (a path, or Python source) with ``bpy`` importable, in its own process.

    The script reads its arguments from ``sys.argv[1:]``. Blender's bundled
    site-packages (which holds ``oslquery``, needed to compile OSL Script nodes
    in background mode) is put on ``sys.path`` before the script runs; ``env`` adds to the
    environment (``BLENDER_USER_RESOURCES``: a user folder of its own). Raises
    ``AssertionError`` with Blender's output when the script fails.
    """
    require(has_bpy(), "Blender's bpy module (python3 -m venv .blender-venv && .blender-venv/bin/pip install bpy)")
    source = Path(script).read_text() if isinstance(script, Path) else script
    prologue = (
        "import sys, pathlib, bpy\n"
        "_res = pathlib.Path(bpy.utils.resource_path('LOCAL'))\n"
        "for _p in sorted(_res.glob('python/lib/python3*/site-packages')):\n"
        "    sys.path.append(str(_p))\n"
    )
    proc = subprocess.run([str(blender_python()), "-c", prologue + source, *map(str, args)], capture_output=True,
                          text=True, timeout=timeout, cwd=cwd, env=None if env is None else {**os.environ, **env})
    if proc.returncode != 0:
        raise AssertionError(f"Blender script failed (exit {proc.returncode}):\n{proc.stdout[-4000:]}\n"
                             f"{proc.stderr[-4000:]}")
    return proc
