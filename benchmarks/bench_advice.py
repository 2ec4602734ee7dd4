"""Benchmark: method advice against a labelled set — does ``analyze`` pick the method whose output is closer?

The labelled set: every example of ``structure_sets.py`` (TUNE and HELD_OUT; scikit-image's brick, grass
and gravel are in TUNE) and ten more GIMP patterns of at least 96 texels (:data:`GIMP_EXTRA`, a fixed
list, in the set ``extra``). Each example's **label** is the method whose 512² outputs (seeds 1 and 2)
have the lower mean patch distance to it (``warp_texton.model.tiling.patch_distance`` over its
``half_distance``): ``texton`` (``synthesize(analyze(u), shape, seed=s)``, the defaults) or ``tiling``
(``synthesize(analyze(u, method="tiling"), shape, seed=s)``). A label whose two distances are within
5 % of each other is marked *close*.

Then each advice under test is asked for the same examples and its agreement with the labels is
reported, over all examples, on HELD_OUT and without the close ones:

* ``structure score`` — ``suggest_method(structure_score(u))`` (``warp_texton.model.tiling``), the
  current advice;
* ``auto`` — the kind of ``analyze(u, method="auto")`` where ``analyze`` accepts it (else reported as
  not available);
* ``fit distances`` — where the tiling model's metadata holds ``texton_distance`` and
  ``tiling_distance`` (what the analysis measured itself), the method with the lower one;
* ``--advice module:function`` — any function u → "texton" or "tiling" (``module`` importable, e.g. a
  file in benchmarks/);
* ``always tiling`` — the baseline: the share of labels that are tiling.

Labels are cached in ``results/advice_labels.json`` keyed by the example's file (path, archive member,
modification time) and the output shape and seeds, so a rerun measures only the advice; each entry keeps
the digest of the package's code it was labelled with, ``bench_seamless.tree_state`` (``--relabel``
redoes them all).

    python benchmarks/bench_advice.py --set tune          # label (or reuse) and score → results/advice_tune.{json,md}
    python benchmarks/bench_advice.py --set all
    python benchmarks/bench_advice.py --quick             # 3 small examples, 256², one seed, nothing cached
"""

from __future__ import annotations

import importlib
import json
import warnings
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent))

from bench_seamless import tree_state  # noqa: E402
from common import GIMP_PATTERNS, machine_line, read_gpat, report_header, run_main, write_atomic  # noqa: E402
from structure_sets import Example, prepare, select  # noqa: E402

from warp_texton import analyze, synthesize  # noqa: E402
from warp_texton.model.tiling import half_distance, patch_distance, structure_score, suggest_method  # noqa: E402

SHAPE = (512, 512)
SEEDS = (1, 2)
QUICK_SHAPE = (256, 256)
CLOSE = 0.05
LABELS = HERE / "results" / "advice_labels.json"
#: Ten GIMP patterns (≥ 96 texels, photographs, none of them in TUNE), fixed before any was labelled.
GIMP_EXTRA = ("Fabric/burlap.pat", "Paper/crinklepaper.pat", "Stone/Craters.pat", "Stone/Moonfoot.pat",
              "Stone/cracked.pat", "Stone/granite1.pat", "Stone/ground1.pat", "Stone/slate.pat", "Water/ice.pat",
              "Wood/walnut.pat")
EXTRA = "extra"


def gimp_extra(skipped: list) -> list[Example]:
    out = []
    for rel in GIMP_EXTRA:
        path = GIMP_PATTERNS / rel
        if not path.is_file():
            skipped.append({"case": f"gimp:{rel}", "reason": f"{path} missing (apt-get install gimp-data)"})
            continue

        def load(path=path):
            return prepare(read_gpat(path))

        out.append(Example(f"gimp:{rel}", "gimp", EXTRA, "extra", "GPL-3+",
                           f"{path}@{path.stat().st_mtime_ns}", load))
    return out


def examples_of(which: str, quick: bool) -> tuple[list[Example], list[dict]]:
    if quick:
        found, skipped = select("tune", sources=("gimp", "skimage"))
        pool = {e.name: e for e in found}
        names = ("skimage:grass", "skimage:brick", "gimp:Stone/brick.pat")
        return [_small(pool[n]) if n.startswith("skimage") else pool[n] for n in names if n in pool], skipped
    skipped: list[dict] = []
    found: list[Example] = []
    if which in ("tune", "held-out", "all"):
        found, skipped = select(which)
    if which in (EXTRA, "all"):
        found += gimp_extra(skipped)
    return found, skipped


def _small(example: Example) -> Example:
    from dataclasses import replace

    load = example.load
    return replace(example, name=f"{example.name}[:128]", key=f"{example.key}[:128]",
                   load=lambda: np.ascontiguousarray(load()[:128, :128]))


# ---------------------------------------------------------------- labels


def label(u: np.ndarray, shape, seeds) -> dict:
    """Both methods' patch distances (over the floor) per seed, the label, and the tiling fit's distances."""
    floor = half_distance(u)
    out: dict = {"floor": floor}
    models = {}
    for method in ("texton", "tiling"):
        t0 = time.perf_counter()
        with warnings.catch_warnings():  # the texton's advice about the example: not what is measured here
            warnings.simplefilter("ignore")
            models[method] = analyze(u) if method == "texton" else analyze(u, method="tiling")
        out[f"{method}_analysis_s"] = round(time.perf_counter() - t0, 2)
        d = [patch_distance(np.asarray(synthesize(models[method], shape, seed=s)), u, seed=s) / floor for s in seeds]
        out[method] = [round(x, 5) for x in d]
    t, g = float(np.mean(out["texton"])), float(np.mean(out["tiling"]))
    out["label"] = "texton" if t < g else "tiling"
    out["close"] = abs(t - g) <= CLOSE * min(t, g)
    md = dict(models["tiling"].metadata)
    out["fit"] = {k: md.get(k) for k in ("structure", "texton_distance", "tiling_distance") if k in md}
    return out


def cached_labels(path: Path) -> dict:
    try:
        return json.loads(path.read_text())
    except (OSError, ValueError):
        return {}


# ---------------------------------------------------------------- advice


def advice_structure(u) -> str:
    return suggest_method(structure_score(u))


def auto_available() -> str | None:
    """None where ``analyze(u, method="auto")`` runs, else why not."""
    u = np.random.default_rng(0).random((64, 64, 3)).astype(np.float32)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            analyze(u, method="auto")
    except Exception as exc:  # the option is being added beside this benchmark
        return f"analyze(method='auto') refused: {type(exc).__name__}: {str(exc)[:120]}"
    return None


def advice_auto(u) -> str:
    return getattr(analyze(u, method="auto"), "kind", "texton")


def advice_fit(entry: dict) -> str | None:
    fit = entry.get("fit", {})
    if fit.get("texton_distance") is None or fit.get("tiling_distance") is None:
        return None
    return "tiling" if fit["tiling_distance"] < fit["texton_distance"] else "texton"


def load_function(spec: str):
    module, _, name = spec.partition(":")
    return getattr(importlib.import_module(module), name)


def agreement(rows: list[dict], advice: str, which=lambda r: True) -> dict:
    rs = [r for r in rows if which(r) and r["advice"].get(advice) is not None]
    agree = sum(r["advice"][advice] == r["label"] for r in rs)
    return {"n": len(rs), "agree": agree, "percent": 100.0 * agree / len(rs) if rs else None}


# ---------------------------------------------------------------- the run


def collect(examples: list[Example], shape, seeds, skipped: list, *, cache: dict | None = None,
            cache_path: Path | None = None, advisers: dict | None = None) -> tuple[list[dict], dict]:
    """(rows, agreement) of each example's label (from ``cache`` where it holds one; new labels written to
    ``cache_path`` as they come) and each adviser's answer (default: :func:`default_advisers`)."""
    cache = {} if cache is None else cache
    state = tree_state()
    if advisers is None:
        advisers = default_advisers(skipped)
    rows = []
    for k, ex in enumerate(examples):
        key = f"{ex.key}|{shape[0]}x{shape[1]}|seeds {','.join(map(str, seeds))}"
        u = ex.load()
        entry = cache.get(key)
        fresh = entry is None
        if entry is None:
            try:
                entry = {**label(u, shape, seeds), "tree": state}
            except Exception as exc:  # an example a method refuses: recorded, the run goes on
                skipped.append({"case": ex.name, "reason": f"{type(exc).__name__}: {exc}"})
                continue
            cache[key] = entry
            if cache_path is not None:  # after each example: an interrupted run keeps what it labelled
                cache_path.parent.mkdir(parents=True, exist_ok=True)
                write_atomic(cache_path, json.dumps(cache, indent=1, sort_keys=True) + "\n")
        advice: dict = {}
        for name, fn in advisers.items():
            try:
                with warnings.catch_warnings():  # the analyses' advice about the example, not measured here
                    warnings.simplefilter("ignore")
                    advice[name] = fn(u)
            except Exception as exc:
                advice[name] = None
                skipped.append({"case": f"{name} on {ex.name}", "reason": f"{type(exc).__name__}: {exc}"})
        advice["fit distances"] = advice_fit(entry)
        advice["always tiling"] = "tiling"  # the baseline an advice must beat: most labels are tiling
        row = {"name": ex.name, "short": ex.short, "set": ex.set, "kind": ex.kind, "shape": list(u.shape),
               "label": entry["label"], "close": entry["close"], "texton": float(np.mean(entry["texton"])),
               "tiling": float(np.mean(entry["tiling"])), "fit": entry.get("fit", {}), "advice": advice,
               "cached": not fresh, "labelled_with": entry.get("tree")}
        rows.append(row)
        print(f"  [{k + 1}/{len(examples)}] {ex.short:42s} texton {row['texton']:.2f} tiling {row['tiling']:.2f} → "
              f"{row['label']}{' (close)' if row['close'] else ''}; " +
              ", ".join(f"{a}: {v}" for a, v in advice.items()) + (" [cached]" if not fresh else ""), flush=True)
    names = list(advisers) + ["fit distances", "always tiling"]
    scores = {a: {"all": agreement(rows, a), "held-out": agreement(rows, a, lambda r: r["set"] == "held-out"),
                  "tune": agreement(rows, a, lambda r: r["set"] == "tune"),
                  "extra": agreement(rows, a, lambda r: r["set"] == EXTRA),
                  "not close": agreement(rows, a, lambda r: not r["close"])} for a in names}
    return rows, scores


def default_advisers(skipped: list, extra=()) -> dict:
    """name → function u → method: the structure score, ``analyze(method="auto")`` where it exists, and
    ``extra`` (module:function specs)."""
    advisers = {"structure score": advice_structure}
    why_not_auto = auto_available()
    if why_not_auto is None:
        advisers["auto"] = advice_auto
    else:
        skipped.append({"case": "advice auto", "reason": why_not_auto})
    for spec in extra:
        advisers[spec] = load_function(spec)
    return advisers


def run(args) -> dict:
    shape = QUICK_SHAPE if args.quick else (args.shape, args.shape)
    seeds = SEEDS[:1] if args.quick else (SEEDS if args.seeds is None else tuple(range(1, args.seeds + 1)))
    examples, skipped = examples_of(args.set, args.quick)
    if args.only:
        examples = [e for e in examples if any(s in e.name for s in args.only)]
    cache = {} if (args.quick or args.relabel) else cached_labels(args.labels)
    advisers = default_advisers(skipped, args.advice or ())
    start = time.perf_counter()
    rows, scores = collect(examples, shape, seeds, skipped, cache=cache,
                           cache_path=None if args.quick else args.labels, advisers=advisers)
    state = tree_state()
    stale = sum(1 for r in rows if r["labelled_with"] != state)
    return {**report_header("advice", "cpu"), "working_tree": state,
            "parameters": {"set": "quick" if args.quick else args.set, "shape": list(shape), "seeds": list(seeds),
                           "close": CLOSE},
            "seconds": round(time.perf_counter() - start, 1), "results": rows, "agreement": scores,
            "labels_from_other_tree": stale, "skipped": skipped}


def _pct(a: dict) -> str:
    return "–" if a["percent"] is None else f"{a['percent']:.0f} % ({a['agree']}/{a['n']})"


def markdown(report: dict) -> str:
    p = report["parameters"]
    lines = [f"# Method advice against labels ({report['date']}, set {p['set']})", "", machine_line(report),
             f"Package working tree `{report.get('working_tree')}`; {report['labels_from_other_tree']} labels were "
             f"made with another working tree. Outputs {p['shape'][1]}×{p['shape'][0]}, seeds "
             f"{', '.join(map(str, p['seeds']))}; label: the method with the lower mean patch distance over the "
             f"example's floor (close: within {100 * p['close']:.0f} %).", "",
             "| advice | all | held-out | tune | extra GIMP | without close labels |", "|---|---|---|---|---|---|"]
    for a, s in report["agreement"].items():
        lines.append(f"| {a} | {_pct(s['all'])} | {_pct(s['held-out'])} | {_pct(s['tune'])} | {_pct(s['extra'])} | "
                     f"{_pct(s['not close'])} |")
    advisers = list(report["agreement"])
    lines += ["", "| example | set | kind | texton | tiling | label | " + " | ".join(advisers) + " |",
              "|---|---|---|---:|---:|---|" + "---|" * len(advisers)]
    for r in report["results"]:
        cells = [("–" if r["advice"].get(a) is None else
                  (r["advice"][a] if r["advice"][a] == r["label"] else f"**{r['advice'][a]}**")) for a in advisers]
        lines.append(f"| {r['short']} | {r['set']} | {r['kind']} | {r['texton']:.2f} | {r['tiling']:.2f} | "
                     f"{r['label']}{' (close)' if r['close'] else ''} | " + " | ".join(cells) + " |")
    lines += ["", "Bold: advice that disagrees with the label."]
    if report["skipped"]:
        lines += ["", "## Not measured", ""] + [f"* {s['case']}: {s['reason']}" for s in report["skipped"]]
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    def extra(parser):
        parser.add_argument("--set", default="all", choices=("tune", "held-out", EXTRA, "all"),
                            help="which examples (structure_sets.py; extra: the GIMP_EXTRA patterns)")
        parser.add_argument("--shape", type=int, default=SHAPE[0], help="side of the outputs")
        parser.add_argument("--only", nargs="*", help="only examples whose name contains one of these")
        parser.add_argument("--advice", nargs="*", help="more advice to score, as module:function (u → method)")
        parser.add_argument("--labels", type=Path, default=LABELS, help="the label cache (JSON)")
        parser.add_argument("--relabel", action="store_true", help="label every example again")
        parser.add_argument("--seeds", type=int, choices=range(1, 17), metavar="N", default=None,
                            help="label with outputs of seeds 1..N (default: 1, 2); a patch distance is heavy-tailed "
                                 "over seeds, so more seeds make steadier labels")

    given = sys.argv[1:] if argv is None else list(argv)
    which = "all"
    for k, a in enumerate(given):
        if a == "--set" and k + 1 < len(given):
            which = given[k + 1]
        elif a.startswith("--set="):
            which = a.split("=", 1)[1]
    name = "advice" if which == "all" else f"advice_{which.replace('-', '_')}"
    return run_main(__doc__, name, run, markdown, argv, repeat=1, extra_args=extra)


if __name__ == "__main__":
    sys.exit(main())
