"""The shader languages are one registry (``warp_texton.runtimes.languages``): each language is one port
package that exports either model kind with the same functions, and the export, the command line and the
viewer's WebGL2 mode all reach the languages through it."""

from __future__ import annotations

import numpy as np
import pytest

from warp_texton import Texton, TextonError, export_shader
from warp_texton.cli.parser import build_parser
from warp_texton.model.tiling import TilingModel
from warp_texton.runtimes import export, glsl, languages, osl
from warp_texton.runtimes.languages import LANGUAGES, WEBGL, Language, language


@pytest.fixture(scope="module")
def models():
    rng = np.random.default_rng(0)
    return {"texton": Texton(rng.standard_normal((8, 8, 1)) / 8, [0.5]),
            "tiling": TilingModel(rng.random((40, 40, 3)).astype(np.float32), 8.0)}


def test_each_language_is_one_port_for_either_model_kind(models, tmp_path):
    assert {name: lang.port() for name, lang in LANGUAGES.items()} == {"glsl": glsl, "osl": osl}
    assert [name for name, lang in LANGUAGES.items() if lang.page] == [WEBGL]
    for name, lang in LANGUAGES.items():
        port = lang.port()
        assert lang.name == name and lang.summary and port.META_FILE in port.FILES
        assert hasattr(port, "preview") == hasattr(port, "library") == lang.page
        for kind, model in models.items():
            out = export_shader(model, name, tmp_path / f"{name}_{kind}", seed=3)
            written = {p.name for p in out.iterdir()}
            assert port.META_FILE in written and written <= port.FILES, (name, kind, written)
    # the export's files and markers are the ports'
    assert export.EXPORT_FILES == glsl.FILES | osl.FILES
    assert export.META_FILES == (glsl.META_FILE, osl.META_FILE)


def test_the_cli_takes_the_registrys_languages():
    parser = build_parser()
    for name in LANGUAGES:
        assert parser.parse_args(["shader", "t.exr", "--lang", name, "-o", "out"]).lang == name
    with pytest.raises(SystemExit):
        parser.parse_args(["shader", "t.exr", "--lang", "hlsl", "-o", "out"])


def test_unknown_languages_are_one_error(models, tmp_path):
    for lang in ("hlsl", None, 3):
        with pytest.raises(TextonError, match="lang must be one of glsl, osl") as e:
            language(lang)
        assert e.value.param == "lang"
        with pytest.raises(TextonError, match="lang must be one of glsl, osl"):
            export_shader(models["texton"], lang, tmp_path / "ex")
    assert list(tmp_path.iterdir()) == []


def test_the_export_the_pages_and_the_viewer_load_the_port_through_the_registry(models, tmp_path, monkeypatch):
    """A language whose record loads a recording stand-in: every path that makes shader code asks the
    registry for the port (none keeps a port of its own)."""
    from warp_texton.view.webgl import shader_payload, tiling_payload

    loads: list[str] = []

    def recording(name):
        real = LANGUAGES[name]

        def load():
            loads.append(name)
            return real.port()
        return Language(real.name, real.summary, load, real.page)

    for name in list(LANGUAGES):
        monkeypatch.setitem(languages.LANGUAGES, name, recording(name))
    export_shader(models["tiling"], "osl", tmp_path / "osl")
    assert loads == ["osl"]
    export_shader(models["texton"], "glsl", tmp_path / "glsl")
    export.write_shader_preview(models["tiling"], tmp_path / "p.html", (8, 8))
    payload = tiling_payload(models["tiling"])
    texton_payload = shader_payload(models["texton"], filters=["none"])
    assert loads == ["osl", "glsl", "glsl", "glsl", "glsl"]
    assert "uniform uint TL_SEED;" in payload["library"] and "tiling_noise_at" in payload["main"]
    assert "uniform uint TN_SEED;" in texton_payload["library"]
