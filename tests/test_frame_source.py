"""io.FrameSource: frames read with a step (grab over the skipped ones) equal the frames read one by one."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from tendrilkit import io as tio
from tendrilkit.exceptions import FrameReadError

N_FRAMES = 40
BITS = 6
SQUARE = 16


def numbered_frame(i: int) -> np.ndarray:
    """A 128 x 112 BGR frame showing ``i`` in binary (one black or white square per bit) and a ramp."""
    img = np.zeros((112, 128, 3), np.uint8)
    img[:, :, 1] = np.arange(128, dtype=np.uint8)[None, :]          # texture the codec must keep
    for b in range(BITS):
        img[16:16 + SQUARE, 8 + 20 * b:8 + 20 * b + SQUARE] = 255 if (i >> b) & 1 else 0
    img[64:96, :, 2] = (7 * i) % 256                                 # and a per-frame level
    return img


def frame_number(img: np.ndarray) -> int:
    bits = [img[16 + 4:16 + SQUARE - 4, 8 + 20 * b + 4:8 + 20 * b + SQUARE - 4].mean() > 127 for b in range(BITS)]
    return sum(1 << b for b, on in enumerate(bits) if on)


@pytest.fixture(scope="module", params=[("MJPG", ".avi"), ("mp4v", ".mp4")], ids=["mjpg-avi", "mp4v-mp4"])
def numbered_video(request, tmp_path_factory):
    fourcc, suffix = request.param
    path = tmp_path_factory.mktemp("video") / f"numbered{suffix}"
    w = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*fourcc), 10.0, (128, 112))
    assert w.isOpened()
    for i in range(N_FRAMES):
        w.write(numbered_frame(i))
    w.release()
    with tio.FrameSource(path) as src:
        one_by_one = [src.read(i) for i in range(N_FRAMES)]
    assert [frame_number(f) for f in one_by_one] == list(range(N_FRAMES))
    return path, one_by_one


class _CountingCapture:
    """Delegates to a cv2.VideoCapture and counts the calls that make images or seek."""

    def __init__(self, cap):
        self._cap = cap
        self.calls = {"grab": 0, "read": 0, "retrieve": 0, "set": 0}

    def __getattr__(self, name):
        attr = getattr(self._cap, name)
        if name in self.calls:
            def counted(*a, **k):
                self.calls[name] += 1
                return attr(*a, **k)
            return counted
        return attr


@pytest.mark.parametrize("start, step", [(0, 2), (1, 3), (5, 7), (0, 13)])
def test_frames_read_with_a_step_equal_frames_read_one_by_one(numbered_video, start, step):
    path, one_by_one = numbered_video
    wanted = list(range(start, N_FRAMES, step))
    with tio.FrameSource(path) as src:
        counter = _CountingCapture(src._cap)
        src._cap = counter
        got = [src.read(i) for i in wanted]
    assert [frame_number(f) for f in got] == wanted
    for i, f in zip(wanted, got):
        assert np.array_equal(f, one_by_one[i]), f"frame {i} differs from the one read one by one"
    # the skipped frames were stepped over with grab() (no image made, no seek)
    assert counter.calls["set"] == 0
    reads = len(wanted) - (wanted[0] == 0)   # frame 0 was read when the source opened
    assert counter.calls["read"] == reads and counter.calls["retrieve"] == 0
    assert counter.calls["grab"] == wanted[-1] - reads   # frames 1 .. last: each grabbed or read once

def test_long_jumps_and_going_back_seek_to_the_same_frames(numbered_video, monkeypatch):
    path, one_by_one = numbered_video
    monkeypatch.setattr(tio, "MAX_GRAB_FRAMES", 4)
    order = [3, 8, 20, 21, 30, 2, 0, 39]      # +5 (grab), +12 (seek), +1, +9 (seek), back, back, +39
    with tio.FrameSource(path) as src:
        got = [src.read(i) for i in order]
    assert [frame_number(f) for f in got] == order
    for i, f in zip(order, got):
        assert np.array_equal(f, one_by_one[i])


def test_reading_past_the_end_with_a_step_is_a_frame_error(numbered_video):
    path, _ = numbered_video
    with tio.FrameSource(path) as src:
        src.read(N_FRAMES - 3)
        with pytest.raises(FrameReadError, match="cannot be read"):
            src.read(N_FRAMES + 2)
        # the source is still usable afterwards (seeks)
        assert frame_number(src.read(1)) == 1


def test_reading_a_closed_video_is_a_frame_error(numbered_video):
    path, _ = numbered_video
    src = tio.FrameSource(path)
    src.close()
    with pytest.raises(FrameReadError, match="closed"):
        src.read(3)


def test_the_frame_loop_steps_over_skipped_frames_without_decoding_them(numbered_video, monkeypatch):
    """``frames.step`` > 1 in a run (runner._iter_chunk): every view's skipped frames grabbed, never decoded or sought."""
    from types import SimpleNamespace

    from tendrilkit import runner
    from tendrilkit.pipeline import FrameResult

    path, _ = numbered_video
    captures = []

    class CountingSource(tio.FrameSource):
        def __init__(self, p):
            super().__init__(p)
            self._cap = _CountingCapture(self._cap)
            captures.append(self._cap)

    seen = []

    def fake_reconstruct(images, cameras, exp, *, frame, **kw):
        seen.append((frame, [frame_number(im) for im in images]))
        return FrameResult(frame=frame, time_s=0.0, status="failed", message="")

    monkeypatch.setattr(tio, "FrameSource", CountingSource)
    monkeypatch.setattr(runner, "reconstruct_frame", fake_reconstruct)
    exp = SimpleNamespace(videos=[path, path, path], reconstruction=SimpleNamespace(method="chain"))
    frames = list(range(2, N_FRAMES, 5))
    results = list(runner._iter_chunk(frames, [None] * 3, exp, [None] * 3, False))
    assert [r.frame for r in results] == frames
    assert seen == [(f, [f, f, f]) for f in frames]
    assert len(captures) == 3
    for cap in captures:
        assert cap.calls["set"] == 0 and cap.calls["retrieve"] == 0
        assert cap.calls["read"] == len(frames)                   # one decoded image per processed frame
        assert cap.calls["grab"] == frames[-1] - len(frames)      # frames 1 .. last not processed: grabbed only
