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


def test_fit_curves_gathers_each_frames_fit_in_frame_order():
    """fit_curves: frames in order, each frame's points sorted, its first time_s (NaN only when all are),
    the fitted points numbered from 0, failed frames in the metrics only: the same as fit_frame per frame."""
    frames = {}
    for frame, seed, n in ((7, 4, 120), (3, 5, 90), (12, 6, 60)):
        P = random_pwc_curve(seed).points_mm[:n]
        t = np.full(n, 2.0 * frame)
        if frame == 3:
            t[:] = np.nan
        if frame == 12:
            t[0] = np.nan  # the first point's time is the frame's, NaN or not
        frames[frame] = (P, t)
    frames[5] = (np.tile([1.0, 2.0, 3.0], (20, 1)), np.full(20, 1.0))  # fails
    table = pd.concat([pd.DataFrame({"frame": f, "time_s": t, "point": np.arange(len(P)), "x_mm": P[:, 0],
                                     "y_mm": P[:, 1], "z_mm": P[:, 2]}) for f, (P, t) in frames.items()])
    from tendrilkit.fitting import fit_curves, fit_frame

    pwc, segs, mets = fit_curves(table.sample(frac=1.0, random_state=1))
    assert mets["frame"].tolist() == [3, 5, 7, 12]
    assert mets["status"].tolist() == ["ok", "failed", "ok", "ok"]
    assert pwc["frame"].unique().tolist() == [3, 7, 12]
    for f in (3, 7, 12):
        P, t = frames[f]
        t_s = float(t[0]) if np.any(~np.isnan(t)) else np.nan
        fitted, seg_rows, row = fit_frame(P, frame=f, time_s=t_s)
        got = pwc[pwc["frame"] == f]
        assert got["point"].tolist() == list(range(len(P)))
        assert np.array_equal(got[["x_mm", "y_mm", "z_mm"]].to_numpy(), fitted)
        assert np.array_equal(got["time_s"].to_numpy(), np.full(len(P), t_s), equal_nan=True)
        assert len(segs[segs["frame"] == f]) == len(seg_rows)
    assert (pwc.loc[pwc["frame"] == 7, "time_s"] == 14.0).all()
    assert np.isnan(pwc.loc[pwc["frame"].isin([3, 12]), "time_s"]).all()
    assert pwc["frame"].dtype == np.int64 and pwc["point"].dtype == np.int64


@pytest.mark.parametrize("env, numpy_first, expected", [({}, False, "1"), ({"OPENBLAS_NUM_THREADS": "3"}, False, "3"),
                                                        ({}, True, None)])
def test_fit_command_uses_one_blas_thread_unless_told(env, numpy_first, expected):
    import os

    base = {k: v for k, v in os.environ.items() if k not in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")}
    code = ("import numpy; " if numpy_first else "") + (
        "import os, tendrilkit.cli as c; c._single_threaded_blas(); print(os.environ.get('OPENBLAS_NUM_THREADS'))")
    out = subprocess.run([sys.executable, "-c", code], cwd=REPO, env={**base, **env}, capture_output=True, text=True,
                         check=True).stdout.strip()
    assert out == str(expected)


def test_the_fit_commands_writer_writes_what_pandas_writes(tmp_path):
    """io.columns.write_columns (the fit command's, no pandas) gives the bytes of io.write_result: floats at every
    magnitude, missing time and integers, a failed frame, a message that needs quoting."""
    from tendrilkit import fitting as F
    from tendrilkit.io import write_result
    from tendrilkit.io.columns import write_columns
    from tendrilkit.schema import PWC_CURVES

    rows = []
    for f, (seed, scale) in enumerate(((0, 1e-7), (1, 1e12))):
        P = random_pwc_curve(seed).points_mm[:120] * [scale, 1.0, 1.0]
        rows.append(pd.DataFrame({"frame": 10 * f, "time_s": np.nan if f else 2.5, "point": np.arange(len(P)),
                                  "x_mm": P[:, 0], "y_mm": P[:, 1], "z_mm": P[:, 2]}))
    rows.append(pd.DataFrame({"frame": 99, "time_s": 9.0, "point": np.arange(20), "x_mm": 1.0, "y_mm": 2.0,
                              "z_mm": 3.0}))
    df = pd.concat(rows)
    pwc, segs, mets = F._fit_arrays(df["frame"].to_numpy(), df["point"].to_numpy(), df["time_s"].to_numpy(float),
                                    df[["x_mm", "y_mm", "z_mm"]].to_numpy(float), None)
    mets[0]["message"] = 'a, "quoted" message\nover two lines'
    assert [m["status"] for m in mets] == ["ok", "ok", "failed"]
    frames = (pd.DataFrame(pwc), pd.DataFrame(segs, columns=list(PWC_SEGMENTS.columns)), F.metrics_table(mets))
    columns = (pwc, F._row_columns(segs, PWC_SEGMENTS), F._row_columns(mets, PWC_METRICS))
    for i, (frame, cols, table) in enumerate(zip(frames, columns, (PWC_CURVES, PWC_SEGMENTS, PWC_METRICS))):
        write_result(frame, tmp_path / f"pandas{i}.csv", table)
        write_columns(cols, tmp_path / f"columns{i}.csv", table)
        assert (tmp_path / f"pandas{i}.csv").read_bytes() == (tmp_path / f"columns{i}.csv").read_bytes(), table.name
    with pytest.raises(ValueError, match="columns differ"):
        write_columns({"frame": [0]}, tmp_path / "bad.csv", PWC_CURVES)


def _last_line(code: str, csv, out) -> str:
    """The last line ``code`` prints, run in a fresh Python from the repository (``sys.argv[1:]``: ``csv``, ``out``);
    it must exit 0."""
    r = subprocess.run([sys.executable, "-c", code, str(csv), str(out)], capture_output=True, text=True, cwd=REPO)
    assert r.returncode == 0, r.stderr
    return r.stdout.strip().splitlines()[-1]


def test_fit_command_imports_no_pandas(tmp_path):
    csv = tmp_path / "curves.csv"
    write_curves(csv, seeds=(3,), degenerate=False)
    code = ("import sys, runpy; sys.argv = ['tendrilkit', 'fit', sys.argv[1], '--out', sys.argv[2]]\n"
            "try:\n    runpy.run_module('tendrilkit', run_name='__main__')\nexcept SystemExit as e:\n"
            "    assert e.code == 0, e.code\nprint('pandas' in sys.modules)")
    assert _last_line(code, csv, tmp_path / "out") == "False"
    assert (tmp_path / "out" / "pwc_metrics.csv").read_text().count("\n") == 2


@pytest.mark.parametrize("imported_first", ["", "import cffi, numba; "])
def test_fit_command_starts_numba_without_its_extras_and_gives_them_back(tmp_path, imported_first):
    """The fit command hides coverage and cffi from numba's first import (a tenth of a second of its start):
    numba then runs without them, the fit is the same, and both import normally once the command is done.
    A process that imported numba (or the package) first is left alone."""
    csv = tmp_path / "curves.csv"
    write_curves(csv, seeds=(3,), degenerate=False)
    code = (imported_first + "import sys\nfrom tendrilkit.cli import main\n"
            "code = main(['fit', sys.argv[1], '--out', sys.argv[2]])\n"
            "import numba.misc.coverage_support as c, numba.core.typing.cffi_utils as f, cffi, coverage\n"
            "print(code, c.coverage_available, f.ffi is not None, sys.modules['cffi'] is cffi)")
    expected = "0 False False True" if not imported_first else "0 True True True"
    assert _last_line(code, csv, tmp_path / "out") == expected
    fit = pd.read_csv(tmp_path / "out" / "pwc_curves.csv")
    other = tmp_path / "ref"
    run_fit(csv, other)  # in this process, numba as the tests load it
    assert (other / "pwc_curves.csv").read_bytes() == (tmp_path / "out" / "pwc_curves.csv").read_bytes()
    assert len(fit) == len(random_pwc_curve(3).points_mm)


@pytest.mark.parametrize("imported_first", ["", "import scipy.linalg; "])
def test_fit_command_loads_blas_without_scipy_linalg(tmp_path, imported_first):
    """The fit command gives numba scipy's BLAS and LAPACK modules without importing ``scipy.linalg``
    (a fifth of a second of its start): its compiled kernels (matrix products, solves) run on them and fit
    the same bytes, and ``scipy.linalg`` imports in full afterwards. A process that imported it first keeps it."""
    csv = tmp_path / "curves.csv"
    write_curves(csv, seeds=(3,), degenerate=False)
    code = (imported_first + "import sys\nfrom tendrilkit.cli import main\n"
            "code = main(['fit', sys.argv[1], '--out', sys.argv[2]])\n"
            "loaded = 'scipy.linalg' in sys.modules\n"
            "import numpy as np, scipy.linalg\nfrom scipy.linalg import solve_banded\n"
            "print(code, loaded, np.allclose(scipy.linalg.solve(np.eye(2) * 2, np.ones(2)), 0.5), "
            "'scipy.linalg.cython_lapack' in sys.modules)")
    expected = "0 False True True" if not imported_first else "0 True True True"
    assert _last_line(code, csv, tmp_path / "out") == expected
    other = tmp_path / "ref"
    run_fit(csv, other)  # in this process, scipy.linalg and numba as the tests load them
    for name in ("pwc_curves.csv", "pwc_segments.csv", "pwc_metrics.csv"):
        assert (other / name).read_bytes() == (tmp_path / "out" / name).read_bytes()


def test_fit_command_fits_without_the_cyclic_collector(tmp_path, monkeypatch):
    """The fit command runs its fits with Python's cyclic garbage collector off (its collections walked numba's
    objects for nothing) and leaves it as it found it: on again after a run, still off if it was off."""
    import gc

    from tendrilkit import cli, fitting

    csv = tmp_path / "curves.csv"
    write_curves(csv, seeds=(3,), degenerate=False)
    seen = []
    fit = fitting.run_fit
    monkeypatch.setattr(fitting, "run_fit", lambda *a, **k: seen.append(gc.isenabled()) or fit(*a, **k))
    assert gc.isenabled()
    assert cli.main(["fit", str(csv), "--out", str(tmp_path / "a"), "--workers", "1"]) == 0
    assert seen == [False] and gc.isenabled()
    gc.disable()
    try:
        assert cli.main(["fit", str(csv), "--out", str(tmp_path / "b"), "--workers", "1"]) == 0
        assert seen == [False, False] and not gc.isenabled()
    finally:
        gc.enable()
    for name in ("pwc_curves.csv", "pwc_segments.csv", "pwc_metrics.csv"):
        assert (tmp_path / "a" / name).read_bytes() == (tmp_path / "b" / name).read_bytes()


@pytest.mark.parametrize("x_cells", [["1.5", "-2e-3", "+4", "5."], ["1.5", "", "3", "NA"], ["1", "-nan", "NaN", "2"],
                                     ["1", " 2 ", "3E0", "4"], ["1", "1_0", "2", "3"], ["1", "2", "x", "3"]])
def test_curves_are_read_as_cell_by_cell(tmp_path, x_cells):
    """The reader's one-pass column (plain numbers) reads what the cell-by-cell reading reads, and any other column
    (missing cells, NA words, NaN written out, '_', text) is read cell by cell: the same numbers, or the
    same error naming the column and row."""
    from tendrilkit import fitting as F

    lines = ["frame,time_s,point,x_mm,y_mm,z_mm"] + [f"0,1.0,{i},{x},2.0,3.0" for i, x in enumerate(x_cells)]
    lines[2] = "0,1.0,1,{},2.0".format(x_cells[1])  # a short row: its z_mm cell missing
    csv = tmp_path / "curves.csv"
    csv.write_text("\n".join(lines) + "\n")
    expected = [F._number(c) for c in x_cells]
    if any(v is None for v in expected):
        with pytest.raises(ExperimentError, match=f"column x_mm, row {[v is None for v in expected].index(True) + 2} "):
            F._read_curves(csv)
        return
    got = F._read_curves(csv)
    assert got.xyz_mm[:, 0].tobytes() == np.array(expected, dtype=float).tobytes()  # NaN's sign bit too
    assert np.isnan(got.xyz_mm[1, 2]) and np.array_equal(got.xyz_mm[[0, 2, 3], 2], [3.0, 3.0, 3.0])
    assert (F._plain_numbers(x_cells) is None) == (x_cells not in (["1.5", "-2e-3", "+4", "5."], ["1", " 2 ", "3E0", "4"]))


@pytest.mark.parametrize("text, one_pass", [
    ("frame,time_s,point,x_mm,y_mm,z_mm\n0,1.0,0,1.5,-2e-3,+4\n0,1.0,1,5.,1E300,-0.0\n", True),
    ("\ufeffz_mm,point,frame,y_mm,x_mm,extra\n\n3, 0 ,7,2.0,1.0,9\n\n4,1,7,2.5,0.1,1e-320\n\n", True),  # BOM, blank lines
    ("frame,point,x_mm,y_mm,z_mm\n0,0,1,2,3\n0,1,1,2,inf\n", True),  # no time_s; an infinite coordinate
    ("frame,point,x_mm,y_mm,z_mm\n0,0,1,2,3\n0,1,1_0,2,3\n", False),  # '_': Python's float reads it
    ("frame,point,x_mm,y_mm,z_mm\n0,0,1,2,3\n0,1,\"4\",2,3\n", False),  # quoted
    ("frame,point,x_mm,y_mm,z_mm\r\n0,0,1,2,3\r\n", False),  # CR LF
    ("frame,point,x_mm,y_mm,z_mm\n0,0,1,2,3\n0,1,1,2\n", False),  # a short row
    ("frame,point,x_mm,y_mm,z_mm\n0,0,1,2,3\n \n", False),  # a row of one blank cell
    ("frame,point,x_mm,y_mm,z_mm\n0,0,1,2,NaN\n", False),  # NaN written out
    ("frame,point,x_mm,y_mm,z_mm\n0,0,1,2,x\n", False),  # text
    ("frame,point,x_mm,y_mm,z_mm,note\n0,0,1,2,3,a\n", False),  # a column of text
    ("frame,point,x_mm,y_mm,z_mm\n0,0,1,2,\u0663\n", False),  # a digit Python reads, numpy's reader does not
])
def test_curves_read_in_one_pass_as_cell_by_cell(tmp_path, monkeypatch, text, one_pass):
    """A curves.csv of plain numbers is read in one pass (_numeric_table, numpy's reader): the same arrays, bytes
    and dtypes, as the rows read cell by cell; any other file (a cell Python's float and numpy's reader could read
    apart, a quote, CR, short rows, NaN, text) is left to the cells' reading, which reads or reports it as before."""
    from tendrilkit import fitting as F

    csv = tmp_path / "curves.csv"
    csv.write_bytes(text.encode("utf-8"))
    assert (F._numeric_table(csv) is not None) == one_pass

    def read():
        try:
            c = F._read_curves(csv)
        except ExperimentError as e:
            return str(e)
        return [(a.dtype.str, a.shape, a.tobytes()) for a in (c.frame, c.point, c.time_s, c.xyz_mm)]

    fast = read()
    monkeypatch.setattr(F, "_numeric_table", lambda path: None)
    assert read() == fast


def test_fit_over_workers_writes_the_same_tables(tmp_path, monkeypatch):
    """run_fit over forked workers (frames in chunks, at least MIN_FRAMES_PER_WORKER each) writes the bytes of one
    process, a failed frame included."""
    from tendrilkit import fitting as F

    csv = tmp_path / "curves.csv"
    write_curves(csv, seeds=tuple(range(2 * F.MIN_FRAMES_PER_WORKER + 1)))
    one = run_fit(csv, tmp_path / "one")
    pools = []
    in_pool = F._fit_in_pool
    monkeypatch.setattr(F, "_fit_in_pool", lambda *a: pools.append(a[-1]) or in_pool(*a))
    two = run_fit(csv, tmp_path / "two", workers=2)
    assert pools == [2]
    assert (one.n_frames, one.n_failed) == (two.n_frames, two.n_failed) == (2 * F.MIN_FRAMES_PER_WORKER + 2, 1)
    for name in ("pwc_curves.csv", "pwc_segments.csv", "pwc_metrics.csv"):
        assert (tmp_path / "one" / name).read_bytes() == (tmp_path / "two" / name).read_bytes(), name


def test_fit_over_workers_ends_them_on_sigterm(tmp_path):
    """SIGTERM while the workers fit: exit 143 with one line, and no worker left running."""
    import os
    import signal
    import time

    csv = tmp_path / "curves.csv"
    P = random_pwc_curve(0).points_mm
    n = 1000  # seconds of fitting on two workers (100 frames could end before the workers were seen: 10 ms a fit)
    pd.DataFrame({"frame": np.repeat(np.arange(n), len(P)), "time_s": 0.0, "point": np.tile(np.arange(len(P)), n),
                  "x_mm": np.tile(P[:, 0], n), "y_mm": np.tile(P[:, 1], n),
                  "z_mm": np.tile(P[:, 2], n)}).to_csv(csv, index=False)
    out = tmp_path / "out-sigterm-test"

    def ours() -> list[int]:  # the command and its forked workers carry its arguments
        pids = []
        for d in os.listdir("/proc"):
            try:
                if d.isdigit() and str(out).encode() in open(f"/proc/{d}/cmdline", "rb").read():
                    pids.append(int(d))
            except OSError:
                pass
        return pids

    proc = subprocess.Popen([sys.executable, "-m", "tendrilkit", "fit", str(csv), "--out", str(out), "--workers", "2"],
                            cwd=REPO, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    t0 = time.monotonic()
    while len(ours()) < 3 and proc.poll() is None and time.monotonic() - t0 < 120:
        time.sleep(0.05)
    assert proc.poll() is None, "the fit ended before its workers were seen"
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 143, err
    assert err.strip().count("\n") == 0 and "terminated" in err and "Traceback" not in err
    t0 = time.monotonic()
    while ours() and time.monotonic() - t0 < 10:
        time.sleep(0.05)
    assert ours() == []


def test_distinct_rows_count_is_numpys_unique():
    """fit_frame's count of distinct points (rows sorted, changes counted) is len(np.unique(axis=0)), 0.0
    and -0.0 one number."""
    from tendrilkit.fitting import _distinct_rows

    rng = np.random.default_rng(0)
    for t in range(500):
        n = int(rng.integers(0, 30))
        p = (rng.choice([0.0, -0.0, 1.0, -1.0, 2.5], size=(n, 3)) if t % 2 else np.round(rng.normal(size=(n, 3)), 1))
        if n and t % 3 == 0:
            p = p[rng.integers(0, n, n)]
        assert _distinct_rows(p) == (len(np.unique(p, axis=0)) if n else 0)


def test_float_cells_are_numpys_text():
    """write_columns writes a float by Python's repr: numpy's shortest round-trip text, over the whole range."""
    rng = np.random.default_rng(1)
    a = rng.integers(0, 2**63 - 1, 20000, dtype=np.int64).view(np.float64)
    a = np.r_[a[np.isfinite(a)], 0.0, -0.0, 1e16, 9.999999999999999e15, 1e-4, 1e-5, 5e-324]
    assert list(map(repr, a.tolist())) == a.astype(str).tolist()
