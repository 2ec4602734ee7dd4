"""The viewer's caches: a bounded LRU whose concurrent callers share one computation."""

from __future__ import annotations

import threading
from collections import OrderedDict
from concurrent.futures import Future


class Memo:
    """A bounded LRU of computed values; concurrent callers of one key share one
    computation (the others wait for it). Failures are not kept."""

    def __init__(self, budget: float, weight=lambda value: 1):
        self._budget = budget
        self._weight = weight
        self._total = 0
        self._lock = threading.Lock()
        self._done: OrderedDict = OrderedDict()
        self._pending: dict[object, Future] = {}

    def get(self, key, compute):
        with self._lock:
            if key in self._done:
                self._done.move_to_end(key)
                return self._done[key]
            future = self._pending.get(key)
            owner = future is None
            if future is None:
                future = self._pending[key] = Future()
        if not owner:
            return future.result()
        try:
            value = compute()
        except BaseException as exc:
            with self._lock:
                del self._pending[key]
            future.set_exception(exc)
            raise
        with self._lock:
            del self._pending[key]
            self._done[key] = value
            self._total += self._weight(value)
            while self._total > self._budget and len(self._done) > 1:
                _, old = self._done.popitem(last=False)
                self._total -= self._weight(old)
        future.set_result(value)
        return value

    def __contains__(self, key) -> bool:
        with self._lock:
            return key in self._done

    def __len__(self) -> int:
        with self._lock:
            return len(self._done)
