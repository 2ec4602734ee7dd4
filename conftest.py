"""Every docstring example (the doctests of ``warp_texton/``, run by ``--doctest-modules``)
runs in a temporary folder of its own, so that examples write their files by plain names,
as a user would, and leave nothing behind."""

import pytest


@pytest.fixture(autouse=True)
def _doctest_in_tmp_path(request, tmp_path, monkeypatch):
    if type(request.node).__name__ == "DoctestItem":
        monkeypatch.chdir(tmp_path)


#: The Blender add-on's source imports ``bpy``: it runs in Blender only (tests/blender/ installs it there).
collect_ignore_glob = ["warp_texton/blender/addon/*"]
