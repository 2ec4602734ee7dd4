"""Two fixed sets of texture photographs for the structure benchmarks: TUNE and HELD_OUT.

The selection is a rule written down before any result was looked at, applied the same way to
every package; nothing in it is chosen by hand.

**Sources.** TUNE: Debian's ``nexuiz-textures`` and ``openarena-081-textures``, GIMP's patterns
(``gimp-data``) and scikit-image's ``brick``, ``grass`` and ``gravel``. HELD_OUT: Debian's
``ufoai-textures``, ``cube2-data`` and ``colobot-common-textures``. Each Debian package is a
``dpkg-deb -x`` tree (nothing installed) found under the data folder ``$WARP_TEXTON_DATA``
(default ``.ci-data/`` in the checkout) as ``<folder>/<short name>`` or ``<folder>/<package>``
(``openarena`` or ``openarena-081-textures``; openarena also where ``common.openarena_pk3`` finds
it), or installed under ``/``. Its images are every ``.jpg``, ``.jpeg``, ``.png`` and ``.tga`` file of
the tree and of the zip archives (``.pk3``) in it, read in place. A package that is absent is
skipped with the reason.

**Rule.** For each image of a package, on its file name's stem (lower case; not its folders):

1. Auxiliary maps are left out: a stem whose last ``_`` part is one of :data:`AUXILIARY`
   (normal, gloss, glow, bump, specular, height maps, player-colour masks...).
2. A stem containing a word of :data:`VETO` (``rocket``...) is left out.
3. *structured* if the stem contains a word of :data:`STRUCTURED_WORDS` (bricks, tiles, walls,
   floors, stone, plates, grates, planks, wood, metal, panels...), else *stochastic* if it contains
   one of :data:`STOCHASTIC_WORDS` (grass, sand, dirt, rock, gravel, concrete, ground...), else
   left out. Plain substring tests: ``e7bricks01`` is structured, ``dirty04`` stochastic.
4. The candidates of each kind are sorted by the SHA-1 of ``<package>/<path>`` and taken in that
   order; an image is kept when it loads, is at least :data:`MIN_SIDE` texels on its smaller side,
   at most :data:`MAX_ASPECT` times longer than wide, has transparent texels (alpha < 250) on at
   most 1 % of its area (decals and grates with holes: their colours there are undefined), and a
   luminance standard deviation of at least :data:`MIN_STD` (not a flat colour), until
   :data:`CAP` (8 structured, 4 stochastic) are kept.
5. Kept images are float32 RGB in [0, 1] (grey is repeated), halved by 2 × 2 box means until each
   side is at most :data:`MAX_SIDE` (odd last rows and columns dropped).

GIMP patterns follow the same rule (their stems are names: ``brick``, ``wood1``, ``marble2``);
scikit-image's three are fixed: ``brick`` structured, ``grass`` and ``gravel`` stochastic.

Each kept example reports whether it is seamless: ``warp_texton.model.lattice.seam_ratios(u).wrap``
on both axes (:func:`seamless`).

Licences (each package's ``/usr/share/doc/<package>/copyright``): nexuiz-textures, openarena-081-textures
and ufoai-textures GPL-2+ (a few ufoai files CC-BY/CC-BY-SA, see its copyright file), cube2-data
CC-BY-3.0, colobot-common-textures GPL-3+, gimp-data GPL-3+, scikit-image's data CC0.

    python benchmarks/structure_sets.py             # list both sets (name, kind, size, seamless)
    WARP_TEXTON_DATA=/work/data python benchmarks/structure_sets.py --set held-out
"""

from __future__ import annotations

import argparse
import hashlib
import io
import os
import sys
import zipfile
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Iterator

import numpy as np

HERE = Path(__file__).resolve().parent

__all__ = ["Example", "Package", "PACKAGES", "TUNE", "HELD_OUT", "select", "data_root", "seamless", "classify",
           "prepare", "CAP", "MAX_SIDE", "MIN_SIDE"]

#: Words of a stem that make it a structured texture (substring tests on the lower-case stem).
STRUCTURED_WORDS = ("brick", "tile", "wall", "floor", "stone", "plate", "grate", "grill", "grid", "plank", "wood",
                    "metal", "panel", "cobble", "pave", "block", "roof", "shingle", "slab", "mosaic", "parquet")
#: Words that make it stochastic (when no structured word is in it).
STOCHASTIC_WORDS = ("grass", "sand", "dirt", "rock", "gravel", "concrete", "ground", "mud", "soil", "earth", "moss",
                    "snow", "asphalt", "desert", "pebble", "rust", "cement", "plaster", "stucco", "terrain", "cliff",
                    "marble", "granite", "bark")
#: Words that leave a stem out whatever else it holds.
VETO = ("rocket", "sky", "icon", "logo", "font", "decal", "sign")
#: Last ``_`` parts of the stems of maps that are not colour.
AUXILIARY = frozenset({"norm", "normal", "normals", "nm", "bump", "gloss", "glow", "spec", "specular", "sm", "gm",
                       "hm", "sc", "height", "disp", "ao", "mask", "alpha", "luma", "dudv", "pants", "shirt", "g"})
IMAGE_SUFFIXES = (".jpg", ".jpeg", ".png", ".tga")
#: Examples kept per package and kind.
CAP = {"structured": 8, "stochastic": 4}
MIN_SIDE = 64
MAX_SIDE = 512
MAX_ASPECT = 1.5
MIN_STD = 0.02
#: Largest image file read (the textures are at most a few MB).
MAX_BYTES = 32 << 20


@dataclass(frozen=True)
class Package:
    """A Debian package of textures: its short name, package name, set and licence."""

    short: str
    debian: str
    set: str  # "tune" or "held-out"
    licence: str


PACKAGES = (
    Package("nexuiz", "nexuiz-textures", "tune", "GPL-2+"),
    Package("openarena", "openarena-081-textures", "tune", "GPL-2+"),
    Package("ufoai", "ufoai-textures", "held-out", "GPL-2+ (some files CC-BY/CC-BY-SA-3.0)"),
    Package("cube2", "cube2-data", "held-out", "CC-BY-3.0"),
    Package("colobot", "colobot-common-textures", "held-out", "GPL-3+"),
)
TUNE = "tune"
HELD_OUT = "held-out"


@dataclass(frozen=True)
class Example:
    """One example of a set: ``name`` is ``<source>:<path>``; ``key`` names its file and version (path,
    archive member, modification time) for caches of results."""

    name: str
    source: str
    set: str
    kind: str  # "structured" or "stochastic"
    licence: str
    key: str
    load: Callable[[], np.ndarray]

    @property
    def short(self) -> str:
        """A short label: the source and the file's stem."""
        return f"{self.source}:{Path(self.name.split(':', 1)[1]).stem}"


def data_root() -> Path:
    """The data folder: ``$WARP_TEXTON_DATA``, default ``.ci-data/`` in the checkout."""
    return Path(os.environ.get("WARP_TEXTON_DATA", HERE.parent / ".ci-data"))


def classify(stem: str) -> str | None:
    """The rule's steps 1–3 on a file's stem: "structured", "stochastic" or None (left out)."""
    s = stem.lower()
    if s.rsplit("_", 1)[-1] in AUXILIARY and "_" in s:
        return None
    if any(v in s for v in VETO):
        return None
    if any(w in s for w in STRUCTURED_WORDS):
        return "structured"
    if any(w in s for w in STOCHASTIC_WORDS):
        return "stochastic"
    return None


def prepare(u: np.ndarray) -> np.ndarray:
    """Step 5: float32 (H, W, 3) in [0, 1], halved by 2 × 2 box means until each side is at most MAX_SIDE."""
    a = np.asarray(u, np.float32)
    a = a[:, :, None] if a.ndim == 2 else a
    if a.shape[2] == 1:
        a = np.repeat(a, 3, axis=2)
    while max(a.shape[:2]) > MAX_SIDE:
        h, w = (a.shape[0] // 2) * 2, (a.shape[1] // 2) * 2
        a = a[:h, :w]
        a = 0.25 * (a[0::2, 0::2] + a[1::2, 0::2] + a[0::2, 1::2] + a[1::2, 1::2])
    return np.ascontiguousarray(a, np.float32)


def _decode(data: bytes, what: str) -> tuple[np.ndarray | None, str]:
    """(RGB float32 image or None, why not) of an image file's bytes, checked by step 4."""
    from PIL import Image

    try:
        with Image.open(io.BytesIO(data)) as im:
            im.load()
            has_alpha = "A" in im.getbands() or "transparency" in im.info
            rgba = np.asarray(im.convert("RGBA"), np.uint8)
    except Exception as exc:  # a file the reader refuses: left out, with the reason
        return None, f"{what}: unreadable ({type(exc).__name__})"
    h, w = rgba.shape[:2]
    if min(h, w) < MIN_SIDE:
        return None, f"{what}: {w}x{h} is under {MIN_SIDE}"
    if max(h, w) > MAX_ASPECT * min(h, w):
        return None, f"{what}: {w}x{h} is not square-ish"
    if has_alpha and np.mean(rgba[..., 3] < 250) > 0.01:
        return None, f"{what}: transparent texels"
    rgb = rgba[..., :3].astype(np.float32) / 255.0
    if float(rgb.mean(axis=2).std()) < MIN_STD:
        return None, f"{what}: flat"
    return rgb, ""


def _package_tree(p: Package) -> Path | None:
    """The package's ``dpkg-deb -x`` tree (or, for openarena, its archive alone), or None."""
    root = data_root()
    for place in (root / p.short, root / p.debian):
        if (place / "usr").is_dir():
            return place
    if p.short == "openarena":
        try:
            from common import openarena_pk3
        except ImportError:  # imported as benchmarks.structure_sets
            from .common import openarena_pk3
        try:
            return openarena_pk3()
        except OSError:
            pass
    if Path(f"/usr/share/doc/{p.debian}").is_dir():
        return Path("/")
    return None


@dataclass(frozen=True)
class _Candidate:
    path: str  # relative to the package tree, ``archive.pk3!member`` inside an archive
    kind: str
    read: Callable[[], bytes]
    key: str


def _files(tree: Path, debian: str) -> list[Path]:
    if tree == Path("/"):  # installed: the package's own files, as dpkg lists them
        try:
            listed = Path(f"/var/lib/dpkg/info/{debian}.list").read_text().split("\n")
        except OSError:
            return []
        return sorted(Path(f) for f in listed if f)
    return sorted((tree / "usr").rglob("*"))


def _candidates(tree: Path, debian: str) -> Iterator[_Candidate]:
    if tree.is_file():  # an archive alone
        yield from _archive(tree, tree.name)
        return
    for f in _files(tree, debian):
        if not f.is_file():
            continue
        rel = f.relative_to(tree).as_posix()
        low = f.name.lower()
        if low.endswith(".pk3"):
            yield from _archive(f, rel)
        elif low.endswith(IMAGE_SUFFIXES):
            kind = classify(f.stem)
            if kind is not None and f.stat().st_size <= MAX_BYTES:
                yield _Candidate(rel, kind, f.read_bytes, f"{f}@{f.stat().st_mtime_ns}")


def _archive(path: Path, rel: str) -> Iterator[_Candidate]:
    try:
        z = zipfile.ZipFile(path)
    except (OSError, zipfile.BadZipFile):
        return
    mtime = path.stat().st_mtime_ns
    with z:
        infos = z.infolist()
    for info in infos:
        name = info.filename
        if not name.lower().endswith(IMAGE_SUFFIXES) or info.file_size > MAX_BYTES:
            continue
        kind = classify(Path(name).stem)
        if kind is None:
            continue

        def read(name=name):
            with zipfile.ZipFile(path) as zz:
                return zz.read(name)

        yield _Candidate(f"{rel}!{name}", kind, read, f"{path}!{name}@{mtime}")


def _hash(text: str) -> str:
    return hashlib.sha1(text.encode("utf-8")).hexdigest()


def _pick(source: str, set_: str, licence: str, candidates, skipped: list) -> list[Example]:
    """Step 4 over a source's candidates: hash order, checks, caps."""
    out: list[Example] = []
    count = {k: 0 for k in CAP}
    for c in sorted(candidates, key=lambda c: _hash(f"{source}/{c.path}")):
        if count[c.kind] >= CAP[c.kind]:
            continue
        try:
            data = c.read()
        except OSError as exc:
            skipped.append({"case": f"{source}:{c.path}", "reason": f"unreadable: {exc}"})
            continue
        rgb, why = _decode(data, c.path)
        if rgb is None:
            continue  # the rule's checks: not a skip to report, the next candidate is taken
        count[c.kind] += 1
        image = prepare(rgb)
        out.append(Example(f"{source}:{c.path}", source, set_, c.kind, licence, c.key,
                           lambda image=image: image.copy()))
    return out


def _gimp(skipped: list) -> list[Example]:
    try:
        from common import GIMP_PATTERNS, read_gpat
    except ImportError:
        from .common import GIMP_PATTERNS, read_gpat
    if not GIMP_PATTERNS.is_dir():
        skipped.append({"case": "gimp", "reason": f"{GIMP_PATTERNS} missing (apt-get install gimp-data)"})
        return []
    cands = []
    for f in sorted(GIMP_PATTERNS.rglob("*.pat")):
        kind = classify(f.stem)
        if kind is None:
            continue

        def read(f=f):
            return f.read_bytes()

        cands.append(_Candidate(f.relative_to(GIMP_PATTERNS).as_posix(), kind, read, f"{f}@{f.stat().st_mtime_ns}"))
    out: list[Example] = []
    count = {k: 0 for k in CAP}
    for c in sorted(cands, key=lambda c: _hash(f"gimp/{c.path}")):
        if count[c.kind] >= CAP[c.kind]:
            continue
        try:
            u = read_gpat(GIMP_PATTERNS / c.path)
        except (OSError, ValueError):
            continue
        h, w = u.shape[:2]
        if min(h, w) < MIN_SIDE or max(h, w) > MAX_ASPECT * min(h, w) or float(u.mean(axis=2).std()) < MIN_STD:
            continue
        count[c.kind] += 1
        image = prepare(u)
        out.append(Example(f"gimp:{c.path}", "gimp", TUNE, c.kind, "GPL-3+", c.key, lambda image=image: image.copy()))
    return out


SKIMAGE = (("brick", "structured"), ("grass", "stochastic"), ("gravel", "stochastic"))


def _skimage(skipped: list) -> list[Example]:
    try:
        import skimage
        from skimage import data
    except ImportError:
        skipped.append({"case": "skimage", "reason": "scikit-image is not installed"})
        return []
    out = []
    for name, kind in SKIMAGE:
        def load(name=name):
            return prepare(getattr(data, name)().astype(np.float32) / 255.0)

        out.append(Example(f"skimage:{name}", "skimage", TUNE, kind, "CC0", f"skimage:{name}@{skimage.__version__}",
                           load))
    return out


def select(which: str = "all", *, sources: tuple[str, ...] | None = None) -> tuple[list[Example], list[dict]]:
    """(examples, skipped) of ``which`` ("tune", "held-out" or "all"), in a fixed order: the sources as
    listed in the module docstring, then each source's picks in hash order. ``sources`` limits the
    sources by short name ("nexuiz", "gimp", "skimage"...); skipped lists the sources absent here."""
    if which not in ("tune", "held-out", "all"):
        raise ValueError(f"set must be tune, held-out or all, got {which!r}")
    examples: list[Example] = []
    skipped: list[dict] = []
    wanted = lambda s: sources is None or s in sources  # noqa: E731
    for p in PACKAGES:
        if which not in ("all", p.set) or not wanted(p.short):
            continue
        tree = _package_tree(p)
        if tree is None:
            skipped.append({"case": p.short, "reason": f"{p.debian} not found under {data_root()} (apt-get download "
                            f"{p.debian} && dpkg-deb -x {p.debian}_*.deb {data_root() / p.short}, or set "
                            "WARP_TEXTON_DATA)"})
            continue
        examples += _pick(p.short, p.set, p.licence, _candidates(tree, p.debian), skipped)
    if which in ("all", TUNE):
        if wanted("gimp"):
            examples += _gimp(skipped)
        if wanted("skimage"):
            examples += _skimage(skipped)
    order = {p.short: k for k, p in enumerate(PACKAGES)}
    order.update({"gimp": 2, "skimage": 2})  # TUNE's sources before HELD_OUT's, as listed
    examples.sort(key=lambda e: (e.set != TUNE, order.get(e.source, 9), e.source))
    return examples, skipped


def seamless(u) -> bool:
    """Whether an example tiles: ``seam_ratios(u).wrap`` on both axes."""
    from warp_texton.model.lattice import seam_ratios

    wx, wy = seam_ratios(u).wrap
    return bool(wx and wy)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description="List the TUNE and HELD_OUT sets of the structure benchmarks.")
    parser.add_argument("--set", default="all", choices=("tune", "held-out", "all"))
    args = parser.parse_args(argv)
    examples, skipped = select(args.set)
    for e in examples:
        u = e.load()
        print(f"{e.set:8s} {e.kind:10s} {u.shape[1]:4d}x{u.shape[0]:<4d} "
              f"{'seamless' if seamless(u) else 'crop    '} {e.name}")
    for s in skipped:
        print(f"skipped {s['case']}: {s['reason']}")
    return 0


if __name__ == "__main__":
    sys.path.insert(0, str(HERE))
    sys.path.insert(0, str(HERE.parent))
    sys.exit(main())
