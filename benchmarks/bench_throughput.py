"""Throughput of the default reconstruction on one core, against the cost of decoding.

    .venv/bin/python benchmarks/bench_throughput.py            # everything (a few minutes)
    .venv/bin/python benchmarks/bench_throughput.py sequence   # 1. only
    .venv/bin/python benchmarks/bench_throughput.py sequence --method multiview  # 1. by another method
    .venv/bin/python benchmarks/bench_throughput.py scaling    # 2. only

1. A 60-frame S3 phantom (three 1080p views, self-crossings), the default
   method, one core (``cv2.setNumThreads(1)``, single-threaded BLAS and numba):
   the decode time of the frames (every frame of every view read in order;
   measured before, between and after the other passes, median), the whole
   per-frame cost of the frame loop (reading + segmentation + ordering +
   matching + triangulation + fit + verification, as ``reconstruct`` with
   ``--workers 1`` runs it) plus writing the results (a JSON file per frame,
   the tables), and the same with ``frames.step: 3`` (skipped frames grabbed,
   not converted to images; what a skipped frame costs, grab() against read(),
   is printed too). ``--method chain|multiview`` sets ``reconstruction.method``
   (default: the experiment file's, i.e. the default method). Prints the ratio to decoding (target: at most 4x),
   frames per second (target: at least 10), the mean cost of every stage, and
   the same figures with the piece-wise clothoid fit at its target (5 ms),
   and how the verification splits between the views' evidence
   (``evidence.view_evidence``) and the checks (``verify*.py``).
   Both CPU time of this process (what one core pays, robust to a shared
   machine) and wall time are printed.
2. How the cost of one frame grows (synthetic tube views through the IJCV25
   rig, median of repetitions): with the points per curve (100-1000), the
   tendril's length in pixels, and the number of views (2-6). Prints each
   table with the cost per unit (per point, per px, per view) so that a
   growing column shows where the growth stops being linear.

Numbers on a machine shared with other jobs are upper bounds: compare the
ratios, which are measured in the same run.
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import cv2  # noqa: E402
import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import types  # noqa: E402

import tendrilkit.pipeline as _pipeline  # noqa: E402
from tendrilkit.camera import Camera  # noqa: E402
from tendrilkit.phantom import render_tube_views  # noqa: E402
from tendrilkit.runner import _iter_chunk, _warm_up  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_reconstruct import time_frame as _time_frames  # noqa: E402  (one timing loop for both benchmarks)

# the pipeline's per-stage timings in CPU seconds of this process (one core), not wall
# seconds, which a shared machine inflates: a benchmark-only substitution
_pipeline.time = types.SimpleNamespace(perf_counter=time.process_time)

REPEATS = 5


def _clocks():
    return time.perf_counter(), time.process_time()


def _since(t0):
    w, c = _clocks()
    return w - t0[0], c - t0[1]


def decode_all(videos, frames) -> tuple[float, float]:
    """Read ``frames`` of every view in order, as the frame loop does (wall s, CPU s)."""
    from tendrilkit.io import open_views

    t0 = _clocks()
    sources = open_views(list(videos))
    try:
        for f in frames:
            for s in sources:
                s.read(f)
    finally:
        for s in sources:
            s.close()
    return _since(t0)


def skip_cost(videos, n_frames: int) -> dict:
    """CPU ms per frame of a view's video: ``read()`` (demux, decode, BGR image) against ``grab()`` (no image).

    What ``frames.step`` > 1 saves on the skipped frames: :class:`tendrilkit.io.FrameSource` steps over them
    with ``grab()``. For an inter-frame codec (the phantoms' MPEG-4, H.264) a grabbed frame is still
    decoded (the next one depends on it); only the conversion to a BGR image is saved. Each pass reads the
    first ``n_frames`` of every view from the start; the passes alternate (grab, read, grab, read) and the
    median is taken.
    """
    out: dict = {"read": [], "grab": []}
    for kind in ("grab", "read", "grab", "read"):
        t0 = time.process_time()
        for p in videos:
            cap = cv2.VideoCapture(str(p))
            for _ in range(n_frames):
                ok = cap.read()[0] if kind == "read" else cap.grab()
                if not ok:
                    break
            cap.release()
        out[kind].append((time.process_time() - t0) / n_frames)
    return {k: float(np.median(v)) for k, v in out.items()}


def frame_loop(exp, cameras, frames) -> tuple[float, float, list, float]:
    """The frame loop of ``reconstruct --workers 1`` (reading included; no files written).

    Also returns the CPU seconds spent in :func:`tendrilkit.evidence.view_evidence` during the loop (the
    chain method's ``verify`` stage makes every view's evidence, then runs the checks on it): how the
    verification's cost splits between the evidence and the checks.
    """
    import tendrilkit.evidence as evidence

    spent = [0.0]
    plain = evidence.view_evidence

    def timed(*args, **kwargs):  # a benchmark-only substitution, as the pipeline's clock above
        t = time.process_time()
        try:
            return plain(*args, **kwargs)
        finally:
            spent[0] += time.process_time() - t

    evidence.view_evidence = timed
    try:
        t0 = _clocks()
        # the runner's state at a chunk's start: no curve (multiview) or no centroids per view (chain)
        start = None if exp.reconstruction.method == "multiview" else [None] * exp.n_views
        results = list(_iter_chunk(frames, start, exp, cameras, True))
        w, c = _since(t0)
    finally:
        evidence.view_evidence = plain
    return w, c, results, spent[0]


def write_results(exp, results, out: Path) -> tuple[float, float]:
    """What ``reconstruct`` writes from the frames' results: one JSON file per frame, then the tables."""
    from tendrilkit import schema
    from tendrilkit.assembly import assemble_tables, with_temporal_checks
    from tendrilkit.io import write_frame_record, write_result

    t0 = _clocks()
    for r in results:
        write_frame_record(out / "frames" / f"frame_{r.frame:06d}.json", "bench", r.frame, r.to_json())
    tables = assemble_tables(with_temporal_checks(results, exp.verification), exp.n_views)
    for name, df in tables.items():
        write_result(df, out / name, schema.frames_table(exp.n_views) if name == "frames.csv"
                     else schema.RESULT_TABLES[name])
    return _since(t0)


#: The stages of :func:`tendrilkit.pipeline.reconstruct_frame`'s timings, in the order of the method.
STAGES = ("evidence", "segment", "order", "match", "triangulate", "multiview", "base", "resample", "reprojection", "pwc",
          "verify")
#: The piece-wise clothoid fit's cost once issue 17's fit is in (about 5 ms, ``bench_pwc.py``), for the projection.
FIT_TARGET_S = 0.005


def sequence(site: str = "S3", n_frames: int = 60, method: str | None = None) -> None:
    from tendrilkit.extrinsics import calibrate_experiment
    from tendrilkit.params import load_experiment
    from tendrilkit.phantom import write_phantom_experiment

    tmp = Path(tempfile.mkdtemp(prefix="bench_throughput_"))
    print(f"1. {site} phantom, {n_frames} frames: writing the experiment ...", flush=True)
    exp = load_experiment(write_phantom_experiment(site, tmp, n_frames=n_frames, seed=0))
    if method is not None:
        exp = exp.model_copy(update={"reconstruction": exp.reconstruction.model_copy(update={"method": method})})
    cameras = calibrate_experiment(exp).cameras
    _warm_up(True)
    frames = list(range(n_frames))
    w, h = cv2.VideoCapture(str(exp.videos[0])).get(cv2.CAP_PROP_FRAME_WIDTH), None
    rows = []
    for step in (1, 3):
        sel = frames[::step]
        # decoding measured before and after the frame loop (interleaved: the same load for both)
        dec = [decode_all(exp.videos, sel)]
        loop_w, loop_c, results, ev_c = frame_loop(exp, cameras, sel)
        dec.append(decode_all(exp.videos, sel))
        wr_w, wr_c = write_results(exp, results, tmp / f"out_step{step}")
        dec.append(decode_all(exp.videos, sel))
        dec_w = float(np.median([d[0] for d in dec]))
        dec_c = float(np.median([d[1] for d in dec]))
        # the decode reference reads the selected frames as the loop does (step > 1: the skipped
        # frames grabbed, io.FrameSource), so the ratio is the cost of everything but reading
        stages: dict = {}
        for r in results:
            for k, v in r.timings.items():
                stages.setdefault(k, []).append(v)
        n_ok = sum(r.status == "ok" for r in results)
        rows.append((step, len(sel), dec_w, dec_c, loop_w, loop_c, wr_w, wr_c, n_ok, stages, ev_c))
    print(f"   reconstruction.method {exp.reconstruction.method}; "
          f"views {len(exp.videos)} x {int(w)} px wide, {exp.points} points, one core "
          f"(load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores)")
    for step, n, dec_w, dec_c, loop_w, loop_c, wr_w, wr_c, n_ok, stages, ev_c in rows:
        tot_c, tot_w = loop_c + wr_c, loop_w + wr_w
        per_c, per_w = tot_c / n, tot_w / n
        print(f"   step {step}: {n} frames ({n_ok} ok); reading the 3 views: {1e3 * dec_c / n:.1f} ms/frame CPU "
              f"({1e3 * dec_w / n:.1f} wall); whole frame incl. decoding and writing: {1e3 * per_c:.1f} ms/frame CPU "
              f"({1e3 * per_w:.1f} wall) = {tot_c / dec_c:.2f}x decode CPU ({tot_w / dec_w:.2f}x wall) "
              f"[target <= 4x]; {1 / per_c:.1f} frames/s per core CPU ({1 / per_w:.1f} wall) [target >= 10]")
        mean = {k: float(np.mean(v)) for k, v in stages.items()}
        split = ", ".join(f"{k} {1e3 * mean[k]:.1f}" for k in STAGES if k in mean)
        other = ", ".join(f"{k} {1e3 * v:.1f}" for k, v in mean.items() if k not in STAGES)
        accounted = sum(mean.values())
        print(f"      per stage (mean CPU ms/frame): decode {1e3 * dec_c / n:.1f}, {split}"
              f"{', ' + other if other else ''}, writing {1e3 * wr_c / n:.1f}; "
              f"loop overhead {1e3 * (loop_c / n - accounted) - 1e3 * dec_c / n:.1f}")
        if "verify" in mean and exp.reconstruction.method == "chain":  # its verify = every view's evidence (evidence.py) + the checks (verify*.py)
            print(f"      verify {1e3 * mean['verify']:.1f} = the views' evidence {1e3 * ev_c / n:.1f} "
                  f"+ the checks {1e3 * (mean['verify'] - ev_c / n):.1f} (mean CPU ms/frame; the checks' share includes "
                  f"the evidence's figures made when first read: inside distances, sampled distances)")
        # with the piece-wise clothoid fit at its target cost (issue 17: ~5 ms), everything else as measured
        proj_c = per_c - mean.get("pwc", 0.0) + FIT_TARGET_S
        print(f"      with the fit at {1e3 * FIT_TARGET_S:.0f} ms: {1e3 * proj_c:.1f} ms/frame CPU = "
              f"{proj_c * n / dec_c:.2f}x decode CPU, {1 / proj_c:.1f} frames/s per core")
    sk = skip_cost(exp.videos, n_frames)
    print(f"   a skipped frame (frames.step > 1, the {len(exp.videos)} views): grab() {1e3 * sk['grab']:.1f} ms CPU "
          f"against read() {1e3 * sk['read']:.1f} ms = {sk['grab'] / sk['read']:.0%} of a read frame (this "
          f"container's codec predicts frames from frames: a grabbed frame is decoded, not converted to BGR)")


# ------------------------------------------------------------------ scaling


def tube(length_scale: float = 1.0) -> np.ndarray:
    """The curled tube of bench_reconstruct, its size scaled about its base."""
    s = np.linspace(0, 1, 3000)
    th = np.clip(s - 0.4, 0, None) * 6 * np.pi
    X = np.c_[-5 + 50 * s, 6 * np.sin(th), 20 + 6 * (1 - np.cos(th))]
    return X[0] + length_scale * (X - X[0])


def turned_cameras(cams: list[Camera], n_views: int, centre: np.ndarray) -> list[Camera]:
    """``n_views`` cameras: the rig's, then the reference view turned about the scene's vertical axis."""
    out = list(cams[:n_views])
    ref = cams[1]
    axis = ref.R.T @ np.array([0.0, -1.0, 0.0])          # the reference image's up direction, in the world
    for k in range(len(out), n_views):
        ang = np.deg2rad((-1) ** k * 12.0 * (1 + k // 2))
        Q = cv2.Rodrigues(axis * ang)[0]
        out.append(Camera(K=ref.K, dist=ref.dist, R=ref.R @ Q, t_mm=ref.R @ (centre - Q @ centre) + ref.t_mm,
                          width=ref.width, height=ref.height))
    return out[:n_views]


def time_frame(images, cams, exp) -> tuple[float, str, dict]:
    """CPU seconds per frame (median), its status, and the median of each stage."""
    totals, r, stages = _time_frames(images, cams, exp, clock=time.process_time, repeats=REPEATS)
    return float(np.median(totals)), r.status, {k: float(np.median(v)) for k, v in stages.items()}


def _row(label, x, t, status, stages, unit, prev):
    """One row: total, without the fit, the marginal cost without the fit since the previous row, top stages.

    Returns ``(x, cost without the fit)`` for the next row's marginal cost: a marginal cost per unit that
    keeps growing down a table is where the growth stops being linear.
    """
    rest = t - stages.get("pwc", 0.0)
    marginal = "" if prev is None else f"{1e6 * (rest - prev[1]) / (x - prev[0]):9.1f}"
    top = sorted(((k, v) for k, v in stages.items() if k != "pwc"), key=lambda kv: -kv[1])[:3]
    print(f"   {label:>8} {x:>6.0f} {1e3 * t:8.1f} {1e3 * stages.get('pwc', 0.0):8.1f} {1e3 * rest:8.1f} "
          f"{marginal:>9} {status:8s} " + ", ".join(f"{k} {1e3 * v:.1f}" for k, v in top))
    return x, rest


def _header(unit: str) -> None:
    print(f"   {'':>8} {'':>6} {'total':>8} {'fit':>8} {'no fit':>8} {'us/' + unit:>9} {'status':8s} "
          f"largest stages but the fit")


def scaling() -> None:
    from tendrilkit.calibration import ijcv25_rig

    rig = ijcv25_rig()
    X = tube()
    images, cams, exp = render_tube_views(X, width_px=9, margin_px=40, name="bench", fps=30)
    print("2. cost of one frame (CPU ms, median of", REPEATS, "runs): total, the piece-wise clothoid fit, the rest,")
    print("   the rest's marginal cost per unit since the previous row (us), and its three largest stages (ms)")
    print("   points per curve (synthetic tube, 3 views):")
    _header("point")
    prev = None
    for n in (100, 200, 400, 700, 1000):
        e = exp.model_copy(update={"points": n})
        t, st, sg = time_frame(images, cams, e)
        prev = _row("points", n, t, st, sg, "point", prev)
    print("   tendril length in the reference view (px), 200 points:")
    _header("px")
    prev = None
    for scale in (0.5, 1.0, 1.5, 2.0, 2.5):
        Xs = tube(scale)
        p = rig[1].project(Xs)
        inside = np.all((p >= 0) & (p < [rig[1].width, rig[1].height]))
        if not inside:
            continue
        L = float(np.sum(np.linalg.norm(np.diff(p, axis=0), axis=1)))
        im, cm, e = render_tube_views(Xs, width_px=9, margin_px=40, name="bench", fps=30)
        t, st, sg = time_frame(im, cm, e)
        prev = _row("length", L, t, st, sg, "px", prev)
    print("   number of views (the rig, then the reference view turned about the vertical), 200 points:")
    _header("view")
    prev = None
    centre = X.mean(axis=0)
    for nv in (2, 3, 4, 5, 6):
        cm = turned_cameras(rig, nv, centre)
        im, cm, e = render_tube_views(X, width_px=9, margin_px=40, name="bench", fps=30, cameras=cm)
        t, st, sg = time_frame(im, cm, e)
        prev = _row("views", nv, t, st, sg, "view", prev)


def main(argv: list[str]) -> None:
    cv2.setNumThreads(1)
    method = None
    if "--method" in argv:
        i = argv.index("--method")
        if i + 1 >= len(argv) or argv[i + 1] not in ("chain", "multiview"):
            raise SystemExit("--method takes chain or multiview")
        method = argv[i + 1]
        argv = argv[:i] + argv[i + 2:]
    what = argv[0] if argv else "all"
    if what not in ("all", "sequence", "scaling"):
        raise SystemExit(f"unknown part {what!r}: all, sequence or scaling")
    if what in ("all", "sequence"):
        sequence(method=method)
    if what in ("all", "scaling"):
        scaling()


if __name__ == "__main__":
    main(sys.argv[1:])
