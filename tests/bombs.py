"""Run a bomb (a call whose cost grows with its arguments) in a child process
with an address-space limit and a timeout, and report how it ended.

The budget tests (``tests/test_budgets_*.py``) use it to check that a request
that would take too much memory or time is refused cleanly, well inside both
limits: one ``TextonError`` (or one CLI line with exit status 2, or one 4xx
answer), no traceback, and nothing left behind.
"""

from __future__ import annotations

import json
import os
import resource
import subprocess
import sys
import time
from dataclasses import dataclass

#: The child's address-space limit: a refusal must need far less than the work it refuses.
ADDRESS_SPACE = 2 << 30
#: Wall-clock seconds after which the child is killed: a generous bound, since a loaded
#: machine stretches the wall time; how quick a refusal was is judged by the CPU time the
#: child spent (``Outcome.cpu_seconds``), which load barely changes.
TIMEOUT = 60.0
#: CPU seconds a refusal may take at most (start-up, Warp's import and the set-up included).
CPU_LIMIT = 10.0

#: Appended to the bomb's code: the child reports its peak resident memory on exit.
_REPORT = """
import atexit as _atexit, json as _json, resource as _resource, sys as _sys
_atexit.register(lambda: _sys.stderr.write("\\nBOMB-PEAK " + _json.dumps(
    _resource.getrusage(_resource.RUSAGE_SELF).ru_maxrss * 1024) + "\\n"))
"""


@dataclass
class Outcome:
    returncode: int | None  # None: killed at the timeout
    seconds: float  # wall clock
    cpu_seconds: float  # user + system time of the child: the work it did
    peak_bytes: int | None
    stdout: str
    stderr: str  # without the peak report

    @property
    def error_lines(self) -> list[str]:
        return [line for line in self.stderr.splitlines() if line.strip()]


def _limit():
    resource.setrlimit(resource.RLIMIT_AS, (ADDRESS_SPACE, ADDRESS_SPACE))


def run_bomb(code: str, *args: str, timeout: float = TIMEOUT, env: dict | None = None) -> Outcome:
    """Run ``code`` (a Python script; ``sys.argv[1:]`` = ``args``) in a child process
    with RLIMIT_AS = ADDRESS_SPACE, killed after ``timeout`` seconds (a time-out
    fails the caller's assertions: returncode None)."""
    t0 = time.perf_counter()
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    child_env = {**os.environ, "PYTHONUNBUFFERED": "1", **(env or {})}
    try:
        done = subprocess.run([sys.executable, "-c", _REPORT + code, *args], capture_output=True, text=True,
                              timeout=timeout, preexec_fn=_limit, env=child_env)
        rc, out, err = done.returncode, done.stdout, done.stderr
    except subprocess.TimeoutExpired as exc:
        rc = None
        out = exc.stdout.decode() if isinstance(exc.stdout, bytes) else (exc.stdout or "")
        err = exc.stderr.decode() if isinstance(exc.stderr, bytes) else (exc.stderr or "")
    seconds = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)  # a killed child counts once reaped, as run() does
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    peak = None
    kept = []
    for line in err.splitlines():
        if line.startswith("BOMB-PEAK "):
            peak = int(json.loads(line[len("BOMB-PEAK "):]))
        else:
            kept.append(line)
    return Outcome(rc, seconds, cpu, peak, out, "\n".join(kept))


def api_bomb(call: str, setup: str = "") -> str:
    """Script: run ``call`` (an expression using ``wt``, numpy as ``np``, after ``setup``);
    print ``refused: <message>`` for a TextonError, ``accepted`` otherwise."""
    return (
        "import numpy as np\nimport warp_texton as wt\n" + setup + "\n"
        "try:\n"
        f"    {call}\n"
        "except wt.TextonError as exc:\n"
        "    print('refused:', exc)\n"
        "else:\n"
        "    print('accepted')\n"
    )


def assert_refused(outcome: Outcome, match: str = "", *, within: float = CPU_LIMIT) -> None:
    """A clean, quick, small refusal: exit 0 with ``refused: ...`` printed (API) or exit 2
    with one error line (CLI), within ``within`` CPU seconds (the work done: a loaded machine
    stretches the wall clock, not this) and under the address-space limit."""
    assert outcome.returncode is not None, f"not refused within {TIMEOUT} s: {outcome.stderr[-300:]}"
    assert outcome.cpu_seconds < within, f"refused after {outcome.cpu_seconds:.1f} CPU seconds"
    assert "Traceback" not in outcome.stderr, outcome.stderr[-800:]
    if outcome.returncode == 0:
        assert outcome.stdout.startswith("refused:"), outcome.stdout[-300:] + outcome.stderr[-300:]
        text = outcome.stdout
    else:
        assert outcome.returncode == 2, (outcome.returncode, outcome.stderr[-500:])
        assert len(outcome.error_lines) == 1, outcome.stderr
        text = outcome.stderr
    if match:
        import re

        assert re.search(match, text), text
