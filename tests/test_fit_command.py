"""The fit command: run_fit on a small curves.csv, its tables, and its errors."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from tendrilkit.exceptions import ExperimentError
from tendrilkit.fitting import run_fit
from tendrilkit.pwc.datasets import mean_distance_mm, random_pwc_curve
from tendrilkit.schema import PWC_METRICS, PWC_SEGMENTS

REPO = Path(__file__).resolve().parents[1]


def write_curves(path: Path, seeds=(0, 1), degenerate: bool = True) -> list:
    rows, truths = [], []
    for f, seed in enumerate(seeds):
        tc = random_pwc_curve(seed)
        truths.append(tc)
        P = tc.points_mm
        rows.append(pd.DataFrame({"frame": 10 * f, "time_s": 2.0 * f, "point": np.arange(len(P)),
                                  "x_mm": P[:, 0], "y_mm": P[:, 1], "z_mm": P[:, 2]}))
    if degenerate:  # all points at one place: a failed frame, not a crashed run
        rows.append(pd.DataFrame({"frame": 99, "time_s": 9.0, "point": np.arange(20),
                                  "x_mm": 1.0, "y_mm": 2.0, "z_mm": 3.0}))
    df = pd.concat(rows).sample(frac=1.0, random_state=0)   # row order must not matter
    df.to_csv(path, index=False)
    return truths


def test_run_fit_writes_the_three_tables(tmp_path):
    csv = tmp_path / "curves.csv"
    truths = write_curves(csv)
    summary = run_fit(csv, tmp_path / "out")
    assert (summary.n_frames, summary.n_ok, summary.n_failed) == (3, 2, 1)
    pwc = pd.read_csv(tmp_path / "out" / "pwc_curves.csv")
    assert list(pwc.columns) == ["frame", "time_s", "point", "x_mm", "y_mm", "z_mm"]
    assert sorted(pwc["frame"].unique()) == [0, 10]
    for f, tc in zip((0, 10), truths):
        P = pwc[pwc["frame"] == f].sort_values("point")[["x_mm", "y_mm", "z_mm"]].to_numpy()
        assert P.shape == (200, 3)
        assert mean_distance_mm(P, tc.dense_mm) < 0.3
    segs = pd.read_csv(tmp_path / "out" / "pwc_segments.csv")
    assert list(segs.columns) == list(PWC_SEGMENTS.columns)
    assert set(segs["kind"]) == {"kappa", "tau"}
    for (f, kind), g in segs.groupby(["frame", "kind"]):
        g = g.sort_values("segment")
        assert g["s0_mm"].iloc[0] == 0.0
        assert np.allclose(g["s1_mm"].to_numpy()[:-1], g["s0_mm"].to_numpy()[1:])      # contiguous
        assert np.allclose(g["value_s1"].to_numpy()[:-1], g["value_s0"].to_numpy()[1:])  # continuous
    met = pd.read_csv(tmp_path / "out" / "pwc_metrics.csv")
    assert list(met.columns) == list(PWC_METRICS.columns)
    ok = met[met["status"] == "ok"]
    assert (ok["r2_entire"] >= 0.999).all()
    bad = met[met["status"] == "failed"].iloc[0]
    assert bad["frame"] == 99 and "DegenerateCurveError" in bad["message"]
    assert not list((tmp_path / "out").glob("*.tmp"))


def test_fixed_options(tmp_path):
    csv = tmp_path / "curves.csv"
    write_curves(csv, seeds=(3,), degenerate=False)
    opts = {"selection": "fixed", "penalty_kappa": 0.05, "penalty_tau": 0.05, "refine": False}
    run_fit(csv, tmp_path / "out", options=opts)
    met = pd.read_csv(tmp_path / "out" / "pwc_metrics.csv")
    assert met["penalty_kappa"].iloc[0] == 0.05


@pytest.mark.parametrize("content, match", [
    (None, "not found"),
    ("frame,point,x_mm\n0,0,1\n", "missing column"),
    ("frame,time_s,point,x_mm,y_mm,z_mm\na,0,0,1,2,3\n", "frame"),
])
def test_bad_csv_is_an_experiment_error(tmp_path, content, match):
    csv = tmp_path / "curves.csv"
    if content is not None:
        csv.write_text(content)
    with pytest.raises(ExperimentError, match=match):
        run_fit(csv, tmp_path / "out")


def test_cli_reports_a_missing_csv_in_one_line(tmp_path):
    r = subprocess.run([sys.executable, "-m", "tendrilkit", "fit", str(tmp_path / "nope.csv"), "--out", str(tmp_path)],
                       capture_output=True, text=True, cwd=REPO)
    assert r.returncode == 2
    assert r.stderr.strip().count("\n") == 0 and "not found" in r.stderr
    assert "Traceback" not in r.stderr
