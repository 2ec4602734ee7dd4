"""The memory budget (warp_texton.core.limits)."""

from __future__ import annotations

import pytest

from warp_texton import TextonError
from warp_texton.core import limits


@pytest.fixture(autouse=True)
def fresh_budget(monkeypatch):
    monkeypatch.delenv(limits.BUDGET_ENV, raising=False)
    limits.set_memory_budget(None)
    yield
    limits.set_memory_budget(None)


@pytest.mark.parametrize("text, value", [("1024", 1024), ("512M", 512 << 20), ("8g", 8 << 30), ("1.5T", int(1.5 * (1 << 40))),
                                         (" 2 GiB ", 2 << 30), ("3KB", 3072)])
def test_parse_bytes(text, value):
    assert limits.parse_bytes(text) == value


@pytest.mark.parametrize("text", ["", "lots", "-1G", "0", "1X", "nan", "0.5"])
def test_parse_bytes_refuses(text):
    with pytest.raises(TextonError, match=limits.BUDGET_ENV):
        limits.parse_bytes(text)


def test_default_is_half_the_physical_memory():
    total = limits.physical_memory()
    assert limits.memory_budget() == (total // 2 if total else limits.FALLBACK_BUDGET)


def test_environment_then_override(monkeypatch):
    monkeypatch.setenv(limits.BUDGET_ENV, "3G")
    assert limits.memory_budget() == 3 << 30
    limits.set_memory_budget("1M")
    assert limits.memory_budget() == 1 << 20
    limits.set_memory_budget(None)
    assert limits.memory_budget() == 3 << 30


def test_bad_environment_is_one_clear_error(monkeypatch):
    monkeypatch.setenv(limits.BUDGET_ENV, "plenty")
    with pytest.raises(TextonError, match=r"WARP_TEXTON_MEMORY_BUDGET: 'plenty' is not a size"):
        limits.memory_budget()


@pytest.mark.parametrize("value", [0, -5, True, "x", [1], float("nan")])
def test_bad_override(value):
    with pytest.raises(TextonError, match="memory budget|WARP_TEXTON|not a size|at least"):
        limits.set_memory_budget(value)


def test_check_memory_names_the_request_the_budget_and_the_way_out():
    limits.set_memory_budget("1M")
    limits.check_memory(1 << 20, "a raster", "use a smaller raster")
    with pytest.raises(TextonError) as err:
        limits.check_memory((1 << 20) + 1, "a 4096x4096 raster", "use a smaller raster")
    msg = str(err.value)
    assert msg.startswith("a 4096x4096 raster needs about 1 MiB, over the memory budget of 1 MiB; use a smaller raster")
    assert "WARP_TEXTON_MEMORY_BUDGET" in msg
    for bad in (float("nan"), float("inf")):
        with pytest.raises(TextonError):
            limits.check_memory(bad, "x", "y")


@pytest.mark.parametrize("value", [float("inf"), float("-inf"), float("nan"), 1e400])
def test_infinite_budgets_are_refused(value):
    # float('inf') used to raise OverflowError from int()
    with pytest.raises(TextonError, match="memory budget must be a finite number"):
        limits.set_memory_budget(value)
    with pytest.raises(TextonError, match="work budget must be a finite number"):
        limits.set_work_budget(value)


def test_scoped_budget_lowers_this_thread_only():
    import threading

    limits.set_memory_budget("1G")
    try:
        seen = []
        with limits.scoped_budget(memory=1 << 20, work=100):
            assert limits.memory_budget() == 1 << 20 and limits.work_budget() == 100
            with pytest.raises(TextonError,
                               match="over the memory budget of 1 MiB"):
                limits.check_memory(2 << 20, "a request", "ask for less")
            with limits.scoped_budget(memory=8 << 30):  # never above the enclosing budget
                assert limits.memory_budget() == 1 << 20
            other = threading.Thread(target=lambda: seen.append(limits.memory_budget()))
            other.start()
            other.join()
        assert seen == [1 << 30] and limits.memory_budget() == 1 << 30
        with limits.scoped_budget(memory=8 << 30):  # nor above the process's
            assert limits.memory_budget() == 1 << 30
    finally:
        limits.set_memory_budget(None)


def test_over_budget_is_a_texton_error_subclass():
    from warp_texton.core.errors import OverBudget

    with pytest.raises(OverBudget) as info:
        limits.check_work(float("inf"), "a request", "ask for less")
    assert isinstance(info.value, TextonError)


def test_checkpoint_stops_a_cancelled_computation():
    wanted = [True]
    limits.checkpoint()  # outside a cancellable block: nothing to stop
    with limits.cancellable(lambda: wanted[0]):
        limits.checkpoint()
        wanted[0] = False
        with pytest.raises(limits.Cancelled):
            limits.checkpoint()
    limits.checkpoint()
