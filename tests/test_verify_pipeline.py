"""Verification inside the pipeline: a wrong frame becomes ``doubtful`` with the failed check named.

Corruptions of real phantom renders (the frame images of one view changed
after rendering), run through ``reconstruct``; and single frames through
:func:`tendrilkit.pipeline.reconstruct_frame` with a wrong camera.
"""

from __future__ import annotations

import contextlib
import io
from pathlib import Path

import cv2
import numpy as np
import pandas as pd
import pytest

CHECKS = ("precision:", "off tendril:", "centre:", "coverage:", "tip:", "base:", "fit:")


def _fake_continuation(img: np.ndarray, proj_xy: np.ndarray, *, start: float = 0.45) -> np.ndarray:
    """The tendril's outer part erased (board colour) and a false dark continuation drawn instead.

    What a view shows when the 2D stage follows a stem piece or a leaf's edge
    instead of the tendril: the other views disagree.
    """
    out = img.copy()
    n = len(proj_xy)
    k = int(start * n)
    board = tuple(int(c) for c in np.median(img[::8, ::8].reshape(-1, 3), axis=0))
    cv2.polylines(out, [np.round(proj_xy[k:] * 16).astype(np.int32)], False, board, 22, cv2.LINE_AA, 4)
    d = proj_xy[k] - proj_xy[max(k - 10, 0)]
    d = d / np.linalg.norm(d)
    turn = np.array([[0.0, -1.0], [1.0, 0.0]]) @ d         # 90 degrees off the tendril's way
    fake = proj_xy[k] + np.linspace(0, 250, 100)[:, None] * (0.5 * d + turn)
    dark = tuple(int(c) for c in np.percentile(img[::4, ::4].reshape(-1, 3), 1, axis=0))
    cv2.polylines(out, [np.round(fake * 16).astype(np.int32)], False, dark, 5, cv2.LINE_AA, 4)
    return out


@pytest.fixture(scope="module")
def corrupted_run(tmp_path_factory):
    """An S3 phantom of 4 frames as image folders; frame 2 of view 1 corrupted; reconstructed with 1 worker."""
    from tendrilkit.io import open_views
    from tendrilkit.phantom import write_phantom_experiment
    from tendrilkit.runner import run_reconstruct

    base = tmp_path_factory.mktemp("verify_e2e")
    # seed 12: every uncorrupted frame right (seed 11's frame 3, max 2.9 mm off, is rightly doubtful: self-contact)
    exp_path = Path(write_phantom_experiment("S3", base / "exp", n_frames=4, seed=12))
    proj = pd.read_csv(base / "exp" / "ground_truth" / "gt_projections.csv")
    text = exp_path.read_text()
    sources = open_views([base / "exp" / f"view{v}.mp4" for v in (1, 2, 3)])
    for v, src in enumerate(sources, start=1):
        folder = base / "exp" / f"v{v}"
        folder.mkdir()
        for f in range(4):
            img = src.read(f)
            if (v, f) == (1, 2):
                p = proj[(proj.frame == f) & (proj.view == v)].sort_values("point")[["x_px", "y_px"]].to_numpy()
                img = _fake_continuation(img, p)
            cv2.imwrite(str(folder / f"{f:06d}.png"), img)
        src.close()
        text = text.replace(f"view{v}.mp4", f"v{v}")
    exp2 = base / "exp" / "corrupted.yaml"
    exp2.write_text(text)
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        summary = run_reconstruct(exp2, base / "out", workers=1, progress=False)
        code = summary.exit_code
        print(summary)
    return base, code, buf.getvalue()


@pytest.mark.slow
def test_wrong_frame_is_doubtful_and_named(corrupted_run):
    base, code, stdout = corrupted_run
    f = pd.read_csv(base / "out" / "frames.csv")
    assert f.set_index("frame").loc[[0, 1, 3], "status"].eq("ok").all(), f[["frame", "status", "message"]]
    row = f.set_index("frame").loc[2]
    assert row.status == "doubtful", row.message
    first = row.message.split("; ")[0]
    assert first.startswith(CHECKS) and "view 1" in first and "limit" in first, row.message
    assert code == 1
    assert stdout.strip().splitlines()[-1] == "4 frames: 3 ok, 1 doubtful, 0 failed"
    # the figures are in frames.csv, named with units
    for col in ("on_tendril_frac_v1", "off_tendril_max_px_v1", "coverage_frac_v1", "base_px_v1", "views_checked",
                "length_change_pct", "shape_change_mm", "dt_prev_s"):
        assert col in f.columns, col
    assert (f.loc[f.status == "ok", "on_tendril_frac_v1"] >= 0.97).all()
    # and the contact sheet shows it
    assert (base / "out" / "qc_contact_sheet.png").is_file()


@pytest.mark.slow
def test_analyses_exclude_doubtful_frames_by_default(corrupted_run):
    from tendrilkit.io import read_results
    from tendrilkit.sequence import shape_change, tip_trajectory

    base, _, _ = corrupted_run
    res = read_results(base / "out")
    with pytest.warns(UserWarning, match="doubtful"):
        ch = shape_change(res.curves, frames=res.frames)
    assert ch["frame"].tolist() == [0, 1, 3]
    assert 2 in ch.attrs["excluded_frames"]
    ch2 = shape_change(res.curves, frames=res.frames, include_doubtful=True)
    assert ch2["frame"].tolist() == [0, 1, 2, 3]
    tr = tip_trajectory(res.curves, frames=res.frames, include_doubtful=True)
    assert tr["frame"].tolist() == [0, 1, 2, 3]


@pytest.mark.slow
def test_overlay_command_writes_video_and_sheet(corrupted_run, tmp_path):
    from tendrilkit.cli import main

    base, _, _ = corrupted_run
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        code = main(["overlay", str(base / "exp" / "corrupted.yaml"), str(base / "out"),
                     "--video", str(tmp_path / "ov.mp4"), "--sheet", str(tmp_path / "sheet.png"), "--height", "240"])
    assert code == 0
    cap = cv2.VideoCapture(str(tmp_path / "ov.mp4"))
    n = 0
    while True:
        ok, img = cap.read()
        if not ok:
            break
        n += 1
        assert img.shape[0] == 240
    assert n == 4
    assert (tmp_path / "sheet.png").stat().st_size > 1000
    # a bad suffix: one line, exit 2
    assert main(["overlay", str(base / "exp" / "corrupted.yaml"), str(base / "out"), "--video",
                 str(tmp_path / "ov.gif")]) == 2


def _tube():
    from tendrilkit.phantom import render_tube_views

    t = np.linspace(0, 1, 600)[:, None]
    X = np.column_stack([-10 + 40 * t[:, 0], 8 * np.sin(3 * t[:, 0]), 20 + 6 * t[:, 0] ** 2])
    return render_tube_views(X, width_px=7, margin_px=60, name="tube", fps=1)


def test_right_tube_frame_is_ok():
    from tendrilkit.pipeline import reconstruct_frame

    images, cams, exp = _tube()
    r = reconstruct_frame(images, cams, exp, frame=0)
    assert r.status == "ok", r.message
    for v in (1, 2, 3):
        assert r.quality[f"on_tendril_frac_v{v}"] >= 0.97
        assert r.quality[f"coverage_frac_v{v}"] >= 0.9


@pytest.mark.parametrize("shift_px", [12.0, 30.0])
def test_view_shifted_by_a_wrong_camera_is_doubtful(shift_px):
    """One view's principal point off by 12 or 30 px (a bumped camera): never ok."""
    from tendrilkit.camera import Camera
    from tendrilkit.pipeline import reconstruct_frame

    images, cams, exp = _tube()
    K = cams[0].K.copy()
    K[0, 2] += shift_px
    wrong = [Camera(K=K, dist=cams[0].dist, R=cams[0].R, t_mm=cams[0].t_mm, width=cams[0].width,
                    height=cams[0].height)] + list(cams[1:])
    r = reconstruct_frame(images, wrong, exp, frame=0)
    assert r.status in ("doubtful", "failed"), r.message
    if r.status == "doubtful":
        assert r.message.split("; ")[0].startswith(CHECKS), r.message
