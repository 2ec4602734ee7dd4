"""Benchmarks of warp-texton: the runner (``python -m benchmarks``, see
``runner.py``) and the single-purpose scripts ``bench_*.py``, which also run
on their own (``python benchmarks/bench_synthesis.py``).

Results, with the machine, date and commit they came from, go to
``benchmarks/results/``; docs/benchmarks.md discusses them.
"""
