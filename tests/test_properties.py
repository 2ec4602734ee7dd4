"""Property-based tests (Hypothesis): every public function gives valid output or one
``TextonError``, never another exception, a crash, a hang, or a file left behind.

The table of functions and argument strategies is tests/property_api.py (one
entry per function: add a function there). Each example draws a valid set of
arguments, then replaces up to two of them with values that must be refused
(the error must then name the parameter) or with edge values (huge, tiny, far:
accepted or refused, either is fine). Calls run in a worker process
(tests/property_worker.py) with small memory and work budgets and a limited
address space, so a crash, an unbounded allocation or a hang fails one example,
not the whole pytest run.

Profiles (registered in conftest.py): ``ci`` (default: derandomized, a bounded
number of examples per function, a few minutes in all) and ``slow`` (random,
many more examples): ``python -m pytest tests/test_properties.py
--hypothesis-profile slow`` (or ``HYPOTHESIS_PROFILE=slow``).
"""

from __future__ import annotations

import os
import pickle
import re
import select
import shutil
import struct
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import event, given, note
from hypothesis import strategies as st

import property_api as api

HERE = Path(__file__).resolve().parent
#: The worker's budgets: small, so that refusals come before work.
WORKER_ENV = {"WARP_TEXTON_MEMORY_BUDGET": "256M", "WARP_TEXTON_WORK_BUDGET": "3e8",
              "PROPERTY_WORKER_ADDRESS_SPACE": str(12 << 30)}
#: A call that takes longer than this hangs (the work budget keeps calls well under a second).
CALL_TIMEOUT = 120.0
#: The first calls compile the kernels.
WARM_TIMEOUT = 1200.0
#: One line, in the package's words.
ERROR_LINE = re.compile(r"^warp-texton: (error|warning): \S")


class Worker:
    """The worker process; restarted after a crash or a hang."""

    def __init__(self):
        self.proc = None
        self.log = None

    def start(self) -> None:
        self.log = tempfile.TemporaryFile()
        env = {**os.environ, **WORKER_ENV, "PYTHONPATH": os.pathsep.join([str(HERE), *sys.path])}
        self.proc = subprocess.Popen([sys.executable, str(HERE / "property_worker.py")], stdin=subprocess.PIPE,
                                     stdout=subprocess.PIPE, stderr=self.log, env=env)

    def close(self) -> None:
        if self.proc is not None:
            self.proc.kill()
            self.proc.wait()
            self.proc = None

    def stderr_tail(self) -> str:
        self.log.seek(0)
        return self.log.read()[-3000:].decode("utf-8", "replace")

    def call(self, target: str, kwargs: dict, check: str | None = None, timeout: float = CALL_TIMEOUT):
        if self.proc is None or self.proc.poll() is not None:
            self.start()
        data = pickle.dumps((target, kwargs, check))
        try:
            self.proc.stdin.write(struct.pack("<Q", len(data)) + data)
            self.proc.stdin.flush()
        except BrokenPipeError:
            return self._dead()
        out = self.proc.stdout
        ready, _, _ = select.select([out], [], [], timeout)
        if not ready:
            tail = self.stderr_tail()
            self.close()
            return ("hang", f"no answer after {timeout:.0f} s", tail)
        head = out.read(8)
        if len(head) < 8:
            return self._dead()
        (n,) = struct.unpack("<Q", head)
        return pickle.loads(out.read(n))

    def _dead(self):
        self.proc.wait()
        code = self.proc.returncode
        tail = self.stderr_tail()
        self.proc = None
        return ("crash", f"the worker died with status {code}", tail)


@pytest.fixture(scope="module")
def worker():
    w = Worker()
    w.start()
    # compile the kernels once, with a long timeout (a clean machine builds them here)
    warm = w.call("property_api:warm_up", {}, None, timeout=WARM_TIMEOUT)
    assert warm[0] == "ok", warm
    yield w
    w.close()


def describe(kwargs: dict) -> str:
    """A short, readable account of a call's arguments for failure messages."""
    def short(v):
        if isinstance(v, np.ndarray):
            return f"array(shape={v.shape}, dtype={v.dtype})"
        text = repr(v)
        return text if len(text) < 120 else text[:117] + "..."
    return ", ".join(f"{k}={short(v)}" for k, v in kwargs.items())


def new_files(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir())


def entry_params():
    out = []
    for e in api.ENTRIES:
        marks = [pytest.mark.xfail(strict=False, reason=f"reported for {e.xfail}")] if e.xfail else []
        out.append(pytest.param(e.name, marks=marks, id=e.name))
    return out


@pytest.mark.slow
@pytest.mark.parametrize("name", entry_params())
def test_valid_output_or_one_texton_error(name, worker):
    entry = api.BY_NAME[name]
    for package in entry.needs:  # an optional extra (dask, mesh) that this installation lacks
        pytest.importorskip(package)
    candidates = sorted(set(entry.refused) | set(entry.edges))

    @given(st.data())
    def prop(data):
        kwargs = dict(data.draw(entry.valid, label="valid arguments"))
        corrupt = data.draw(st.lists(st.sampled_from(candidates), max_size=2, unique=True), label="replaced") \
            if candidates else []
        mode = {}
        for p in corrupt:
            kinds = [k for k in ("refused", "edges") if p in getattr(entry, k)]
            mode[p] = data.draw(st.sampled_from(kinds), label=f"kind of {p}")
            kwargs[p] = data.draw(getattr(entry, mode[p])[p], label=f"{mode[p]} {p}")
        folder = Path(tempfile.mkdtemp(prefix="prop-"))
        try:
            if "folder" in entry.files:
                kwargs["folder"] = str(folder)
            if "path" in entry.files and isinstance(kwargs.get("path"), str):
                kwargs["path"] = str(folder / kwargs["path"])
            call = f"{entry.name}({describe(kwargs)})"
            note(call)
            outcome = worker.call(entry.target, kwargs, entry.check)
            kind = outcome[0]
            event(f"{kind}, {'valid arguments' if not mode else ', '.join(sorted(set(mode.values())))}")
            assert kind in ("ok", "TextonError"), (
                f"{call}: {kind}: {outcome[1]}\n{outcome[2] if len(outcome) > 2 else ''}"
                + (f"\n{outcome[3]}" if len(outcome) > 3 else ""))
            refused = [p for p, k in mode.items() if k == "refused"]
            if kind == "ok":
                assert outcome[1] is None, f"{call}: invalid output: {outcome[1]}"
                assert not refused, f"{call}: accepted {', '.join(refused)}, which it should refuse"
            else:
                message = outcome[1]
                assert message and "\n" not in message, f"{call}: the error is not one line: {message!r}"
                if refused:
                    names = [entry.names.get(p, p) for p in refused] + [entry.names.get(p, p) for p in mode]
                    assert any(n in message for n in names), (
                        f"{call}: the error does not name {' or '.join(names)}: {message}")
                elif not mode:
                    assert re.search(entry.may_refuse, message), (
                        f"{call}: valid arguments refused: {message}")
            left = [f for f in new_files(folder) if ".part" in f]
            assert not left, f"{call}: temporary files left behind: {left}"
            if kind == "TextonError" and "path" in entry.files and isinstance(kwargs.get("path"), str):
                assert not Path(kwargs["path"]).exists(), f"{call}: refused, yet {kwargs['path']} was written"
        finally:
            shutil.rmtree(folder, ignore_errors=True)

    prop()


@pytest.mark.slow
def test_command_line_gives_one_line_and_status(worker):
    """Any command line of analyze, gaussian, synthesize, render-plane and mix: status 0
    or 2, stderr only one-line errors and warnings, no temporary file, and no output
    when it fails. (``surface`` takes meshes, which the API entries of property_api.py cover.)"""

    @given(api.cli_argv())
    def prop(argv):
        command, inputs, output, options = argv
        folder = Path(tempfile.mkdtemp(prefix="prop-cli-"))
        try:
            call = f"warp-texton {command} {' '.join(inputs)} -o {output} {' '.join(options)}"
            note(call)
            outcome = worker.call("property_api:run_cli", dict(folder=str(folder), command=command, inputs=inputs,
                                                               output=output, options=options), "__return__")
            assert outcome[0] == "ok", f"{call}: {outcome}"
            status, err, created = outcome[2]
            event(f"status {status}")
            lines = [ln for ln in err.splitlines() if ln.strip()]
            assert status in (0, 2), f"{call}: status {status}\n{err}"
            assert all(ERROR_LINE.match(ln) for ln in lines), f"{call}: stderr is not one-line messages:\n{err}"
            errors = [ln for ln in lines if ln.startswith("warp-texton: error:")]
            assert len(errors) == (status == 2), f"{call}: status {status} with errors {errors}"
            assert not any(".part" in f for f in created), f"{call}: temporary files left: {created}"
            if status == 2:
                assert output not in created, f"{call}: failed, yet wrote {output}"
        finally:
            shutil.rmtree(folder, ignore_errors=True)

    prop()
