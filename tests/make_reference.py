"""Record tests/data/reference_outputs.npz from the current code (CPU). See reference_cases.py.

    python tests/make_reference.py                       # every case
    python tests/make_reference.py --only mixed_map,mixed_strips

``--only`` re-records the named cases and keeps every other recorded value as
it is: a change that alters some values on purpose re-records just those, and
says so in its commit. ``--check`` records nothing and lists the cases whose
values differ from the recording.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from reference_cases import CASES  # noqa: E402

OUT = Path(__file__).parent / "data" / "reference_outputs.npz"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--only", help="comma-separated case names to re-record")
    parser.add_argument("--check", action="store_true", help="list the cases that differ; write nothing")
    args = parser.parse_args(argv)
    with np.load(OUT) as data:
        recorded = {k: data[k] for k in data.files}
    if args.check:
        differ = [n for n, fn in CASES.items() if n not in recorded or not np.array_equal(fn(), recorded[n])]
        print("differ: " + (", ".join(differ) if differ else "none"))
        return 1 if differ else 0
    names = list(CASES) if args.only is None else [n.strip() for n in args.only.split(",") if n.strip()]
    unknown = sorted(set(names) - set(CASES))
    if unknown:
        parser.error(f"unknown cases: {', '.join(unknown)}; known: {', '.join(CASES)}")
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True).stdout.strip()
    values = {k: v for k, v in recorded.items() if k in CASES and k != "commit"}
    values.update({name: CASES[name]() for name in names})
    note = recorded.get("commit", np.array("")).item() if args.only else ""
    stamp = commit if not note else f"{note}; {','.join(names)} at {commit}"
    np.savez_compressed(OUT, commit=np.array(stamp), **values)
    print(f"{OUT}: {len(names)} of {len(values)} cases recorded at {commit}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
