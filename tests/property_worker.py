"""The worker process of the property suite: runs one call at a time, apart from pytest.

A call that crashes the interpreter (a kernel fault), allocates without bound
(the worker's address space is limited) or hangs (the parent stops waiting)
then fails one example instead of the whole pytest run. The worker runs with small
budgets (``WARP_TEXTON_MEMORY_BUDGET``, ``WARP_TEXTON_WORK_BUDGET``, set by the
parent), so that the package refuses large requests quickly.

Protocol: the parent writes length-prefixed pickles ``(target, kwargs, check)``
to the worker's stdin; the worker answers one pickle per call on its own copy
of fd 1 (everything the package or Warp prints goes to stderr instead):

* ``("ok", problem)``: the call returned; ``problem`` is None or why the
  result is not valid output (``check`` of tests/property_api.py); with
  ``check = "__return__"``, ``("ok", None, result)``;
* ``("TextonError", message)``;
* ``("error", type name, message, traceback)``: any other exception.
"""

from __future__ import annotations

import importlib
import os
import pickle
import struct
import sys
import traceback
import warnings


def resolve(target: str):
    module, _, attr = target.partition(":")
    obj = importlib.import_module(module)
    for part in attr.split("."):
        obj = getattr(obj, part)
    return obj


def read_message(stream):
    head = stream.read(8)
    if len(head) < 8:
        return None
    (n,) = struct.unpack("<Q", head)
    return pickle.loads(stream.read(n))


def write_message(stream, obj) -> None:
    data = pickle.dumps(obj)
    stream.write(struct.pack("<Q", len(data)) + data)
    stream.flush()


def main() -> int:
    proto = os.fdopen(os.dup(1), "wb")
    os.dup2(2, 1)  # prints (Warp's, tqdm's) go to stderr, not into the protocol
    sys.stdout = sys.stderr
    limit = int(os.environ.get("PROPERTY_WORKER_ADDRESS_SPACE", "0"))
    if limit:
        import resource

        resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    import property_api  # noqa: F401  (the wrappers and checks)
    from warp_texton import TextonError

    warnings.simplefilter("ignore")
    stdin = sys.stdin.buffer
    while True:
        message = read_message(stdin)
        if message is None:
            return 0
        target, kwargs, check = message
        kwargs = {k: v.make() if isinstance(v, property_api.Broadcast) else v for k, v in kwargs.items()}
        try:
            result = resolve(target)(**kwargs)
            if check == "__return__":  # small results the parent reads itself
                answer = ("ok", None, result)
            else:
                answer = ("ok", getattr(property_api, check)(result, kwargs) if check else None)
        except TextonError as exc:
            answer = ("TextonError", str(exc))
        except BaseException as exc:  # noqa: BLE001 - reported to the parent, which fails the example
            answer = ("error", type(exc).__name__, str(exc)[:2000], traceback.format_exc()[-4000:])
        write_message(proto, answer)


if __name__ == "__main__":
    sys.exit(main())
