"""Benchmark: seamless and regular examples — the tiling model against tiling and blending read wrapped and not.

For each example of the fixed sets of ``structure_sets.py`` (``--set tune``: nexuiz, openarena, GIMP,
scikit-image; ``held-out``: ufoai, cube2, colobot; ``synthetic``: the known lattices of
``synthetic_lattices.py``, seamless and cropped; ``all``) and each seed, three methods make a 512²
output:

* **peer wrapped** — ``peers.TilingBlending(u, periodic=True)``: the example read wrapped, triangles
  of half its side (the peer's best setting for a seamless example);
* **peer** — ``peers.TilingBlending(u, periodic=False)``: centres kept inside, triangles of a quarter
  of its side (its setting for a crop);
* **package** — ``synthesize(analyze(u, method="tiling"), shape, seed=s)``, the defaults (whatever
  ``analyze`` chooses: wrap, side, lattice).

Measured against the example:

* **patch** — ``warp_texton.model.tiling.patch_distance`` over the example's
  ``half_distance`` (the floor), mean of the seeds;
* **lattice kept** — ``structure.lattice_kept`` on the example's lattice (1: as regular as the
  example): the known one for synthetic examples, else the strongest of
  ``warp_texton.model.lattice_detection.detect_lattices(u, seam_ratios(u).wrap)``; none where none is found;
* **residual repetition** — ``structure.residual_repetition`` on the same lattice (plain
  ``bench_quality.repetition`` without one); the example's own beside it;
* **ms** — milliseconds per output, best of the seeds; **setup** — the peer's constructor or
  ``analyze``, seconds.

Each example is classified seamless (``seam_ratios(u).wrap`` on both axes) or a crop. Ratios:
package / peer wrapped, and package / the peer in its setting for the example's kind (wrapped for a
seamless example, not for a crop), per example and as the ratio of the means per group.

    python benchmarks/bench_seamless.py --set tune           # → results/seamless_tune.{json,md}
    python benchmarks/bench_seamless.py --set held-out --seeds 2
    python benchmarks/bench_seamless.py --set all --gallery docs/images/structure
    python benchmarks/bench_seamless.py --quick              # 3 examples, 256², one seed (CI)

The packages are looked for under ``$WARP_TEXTON_DATA`` (default ``.ci-data/``); absent ones are
skipped with the reason. ``--gallery DIR`` writes a strip per example (example | peer wrapped |
package, ``--tile`` pixels a panel, the same texel scale in all three) and ``index.json`` (names,
sources, licences) into DIR.
"""

from __future__ import annotations

import hashlib
import json
import re
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent))

from bench_quality import repetition  # noqa: E402
from common import machine_line, report_header, run_main, write_atomic  # noqa: E402
from structure import lattice_kept, residual_repetition  # noqa: E402
from structure_sets import Example, select  # noqa: E402
from synthetic_lattices import CASES, lattice_texture  # noqa: E402

from warp_texton import analyze, synthesize  # noqa: E402
from warp_texton.model.tiling import half_distance, patch_distance  # noqa: E402

SHAPE = (512, 512)
QUICK_SHAPE = (256, 256)
SEEDS = (1, 2, 3)
WRAPPED, PEER, PACKAGE = "peer wrapped", "peer", "package"
METHODS = (WRAPPED, PEER, PACKAGE)
#: The --quick examples: what CI has (scikit-image, gimp-data) and one synthetic lattice.
QUICK = ("skimage:brick", "gimp:Stone/brick.pat", "synthetic:running")  # skimage's cropped to 128²


def synthetic_examples() -> list[Example]:
    """Each case of ``synthetic_lattices.CASES``, seamless and as a crop (seed 1)."""
    out = []
    for kind in CASES:
        for seamless in (True, False):
            tag = "" if seamless else "-crop"

            def load(kind=kind, seamless=seamless):
                return lattice_texture(kind, seamless=seamless, seed=1)[0]

            out.append(Example(f"synthetic:{kind}{tag}", "synthetic", "synthetic", "synthetic", "CC0 (generated)",
                               f"synthetic:{kind}{tag}", load))
    return out


def _cropped(example: Example, side: int) -> Example:
    """The example's top-left side × side texels (the quick run's smaller analyses)."""
    from dataclasses import replace

    load = example.load
    return replace(example, name=f"{example.name}[:{side}]", load=lambda: np.ascontiguousarray(load()[:side, :side]))


def truth_of(example: Example):
    """The known lattice vectors of a synthetic example, else None."""
    if example.source != "synthetic":
        return None
    name = example.name.split(":", 1)[1]
    kind = name.removesuffix("-crop")
    return lattice_texture(kind, seamless=not name.endswith("-crop"), seed=1)[1].vectors


def examples_of(which: str, quick: bool) -> tuple[list[Example], list[dict]]:
    if quick:
        found, skipped = select("tune", sources=("gimp", "skimage"))
        pool = {e.name: e for e in found + synthetic_examples()}
        missing = [n for n in QUICK if n not in pool]
        skipped += [{"case": n, "reason": "not available here"} for n in missing]
        return [_cropped(pool[n], QUICK_SHAPE[0] // 2) if n.startswith("skimage") else pool[n]
                for n in QUICK if n in pool], skipped
    if which == "synthetic":
        return synthetic_examples(), []
    found, skipped = select(which) if which != "all" else select("all")
    if which == "all":
        found += synthetic_examples()
    return found, skipped


def example_lattice(u: np.ndarray, wrap) -> dict | None:
    """The strongest lattice ``detect_lattices`` finds, as {vectors, strength, rank, object}, or None."""
    from warp_texton.model.lattice_detection import detect_lattices

    try:
        found = detect_lattices(u, wrap)
    except Exception as exc:  # the detection is being written beside this benchmark: record, go on
        return {"error": f"{type(exc).__name__}: {exc}"}
    if not found:
        return None
    lat = found[0]
    return {"vectors": [list(map(float, v)) for v in lat.vectors], "strength": lat.strength, "rank": lat.rank,
            "object": lat}


def model_info(model) -> dict:
    """What the package's analysis chose: side, wrap, lattice (where the model says), its metadata's fit."""
    info: dict = {"side": float(model.side)}
    for attr in ("wrap", "lattice"):
        value = getattr(model, attr, None)
        if attr == "lattice" and value is not None:
            value = {"vectors": [list(map(float, v)) for v in value.vectors], "strength": value.strength}
        elif isinstance(value, tuple):
            value = [bool(v) for v in value]
        info[attr] = value
    md = dict(model.metadata)
    info["structure"] = md.get("structure")
    return info


def methods_of(u: np.ndarray) -> tuple[dict, dict, dict]:
    """(name → sample(shape, seed), name → setup seconds, what the package chose)."""
    from benchmarks.peers import TilingBlending

    fns, setup = {}, {}
    for name, periodic in ((WRAPPED, True), (PEER, False)):
        t0 = time.perf_counter()
        tb = TilingBlending(u, periodic=periodic)
        setup[name] = time.perf_counter() - t0
        fns[name] = lambda shape, s, tb=tb: tb(shape, seed=s)
    t0 = time.perf_counter()
    model = analyze(u, method="tiling")
    setup[PACKAGE] = time.perf_counter() - t0
    fns[PACKAGE] = lambda shape, s: np.asarray(synthesize(model, shape, seed=s))
    return fns, setup, model_info(model)


def measure(example: Example, shape, seeds, gallery: dict | None = None) -> dict:
    """The row of one example: its classification and lattice, and each method's measures."""
    from warp_texton.model.lattice import seam_ratios

    u = example.load()
    seams = seam_ratios(u)
    wrap = tuple(bool(w) for w in seams.wrap)
    seamless = all(wrap)
    truth = truth_of(example)
    detected = example_lattice(u, wrap)
    if truth is not None:
        lattice = {"vectors": [list(v) for v in truth], "rank": len(truth), "strength": None, "from": "truth",
                   "object": [tuple(v) for v in truth]}
    elif detected is not None and "object" in detected:
        lattice = {**detected, "from": "detected"}
    else:
        lattice = None
    lat = None if lattice is None else lattice["object"]
    floor = half_distance(u)
    fns, setup, chosen = methods_of(u)
    acc: dict = {m: {"patch": [], "kept": [], "resid": [], "rep": [], "s": []} for m in fns}
    for fn in fns.values():
        fn((64, 64), 0)  # warm up: kernels compile, pages touched
    for seed in seeds:
        for name, fn in fns.items():
            t0 = time.perf_counter()
            o = fn(shape, seed)
            acc[name]["s"].append(time.perf_counter() - t0)
            acc[name]["patch"].append(patch_distance(o, u, seed=seed) / floor)
            acc[name]["kept"].append(lattice_kept(o, u, lat))
            acc[name]["resid"].append(residual_repetition(o, u, lat))
            acc[name]["rep"].append(repetition(o))
            if gallery is not None and seed == seeds[0]:
                gallery[name] = o
    if gallery is not None:
        gallery["example"] = u

    def mean(xs):
        xs = [x for x in xs if x is not None]
        return float(np.mean(xs)) if xs else None

    methods = {name: {"patch": mean(a["patch"]), "patch_seeds": [round(x, 4) for x in a["patch"]],
                      "lattice_kept": mean(a["kept"]), "residual_repetition": mean(a["resid"]),
                      "repetition": mean(a["rep"]), "ms": 1e3 * min(a["s"]), "setup_s": setup[name]}
               for name, a in acc.items()}
    best_peer = WRAPPED if seamless else PEER
    row = {
        "name": example.name, "short": example.short, "source": example.source, "set": example.set,
        "kind": example.kind, "licence": example.licence, "shape": list(u.shape),
        "seamless": seamless, "seams": [round(seams.ratio_x, 3), round(seams.ratio_y, 3)],
        "lattice": None if lattice is None else {k: v for k, v in lattice.items() if k != "object"},
        "detected": None if detected is None else {k: v for k, v in detected.items() if k != "object"},
        "example_repetition": repetition(u),
        "example_residual_repetition": residual_repetition(u, u, lat, wrap) if lat is not None else repetition(u),
        "floor": floor, "package_chose": chosen, "methods": methods,
        "ratio_wrapped": methods[PACKAGE]["patch"] / methods[WRAPPED]["patch"],
        "ratio_peer": methods[PACKAGE]["patch"] / methods[PEER]["patch"],
        "best_peer": best_peer,
        "ratio_best_peer": methods[PACKAGE]["patch"] / methods[best_peer]["patch"],
    }
    return row


def summary(rows: list[dict]) -> list[dict]:
    """Means per (set, kind, seamless) group and over every row: patch of each method, ratio of the means,
    the largest per-example ratio, lattice kept and residual repetition where a lattice is known."""
    groups: dict = {}
    for r in rows:
        for key in ((r["set"], r["kind"], "seamless" if r["seamless"] else "crop"), (r["set"], "all", "all"),
                    ("all", "all", "all")):
            groups.setdefault(key, []).append(r)
    out = []
    for (set_, kind, seam), rs in sorted(groups.items(), key=lambda kv: tuple(kv[0])):
        g = {"set": set_, "kind": kind, "seamless": seam, "n": len(rs)}
        for m in METHODS:
            g[f"patch {m}"] = float(np.mean([r["methods"][m]["patch"] for r in rs]))
            kept = [r["methods"][m]["lattice_kept"] for r in rs if r["methods"][m]["lattice_kept"] is not None]
            g[f"kept {m}"] = float(np.mean(kept)) if kept else None
            g[f"resid {m}"] = float(np.mean([r["methods"][m]["residual_repetition"] for r in rs]))
        g["ratio_wrapped"] = g[f"patch {PACKAGE}"] / g[f"patch {WRAPPED}"]
        best = [r["methods"][r["best_peer"]]["patch"] for r in rs]
        g["ratio_best_peer"] = g[f"patch {PACKAGE}"] / float(np.mean(best))
        g["max_ratio_best_peer"] = max(r["ratio_best_peer"] for r in rs)
        g["within_1.15"] = sum(r["ratio_best_peer"] <= 1.15 for r in rs)
        g["wrapped_over_peer"] = g[f"patch {WRAPPED}"] / g[f"patch {PEER}"]
        out.append(g)
    return out


def tree_state() -> str | None:
    """A digest of the package's code as it is on disk (every file git tracks or would track under
    warp_texton/ and kernels/, committed or not): the numbers depend on it, and it changes under a
    running benchmark only where someone edits the package meanwhile."""
    try:
        listed = subprocess.run(["git", "ls-files", "--cached", "--others", "--exclude-standard", "warp_texton",
                                 "kernels"], cwd=HERE.parent, capture_output=True, timeout=20, check=True).stdout
    except (OSError, subprocess.SubprocessError):
        return None
    h = hashlib.sha1()
    for rel in sorted(set(listed.decode().split())):
        try:
            h.update(rel.encode() + b"\0" + (HERE.parent / rel).read_bytes())
        except OSError:  # listed but deleted in the working tree
            h.update(rel.encode() + b"\0-")
    return h.hexdigest()[:12]


# ---------------------------------------------------------------- gallery


def _slug(name: str) -> str:
    source, path = name.split(":", 1)
    stem = Path(path.split("!")[-1]).with_suffix("").as_posix()
    return re.sub(r"[^A-Za-z0-9]+", "_", f"{source}_{stem}").strip("_").lower()


def _panel(img: np.ndarray, scale: float, tile: int) -> np.ndarray:
    """A tile × tile panel: the top-left (tile / scale)² texels of img, resized by ``scale``, 8-bit RGB."""
    from PIL import Image

    n = int(round(tile / scale))
    a = np.asarray(img, np.float32)
    a = a[:, :, None] if a.ndim == 2 else a
    a = np.repeat(a, 3, axis=2) if a.shape[2] == 1 else a
    a = a[:n, :n]
    im = Image.fromarray((np.clip(a, 0.0, 1.0) * 255.0 + 0.5).astype(np.uint8))
    w, h = im.size
    size = (max(1, int(round(w * scale))), max(1, int(round(h * scale))))
    im = im.resize(size, Image.Resampling.BOX if scale < 1 else Image.Resampling.NEAREST)
    out = np.full((tile, tile, 3), 128, np.uint8)
    b = np.asarray(im)[:tile, :tile]
    out[:b.shape[0], :b.shape[1]] = b
    return out


def write_strip(path: Path, images: dict, tile: int) -> None:
    """example | peer wrapped | package at one texel scale: the example's smaller side fills a panel, or
    twice the panel's side of it where it is larger (details stay visible)."""
    from PIL import Image

    from warp_texton.files.images import atomic_path

    u = images["example"]
    scale = tile / min(*u.shape[:2], 2 * tile)
    sep = np.full((tile, 2, 3), 255, np.uint8)
    parts = []
    for key in ("example", WRAPPED, PACKAGE):
        parts += [_panel(images[key], scale, tile), sep]
    strip = np.concatenate(parts[:-1], axis=1)
    with atomic_path(path) as tmp:
        Image.fromarray(strip).save(tmp, format="PNG", optimize=True)


# ---------------------------------------------------------------- the run


def collect(examples: list[Example], shape, seeds, skipped: list, gallery_dir: Path | None = None,
            tile: int = 128) -> list[dict]:
    """The rows of :func:`measure` of each example (failures go to ``skipped``); with ``gallery_dir``, a strip
    each and ``index.json`` there."""
    index = []
    rows = []
    for k, ex in enumerate(examples):
        images: dict | None = {} if gallery_dir is not None else None
        try:
            row = measure(ex, shape, seeds, images)
        except Exception as exc:  # an example the package refuses: recorded, the run goes on
            skipped.append({"case": ex.name, "reason": f"{type(exc).__name__}: {exc}"})
            print(f"  [{k + 1}/{len(examples)}] {ex.short}: failed: {type(exc).__name__}: {exc}", flush=True)
            continue
        rows.append(row)
        m = row["methods"]
        lat = row["lattice"]
        lat_s = "-" if lat is None else f"{lat['rank']}-D" + (f" {lat['strength']:.2f}" if lat["strength"] else "")
        kept = " ".join("-" if m[x]["lattice_kept"] is None else f"{m[x]['lattice_kept']:.2f}" for x in METHODS)
        print(f"  [{k + 1}/{len(examples)}] {ex.short:42s} {'seamless' if row['seamless'] else 'crop    '} "
              f"lattice {lat_s:9s} patch {m[WRAPPED]['patch']:.2f} {m[PEER]['patch']:.2f} "
              f"{m[PACKAGE]['patch']:.2f} (x{row['ratio_wrapped']:.2f})  kept {kept}  resid "
              f"{m[WRAPPED]['residual_repetition']:.2f} {m[PEER]['residual_repetition']:.2f} "
              f"{m[PACKAGE]['residual_repetition']:.2f}  setup {m[PACKAGE]['setup_s']:.1f} s", flush=True)
        if gallery_dir is not None and images:
            gallery_dir.mkdir(parents=True, exist_ok=True)
            file = f"{_slug(ex.name)}.png"
            write_strip(gallery_dir / file, images, tile)
            index.append({"file": file, "name": ex.name, "licence": ex.licence, "seamless": row["seamless"],
                          "panels": ["example", WRAPPED, PACKAGE]})
    if gallery_dir is not None and index:  # merged with the strips of earlier runs (other sets)
        try:
            earlier = json.loads((gallery_dir / "index.json").read_text())
        except (OSError, ValueError):
            earlier = []
        mine = {e["file"] for e in index}
        merged = sorted([e for e in earlier if e.get("file") not in mine] + index, key=lambda e: e["file"])
        write_atomic(gallery_dir / "index.json", json.dumps(merged, indent=2) + "\n")
    return rows


def run(args) -> dict:
    shape = QUICK_SHAPE if args.quick else (args.shape, args.shape)
    seeds = SEEDS[:1] if args.quick else SEEDS[:args.seeds]
    examples, skipped = examples_of(args.set, args.quick)
    if args.only:
        examples = [e for e in examples if any(s in e.name for s in args.only)]
    start = time.perf_counter()
    rows = collect(examples, shape, seeds, skipped, args.gallery, args.tile)
    return {**report_header("seamless", "cpu"), "working_tree": tree_state(),
            "parameters": {"set": "quick" if args.quick else args.set, "shape": list(shape), "seeds": list(seeds)},
            "seconds": round(time.perf_counter() - start, 1), "results": rows, "summary": summary(rows),
            "skipped": skipped}


def _f(x, fmt=".2f") -> str:
    return "–" if x is None else format(x, fmt)


def table_lines(report: dict) -> list[str]:
    lines = ["| example | kind | seamless | lattice | patch: peer wrapped / peer / package | package / wrapped "
             "| lattice kept: wrapped / peer / package | residual repetition: example / wrapped / peer / package "
             "| setup s (package) | ms wrapped / package |",
             "|---|---|---|---|---|---:|---|---|---:|---|"]
    for r in report["results"]:
        m = r["methods"]
        lat = r["lattice"]
        lat_s = "none" if lat is None else (f"{lat['rank']}-D {lat['from']}" +
                                            (f" {lat['strength']:.2f}" if lat.get("strength") else ""))
        lines.append(
            f"| {r['short']} | {r['kind']} | {'yes' if r['seamless'] else 'no'} | {lat_s} | "
            f"{m[WRAPPED]['patch']:.2f} / {m[PEER]['patch']:.2f} / {m[PACKAGE]['patch']:.2f} | "
            f"{r['ratio_wrapped']:.2f} | {_f(m[WRAPPED]['lattice_kept'])} / {_f(m[PEER]['lattice_kept'])} / "
            f"{_f(m[PACKAGE]['lattice_kept'])} | {r['example_residual_repetition']:.2f} / "
            f"{m[WRAPPED]['residual_repetition']:.2f} / {m[PEER]['residual_repetition']:.2f} / "
            f"{m[PACKAGE]['residual_repetition']:.2f} | {m[PACKAGE]['setup_s']:.1f} | "
            f"{m[WRAPPED]['ms']:.0f} / {m[PACKAGE]['ms']:.0f} |")
    return lines


def summary_lines(report: dict) -> list[str]:
    lines = ["| set | kind | seamless | n | patch: wrapped / peer / package | package / wrapped (means) "
             "| package / best peer (means) | largest / ≤ 1.15× | wrapped / peer | lattice kept: wrapped / peer / "
             "package | residual repetition: wrapped / peer / package |",
             "|---|---|---|---:|---|---:|---:|---|---:|---|---|"]
    for g in report["summary"]:
        lines.append(
            f"| {g['set']} | {g['kind']} | {g['seamless']} | {g['n']} | {g[f'patch {WRAPPED}']:.2f} / "
            f"{g[f'patch {PEER}']:.2f} / {g[f'patch {PACKAGE}']:.2f} | {g['ratio_wrapped']:.2f} | "
            f"{g['ratio_best_peer']:.2f} | {g['max_ratio_best_peer']:.2f} / {g['within_1.15']} of {g['n']} | "
            f"{g['wrapped_over_peer']:.2f} | {_f(g[f'kept {WRAPPED}'])} / {_f(g[f'kept {PEER}'])} / "
            f"{_f(g[f'kept {PACKAGE}'])} | {g[f'resid {WRAPPED}']:.2f} / {g[f'resid {PEER}']:.2f} / "
            f"{g[f'resid {PACKAGE}']:.2f} |")
    return lines


def markdown(report: dict) -> str:
    p = report["parameters"]
    lines = [f"# Seamless and regular examples ({report['date']}, set {p['set']})", "", machine_line(report),
             f"Package working tree `{report.get('working_tree')}` (digest of the code in warp_texton/ and kernels/, "
             f"bench_seamless.tree_state). Outputs {p['shape'][1]}×{p['shape'][0]}, seeds {', '.join(map(str, p['seeds']))}; "
             f"{report['seconds']:.0f} s.", "",
             "patch: multi-scale 7×7 patch sliced-Wasserstein distance over the example's half-to-half distance, mean "
             "of the seeds; lattice kept: the output's autocorrelation at the example's lattice peaks over the "
             "example's (1: as regular); residual repetition: repetition after removing the lattice-periodic mean. "
             "best peer: wrapped for a seamless example, not wrapped for a crop.", "",
             "## Summary", "", *summary_lines(report), "", "## Per example", "", *table_lines(report)]
    if report["skipped"]:
        lines += ["", "## Not measured", ""] + [f"* {s['case']}: {s['reason']}" for s in report["skipped"]]
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    def extra(parser):
        parser.add_argument("--set", default="all", choices=("tune", "held-out", "synthetic", "all"),
                            help="which examples (structure_sets.py, synthetic_lattices.py)")
        parser.add_argument("--seeds", type=int, default=3, choices=(1, 2, 3), help="seeds 1..N")
        parser.add_argument("--shape", type=int, default=SHAPE[0], help="side of the outputs")
        parser.add_argument("--only", nargs="*", help="only examples whose name contains one of these")
        parser.add_argument("--gallery", type=Path, default=None, help="write a PNG strip per example here")
        parser.add_argument("--tile", type=int, default=128, help="gallery panel side, pixels")

    given = sys.argv[1:] if argv is None else list(argv)
    which = "all"
    for k, a in enumerate(given):
        if a == "--set" and k + 1 < len(given):
            which = given[k + 1]
        elif a.startswith("--set="):
            which = a.split("=", 1)[1]
    name = "seamless" if which == "all" else f"seamless_{which.replace('-', '_')}"
    return run_main(__doc__, name, run, markdown, argv, repeat=1, extra_args=extra)


if __name__ == "__main__":
    sys.exit(main())
