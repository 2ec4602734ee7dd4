"""``python -m benchmarks``: the CPU/GPU benchmark runner (see ``runner.py``)."""

import sys

from .runner import main

sys.exit(main())
