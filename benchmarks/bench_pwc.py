"""Timings of the piece-wise clothoid fit (prints; not a test).

    .venv/bin/python benchmarks/bench_pwc.py [--frames 100]

1. one 200-point frame: automatic penalty selection + rebuild (issue 17 target: <= 5 ms;
   the paper: about 200 s; a port of the reference's 10-step search: about 4 s). Measured
   (2026-11, 2 shared cores, load 4): median 14.9 ms CPU per frame (main 0ece53a: 14.8; the fits
   bit-identical); of a frame's CPU, Levenberg-Marquardt 45-55 % (2 iterations for each of ~26
   candidates, 10 for each of ~5 steps taken, the last to convergence), the knot score test 15 %,
   signals and cost tables 10 %, the starts' evaluations 7 %, joins 6 %, the rest Python.
   Measured 2026-12-01 (load 12-14): an evaluation (integration, registration, SSE) is about 28 us,
   of which the integration 16-19: a chain of dependent square roots and divisions, about 90 ns a
   step (the frame held in scalars, or cos/sin taken off the chain, change nothing); laws advanced
   together overlap on an idle core (3 for about 2 of one), but a candidate's starts evaluated so
   gained nothing at that load (82 against 81 us for 3; the arrays' packing costs what the overlap
   saves; not kept). On S3's 60
   reconstructed frames a fit makes about 190 Jacobians and 360 evaluations in its refinements, half
   of them rejected damping trials (the step and the last refinement mostly "mu/10 rejected, mu
   accepted"): keeping mu after a rejection saves 16-20 % of their evaluations (3-4 % of a fit) but
   changes the fits (not kept); the two trials evaluated together gain nothing (the first is taken
   half the time). The retry with more lookahead runs on 25 of the 60 frames: 29 % of all their CPU;
   2026-12-02 (load 3-3.5): the evaluation's frames chained by each step's rotation in the frame's
   own axes (frenet._integrate, the project's one integration, 16 -> 7 us), the normal equations
   without the rotated Jacobian (refine._lm_normal) and solved by Cholesky (6.9 -> 1.9 us), the
   score test in the integration's frame (310 -> 200 us), a join's refit compiled: Levenberg-Marquardt and the score test 9.4 -> 6.2
   ms per fit (the 40 fits' calls replayed), now an iteration's normal equations about 35 us and an
   evaluation 13 us; the rest of a fit (signals, paths, joins, Python) is about 5 ms by itself;
   2026-12-02, later (branch pwc-speed, alternated with main 5d9b8e7; the fits bit-identical:
   ``benchmarks/pwc_identity.py``, every number of 440 fits (the 100 frames of a reconstruction's
   curves.csv and 340 seeded curves) and the fit command's three tables): that rest in fewer, compiled
   steps, each in numpy's order of operations (checked bit for bit on thousands of random inputs): a
   curve's arc length, derivatives, tangent, normals, torsion and binormal (frenet._curve_derivatives,
   _torsion_normals; numpy keeps the power, whose last bits are its own (SVML), and the einsum dot
   products: frames 610 -> 270 us), the PCHIP resampling (225 -> 50 us), a segmentation's join and
   refit in one call (_join_core), the penalty path's hull and segmentations with its programme
   (_path_core), the rebuild's three calls in one (_rebuild_core); once per curve the noise (it was
   estimated twice), the SST, the score test's positions, the start medians and the torsion path
   starts; the fit command's float cells by Python's repr (numpy's text; pwc_curves 79 -> 55 ms) and
   its distinct-row count without np.unique (90 -> 15 us a frame). Per frame (40 seeded curves, 7
   alternate runs of bench_pwc --baseline, load 0.8): median 11.1 -> 9.8 ms CPU (-12 %; at load 4:
   11.3 -> 9.6); curve by curve alternated between two processes (5 rounds, which the machine's drift
   of +-30 % over minutes hits alike): the 40 seeded curves -13 % (median 14.0 -> 12.4 ms then), a
   reconstruction's 100 frames -20 % (12.8 -> 10.3 ms). The fit command --workers 1 on those 100 frames:
   its fits, frame by frame alternated through fit_frame, -11 % (1.43 -> 1.27 s CPU), the tables
   written 0.11-0.14 -> 0.08 s, its start-up unchanged (imports and numba's set-up
   0.5-0.6 s; each compiled function called from Python loads its numba cache at the first call,
   3-5 ms, those bringing BLAS and LAPACK 10-45 ms: 10 such now, 9 before): about 0.15 s of 2.3-2.6 s,
   which whole runs scatter around by +-15 % (medians of 9 alternate runs 3.08 -> 2.55 s CPU at load
   3.5-4.3, of 15 others 2.63 -> 2.70 s at load 1-2; the target's 2 s needs the fits near 1 s).
   Where a fit's CPU goes now: Levenberg-Marquardt about 50 %, the score test 12 %, the cost tables
   and penalty paths 7 %, joins 2 %, the rest Python spread over a hundred lines (none above 1.5 %). Tried and not kept (no
   gain at the same bits): _frame_columns updating only the columns a step can change, or column by
   column (its loop over the parameters vectorises as it is: 12-20 us either way); the count programme
   reading its cost table transposed, or its minimum found by a vectorised pass and a search; a law's
   memo key made once (functools.cached_property's lock at each first read cost more than the bytes).
   The 5 ms target is out of reach at the same bits: Levenberg-Marquardt and the score test alone are
   about 6 ms (BLAS products and libm calls fix their last bits); fewer of them changes the fits;
   2026-12-02, evening (branch pwc-speed2, alternated with main d0679b9 in a clone; the fits bit-identical:
   ``benchmarks/pwc_identity.py``, 440 fits and the fit command's three tables, after every change; the
   machine at load 4-5.5 on its 2 cores throughout, other jobs running): the least-squares cost table with
   the sums of every interval ending at a sample grown together (costs._line_costs: loops over the interval
   starts that vectorise, numpy's error model; each interval's sums take the same terms in the same order:
   150 -> 80 us a table, the same bits on 3000 random signals); the Jacobian's arrays written once
   (_frame_columns and _rigid_columns write their zeros, no clearing pass; the residuals straight into the
   normal equations' last column; the score test's projection without its C_perp array); a start that
   repeats an earlier one not evaluated again (11 % of the starts on the fit command's frames). Per frame
   (40 seeded curves, 7 alternate runs of --baseline): 10.1 -> 9.7 ms CPU at load 4.5, 9.9 -> 10.2 at load
   4.6: no change beyond the noise (the _refine_best calls of 100 fits replayed, best of 8, alternated 4
   times: 0.47-0.49 s either side; the score test's 542 calls 0.100 -> 0.095 s). The fit command (--workers
   1): its curves.csv read in one pass by numpy's reader when every cell is a plain number
   (fitting._numeric_table; numpy reads a cell with PyOS_string_to_double, as float does: the same doubles,
   checked on 300000 texts; anything else, '_', quotes, CR, short rows, NaN, text, read cell by cell as
   before: 90 -> 40 ms for 100 frames); its fits without Python's cyclic collector, the objects then alive
   frozen on the way out (cli._without_cyclic_gc: the run's 270 young, 25 middle and 2 full collections
   walked numba's objects, 80-90 ms, for no garbage: none over 100 fits; and the interpreter's exit walked
   them all again: from the command's last line to the process's end, 5 alternate runs at load 5.4, median
   361 -> 84 ms); a table of numbers' columns written by joining its cells (csv's bytes without its
   per-cell search for commas, quotes and line breaks, which numbers never hold: pwc_curves' rows 19 -> 5 ms). On /work/runs/fitcmd/curves.csv (100 reconstructed frames), 7 alternate runs at load
   5.7: 3.66 -> 2.97 s wall, 2.45 -> 1.89 s CPU (0.81, 0.77); on the benchmark's 100 seeded curves at load
   5.0: 3.60 -> 3.03 s wall, 2.37 -> 2.09 s CPU; at last on an idle machine (load 0-0.4), 6 alternate runs of
   /usr/bin/time on curves.csv: 2.27 -> 2.12 s wall, 2.13 -> 2.01 s user (target 2 s not reached). Where such a run's CPU goes now (parts apart, load 1):
   imports 0.32 s (numpy 0.07, numba 0.20, tendrilkit 0.06), numba's set-up at its first compiled call
   0.13 s, its ten cache loads 0.10 s (_refine_best 35 ms, _score_gains 24 ms, _join_core 11 ms: most of
   it llvmlite's calls over each library's few hundred symbols), the CSV 0.04 s, the fits about 1.0 s, the
   tables 0.06 s (pwc_curves: repr of 80000 floats 35 ms). Of a fit's CPU (perf, by
   library, 500 warm fits): compiled code 37 %, the interpreter 30 %, numpy's C 9 %, OpenBLAS 9.5 %, malloc
   and memset 7.5 %, libm 2.7 %, the cyclic collector 3 % (in a process that keeps it on). Tried and not
   kept: numpy's error model (no zero-division checks) on the step means, the law columns and the
   integration (1-3 % of their microseconds, within the noise; a zero division would no longer raise); a
   higher collector threshold instead of none (10000 or 50000: fewer collections, each walking more, the
   same total; gc.freeze() alone before the fits would miss numba's objects, made at the first fit);
   NUMBA_ENABLE_PROFILING for perf's names of the compiled functions (it bypasses the cache: the profile is
   numba compiling). The 5 ms target stays out of reach at the same bits (the rest is spread: no Python
   function above 3 % of a fit, the compiled steps near their arithmetic), and the fits' changes tried
   before moved the accuracy the wrong way;
2. the paper's grid search on the same frames;
3. ``python -m tendrilkit fit`` on a 100-frame curves.csv, process start included
   (issue 17 target: <= 2 s; on the 100 reconstructed frames of the S3 + S4 site outputs (S3's 60,
   S4's first 40), load 4.7 on 2 cores: 3.6 s CPU with one worker, main 3.75 s), run twice: the
   first run may compile numba's cache; then the
   start-up alone (imports, numba's first cache load) in a fresh process, and whether the
   environment holds compiled bytecode (without it every process compiles numba, pandas and
   scipy from source: about a second more).
Also prints the accuracy on the seeded noisy ground-truth curves and where the time of one
frame goes (CPU per stage, measured in a second pass).

Search variants measured against main 0ece53a on the 340 seeded curves of ``--baseline`` (mean distance
to the truth median / p95 / worst mm, segment counts as the truth; main 0.0486 / 0.0771 / 0.1323, 42.6 %;
CPU on a loaded machine, +-5 %): candidates and steps on every other point, the last fit on all
(-18 % CPU; 0.0490 / 0.0795 / 0.1088, 36.8 %); a first search started at the paths' segmentations for a
penalty of 0.05 (-10 %; 0.0493 / 0.0762 / 0.1352, 27.9 %) or 0.02 (worse); 1 quick iteration instead of 2
(0.0503 / 0.0865, 33.8 %); the step taken refined 3 or 5 iterations instead of 10, or stopped at a
relative gain of 1e-4 / 1e-3 (no clear CPU gain: fits less refined take more steps; p95 or median worse);
the current fit refined as a candidate instead of the step (no gain; worst 0.2058); the score test's
projection without forming it (13 curves change, -9 % of the test only). None kept: the search is
balanced, each change moves single curves by +-0.05 mm and the aggregates the wrong way.

    .venv/bin/python benchmarks/bench_pwc.py --curves-csv RUN/curves.csv   # a reconstruction's curves

times the fit on every frame of a reconstruction's ``curves.csv`` (what the pipeline's ``pwc`` stage
fits; e.g. ``reconstruct params/phantom_S3.yaml``'s) beside the benchmark's ground-truth curves, with
what makes a frame dearer: how many searches a fit ran (the first, and the retries of ``retries``,
which run when the rms residual exceeds ``RETRY_NOISE_RATIO`` of the noise estimated from the points,
counted as at least ``RETRY_ALLOWANCE_FRACTION`` of the rms residual the target R2 allows),
the candidates evaluated, the segments, and that rms-to-noise ratio. Then stops.

    .venv/bin/python benchmarks/bench_pwc.py --command-csv RUN/curves.csv   # issue 17's fit-command figure

times ``python -m tendrilkit fit`` on that CSV (issue 17 means a reconstruction's curves of 100 frames),
process start included, ``--rounds`` runs (wall and CPU, like ``time``), and then where one such run's CPU
goes, part by part in a fresh process (imports: numpy, numba, tendrilkit (no pandas); numba's set-up at its
first compiled call; reading the CSV; the first fit, which loads numba's caches; the other fits; writing
the tables). Then stops.

    .venv/bin/python benchmarks/bench_pwc.py --baseline /tmp/old   # a checkout of the old code

compares with another checkout on the same machine load: the per-frame fit (CPU and wall) and the
fit command, the two run alternately in fresh processes (``--rounds`` each), and prints the ratios
(new / old) with the load average. Each fit process loads its checkout's ``tendrilkit`` from its
working directory. It also fits, with both, every seeded noisy ground-truth curve of this benchmark
(seeds 1000-1039 of the per-frame figures, 5000-5099 of the fit command) and ``--extra`` more
(seeds 2000-2199 by default; development seeds only, < 10000) and prints the accuracy rule of issue 17:
median / mean / 95th percentile / worst mean distance to the truth, segment counts agreeing with the
truth, R2, and the per-curve changes (how many better or worse, the worst change, every curve worse
by more than 0.02 mm).
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ.setdefault(_var, "1")  # one core, as the figures (and the fit command) run

import argparse  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from tendrilkit.pwc import fit_piecewise_clothoid, grid_search_penalties, penalty_table  # noqa: E402
from tendrilkit.pwc.datasets import mean_distance_mm, random_pwc_curve  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--frames", type=int, default=100)
    ap.add_argument("--curves", type=int, default=40, help="ground-truth curves for the per-frame figures")
    ap.add_argument("--baseline", type=Path, help="a checkout of the old code: compare with it, then stop")
    ap.add_argument("--rounds", type=int, default=3, help="--baseline: alternate runs of each")
    ap.add_argument("--extra", type=int, default=200, help="--baseline: more ground-truth curves (seeds from 2000)")
    ap.add_argument("--roundoff", action="store_true",
                    help="--baseline: also the old code on the curves translated by 0.001, 1, 3 mm (round-off alone)")
    ap.add_argument("--curves-csv", type=Path, help="a reconstruction's curves.csv: its frames against the benchmark's")
    ap.add_argument("--command-csv", type=Path, help="time the fit command on this curves.csv, and its parts")
    args = ap.parse_args()
    if args.command_csv is not None and args.baseline is None:
        _fit_command(args.command_csv.resolve(), args.rounds)
        return
    if args.curves_csv is not None:
        _pipeline_curves(args.curves_csv, args.curves)
        return
    if args.baseline is not None:
        _compare(args.baseline.resolve(), args.curves, args.frames, args.rounds,
                 args.command_csv.resolve() if args.command_csv is not None else None)
        _compare_accuracy(args.baseline.resolve(), args.curves, args.frames, args.extra, args.roundoff)
        return

    curves = [random_pwc_curve(1000 + i) for i in range(args.curves)]
    t = time.perf_counter()
    fit_piecewise_clothoid(curves[0].points_mm)
    print(f"first call (numba cache load or compile): {1e3 * (time.perf_counter() - t):.0f} ms")

    times, cpu, dist, r2 = [], [], [], []
    for tc in curves:
        t, c = time.perf_counter(), time.process_time()
        f = fit_piecewise_clothoid(tc.points_mm)
        times.append(time.perf_counter() - t)
        cpu.append(time.process_time() - c)
        dist.append(mean_distance_mm(f.points_mm, tc.dense_mm))
        r2.append(f.r2)
    times, cpu, dist, r2 = 1e3 * np.array(times), 1e3 * np.array(cpu), np.array(dist), np.array(r2)
    print(f"auto selection + rebuild, 200 points: wall median {np.median(times):.1f} ms, "
          f"mean {times.mean():.1f} ms, max {times.max():.1f} ms (target <= 5 ms); "
          f"CPU median {np.median(cpu):.1f} ms, mean {cpu.mean():.1f} ms, worst {cpu.max():.1f} ms (the machine is shared: "
          f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores)")
    print(f"accuracy (0.15 mm noise): mean distance to truth median {np.median(dist):.4f} mm, "
          f"max {dist.max():.4f} mm, <= 0.3 mm on {100 * np.mean(dist <= 0.3):.0f} %, "
          f"R2 >= 0.999 on {100 * np.mean(r2 >= 0.999):.0f} %")

    print("where the time goes (CPU ms per frame, second pass, stages timed separately):")
    for name, ms in _stage_times(curves).items():
        print(f"  {name:44s} {ms:6.2f}")
    _print_refinements("the refinements by kind", [tc.points_mm for tc in curves])

    gt = []
    for tc in curves[:10]:
        t = time.perf_counter()
        grid_search_penalties(tc.points_mm)
        gt.append(time.perf_counter() - t)
    print(f"paper's grid search (10 x 10, up to 4 levels): median {1e3 * np.median(gt):.1f} ms per frame")

    import pandas as pd

    try:  # Table 3 and the grid search on the phantom S3 (paper: frames 1, 100, 200 of S3)
        from tendrilkit.frenet import resample_curve
        from tendrilkit.phantom import make_phantom

        ph = make_phantom("S3")
        rng = np.random.default_rng(0)
        print("Table 3 on phantom S3 (0.15 mm noise; penalties dimensionless; no 3D refinement, as the paper):")
        for f in (0, ph.n_frames // 2, ph.n_frames - 1):
            X = resample_curve(ph.curves_mm[f], 200) + rng.normal(0, 0.15, (200, 3))
            for row in penalty_table(X, [(0.001, 0.001), (0.01, 0.01), (0.1, 0.1)]):
                print(f"  frame {f:3d} " + " ".join(f"{k}={v:.4g}" for k, v in row.items()))
            g = grid_search_penalties(X)
            print(f"  frame {f:3d} grid search: {len(g.levels)} level(s), penalties ({g.penalty_kappa:.4g}, "
                  f"{g.penalty_tau:.4g}), R2 {g.fit.r2:.5f}, SSE {g.fit.sse_mm2:.1f} mm2, converged {g.converged}; "
                  f"auto: R2 {fit_piecewise_clothoid(X).r2:.5f}")
    except ImportError:
        pass

    with tempfile.TemporaryDirectory() as tmp:
        rows = []
        for f in range(args.frames):
            P = random_pwc_curve(5000 + f).points_mm
            rows.append(pd.DataFrame({"frame": f, "time_s": 20.0 * f, "point": np.arange(len(P)),
                                      "x_mm": P[:, 0], "y_mm": P[:, 1], "z_mm": P[:, 2]}))
        csv = Path(tmp) / "curves.csv"
        pd.concat(rows).to_csv(csv, index=False)
        for run in (1, 2):
            t = time.perf_counter()
            c0 = os.times()
            r = subprocess.run([sys.executable, "-m", "tendrilkit", "fit", str(csv), "--out", str(Path(tmp) / "out")],
                               cwd=REPO, capture_output=True, text=True)
            dt = time.perf_counter() - t
            c1 = os.times()
            child_cpu = (c1.children_user - c0.children_user) + (c1.children_system - c0.children_system)
            print(f"fit command, {args.frames} frames, run {run}: {dt:.2f} s end to end, {child_cpu:.2f} s CPU "
                  f"(target <= 2 s)"
                  f" [{r.stdout.strip() or r.stderr.strip()}]")
    code = ("import time; c = time.process_time(); import tendrilkit.cli, tendrilkit.fitting, tendrilkit.io, "
            "tendrilkit.pwc; a = time.process_time() - c; import numpy as np; "
            "u = np.linspace(0, 12, 200); P = np.c_[30 * np.cos(u), 30 * np.sin(u), 8 * u]; "
            # the first call of any compiled function sets numba up (typing registries, scipy.linalg for BLAS)
            "from tendrilkit.pwc.laws import _pwl_step_means; "
            "c = time.process_time(); _pwl_step_means(u[:5], u[[0, 4]], u[:2]); e = time.process_time() - c; "
            "c = time.process_time(); tendrilkit.pwc.fit_piecewise_clothoid(P); b = time.process_time() - c; "
            "c = time.process_time(); tendrilkit.pwc.fit_piecewise_clothoid(P); d = time.process_time() - c; "
            "print(f'{a:.2f} {e + b - d:.2f} {e:.2f}')")
    out = subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True, text=True).stdout.split()
    if len(out) == 3:
        print(f"start-up of the fit command (CPU): imports {out[0]} s, numba's first cache load {out[1]} s (of which "
              f"{out[2]} s numba's own set-up at the first compiled call: its typing registries, scipy.linalg)")
    import numba
    compiled = any((Path(numba.__file__).parent / "core" / "__pycache__").glob("*.pyc"))
    print("site-packages bytecode: " + ("compiled" if compiled else
          "NOT compiled (uv installs without it; `uv pip sync --compile-bytecode` or `python -m compileall`)"))


_COMMAND_PARTS = """
import sys, time
c = time.process_time(); t = {{}}
import numpy as np
t["imports: numpy"] = time.process_time() - c; c = time.process_time()
import tendrilkit.cli as cli
hidden = cli._without_numba_extras()  # as the fit command: numba without coverage and cffi
hidden.__enter__()
cli._blas_without_scipy_linalg()  # as the fit command: scipy's BLAS modules without scipy.linalg
import numba
t["imports: numba (without " + ", ".join(cli.NUMBA_EXTRAS) + ")"] = time.process_time() - c; c = time.process_time()
import tendrilkit.fitting as F, tendrilkit.io as io, tendrilkit.pwc, tendrilkit.schema as S
from tendrilkit.io.columns import write_columns
t["imports: tendrilkit"] = time.process_time() - c; c = time.process_time()
from pathlib import Path
from tendrilkit.pwc.laws import _pwl_step_means
u = np.linspace(0.0, 1.0, 5)
_pwl_step_means(u, u[[0, 4]], u[:2])  # numba's set-up at its first compiled call (registries, scipy.linalg)
t["numba set-up (first compiled call)"] = time.process_time() - c; c = time.process_time()
cv = F._read_curves(Path({csv!r}))
t["reading the CSV (csv module, checks)"] = time.process_time() - c; c = time.process_time()
one = cv.frame == cv.frame.min()
F._fit_arrays(cv.frame[one], cv.point[one], cv.time_s[one], cv.xyz_mm[one], None)
t["first frame's fit (numba's cache loads included)"] = time.process_time() - c; c = time.process_time()
pwc, segs, mets = F._fit_arrays(cv.frame, cv.point, cv.time_s, cv.xyz_mm, None)
n = len(mets)
t[f"all {{n}} fits again, one process (the first's cache loads apart)"] = time.process_time() - c
c = time.process_time()
tables = (pwc, F._row_columns(segs, S.PWC_SEGMENTS), F._row_columns(mets, S.PWC_METRICS))
for cols, name, table in zip(tables, ("a", "b", "c"), (S.PWC_CURVES, S.PWC_SEGMENTS, S.PWC_METRICS)):
    write_columns(cols, Path({out!r}) / name, table)
t["writing the three tables"] = time.process_time() - c
t["pandas imported (0 = no)"] = float("pandas" in sys.modules)
t["numba's coverage support on (0 = no)"] = float(__import__("numba.misc.coverage_support").misc.coverage_support.coverage_available)
for k, v in t.items():
    print(f"{{v:.3f}} {{k}}")
"""


def _fit_command(csv: Path, rounds: int) -> None:
    """Issue 17's figure: ``python -m tendrilkit fit CSV``, process start included; then its parts (CPU).

    Timed with one worker and with the default (every core), alternately; then numba's cache use
    (a run with ``NUMBA_DEBUG_CACHE``: functions loaded from the cache, and compiled).
    """
    if not csv.is_file():
        print(f"--command-csv: {csv} not found; expected a curves.csv")
        raise SystemExit(2)
    with tempfile.TemporaryDirectory() as tmp:
        env = {k: v for k, v in os.environ.items() if k not in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS",
                                                                 "MKL_NUM_THREADS", "NUMBA_NUM_THREADS")}
        variants = {"--workers 1": ["--workers", "1"], f"default ({os.cpu_count()} cores)": []}
        times = {k: ([], []) for k in variants}
        for run in range(rounds + 1):  # the first run may compile numba's caches: shown, not counted
            for name, extra in variants.items():
                t, c0 = time.perf_counter(), os.times()
                r = subprocess.run([sys.executable, "-m", "tendrilkit", "fit", str(csv), "--out",
                                    str(Path(tmp) / "out"), *extra], cwd=REPO, capture_output=True, text=True,
                                   env=env)  # the command sets its BLAS threads
                dt, c1 = time.perf_counter() - t, os.times()
                cpu = (c1.children_user - c0.children_user) + (c1.children_system - c0.children_system)
                if run:
                    times[name][0].append(dt)
                    times[name][1].append(cpu)
                print(f"fit command on {csv.name} {name}, run {run}{' (cache fill, not counted)' if not run else ''}: "
                      f"{dt:.2f} s wall, {cpu:.2f} s CPU [{(r.stdout.strip() or r.stderr.strip()).splitlines()[-1]}] "
                      f"(load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores)")
        for name, (walls, cpus) in times.items():
            print(f"fit command {name}, median of {rounds} runs: {np.median(walls):.2f} s wall, {np.median(cpus):.2f} s "
                  f"CPU (target <= 2 s)")
        r = subprocess.run([sys.executable, "-m", "tendrilkit", "fit", str(csv), "--out", str(Path(tmp) / "out"),
                            "--workers", "1"], cwd=REPO, capture_output=True, text=True,
                           env={**env, "NUMBA_DEBUG_CACHE": "1"})
        text = r.stdout + r.stderr
        print(f"numba's cache in that run: {text.count('[cache] data loaded')} functions loaded from it, "
              f"{text.count('[cache] data saved')} compiled and saved (a fresh clone compiles them at its first run)")
        code = _COMMAND_PARTS.format(csv=str(csv), out=tmp)
        env1 = {**env, "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
        out = subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True, text=True, env=env1)
        if out.returncode:
            print(out.stderr.strip().splitlines()[-1])
            return
        rows = [line.split(" ", 1) for line in out.stdout.strip().splitlines()]
        total = sum(float(v) for v, k in rows if "(0 = no)" not in k)
        print(f"where one run's CPU goes (a fresh process, parts timed apart; the first fit counted twice), "
              f"total {total:.2f} s:")
        for v, k in rows:
            print(f"  {k:62s} {float(v):6.3f}{'' if '(0 = no)' in k else ' s'}")


def _search_figures(curves: list) -> dict:
    """CPU ms per fit, searches per fit, candidates, segments and rms / noise of the first search, per curve."""
    import tendrilkit.pwc.fit as F
    from tendrilkit.frenet import noise_sigma_mm

    searches: list = []
    inner = F._auto_search

    def counted(prep, **kw):
        res = inner(prep, **kw)
        searches.append(res)
        return res

    fit_piecewise_clothoid(curves[0])  # numba's caches
    out = {k: [] for k in ("cpu_ms", "searches", "candidates", "segments", "noise_ratio",
                                "yardstick_ratio")}
    F._auto_search = counted
    try:
        for P in curves:
            searches.clear()
            c = time.process_time()
            f = fit_piecewise_clothoid(P)
            out["cpu_ms"].append(1e3 * (time.process_time() - c))
            out["searches"].append(len(searches))
            out["candidates"].append(sum(len(r["candidates"]) for r in searches))
            out["segments"].append(f.n_segments_kappa + f.n_segments_tau)
            out["noise_ratio"].append(np.sqrt(searches[0]["best"][2] / (3 * f.s_mm.size)) / noise_sigma_mm(P))
            out["yardstick_ratio"].append(np.sqrt(searches[0]["best"][2] / (3 * f.s_mm.size))
                                          / F._retry_yardstick_mm(P, f.data_mm, 0.999))
    finally:
        F._auto_search = inner
    return {k: np.array(v, float) for k, v in out.items()}


def _pipeline_curves(curves_csv: Path, n_curves: int) -> None:
    """A reconstruction's curves against the benchmark's ground-truth curves: what makes its frames dearer."""
    import pandas as pd

    from tendrilkit.pwc.fit import RETRY_ALLOWANCE_FRACTION, RETRY_NOISE_RATIO

    d = pd.read_csv(curves_csv).sort_values(["frame", "point"])
    run = [g[["x_mm", "y_mm", "z_mm"]].to_numpy(float) for _, g in d.groupby("frame")]
    bench = [random_pwc_curve(1000 + i).points_mm for i in range(n_curves)]
    print(f"fit of every frame, CPU ms (load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores):")
    for name, curves in ((f"ground-truth curves ({len(bench)})", bench), (f"{curves_csv} ({len(run)} frames)", run)):
        f = _search_figures(curves)
        print(f"  {name}: points {np.median([len(P) for P in curves]):.0f}; CPU median {np.median(f['cpu_ms']):.1f} "
              f"mean {f['cpu_ms'].mean():.1f} max {f['cpu_ms'].max():.1f} ms; searches per fit {f['searches'].mean():.2f} "
              f"(retried {100 * np.mean(f['searches'] > 1):.0f} %); candidates per fit {f['candidates'].mean():.1f}; "
              f"segments (kappa + tau) {f['segments'].mean():.1f}; first search's rms / noise estimate median "
              f"{np.median(f['noise_ratio']):.2f}, / the retry's yardstick (noise, at least "
              f"{RETRY_ALLOWANCE_FRACTION} of the rms the target R2 allows) median "
              f"{np.median(f['yardstick_ratio']):.2f} (retry above {RETRY_NOISE_RATIO})")
        _print_refinements(f"  {name}: the refinements by kind", curves)


def _print_refinements(title: str, curves: list) -> None:
    """Levenberg-Marquardt calls per fit by kind, and their CPU: what the candidates of the search cost."""
    import tendrilkit.pwc.selection as S

    kinds = {(2, True): "a candidate, from the best of its starts (quick)",
             (2, False): "a candidate knot of the score test (quick)",
             (S.STEP_ITERATIONS, False): "the step taken, further",
             (40, False): "the last step, to convergence"}
    inner = S._refine_laws
    acc: dict = {}

    def counted(prep, lk, lt, iterations=40, rtol=1e-6, state=None):
        c = time.process_time()
        try:
            return inner(prep, lk, lt, iterations, rtol, state)
        finally:
            # a quick candidate is told by its start's state; the steps start from their candidate's end state too
            a = acc.setdefault((iterations, state is not None and iterations == 2), [0, 0.0])
            a[0] += 1
            a[1] += time.process_time() - c

    S._refine_laws = counted
    try:
        for P in curves:
            fit_piecewise_clothoid(P, n_points=len(P))
    finally:
        S._refine_laws = inner
    n = len(curves)
    print(f"{title} (Levenberg-Marquardt calls per fit, {n} fits):")
    for key, (calls, cpu) in sorted(acc.items()):
        print(f"  {kinds.get(key, f'{key[0]} iterations'):50s} {calls / n:5.1f} calls {1e3 * cpu / n:6.2f} ms CPU "
              f"({1e6 * cpu / calls:.0f} us each)")


def _stage_times(curves) -> dict:
    """CPU time per frame of each stage of the automatic fit (wrappers around the stage functions)."""
    import tendrilkit.pwc.fit as F
    import tendrilkit.pwc.laws as L
    import tendrilkit.pwc.selection as S

    stages = [(F, "_prepare", "signals: smoothing, Frenet frames, cost tables"),
              (S, "penalty_path", "search: both penalty paths"),
              (L._Joiner, "join", "continuity: joins and knot refit"),
              (S, "_refine_starts", "selection: starts evaluated, the best refined"),
              (S, "_refine_laws", "refinement: Levenberg-Marquardt"),
              (S, "_best_insertions", "selection: knot score test"),
              (F, "_finish", "rebuild, registration, scores")]
    acc = {label: 0.0 for _, _, label in stages}
    saved = []
    for mod, name, label in stages:
        f = getattr(mod, name)
        saved.append((mod, name, f))

        def timed(*a, _f=f, _label=label, **k):
            c = time.process_time()
            try:
                return _f(*a, **k)
            finally:
                acc[_label] += time.process_time() - c

        setattr(mod, name, timed)
    try:
        c = time.process_time()
        for tc in curves:
            fit_piecewise_clothoid(tc.points_mm)
        total = time.process_time() - c
    finally:
        for mod, name, f in saved:
            setattr(mod, name, f)
    out = {k: 1e3 * v / len(curves) for k, v in acc.items()}
    out["selection: the rest (Python)"] = 1e3 * total / len(curves) - sum(out.values())
    out["total"] = 1e3 * total / len(curves)
    return out


_TIME_FITS = """
import json, os, sys, time
sys.path.insert(0, os.getcwd())
from tendrilkit.pwc import fit_piecewise_clothoid
from tendrilkit.pwc.datasets import random_pwc_curve
curves = [random_pwc_curve(1000 + i).points_mm for i in range({n})]
fit_piecewise_clothoid(curves[0])
wall, cpu = [], []
for P in curves:
    t, c = time.perf_counter(), time.process_time()
    fit_piecewise_clothoid(P)
    wall.append(time.perf_counter() - t)
    cpu.append(time.process_time() - c)
print(json.dumps([wall, cpu]))
"""


def _compare(baseline: Path, n_curves: int, n_frames: int, rounds: int, command_csv: Path | None = None) -> None:
    """Old (``baseline``) against this checkout, alternately in fresh processes, on the same load.

    The fit command runs on the ground-truth curves' CSV and, with ``command_csv`` (``--command-csv``: a
    reconstruction's curves, issue 17's case), on that one too.
    """
    import json

    import pandas as pd

    if not (baseline / "tendrilkit" / "pwc").is_dir():
        print(f"--baseline: {baseline} holds no tendrilkit/pwc; expected a checkout of the old code")
        raise SystemExit(2)
    sides = {"old": baseline, "new": REPO}
    per_fit = {k: ([], []) for k in sides}
    for _ in range(rounds):
        for name, cwd in sides.items():
            r = subprocess.run([sys.executable, "-c", _TIME_FITS.format(n=n_curves)], cwd=cwd,
                               capture_output=True, text=True, check=True)
            wall, cpu = json.loads(r.stdout)
            per_fit[name][0].extend(wall)
            per_fit[name][1].extend(cpu)
    med = {k: (1e3 * np.median(w), 1e3 * np.median(c)) for k, (w, c) in per_fit.items()}
    # the worst frame: each curve's median over the rounds, then the largest
    top = {k: (1e3 * np.median(np.reshape(w, (rounds, -1)), axis=0).max(),
               1e3 * np.median(np.reshape(c, (rounds, -1)), axis=0).max()) for k, (w, c) in per_fit.items()}
    print(f"auto fit, 200 points, {n_curves} ground-truth curves x {rounds} alternate runs, median per frame: "
          f"old wall {med['old'][0]:.1f} ms CPU {med['old'][1]:.1f} ms; new wall {med['new'][0]:.1f} ms "
          f"CPU {med['new'][1]:.1f} ms; new/old wall {med['new'][0] / med['old'][0]:.2f}, "
          f"CPU {med['new'][1] / med['old'][1]:.2f} (target <= 5 ms; load average {os.getloadavg()[0]:.1f} on "
          f"{os.cpu_count()} cores)")
    print(f"  worst frame (its median over the runs): old wall {top['old'][0]:.1f} ms CPU {top['old'][1]:.1f} ms; "
          f"new wall {top['new'][0]:.1f} ms CPU {top['new'][1]:.1f} ms")
    with tempfile.TemporaryDirectory() as tmp:
        rows = []
        for f in range(n_frames):
            P = random_pwc_curve(5000 + f).points_mm
            rows.append(pd.DataFrame({"frame": f, "time_s": 20.0 * f, "point": np.arange(len(P)),
                                      "x_mm": P[:, 0], "y_mm": P[:, 1], "z_mm": P[:, 2]}))
        csv = Path(tmp) / "curves.csv"
        pd.concat(rows).to_csv(csv, index=False)
        for what, path in ((f"the benchmark's {n_frames} ground-truth curves", csv),
                           (f"{command_csv}", command_csv)):
            if path is not None:
                _compare_command(sides, path, Path(tmp), what, rounds)


def _compare_command(sides: dict, csv: Path, tmp: Path, what: str, rounds: int) -> None:
    """The fit command of both sides on ``csv``, alternately, process start included.

    The new side runs twice: with ``--workers 1`` (the old command's one process) and with its default
    (every core), when it has the option.
    """
    runs = {"old": (sides["old"], [])}
    if "--workers" in subprocess.run([sys.executable, "-m", "tendrilkit", "fit", "--help"], cwd=sides["new"],
                                     capture_output=True, text=True).stdout:
        runs["new 1 worker"] = (sides["new"], ["--workers", "1"])
    runs["new"] = (sides["new"], [])
    cmd = {k: ([], []) for k in runs}
    for run in range(rounds + 1):  # the first pair may fill numba's caches: not counted
        for name, (cwd, extra) in runs.items():
            t, c0 = time.perf_counter(), os.times()
            subprocess.run([sys.executable, "-m", "tendrilkit", "fit", str(csv), "--out", str(tmp / name), *extra],
                           cwd=cwd, capture_output=True, text=True, check=True)
            c1 = os.times()
            if run:
                cmd[name][0].append(time.perf_counter() - t)
                cmd[name][1].append((c1.children_user - c0.children_user) + (c1.children_system - c0.children_system))
    m = {k: (np.median(w), np.median(c)) for k, (w, c) in cmd.items()}
    same = all((tmp / "old" / f).read_bytes() == (tmp / k / f).read_bytes()
               for k in runs for f in ("pwc_curves.csv", "pwc_segments.csv", "pwc_metrics.csv"))
    print(f"fit command on {what}, process start included, median of {rounds} alternate runs "
          f"(load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores); result files "
          f"{'identical' if same else 'DIFFERENT'}:")
    for k, (w, c) in m.items():
        print(f"  {k:13s} {w:.2f} s wall {c:.2f} s CPU (target <= 2 s); /old: wall {w / m['old'][0]:.2f}, "
              f"CPU {c / m['old'][1]:.2f}")


_ACCURACY = """
import json, os, sys
import numpy as np
sys.path.insert(0, os.getcwd())
from tendrilkit.pwc import fit_piecewise_clothoid
from tendrilkit.pwc.datasets import mean_distance_mm, random_pwc_curve
out = {{}}
o = {offset!r} * np.array([1.0, -0.5, 0.25])  # a translation: the same fit but for round-off
for seed in {seeds}:
    tc = random_pwc_curve(seed)
    f = fit_piecewise_clothoid(tc.points_mm + o)
    out[seed] = [mean_distance_mm(f.points_mm - o, tc.dense_mm), f.r2, f.sse_mm2, f.n_segments_kappa,
                 f.n_segments_tau, tc.kappa_knots[0].size - 1, tc.tau_knots[0].size - 1]
print(json.dumps(out))
"""


def _compare_accuracy(baseline: Path, n_curves: int, n_frames: int, n_extra: int, roundoff: bool = False) -> None:
    """Issue 17's accuracy rule: old and new on every seeded ground-truth curve, aggregate and per curve.

    ``roundoff``: the old code also on every curve translated by 0.001, 1 and 3 mm (a fit does not depend
    on a translation but for round-off): how far the aggregates and single fits move by round-off alone,
    the yardstick of a change that alters results at round-off only.
    """
    import json

    sets = {"per-frame curves": list(range(1000, 1000 + n_curves)), "fit-command curves": list(range(5000, 5000 + n_frames)),
            "extra curves": list(range(2000, 2000 + n_extra))}
    sets = {k: v for k, v in sets.items() if v}  # --extra 0: none
    seeds = [s for v in sets.values() for s in v]
    if max(seeds) >= 10000:
        print("--extra: seeds from 10000 are kept for the final benchmark")
        raise SystemExit(2)
    res = {}
    for name, cwd in (("old", baseline), ("new", REPO)):
        r = subprocess.run([sys.executable, "-c", _ACCURACY.format(seeds=seeds, offset=0.0)], cwd=cwd,
                           capture_output=True, text=True, check=True)
        res[name] = {int(k): v for k, v in json.loads(r.stdout).items()}

    def figures(d, ks):
        m = np.array([d[k][0] for k in ks])
        r2 = np.array([d[k][1] for k in ks])
        agree = np.mean([d[k][3] == d[k][5] and d[k][4] == d[k][6] for k in ks])
        return (f"mean distance median {np.median(m):.4f} mean {m.mean():.4f} p95 {np.percentile(m, 95):.4f} "
                f"worst {m.max():.4f} mm; segment counts as the truth {100 * agree:.0f} %; "
                f"R2 mean {r2.mean():.6f} min {r2.min():.6f}")

    print("accuracy on the seeded noisy ground-truth curves (0.15 mm noise), old / new:")
    for name, ks in (*sets.items(), ("all", seeds)):
        print(f"  {name} ({len(ks)}): old {figures(res['old'], ks)}")
        print(f"  {' ' * len(name)} ({len(ks)}): new {figures(res['new'], ks)}")
    d = np.array([res["new"][k][0] - res["old"][k][0] for k in seeds])
    worst = int(np.argmax(d))
    print(f"  per curve: {int(np.sum(d < -1e-9))} better, {int(np.sum(d > 1e-9))} worse, "
          f"{int(np.sum(np.abs(d) <= 1e-9))} unchanged; worst change {d[worst]:+.4f} mm (seed {seeds[worst]}), "
          f"best {d.min():+.4f} mm")
    bad = [k for k, x in zip(seeds, d) if x > 0.02]
    print("  worse by more than 0.02 mm: " + (", ".join(
        f"seed {k} {res['old'][k][0]:.4f} -> {res['new'][k][0]:.4f} mm (segments {res['old'][k][3]}+{res['old'][k][4]} -> "
        f"{res['new'][k][3]}+{res['new'][k][4]}, truth {res['old'][k][5]}+{res['old'][k][6]}; SSE "
        f"{res['old'][k][2]:.2f} -> {res['new'][k][2]:.2f} mm2)" for k in bad) if bad else "none"))
    if not roundoff:
        return
    print("round-off alone: the old code on the curves translated by (1, -0.5, 0.25) x offset:")
    for offset in (0.001, 1.0, 3.0):
        r = subprocess.run([sys.executable, "-c", _ACCURACY.format(seeds=seeds, offset=offset)], cwd=baseline,
                           capture_output=True, text=True, check=True)
        moved = {int(k): v for k, v in json.loads(r.stdout).items()}
        d = np.array([moved[k][0] - res["old"][k][0] for k in seeds])
        print(f"  offset {offset:g} mm ({len(seeds)}): {figures(moved, seeds)}; per curve {int(np.sum(d < -1e-9))} "
              f"better, {int(np.sum(d > 1e-9))} worse, worst change {d.max():+.4f} mm")


if __name__ == "__main__":
    main()
