"""Structured example textures that install offline, for the structure benchmarks.

* ``brick`` — scikit-image's ``data.brick()``, 512² grey, CC0.
* ``bricks01``, ``bricks02`` — Nexuiz ``textures/desertfactory_stone/bricks0{1,2}.tga``, 512² RGB;
  ``e7bricks``, ``e7brickfloor`` — Nexuiz ``textures/e7/e7bricks01.jpg`` and
  ``e7brickfloor01.jpg``, 256² RGB. All from Debian's ``nexuiz-textures`` package
  (bookworm 2.5.2-12), GPL-2+ (© 2002–2009 Alientrap; /usr/share/doc/nexuiz-textures/copyright).

The Debian package is fetched without installing it (no root needed)::

    apt-get download nexuiz-textures && dpkg-deb -x nexuiz-textures_*.deb out
    unzip out/usr/share/games/nexuiz/data/textures.pk3 'textures/desertfactory_stone/bricks0*' \
        'textures/e7/e7bricks01.jpg' 'textures/e7/e7brickfloor01.jpg' -d $WARP_TEXTON_STRUCTURED

into ``$WARP_TEXTON_STRUCTURED`` (default ``~/.cache/warp-texton/structured``); a
texture whose file is missing is skipped with the reason.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Callable

import numpy as np

__all__ = ["STRUCTURED", "load", "root"]


def root() -> Path:
    return Path(os.environ.get("WARP_TEXTON_STRUCTURED", Path.home() / ".cache" / "warp-texton" / "structured"))


def _nexuiz(rel: str) -> Callable[[], np.ndarray]:
    def load():
        from PIL import Image

        path = root() / "textures" / rel
        if not path.is_file():
            raise OSError(f"{path} missing (see benchmarks/structured_textures.py)")
        with Image.open(path) as im:
            return np.asarray(im.convert("RGB"), np.float32) / 255.0

    return load


def _brick() -> np.ndarray:
    from skimage import data

    return data.brick().astype(np.float32) / 255.0


#: name → (source and licence, loader)
STRUCTURED: dict[str, tuple[str, Callable[[], np.ndarray]]] = {
    "brick": ("scikit-image data.brick, 512² grey, CC0", _brick),
    "bricks01": ("Nexuiz desertfactory_stone/bricks01, 512² RGB, GPL-2+", _nexuiz("desertfactory_stone/bricks01.tga")),
    "bricks02": ("Nexuiz desertfactory_stone/bricks02, 512² RGB, GPL-2+", _nexuiz("desertfactory_stone/bricks02.tga")),
    "e7bricks": ("Nexuiz e7/e7bricks01, 256² RGB, GPL-2+", _nexuiz("e7/e7bricks01.jpg")),
    "e7brickfloor": ("Nexuiz e7/e7brickfloor01, 256² RGB, GPL-2+", _nexuiz("e7/e7brickfloor01.jpg")),
}


def load(name: str) -> np.ndarray:
    return STRUCTURED[name][1]()
