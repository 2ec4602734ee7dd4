"""Histogram transforms outside the host outputs: the device API, the shader exports, the viewer.

A texton analysed with ``histogram="preserve"`` shows its example's colours in
every host output (tests/test_histogram.py). Each runtime here either applies
the same transform (and is compared with the host outputs) or refuses such a
texton with one ``TextonError`` that names what it does not apply and the
alternative: no runtime shows the Gaussian values silently.
"""

from __future__ import annotations

import pytest

import warp_texton.device as td
from warp_texton import TextonError, analyze, dsn, export_shader, read_image
from warp_texton.shader import write_shader_preview
from warp_texton.demo import demo_texture_path
from warp_texton.view_webgl import shader_payload

from helpers import run_cli

REFUSED = r"texton has a histogram transform .*, which {} does not apply: it would show Gaussian values"


@pytest.fixture(scope="module")
def grey():
    return analyze(read_image(demo_texture_path()), size=16, seed=0, histogram="preserve")


REFUSERS = {
    "the glsl export": lambda t, d: export_shader(t, "glsl", d / "out"),
    "the osl export": lambda t, d: export_shader(t, "osl", d / "out"),
    "the glsl export ": lambda t, d: write_shader_preview(t, d / "out", (8, 8)),  # the preview
    "dsn .*": lambda t, d: dsn(t, (8, 8)),
    "the glsl export  ": lambda t, d: shader_payload(t, filters=("none",)),  # the viewer's WebGL2 mode
    "the device API": lambda t, d: td.pack_plane(t, device="cpu"),
    "the device API ": lambda t, d: td.pack_filtered(t, device="cpu"),
    "the device API  ": lambda t, d: td.pack_surface(t, 0.01, device="cpu"),
}


@pytest.mark.parametrize("target", REFUSERS)
def test_runtimes_without_the_transform_refuse(grey, tmp_path, target):
    with pytest.raises(TextonError, match=REFUSED.format(target.strip())) as err:
        REFUSERS[target](grey, tmp_path)
    assert err.value.param == "texton" and "histogram='gaussian'" in str(err.value)
    assert not (tmp_path / "out").exists() and list(tmp_path.iterdir()) == []  # nothing half-written


def test_cli_shader_refuses(grey, tmp_path, capsys):
    path = tmp_path / "grass.exr"
    grey.save(path)
    for lang in ("glsl", "osl"):
        assert run_cli(["shader", path, "--lang", lang, "-o", tmp_path / "out"]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and f"which the {lang} export does not apply" in err[0], err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["grass.exr"]
