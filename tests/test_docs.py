"""The documentation's examples run as written, so that it cannot drift from the code.

* The Python blocks of the README and of docs/api.md run (each block on its own,
  in a temporary folder, on the CPU).
* The API reference is generated from the docstrings (mkdocs.yml, docs/reference/),
  whose examples run as doctests (``--doctest-modules``). Here: every public name
  of ``warp_texton`` has a docstring with a summary and a reference page that shows
  it, and every name a reference page shows exists.
* ``mkdocs build --strict`` (a broken link, anchor or cross-reference fails it) runs
  in CI after the tests (.ci/run).
"""

from __future__ import annotations

import importlib
import inspect
import os
import re
from pathlib import Path

import pytest

import warp_texton

ROOT = Path(__file__).resolve().parents[1]
PAGES = [ROOT / "README.md", ROOT / "docs" / "api.md"]
REFERENCE = ROOT / "docs" / "reference"


def blocks() -> list[tuple[str, int, str]]:
    out = []
    for page in PAGES:
        text = page.read_text()
        out += [(page.relative_to(ROOT).as_posix(), text[:m.start()].count("\n") + 1, m.group(1))
                for m in re.finditer(r"```python\n(.*?)```", text, re.S)]
    return out


@pytest.mark.slow
@pytest.mark.parametrize("page, line, code", blocks(), ids=[f"{page}:{line}" for page, line, _ in blocks()])
def test_example_runs(page, line, code, tmp_path, monkeypatch, restore_warning_format):
    monkeypatch.chdir(tmp_path)
    exec(compile(code, f"{ROOT / page}:{line}", "exec"), {"__name__": "__docs_example__"})
    assert os.getcwd() == str(tmp_path)


def referenced() -> set[str]:
    """The names the reference pages render (``::: name`` lines)."""
    names = set()
    for page in REFERENCE.glob("*.md"):
        names |= set(re.findall(r"^::: ([\w.]+)", page.read_text(), re.M))
    return names


@pytest.mark.parametrize("name", sorted(warp_texton.__all__))
def test_public_name_is_documented(name):
    assert f"warp_texton.{name}" in referenced(), f"add warp_texton.{name} to a page of docs/reference/"
    obj = getattr(warp_texton, name)
    if name != "__version__":
        doc = inspect.getdoc(obj)
        assert doc and doc.splitlines()[0].strip(), f"warp_texton.{name} has no docstring summary"


@pytest.mark.parametrize("name", sorted(referenced()))
def test_reference_name_exists(name):
    """A name the reference renders is importable (a module, or a name of one)."""
    if name.startswith("kernels."):  # the repository's kernels/, shipped as warp_texton.kernels
        name = "warp_texton." + name
    parts = name.split(".")
    for k in range(len(parts), 0, -1):  # the longest importable module, then attributes
        try:
            obj = importlib.import_module(".".join(parts[:k]))
        except ImportError:
            continue
        for attr in parts[k:]:
            assert hasattr(obj, attr), f"docs/reference/ renders {name}, which does not exist"
            obj = getattr(obj, attr)
        return
    pytest.fail(f"docs/reference/ renders {name}, which does not exist")
