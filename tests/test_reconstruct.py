"""End to end: ``python -m tendrilkit reconstruct`` on a short phantom experiment."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from scipy.spatial import cKDTree

ROOT = Path(__file__).resolve().parents[1]


def _run(exp: Path, out: Path, workers: int) -> subprocess.CompletedProcess:
    env = {**os.environ, "TENDRILKIT_PROGRESS": "0"}
    return subprocess.run([sys.executable, "-m", "tendrilkit", "reconstruct", str(exp), "--out", str(out),
                           "--workers", str(workers)], cwd=ROOT, env=env, capture_output=True, text=True,
                          timeout=600)


def _densify(X: np.ndarray, step: float = 0.05) -> np.ndarray:
    seg = np.linalg.norm(np.diff(X, axis=0), axis=1)
    s = np.concatenate([[0], np.cumsum(seg)])
    si = np.arange(0, s[-1], step)
    return np.stack([np.interp(si, s, X[:, c]) for c in range(3)], axis=1)


@pytest.fixture(scope="module")
def phantom_run(tmp_path_factory):
    from tendrilkit.phantom import write_phantom_experiment

    base = tmp_path_factory.mktemp("reconstruct")
    exp = write_phantom_experiment("S3", base / "exp", n_frames=3, seed=11)
    r1 = _run(exp, base / "out1", 1)
    return base, Path(exp), r1


@pytest.mark.slow
def test_files_and_columns(phantom_run):
    base, _, r1 = phantom_run
    assert r1.returncode == 0, r1.stderr
    assert r1.stdout.strip().splitlines()[-1] == "3 frames: 3 ok, 0 doubtful, 0 failed"
    out = base / "out1"
    for name in ("curves.csv", "pwc_curves.csv", "frames.csv", "reprojection.csv", "ordering.csv",
                 "calibration_markers.csv", "cameras.json"):
        assert (out / name).is_file(), name
    curve_cols = ["frame", "time_s", "point", "x_mm", "y_mm", "z_mm"]
    for name in ("curves.csv", "pwc_curves.csv"):
        c = pd.read_csv(out / name)
        assert c.columns.tolist() == curve_cols
        assert c.groupby("frame").size().tolist() == [200] * 3
        assert c[["frame", "point"]].equals(c[["frame", "point"]].sort_values(["frame", "point"]))
    f = pd.read_csv(out / "frames.csv")
    assert f.columns[:4].tolist() == ["frame", "time_s", "status", "message"]
    assert (f.status == "ok").all() and f.frame.tolist() == [0, 1, 2]
    r = pd.read_csv(out / "reprojection.csv")
    assert r.columns.tolist() == ["frame", "view", "section", "mean_px", "std_px", "max_px", "n_points"]
    assert len(r) == 3 * 3 * 3
    cams = json.loads((out / "cameras.json").read_text())
    assert [c["view"] for c in cams] == [1, 2, 3] and set(cams[0]) >= {"K", "dist", "R", "t_mm"}
    assert len(list((out / "frames").glob("frame_*.json"))) == 3


@pytest.mark.slow
def test_accuracy_against_ground_truth(phantom_run):
    base, exp, _ = phantom_run
    out = base / "out1"
    gt = pd.read_csv(exp.parent / "ground_truth" / "gt_curves.csv")
    cur = pd.read_csv(out / "curves.csv")
    f = pd.read_csv(out / "frames.csv")
    for frame, g in cur.groupby("frame"):
        X = gt[gt.frame == frame].sort_values("point")[["x_mm", "y_mm", "z_mm"]].to_numpy()
        P = g[["x_mm", "y_mm", "z_mm"]].to_numpy()
        d, _ = cKDTree(_densify(X)).query(P)
        assert d.mean() <= 1.0, (frame, d.mean())
        assert np.linalg.norm(P[0] - X[0]) <= 3.0 and np.linalg.norm(P[-1] - X[-1]) <= 3.0
    for v in (1, 2, 3):
        assert f[f"reproj_mean_px_v{v}"].max() <= 1.5


@pytest.mark.slow
def test_workers_identical_and_resume(phantom_run):
    base, exp, _ = phantom_run
    r2 = _run(exp, base / "out2", 2)
    assert r2.returncode == 0, r2.stderr
    for name in ("curves.csv", "pwc_curves.csv", "frames.csv", "reprojection.csv", "ordering.csv"):
        assert (base / "out1" / name).read_bytes() == (base / "out2" / name).read_bytes(), name
    # a rerun skips the finished frames and assembles the same tables
    stamp = {p.name: p.stat().st_mtime_ns for p in (base / "out2" / "frames").glob("*.json")}
    r3 = _run(exp, base / "out2", 2)
    assert r3.returncode == 0
    assert stamp == {p.name: p.stat().st_mtime_ns for p in (base / "out2" / "frames").glob("*.json")}
    assert (base / "out1" / "curves.csv").read_bytes() == (base / "out2" / "curves.csv").read_bytes()


@pytest.mark.slow
def test_an_executor_of_the_caller_gives_the_same_tables(phantom_run):
    """The executor seam: chunks submitted to another concurrent.futures.Executor (as a Dask
    ``Client.get_executor()`` would be) give the tables of the own process pool, byte for byte."""
    from concurrent.futures import ThreadPoolExecutor

    from tendrilkit.runner import run_reconstruct

    base, exp, _ = phantom_run
    submitted = []

    class Recording(ThreadPoolExecutor):
        def submit(self, fn, /, *args, **kwargs):
            submitted.append(args[0][0])  # the chunk's frames
            return super().submit(fn, *args, **kwargs)

    with Recording(2) as pool:
        summary = run_reconstruct(exp, base / "out_exec", workers=2, progress=False, contact_sheet=False,
                                  executor=pool)
    assert summary.exit_code == 0 and str(summary) == "3 frames: 3 ok, 0 doubtful, 0 failed"
    assert {f for chunk in submitted for f in chunk} == {0, 1, 2}  # every chunk went through it
    for name in ("curves.csv", "pwc_curves.csv", "frames.csv", "reprojection.csv", "ordering.csv"):
        assert (base / "out1" / name).read_bytes() == (base / "out_exec" / name).read_bytes(), name


# ------------------------------------------------------------ fast: one frame
def _synthetic_frame():
    """Three views of a curled tube through the IJCV25 rig, and its experiment."""
    from tendrilkit.phantom import render_tube_views

    s = np.linspace(0, 1, 3000)
    th = np.clip(s - 0.4, 0, None) * 6 * np.pi
    X = np.c_[-5 + 50 * s, 6 * np.sin(th), 20 + 6 * (1 - np.cos(th))]
    images, cams, exp = render_tube_views(X, width_px=9, margin_px=40, name="synthetic", fps=2)
    return images, cams, exp, X


@pytest.fixture(scope="module")
def synthetic():
    return _synthetic_frame()


def test_reconstruct_frame_ok(synthetic):
    from tendrilkit.pipeline import reconstruct_frame
    from tendrilkit.schema import quality_columns

    images, cams, exp, X = synthetic
    r = reconstruct_frame(images, cams, exp, frame=3, fit=False)
    assert r.status == "ok" and r.message == "" and r.time_s == 1.5
    assert r.points_mm.shape == (200, 3)
    d, _ = cKDTree(_densify(X)).query(r.points_mm)
    assert d.mean() < 0.5
    assert set(r.quality) == set(quality_columns(3))
    assert all(r.quality[f"reproj_mean_px_v{v}"] < 1.0 for v in (1, 2, 3))
    assert [t["section"] for t in r.reprojection] == ["base", "tip", "entire"] * 3


def _chain(exp):
    """The experiment with ``reconstruction.method: chain``: the tests of its 2D tracking state (per-view
    centroids) and reference view hold whatever the default method is."""
    return exp.model_copy(update={"reconstruction": exp.reconstruction.model_copy(update={"method": "chain"})})


def test_reconstruct_frame_view_lost_then_frame_failed(synthetic):
    from tendrilkit.pipeline import reconstruct_frame

    images, cams, exp, X = synthetic
    exp = _chain(exp)
    blank = np.full_like(images[0], 235)
    r = reconstruct_frame([blank, images[1], images[2]], cams, exp, fit=False)
    # reconstructed from views 2 and 3, but view 1 shows an empty board where the curve projects:
    # nothing confirms it there (tendrilkit.verify), so the frame is doubtful, not ok
    assert r.status == "doubtful" and r.quality["views_used"] == 2 and r.points_mm is not None
    assert r.message.startswith("precision: view 1 has 0 % of the curve on the tendril"), r.message
    assert "view 1: TendrilLostError" in r.message
    r = reconstruct_frame([blank, None, images[2]], cams, exp, read_errors=[None, "FrameReadError: gone", None], fit=False)
    assert r.status == "failed" and r.points_mm is None
    assert "view 1: TendrilLostError" in r.message and "view 2: FrameReadError: gone" in r.message
    assert r.centroids[0] is None and r.centroids[2] is not None  # tracking state survives the failure


def test_reference_view_lost_uses_another(synthetic):
    from tendrilkit.pipeline import reconstruct_frame

    images, cams, exp, X = synthetic
    exp = _chain(exp)
    r = reconstruct_frame([images[0], np.full_like(images[1], 235), images[2]], cams, exp, fit=False)
    # doubtful: the blank view 2 does not confirm the curve (see test_reconstruct_frame_view_lost_then_frame_failed)
    assert r.status == "doubtful" and r.message.startswith("precision: view 2 has 0 %"), r.message
    assert "reference view 2 unavailable, view 1 used instead" in r.message
    d, _ = cKDTree(_densify(X)).query(r.points_mm)
    assert d.mean() < 0.5


def test_frame_result_json_round_trip(synthetic):
    from tendrilkit.pipeline import FrameResult, reconstruct_frame

    images, cams, exp, _ = synthetic
    r = reconstruct_frame(images, cams, exp, fit=False)
    back = FrameResult.from_json(json.loads(json.dumps(r.to_json())))
    np.testing.assert_array_equal(back.points_mm, r.points_mm)
    assert back.quality == r.quality and back.reprojection == r.reprojection and back.centroids == r.centroids
