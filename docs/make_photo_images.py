"""Render the pictures of docs/photographs.md: what uneven lighting and an enlarged
photograph do to texton noise, and what a crop and ``--downscale`` do about it.

Two rows, from scikit-image's CC0 textures:

* lighting: gravel (512²) under a simulated spotlight, analysed whole and as a
  crop of its evenly lit middle;
* enlargement: a 128² patch of grass enlarged 4× (bilinear: an upscaled photo,
  or one taken four times closer), analysed as it is and shrunk back with
  ``downscale(u, 4)``, whose noise is drawn at ``scale=4`` so that features keep
  their size on the page, and at ``scale=1``.

Each analysis's warnings (``ExampleWarning``) are printed. Texton 64² unless
said, MNI 30, seed 1, 256² panels.

    python docs/make_photo_images.py        # about half a minute on 2 CPU cores
"""

from __future__ import annotations

import argparse
import warnings
from pathlib import Path

import numpy as np

from warp_texton import ExampleWarning, analyze, downscale, synthesize, write_image

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "docs" / "images" / "photographs"
SIDE = 256


def enlarged(u: np.ndarray, k: int) -> np.ndarray:
    """u enlarged k times by bilinear interpolation, as an image editor does."""
    m, n = u.shape[:2]
    y = np.clip((np.arange(m * k) + 0.5) / k - 0.5, 0, m - 1)
    x = np.clip((np.arange(n * k) + 0.5) / k - 0.5, 0, n - 1)
    y0, x0 = np.minimum(y.astype(int), m - 2), np.minimum(x.astype(int), n - 2)
    fy, fx = (y - y0)[:, None, None], (x - x0)[None, :, None]
    a, b, c, d = u[y0][:, x0], u[y0][:, x0 + 1], u[y0 + 1][:, x0], u[y0 + 1][:, x0 + 1]
    return ((1 - fy) * ((1 - fx) * a + fx * b) + fy * ((1 - fx) * c + fx * d)).astype(np.float32)


def spotlight(u: np.ndarray) -> np.ndarray:
    """u lit by a soft spot centred at 40 % of its width and height."""
    m, n = u.shape[:2]
    y, x = np.mgrid[:m, :n]
    light = 0.3 + 0.7 * np.exp(-(((x - 0.4 * n) ** 2 + (y - 0.4 * m) ** 2) / (0.3 * n) ** 2))
    return (u * light[..., None]).astype(np.float32)


def learn(name: str, u: np.ndarray, size: int = 64):
    """The texton of u, with the warnings analyze gave (printed)."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        texton = analyze(u, size=size, seed=0)
    found = [f"{type(w.message).__name__}: {w.message}" for w in caught if issubclass(w.category, ExampleWarning)]
    print(f"{name}: {u.shape[1]}x{u.shape[0]}, size {size}: " + ("; ".join(found) if found else "no warning"))
    return texton


def save(name: str, image: np.ndarray) -> None:
    write_image(OUT / f"{name}.png", np.clip(image, 0.0, 1.0))
    print(OUT / f"{name}.png", flush=True)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--device", default="cpu")
    args = parser.parse_args(argv)
    import skimage.data

    OUT.mkdir(parents=True, exist_ok=True)
    noise = dict(shape=(SIDE, SIDE), mni=30.0, seed=1, device=args.device)

    # lighting: the whole photo against an evenly lit crop of it
    gravel = skimage.data.gravel().astype(np.float32)[..., None] / 255.0
    lit = spotlight(gravel)
    save("lit_input", downscale(lit, 2))  # shown at half size: the whole 512² photo
    save("lit_noise", synthesize(learn("lit whole", lit), **noise))
    crop = lit[110:302, 110:302]  # 192², around the spot's centre
    save("crop_input", crop[:SIDE, :SIDE])
    save("crop_noise", synthesize(learn("lit crop", crop), **noise))

    # enlargement: features four times larger than a 64² texton can hold
    grass = skimage.data.grass().astype(np.float32)[..., None] / 255.0
    zoomed = enlarged(grass[:128, :128], 4)  # 512²
    save("zoomed_input", zoomed[:SIDE, :SIDE])
    save("zoomed_noise", synthesize(learn("zoomed", zoomed), **noise))
    small = downscale(zoomed, 4)  # 128²: the grass at its own scale again
    texton = learn("zoomed, downscale 4", small, size=32)
    save("downscaled_noise", synthesize(texton, scale=4.0, **noise))
    save("downscaled_noise_1x", synthesize(texton, **noise))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
