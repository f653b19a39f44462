"""A real H.264 file (long GOP, B-frames) yields the same frames by seeking as by reading in order."""

from __future__ import annotations

import subprocess

import cv2
import numpy as np
import pytest

from tendrilkit.io import FrameSource

imageio_ffmpeg = pytest.importorskip("imageio_ffmpeg")

N, W, H = 90, 320, 240


def _frame_number(img: np.ndarray) -> int:
    """The frame's number from its 8 bit cells (black 0 / white 1), robust to compression."""
    g = cv2.cvtColor(img, cv2.COLOR_BGR2GRAY)
    bits = [int(g[100:140, 20 + 35 * b + 5:20 + 35 * b + 25].mean() > 128) for b in range(8)]
    return int(sum(b << i for i, b in enumerate(bits)))


def _make(i: int) -> np.ndarray:
    img = np.full((H, W, 3), 90, np.uint8)
    for b in range(8):
        v = 255 if (i >> b) & 1 else 0
        img[100:140, 20 + 35 * b:20 + 35 * b + 30] = v
    cv2.putText(img, f"{i:03d}", (100, 60), cv2.FONT_HERSHEY_SIMPLEX, 1.2, (255, 255, 255), 2)
    img[200:, (i * 3) % W:(i * 3) % W + 10] = 200  # motion, so the encoder predicts across frames
    return img


@pytest.mark.parametrize("suffix", [".mp4", ".mov"])
def test_seeking_an_h264_file_gives_the_sequential_frames(tmp_path, suffix):
    path = tmp_path / f"clip{suffix}"
    cmd = [imageio_ffmpeg.get_ffmpeg_exe(), "-y", "-loglevel", "error", "-f", "rawvideo", "-pix_fmt", "bgr24",
           "-s", f"{W}x{H}", "-r", "30", "-i", "-", "-c:v", "libx264", "-preset", "veryfast", "-g", "60",
           "-bf", "3", "-pix_fmt", "yuv420p", str(path)]
    data = b"".join(_make(i).tobytes() for i in range(N))
    subprocess.run(cmd, input=data, check=True)
    probe = subprocess.run([imageio_ffmpeg.get_ffmpeg_exe(), "-i", str(path)], capture_output=True, text=True).stderr
    assert "h264" in probe

    with FrameSource(path) as src:
        assert src.frame_count == N
        seq = [src.read(i) for i in range(N)]
    assert [_frame_number(f) for f in seq] == list(range(N))
    order = [0, 75, 3, 59, 60, 61, 89, 1, 44, 45, 30, 88, 2, 62]
    with FrameSource(path) as src:
        for i in order:
            img = src.read(i)
            assert _frame_number(img) == i
            assert np.array_equal(img, seq[i]), f"frame {i}: seeking decoded other pixels than reading in order"
