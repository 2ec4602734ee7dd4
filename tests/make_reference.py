"""Record tests/data/reference_outputs.npz from the current code (CPU). See reference_cases.py."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from reference_cases import CASES  # noqa: E402

OUT = Path(__file__).parent / "data" / "reference_outputs.npz"

if __name__ == "__main__":
    values = {name: fn() for name, fn in CASES.items()}
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True).stdout.strip()
    np.savez_compressed(OUT, commit=np.array(commit), **values)
    print(f"{OUT}: {len(values)} cases recorded at {commit}")
