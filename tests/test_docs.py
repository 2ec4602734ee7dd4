"""The Python examples of docs/api.md run as written (each block on its own, in a
temporary folder, on the CPU), so the documented API cannot drift from the code."""

from __future__ import annotations

import os
import re
from pathlib import Path

import pytest

API = Path(__file__).resolve().parents[1] / "docs" / "api.md"


def blocks() -> list[tuple[int, str]]:
    text = API.read_text()
    return [(text[:m.start()].count("\n") + 1, m.group(1)) for m in re.finditer(r"```python\n(.*?)```", text, re.S)]


@pytest.mark.slow
@pytest.mark.parametrize("line, code", blocks(), ids=[f"api.md:{line}" for line, _ in blocks()])
def test_api_example_runs(line, code, tmp_path, monkeypatch, restore_warning_format):
    monkeypatch.chdir(tmp_path)
    exec(compile(code, f"{API}:{line}", "exec"), {"__name__": "__api_example__"})
    assert os.getcwd() == str(tmp_path)
