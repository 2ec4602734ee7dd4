"""The viewer refuses a request over its bound before it waits for a computation slot
where the price needs no computation (an upload's size, from its header)."""

from __future__ import annotations

import io
import threading

import numpy as np
from PIL import Image

from warp_texton import Texton
from warp_texton.core.limits import set_memory_budget
from warp_texton.view.viewer import Viewer
from warp_texton.view.queries import BadRequest


def _png(side: int) -> bytes:
    buf = io.BytesIO()
    Image.new("RGB", (side, side)).save(buf, format="PNG")  # all zeros: a few KB
    return buf.getvalue()


def test_upload_over_the_bound_is_refused_while_the_slots_are_busy(tmp_path):
    Texton(np.full((8, 8, 1), 0.1), [0.5]).save(tmp_path / "t.texton")
    set_memory_budget("1G")
    try:
        v = Viewer(tmp_path / "t.texton", device="cpu", slots=2)
    finally:
        set_memory_budget(None)
    outcome = []

    def upload(data):
        try:
            outcome.append(v.add_upload(data, "a.png"))
        except BadRequest as exc:
            outcome.append(exc)

    try:
        for _ in range(2):  # both slots busy, as with two long exports
            v._slots.acquire()
        asker = threading.Thread(target=upload, args=(_png(4096),), daemon=True)
        asker.start()
        asker.join(10)
        assert not asker.is_alive(), "the upload waited for a slot before being priced"
        (exc,) = outcome
        assert isinstance(exc, BadRequest) and exc.status == 413
        assert "decoding the uploaded 4096x4096 image needs about" in str(exc)
        # one within the bound waits for a slot, and is decoded once one is free
        outcome.clear()
        asker = threading.Thread(target=upload, args=(_png(64),), daemon=True)
        asker.start()
        asker.join(0.5)
        assert asker.is_alive() and not outcome
        v._slots.release()
        asker.join(20)
        assert outcome and outcome[0].image.shape == (64, 64, 3)
    finally:
        v._slots.release()
        v.close()
