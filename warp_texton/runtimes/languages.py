"""The shader languages: one registry that the export, the command line and the viewer use.

Each language is one package of ``warp_texton.runtimes`` (its *port*:
:mod:`~warp_texton.runtimes.glsl`, :mod:`~warp_texton.runtimes.osl`) that exports
either kind of model (texton noise, a tiling model) with the same functions:

* ``files(model, *, noise, filter, texel_size, up, side) -> {name: bytes}``: an
  export's files, its description included (:func:`~warp_texton.export_shader`);
* ``FILES``: every file its exports may write, and ``META_FILE``: the description,
  whose ``"warp_texton"`` key marks a folder as an export (``overwrite``);
* where :attr:`Language.page` is true, ``preview(model, shape, *, scale, rotation,
  offset, noise) -> str``: a self-contained WebGL2 page
  (:func:`~warp_texton.runtimes.export.write_shader_preview`, ``--html``), and
  ``library(model, *, noise, filter)``: what the viewer's WebGL2 mode draws with.

A record here names the language and what it offers without importing its port
(``warp-texton --help`` starts nothing), and :meth:`Language.port` imports it
(a static import, run on first use). A new language is a port package and one
record in :data:`LANGUAGES`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from types import ModuleType

from ..core.errors import TextonError


@dataclass(frozen=True)
class Language:
    """One shader language: its name, a one-line description, whether it has a WebGL2 page, its port."""

    name: str
    summary: str
    load: Callable[[], ModuleType]
    page: bool = False

    def port(self) -> ModuleType:
        """The language's port (imported on first use)."""
        return self.load()


def _glsl() -> ModuleType:
    from . import glsl

    return glsl


def _osl() -> ModuleType:
    from . import osl

    return osl


#: The shader languages, by the name ``export_shader``'s ``lang`` and the CLI's ``--lang`` take.
LANGUAGES: dict[str, Language] = {
    "glsl": Language("glsl", "GLSL ES 3.00 (WebGL2) and desktop GLSL 3.30+, with a WebGL2 preview page", _glsl,
                     page=True),
    "osl": Language("osl", "Open Shading Language (Blender Cycles, Arnold, RenderMan, V-Ray)", _osl),
}
#: The language WebGL2 pages draw with: the preview pages and the viewer's WebGL2 mode.
WEBGL = "glsl"


def language(lang) -> Language:
    """The record of ``lang``; one error naming the languages for anything else."""
    if not isinstance(lang, str) or lang not in LANGUAGES:
        raise TextonError(f"lang must be one of {', '.join(LANGUAGES)}, got {lang!r:.60}", param="lang")
    return LANGUAGES[lang]
