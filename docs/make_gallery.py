"""Make the gallery: docs/images/gallery/*.png and docs/gallery.md, from real textures.

Textures (see DATA.md of the project): scikit-image's grass, gravel and brick
(512 × 512 grey, CC0) and, when Debian's ``gimp-data`` is installed, GIMP's
seamless colour pattern Wood/walnut (128 × 128, GPL-3+), read from its
``.pat`` file by the small GPAT reader of ``benchmarks/common.py``; without it that row is left out.

For each texture: the input, a sample of its Gaussian model
(``gaussian_texture``), its texton (``texton_preview``), texton noise at MNI 5,
10 and 30, and a 2 × 2 tiling of a periodic tile. Then, as the package has
them: a filtered plane (rendered by make_filtering_images.py), a surface render (``render_mesh``),
a mixing strip (``mix_textons`` + ``synthesize_mixed``, grass → brick in 21
steps) and a mix driven by a ρ map. Everything runs on the CPU device with
fixed seeds (CUDA gives the same noise).

    python docs/make_gallery.py
"""

from __future__ import annotations

import importlib.util
import sys
import time
from pathlib import Path

import numpy as np

from warp_texton import (analyze, gaussian_texture, mix_textons, synthesize, synthesize_mixed,
                         write_image)
from warp_texton.demo import texton_preview
from warp_texton.files.images import atomic_path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
from common import GIMP_PATTERNS, read_gpat  # noqa: E402  (one GPAT reader, shared with the benchmarks)

HERE = Path(__file__).resolve().parent
OUT = HERE / "images" / "gallery"
PAGE = HERE / "gallery.md"
WALNUT = GIMP_PATTERNS / "Wood" / "walnut.pat"

SIDE = 256  # every panel is SIDE × SIDE pixels
MNIS = (5, 10, 30)
SEED = 1
DEVICE = "cpu"


#: The "Filtered plane" section: its pictures come from docs/make_filtering_images.py.
FILTERED_PLANE = [
    "An infinite ground plane in perspective (`render_plane`, CGF §5 and Fig. 3), the view of "
    "`benchmarks/bench_filtering.py`: 1024 × 1024, camera tilted 70° from straight down, field of view 40°, "
    "horizon at the top edge; texton 64² of the benchmark texture, MNI 30, seed 1. Close-ups enlarged 3× of "
    "a far window (top row) and a middle one (bottom row), left to right: unfiltered, `\"mip\"`, "
    "`\"anisotropic\"`, and the 20 × 20 supersampled reference. The four share one contrast stretch "
    "(mean ± 3σ).",
    "",
    "![filtered plane close-ups](images/filtering/closeups.png)",
    "",
    "Far halves of the renders: [unfiltered](images/filtering/plane_none.png), [mip](images/filtering/plane_mip.png), "
    "[anisotropic](images/filtering/plane_anisotropic.png), [reference](images/filtering/plane_reference.png) "
    "(made by `docs/make_filtering_images.py`; errors and times in [benchmarks.md](benchmarks.md)).",
]

def centre_crop(u: np.ndarray, side: int) -> np.ndarray:
    y0, x0 = (u.shape[0] - side) // 2, (u.shape[1] - side) // 2
    return u[y0:y0 + side, x0:x0 + side]


def enlarge(img: np.ndarray, side: int) -> np.ndarray:
    """Nearest-neighbour enlargement by the largest integer factor that fits ``side``."""
    k = max(1, side // max(img.shape[:2]))
    return np.repeat(np.repeat(img, k, axis=0), k, axis=1)


def textures() -> list[dict]:
    """The gallery's sources: name, image, texton size, what to show as the input, credit."""
    from skimage import data

    out = []
    notes = {
        "grass": "a good Gaussian texture",
        "gravel": "a good Gaussian texture",
        "brick": "structured, a hard case: its Gaussian model keeps the direction and scale of the bricks "
                 "(their spectrum) but not the sharp, aligned mortar lines, so its Gaussian version and its "
                 "noise show streaks rather than bricks",
    }
    for name, note in notes.items():
        u = getattr(data, name)().astype(np.float32)[:, :, None] / 255.0
        out.append({"name": name, "u": u, "size": 64, "shown": centre_crop(u, SIDE),
                    "credit": f"scikit-image `data.{name}()`, 512 × 512 grey, CC0; {note}",
                    "input_caption": "input (centre 256², of 512²)"})
    if WALNUT.is_file():
        try:
            u = read_gpat(WALNUT)
        except ValueError as exc:
            print(f"skipping the GIMP pattern: {exc}")
        else:
            h, w = u.shape[:2]
            reps = (-(-SIDE // h), -(-SIDE // w), 1)
            out.append({"name": "walnut", "u": u, "size": min(64, (min(h, w) + 1) // 2),
                        "shown": np.tile(u, reps)[:SIDE, :SIDE],
                        "credit": f"GIMP pattern Wood/walnut (Debian `gimp-data`), {w} × {h} RGB, seamless, GPL-3+",
                        "input_caption": f"input ({w}×{h}, seamless, shown tiled)"})
    else:
        print(f"skipping the GIMP pattern: {WALNUT} is absent (apt-get install gimp-data)")
    return out


def texture_panels(t: dict) -> dict:
    """Write one texture's panels; returns captions and facts for the page."""
    name, u = t["name"], t["u"]
    t0 = time.perf_counter()
    texton = analyze(u, size=t["size"], seed=0)
    seconds = time.perf_counter() - t0
    panels = {
        "input": (t["input_caption"], t["shown"]),
        "gaussian": ("Gaussian version (`gaussian_texture`)", gaussian_texture(u, shape=(SIDE, SIDE), seed=SEED)),
        "texton": (f"texton {t['size']}² (`texton_preview`, enlarged)", enlarge(texton_preview(texton), SIDE)),
    }
    for mni in MNIS:
        panels[f"mni{mni}"] = (f"texton noise, MNI {mni}",
                               synthesize(texton, (SIDE, SIDE), mni=mni, seed=SEED, device=DEVICE))
    half = SIDE // 2
    tile = synthesize(texton, (half, half), mni=30, seed=SEED, period=(half, half), device=DEVICE)
    panels["tiling"] = (f"2 × 2 tiling of a periodic {half}² tile (MNI 30)", np.tile(tile, (2, 2, 1)))
    files = {}
    for key, (caption, img) in panels.items():
        path = OUT / f"{name}_{key}.png"
        write_image(path, img)
        files[key] = (caption, path.name)
    return {"files": files, "rme": texton.metadata["model_error"], "seconds": seconds, "texton": texton}


def mixing_panels(by_name: dict) -> list[tuple[str, str]]:
    """Grass → brick in 21 strips (CGF §7, Fig. 5), and gravel / brick along a ρ map."""
    grass, gravel, brick = (by_name[n]["u"] for n in ("grass", "gravel", "brick"))
    rhos = np.linspace(0.0, 1.0, 21)
    shown = []
    strip_textons = mix_textons(grass, brick, rhos, size=64, seed=0)
    strip = synthesize_mixed(strip_textons, "strips", (192, 1008), mni=30, seed=SEED, device=DEVICE)
    write_image(OUT / "mix_grass_brick.png", strip)
    shown.append(("Mixing strip: grass (left) to brick (right), 21 textons along the optimal-transport "
                  "path between the two Gaussian models (`mix_textons`), each impact taking the texton of "
                  "its strip (`synthesize_mixed(..., \"strips\")`), 1008 × 192, MNI 30.", "mix_grass_brick.png"))
    h, w = SIDE, 2 * SIDE
    y, x = np.mgrid[0:h, 0:w] + 0.5
    edge = w / 2 + 48 * np.sin(2 * np.pi * y / h)
    rho = np.clip((x - edge) / 64 + 0.5, 0.0, 1.0).astype(np.float32)
    map_textons = mix_textons(gravel, brick, rhos, size=64, seed=0)
    mixed = synthesize_mixed(map_textons, rho, (h, w), mni=30, seed=SEED, device=DEVICE)
    write_image(OUT / "mix_map.png", rho)
    write_image(OUT / "mix_gravel_brick_map.png", mixed)
    shown.append(("the ρ map (black: ρ = 0, gravel; white: ρ = 1, brick), 512 × 256.", "mix_map.png"))
    shown.append(("gravel and brick mixed along that map: 21 textons from `mix_textons`, each impact "
                  "takes texton round(20 ρ) at its position, and the mean follows ρ; MNI 30.",
                  "mix_gravel_brick_map.png"))
    return shown


def surface_panel(by_name: dict):
    """A torus without UVs rendered with surface texton noise; None without ``warp_texton.surface.points``."""
    if importlib.util.find_spec("warp_texton.surface.points") is None:
        print("skipping the surface render: warp_texton.surface.points does not exist")
        return None
    import trimesh

    from warp_texton import Camera, render_mesh

    source = by_name.get("walnut") or by_name["gravel"]
    mesh = trimesh.creation.torus(major_radius=1.0, minor_radius=0.45, major_sections=96, minor_sections=48)
    cam = Camera.framing(mesh, direction=(1.0, -1.2, 1.1), zoom=1.6)
    texel = 1.0 / 160.0
    img = render_mesh(mesh, source["panels"]["texton"], (SIDE, int(SIDE * 1.5)), texel_size=texel, camera=cam,
                      mni=60, seed=SEED, device=DEVICE)
    write_image(OUT / "surface_torus.png", img)
    caption = (f"Surface texton noise (CGF §6) of the {source['name']} texton on a torus without texture "
               f"coordinates, ray cast with `render_mesh` ({len(mesh.vertices)} vertices, 160 texels per "
               "unit, major radius 1, MNI 60).")
    return caption, "surface_torus.png"


def image(cell: tuple[str, str]) -> str:
    """Markdown for a panel; the alt text is the file's stem (captions carry markup)."""
    _, file = cell
    return f"![{Path(file).stem.replace('_', ' ')}](images/gallery/{file})"


def page(sources: list[dict], mixing, surface) -> str:
    lines = [
        "# Gallery",
        "",
        "Generated by [`docs/make_gallery.py`](make_gallery.py) (`python docs/make_gallery.py`) from real "
        "textures; every panel is 256 × 256 at one pixel per texel unless said otherwise, on the CPU device with "
        f"seed {SEED} (CUDA gives the same noise). Textons: order 1 (bilinear), 50 iterations, seed 0.",
        "",
        "Each texture shows:",
        "",
        "* the input;",
        "* a sample of its Gaussian model (`gaussian_texture`): if it looks like the input, a texton will too;",
        "* the texton (`texton_preview`: mean + α √(r s), enlarged). Order-1 coefficients α carry the highest "
        "frequencies boosted by 1/√b̂, which shows as a fine checkerboard where the input has many (walnut); "
        "the noise's spectrum, |α̂|² b̂, approximates the input's;",
        "* texton noise at MNI 5, 10 and 30: at 5 the noise is sparse and shows smooth patches where few "
        "textons overlap; at 30 it looks Gaussian;",
        f"* a 2 × 2 tiling of a {SIDE // 2}² tile made periodic with `period=({SIDE // 2}, {SIDE // 2})`, "
        "which repeats without a seam.",
    ]
    for s in sources:
        f = s["panels"]["files"]
        lines += [
            "",
            f"## {s['name'].capitalize()}",
            "",
            f"{s['credit']}. Texton {s['size']}², model error (RME) {s['panels']['rme']:.3f}.",
            "",
            "| " + " | ".join(f[k][0] for k in ("input", "gaussian", "texton", "tiling")) + " |",
            "|---|---|---|---|",
            "| " + " | ".join(image(f[k]) for k in ("input", "gaussian", "texton", "tiling")) + " |",
            "",
            "| " + " | ".join(f[f"mni{m}"][0] for m in MNIS) + " |",
            "|---|---|---|",
            "| " + " | ".join(image(f[f"mni{m}"]) for m in MNIS) + " |",
        ]
    lines += ["", "## Filtered plane", ""] + FILTERED_PLANE
    lines += ["", "## Surface", ""]
    if surface:
        lines += [image(surface), "", surface[0]]
    else:
        lines += ["Not in this build: `warp_texton.surface.points` is absent."]
    lines += ["", "## Mixing", "", image(mixing[0]), "", mixing[0][0], "",
              "| ρ map | mixed noise |", "|---|---|",
              f"| {image(mixing[1])} | {image(mixing[2])} |", "", f"Left: {mixing[1][0]} Right: {mixing[2][0]}"]
    return "\n".join(lines) + "\n"


def main() -> int:
    OUT.mkdir(parents=True, exist_ok=True)
    sources = textures()
    by_name = {}
    for s in sources:
        s["panels"] = texture_panels(s)
        by_name[s["name"]] = s
        print(f"{s['name']}: texton {s['size']}², RME {s['panels']['rme']:.3f}, "
              f"analysis {s['panels']['seconds']:.2f} s", flush=True)
    mixing = mixing_panels(by_name)
    surface = surface_panel(by_name)
    with atomic_path(PAGE) as tmp:
        Path(tmp).write_text(page(sources, mixing, surface), encoding="utf-8")
    total = sum(p.stat().st_size for p in OUT.glob("*.png"))
    print(f"wrote {PAGE} and {len(list(OUT.glob('*.png')))} images ({total / 1e6:.2f} MB) in {OUT}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
