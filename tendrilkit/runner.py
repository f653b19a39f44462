"""The run over an experiment's frames: chunks, workers, speculation and resuming.

``python -m tendrilkit reconstruct EXPERIMENT.yaml --out DIR`` is
:func:`run_reconstruct`: load and check the experiment, calibrate the rig once
(``DIR/cameras.json``, ``DIR/calibration_markers.csv``), reconstruct every
selected frame (:func:`tendrilkit.pipeline.reconstruct_frame`) in chunks of
consecutive frames, then assemble and write the tables
(:mod:`tendrilkit.assembly`; the files are listed in :mod:`tendrilkit.pipeline`).

Tracking and workers
    Segmentation takes, in every view, the component nearest the previous
    frame's centroid (the paper's tracking), so a frame depends on the frames
    before it. Frames are processed in chunks of consecutive frames, in
    parallel processes (``cv2.setNumThreads(1)`` in each); a chunk starts
    without a previous centroid and is accepted only if that cannot change
    the result: in every view, the chunk's first frame has a single
    component (the choice does not depend on the previous centroid), or the
    true previous centroid is also none, or the segmentation of that frame
    from the true previous centroid (run again in the parent process: a few
    milliseconds) picks the component of the same centroid, hence the same
    mask. Otherwise the chunk is recomputed from the true previous
    centroids, frame by frame, until both computations carry the same
    tracking state; from there on the chunk's own results had the same
    inputs and are kept. The results are therefore identical, byte for byte,
    whatever the number of workers.

    With ``reconstruction.method: multiview`` the tracking state is the
    previous frame's 3D curve (:mod:`tendrilkit.multiview`; none after a
    frame that is not ``ok``). The frames are cut into fixed chunks of
    ``reconstruction.chunk_frames`` processed frames, independent of the
    number of workers; each chunk starts by acquiring the curve from the
    base, then tracks it frame by frame, so the results are identical
    whatever the number of workers (a resumed run starts a chunk's remaining
    frames from the curve of the last finished one).

Resuming
    Every finished frame is written atomically to
    ``DIR/frames/frame_000123.json`` with a fingerprint of the run (resolved
    experiment including ``frames`` start and step, since tracking depends on
    the frames seen; each video's size, modification time and a hash of 16
    blocks spread over it; cameras; tendrilkit's version and source code), its
    frame number and a checksum of its content (:func:`tendrilkit.io.write_frame_record`).
    Running the same command again reuses the calibration it wrote
    (``cameras.json``, stamped in ``frames/calibration_stamp.json``), skips
    the frames whose file verifies (same fingerprint, same frame, checksum;
    an edited, truncated or copied file is recomputed) and assembles the
    tables from the per-frame files; an interrupted run (Ctrl-C, SIGTERM)
    keeps its finished frames.

Exit code
    0 if every frame is ``ok``, 1 if some are ``doubtful`` or ``failed`` (the
    run still completes and writes every table); user mistakes raise
    :class:`~tendrilkit.exceptions.ExperimentError` (exit code 2 in the CLI);
    Ctrl-C propagates ``KeyboardInterrupt`` (exit code 130 in the CLI; SIGTERM
    143) after the finished frames are on disk; a result file that cannot be
    written raises :class:`~tendrilkit.exceptions.OutputWriteError` (exit
    code 74), the finished frames kept. The summary
    (:class:`ReconstructSummary`, printed by the command line) is
    ``N frames: X ok, Y doubtful, Z failed``.

Verification
    Per frame in :mod:`tendrilkit.pipeline`; against the neighbouring frames
    at assembly (:func:`tendrilkit.assembly.with_temporal_checks`), over the
    ordered frames: the same whatever the chunks or workers.

Executor seam
    The chunks are submitted to an object with the
    :class:`concurrent.futures.Executor` interface (``submit``, futures);
    the default is tendrilkit's own process pool, and ``executor=`` takes
    another (e.g. a Dask ``Client.get_executor()``), which the caller owns.
"""

from __future__ import annotations

import hashlib
import json
import math
import multiprocessing as mp
import os
import warnings
from concurrent.futures import Executor, ProcessPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from tendrilkit import schema
from tendrilkit.camera import Camera
from tendrilkit.exceptions import ExperimentError, FrameError, FrameReadError
from tendrilkit.options import stage_options
from tendrilkit.assembly import assemble_tables, with_run_checks, with_temporal_checks
from tendrilkit.pipeline import RESULT_FILES, FrameResult, reconstruct_frame
from tendrilkit.pools import ignore_interrupts, signals_held, stop_pool
from tendrilkit.segmentation import segment_view

__all__ = ["ReconstructSummary", "run_reconstruct", "frame_fingerprint", "RESULT_FILES"]

_FORMAT_VERSION = 1
_MAX_CHUNK = 16


@dataclass(frozen=True)
class ReconstructSummary:
    """What :func:`run_reconstruct` did; ``str()`` is the command's last line."""

    n_frames: int
    n_ok: int
    n_doubtful: int
    n_failed: int
    out_dir: Path

    @property
    def exit_code(self) -> int:
        """0 if every frame is ``ok``, 1 if some are ``doubtful`` or ``failed``."""
        return 0 if self.n_ok == self.n_frames else 1

    def __str__(self) -> str:
        return f"{self.n_frames} frames: {self.n_ok} ok, {self.n_doubtful} doubtful, {self.n_failed} failed"


def _read_views(sources, frame: int):
    images, errors = [], []
    for src in sources:
        try:
            images.append(src.read(frame))
            errors.append(None)
        except FrameError as e:
            images.append(None)
            errors.append(f"{type(e).__name__}: {e}")
    return images, errors


def _next_state(state: list, res: FrameResult) -> list:
    """Tracking state after a frame: per view, its centroid if segmented, else the previous one."""
    return [c if c is not None else s for s, c in zip(state, res.centroids or [None] * len(state))]


def _run_chunk(args) -> list[FrameResult]:
    """Process consecutive frames from a tracking state (in a worker); see :func:`_iter_chunk`."""
    return list(_iter_chunk(*args))


def _worker_init() -> None:
    import cv2

    ignore_interrupts()  # the parent handles Ctrl-C and SIGTERM; stop_pool() ends the workers with it
    cv2.setNumThreads(1)


def _speculation_holds(true_state: list, first: FrameResult, exp=None, sources=None) -> bool:
    """Whether a chunk computed from no previous centroid equals the one from ``true_state``.

    It does if, in every view, the chunk's first frame had one component to
    choose from or no true previous centroid exists; otherwise (given the
    frame's ``sources``) the segmentation of that view is run again from the
    true previous centroid: the same centroid means the same component, the
    same mask and the same results.
    """
    n_comp = first.n_components or [None] * len(true_state)
    doubtful = [v for v, (st, n) in enumerate(zip(true_state, n_comp)) if st is not None and n != 1]
    if not doubtful:
        return True
    if exp is None or sources is None:
        return False
    seg_opts = stage_options(exp, "segmentation")
    for v in doubtful:
        try:
            img = sources[v].read(first.frame)
        except FrameError:
            return False
        marks = exp.views[v]
        try:
            seg = segment_view(img, roi=marks.roi, keep_out=marks.keep_out, base_point_xy=marks.base_point,
                               prev_centroid_xy=true_state[v], **seg_opts)
            c = [float(x) for x in seg.centroid_xy]
        except FrameError:
            c = None
        if c != (first.centroids[v] if first.centroids else None):
            return False
    return True


def frame_fingerprint(exp, cameras: list[Camera], video_info: list[dict]) -> str:
    """SHA-256 of what determines a frame's result: resolved parameters, videos, cameras, code."""
    from tendrilkit import __version__ as version
    from tendrilkit.params import experiment_to_dict

    payload = {
        "format": _FORMAT_VERSION,
        "version": version,
        "code": _code_digest(),
        # frames: start and step change the tracking (the frames seen); stop does not change a frame's result
        "experiment": {k: v for k, v in experiment_to_dict(exp).items() if k not in ("frames", "name")},
        "frames": {"start": exp.frames.start, "step": exp.frames.step},
        "videos": video_info,
        "cameras": [c.to_dict(i + 1) for i, c in enumerate(cameras)],
    }
    text = json.dumps(payload, sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()


def _code_digest() -> str:
    """SHA-256 of tendrilkit's own source files, sub-packages included: a changed algorithm recomputes the frames."""
    h = hashlib.sha256()
    root = Path(__file__).resolve().parent
    for p in sorted(root.rglob("*.py")):
        h.update(p.relative_to(root).as_posix().encode())
        h.update(p.read_bytes())
    return h.hexdigest()


def _calibration_stamp(exp, video_info: list[dict]) -> str:
    """SHA-256 of what the calibration depends on: intrinsics, marker, extrinsics files, first frame, videos."""
    from tendrilkit import __version__ as version
    from tendrilkit.params import experiment_to_dict

    d = experiment_to_dict(exp)
    payload = {"version": version, "code": _code_digest(), "videos": video_info, "start": exp.frames.start,
               **{k: d.get(k) for k in ("cameras", "marker", "extrinsics", "calibration")}}
    return hashlib.sha256(json.dumps(payload, sort_keys=True, default=str).encode()).hexdigest()


def _frame_path(out: Path, frame: int) -> Path:
    return out / "frames" / f"frame_{frame:06d}.json"


def _load_done(out: Path, frames: list[int], fp: str) -> dict[int, FrameResult]:
    """The finished frames whose file verifies (:func:`tendrilkit.io.read_frame_record`); the others are recomputed."""
    from tendrilkit.io import read_frame_record

    done = {}
    for f in frames:
        d = read_frame_record(_frame_path(out, f), fp, f)
        if d is None:
            continue
        try:
            done[f] = FrameResult.from_json(d)
        except (KeyError, TypeError, ValueError, AttributeError):
            continue
    return done


def _chunks(frames: list[int], workers: int) -> list[list[int]]:
    if workers <= 1:
        return [frames] if frames else []
    # small chunks: progress and Ctrl-C lose at most a chunk per worker; a chunk boundary costs nothing
    # unless the speculation fails there (several components in the first frame)
    size = min(_MAX_CHUNK, max(2, math.ceil(len(frames) / (4 * workers))))
    return [frames[i:i + size] for i in range(0, len(frames), size)]


def run_reconstruct(experiment_path: str | Path, out_dir: str | Path, *, workers: int | None = None,
                    progress: bool = True, fit: bool = True, overrides: dict | None = None,
                    contact_sheet: bool = True, executor: Executor | None = None) -> ReconstructSummary:
    """``python -m tendrilkit reconstruct``: every selected frame of an experiment.

    Parameters
    ----------
    experiment_path : str or Path
        The experiment YAML file.
    out_dir : str or Path
        Output folder (created): the tables of :data:`RESULT_FILES`,
        ``cameras.json`` and ``frames/`` (one JSON file per finished frame).
    workers : int, optional
        Processes for frames (default: every core). The results do not
        depend on it.
    progress : bool
        Progress bar on a terminal (:func:`tendrilkit.progress.progress`).
    fit : bool
        Fit the piece-wise clothoid (``pwc_curves.csv``).
    overrides : dict, optional
        Optional sections of the experiment to change for this run, e.g.
        ``{"correspondence": {"method": "frechet"}}`` (they enter the
        fingerprint).
    contact_sheet : bool
        Write ``qc_contact_sheet.png`` (:func:`tendrilkit.qc.write_contact_sheet`):
        the doubtful frames and a sample of ok ones, the reconstruction
        projected onto every view.
    executor : concurrent.futures.Executor, optional
        Where the chunks run when ``workers`` > 1 (e.g. a Dask
        ``Client.get_executor()``; the caller shuts it down). Default:
        tendrilkit's own pool of ``workers`` processes.

    Returns
    -------
    ReconstructSummary
        Its ``exit_code``: 0 if every frame is ``ok``, 1 if some are
        ``doubtful`` or ``failed``; ``str()``: ``N frames: X ok, Y doubtful, Z failed``.

    Raises
    ------
    ExperimentError
        The experiment file, a video or the output folder is unusable, or the
        calibration fails.
    """
    from tendrilkit.extrinsics import calibrate_experiment
    from tendrilkit.inputs import check_inputs
    from tendrilkit.io import (check_writable_dir, file_stamp, open_views, read_cameras, read_csv, write_cameras,
                               write_result, write_frame_record, write_json)
    from tendrilkit.params import load_experiment, with_overrides
    from tendrilkit.progress import progress as progress_bar
    from tendrilkit.verify import Thresholds
    from tendrilkit.verify_calibration import world_marker_message

    exp = with_overrides(load_experiment(experiment_path), overrides)
    out = check_writable_dir(out_dir)
    sources = open_views(list(exp.videos))
    try:
        sizes = [(s.width, s.height) for s in sources]
        counts = [s.frame_count for s in sources]
        video_info = [{"path": str(p), **file_stamp(p), "frames": n, "width": w, "height": h}
                      for p, n, (w, h) in zip(exp.videos, counts, sizes)]
        check_inputs(exp, sources)
    finally:
        for s in sources:
            s.close()
    n_video = max(counts)  # a shorter view's missing frames fail in that view only (FrameReadError)
    fr = exp.frames
    stop = n_video if fr.stop is None else min(fr.stop, n_video)
    frames = list(range(fr.start, stop, fr.step))
    if not frames:
        raise ExperimentError(f"{exp.source}: frames: no frame selected (start {fr.start}, stop {fr.stop}, "
                              f"step {fr.step}; the longest video has {n_video} frames)")

    # calibrate once per experiment and videos: a rerun reuses the rig it wrote
    cal_stamp = _calibration_stamp(exp, video_info)
    stamp_path = out / "frames" / "calibration_stamp.json"
    cameras = None
    if stamp_path.is_file() and (out / "cameras.json").is_file() and (out / "calibration_markers.csv").is_file():
        try:
            if json.loads(stamp_path.read_text(encoding="utf-8")).get("stamp") == cal_stamp:
                cameras = read_cameras(out / "cameras.json")
                markers = read_csv(out / "calibration_markers.csv", table=schema.CALIBRATION_MARKERS)
        except (OSError, json.JSONDecodeError, ExperimentError):
            cameras = None
    if cameras is None:
        calib = calibrate_experiment(exp)
        cameras = calib.cameras
        markers = calib.markers
        write_cameras(cameras, out / "cameras.json", quality=calib.view_quality())
        write_result(markers, out / "calibration_markers.csv", schema.CALIBRATION_MARKERS)
        write_json({"stamp": cal_stamp}, stamp_path)
    # the world frame the rig was calibrated in: every frame's millimetres depend on it (verify_calibration)
    run_check = world_marker_message(markers, exp.marker.id,
                                     Thresholds.from_params(exp.verification).max_world_marker_px)

    fp = frame_fingerprint(exp, cameras, video_info)
    done = _load_done(out, frames, fp)
    todo = [f for f in frames if f not in done]
    workers = max(1, int(workers) if workers is not None else (os.cpu_count() or 1))
    workers = min(workers, max(1, len(todo)))
    V = exp.n_views

    def save(res: FrameResult) -> None:
        write_frame_record(_frame_path(out, res.frame), fp, res.frame, res.to_json())
        done[res.frame] = res

    # runs of consecutive to-do frames (done frames between them carry the tracking state)
    runs: list[list[int]] = []
    pos = {f: i for i, f in enumerate(frames)}
    for f in todo:
        if runs and pos[f] == pos[runs[-1][-1]] + 1:
            runs[-1].append(f)
        else:
            runs.append([f])
    multiview = exp.reconstruction.method == "multiview"
    if multiview:  # fixed chunks (acquired afresh at each start): the same results for any number of workers
        size = exp.reconstruction.chunk_frames
        chunks = [[f for f in r if pos[f] // size == k] for r in runs for k in sorted({pos[f] // size for f in r})]
    else:
        chunks = [c for r in runs for c in _chunks(r, workers)]

    def state_before(f: int):
        if multiview:  # the previous frame's curve within the chunk (done frames: a resumed run)
            i = pos[f]
            return None if i % exp.reconstruction.chunk_frames == 0 else _next_curve(done[frames[i - 1]])
        st: list = [None] * V
        for g in frames[: pos[f]]:
            st = _next_state(st, done[g])
        return st

    import cv2

    def produce():
        """Finished frames in frame order, each already tracked from the true previous centroids."""
        if workers == 1 and executor is None:
            for chunk in chunks:
                yield from _iter_chunk(chunk, state_before(chunk[0]), exp, cameras, fit)
            return
        pool = executor if executor is not None else _own_pool(workers, fit)
        try:
            with _Sources(exp) as sources:
                yield from _collect(pool, sources)
        finally:
            if executor is None:
                stop_pool(pool)

    def _collect(pool: Executor, sources):
        with signals_held():  # a pool of ours forks its workers at the first submit
            if multiview:
                jobs = [pool.submit(_run_chunk, (c, state_before(c[0]), exp, cameras, fit)) for c in chunks]
            else:
                jobs = [pool.submit(_run_chunk, (c, [None] * V, exp, cameras, fit)) for c in chunks]
        for chunk, job in zip(chunks, jobs):
            results = job.result()
            state = state_before(chunk[0]) if not multiview else None
            if not multiview and not _speculation_holds(state, results[0], exp, sources):
                # recompute from the true state until both chains carry the same tracking state:
                # from there on the speculative results had the same inputs
                spec_states, st = [], [None] * V
                for res in results:
                    st = _next_state(st, res)
                    spec_states.append(st)
                fixed = []
                for i, f in enumerate(chunk):
                    res = pool.submit(_run_chunk, ([f], state, exp, cameras, fit)).result()[0]
                    fixed.append(res)
                    state = _next_state(state, res)
                    if state == spec_states[i]:
                        break
                results = fixed + results[len(fixed):]
            for res in results:
                yield res

    old_threads = cv2.getNumThreads()
    cv2.setNumThreads(1)  # the same single-threaded OpenCV in-process as in the workers
    try:
        for res in progress_bar(produce(), total=len(todo), desc=exp.name, enabled=None if progress else False):
            save(res)
    finally:
        cv2.setNumThreads(old_threads)

    results = with_run_checks(with_temporal_checks([done[f] for f in frames], exp.verification),
                              [run_check] if run_check else [])
    tables = assemble_tables(results, V)
    for name, df in tables.items():
        write_result(df, out / name, schema.frames_table(V) if name == "frames.csv" else schema.RESULT_TABLES[name])
    if contact_sheet:
        from tendrilkit.qc import CONTACT_SHEET, write_contact_sheet

        write_contact_sheet(exp, cameras, tables["frames.csv"], tables["curves.csv"], tables["pwc_curves.csv"],
                            out / CONTACT_SHEET)
    n_ok = sum(r.status == "ok" for r in results)
    n_doubtful = sum(r.status == "doubtful" for r in results)
    n_failed = len(results) - n_ok - n_doubtful
    return ReconstructSummary(len(results), n_ok, n_doubtful, n_failed, out)


def _own_pool(workers: int, fit: bool) -> ProcessPoolExecutor:
    """tendrilkit's own pool: forked workers (the kernels compiled once here) with OpenCV single-threaded."""
    if "fork" in mp.get_all_start_methods():
        ctx = mp.get_context("fork")
        _warm_up(fit)  # compile once here; the forked workers inherit the compiled kernels
    else:
        ctx = mp.get_context("spawn")
    return ProcessPoolExecutor(workers, mp_context=ctx, initializer=_worker_init)


class _Sources:
    """The views' frame sources, opened lazily (the parent checks speculative chunks with them)."""

    def __init__(self, exp) -> None:
        self.exp = exp
        self._src = None

    def __getitem__(self, v: int):
        if self._src is None:
            from tendrilkit.io import open_views

            self._src = open_views(list(self.exp.videos))
        return self._src[v]

    def __enter__(self) -> "_Sources":
        return self

    def __exit__(self, *exc) -> None:
        for s in self._src or []:
            s.close()


def _warm_up(fit: bool) -> None:
    """Run the compiled kernels once on a small synthetic curve and mask (numba compiles or loads its cache).

    The skeleton ordering is included: its graph walk is compiled too, and a
    worker would otherwise load it in its first chunk.
    """
    from tendrilkit.correspondence import discrete_frechet, match_epipolar
    from tendrilkit.pwc import fit_piecewise_clothoid
    from tendrilkit.skeleton import order_skeleton
    from tendrilkit.triangulation import reprojection_table, triangulate

    mask = np.zeros((40, 60), bool)  # a stroke with a side branch: a junction and three ends
    mask[18:22, 5:55] = True
    mask[5:20, 30:33] = True
    try:
        with warnings.catch_warnings():  # the branch is left out of the walk: a warm-up, not a frame
            warnings.simplefilter("ignore")
            order_skeleton(mask, base_point_xy=(5.0, 20.0))
    except FrameError:
        pass

    s = np.linspace(0.0, 1.0, 60)
    X = np.c_[30 * s, 5 * np.sin(4 * s), 200 + 5 * np.cos(4 * s)]
    cams = [Camera(K=np.array([[1000.0, 0, 500], [0, 1000, 500], [0, 0, 1]]), t_mm=np.array([tx, 0.0, 0.0]))
            for tx in (-40.0, 0.0, 40.0)]
    curves = [c.project(X) for c in cams]
    try:
        m = match_epipolar(curves, cams, reference=1, k=20)
        tri = triangulate(m, cams)
        reprojection_table(np.nan_to_num(tri.points_mm), curves, cams)
        discrete_frechet(curves[0], curves[1])
        if fit:
            fit_piecewise_clothoid(X)
    except FrameError:  # a warm-up only; the real frames report their own errors
        pass


def _next_curve(res: FrameResult) -> np.ndarray | None:
    """Multiview tracking state after a frame: its curve if it is ``ok``, else None (acquire).

    Tracking from a ``doubtful`` frame's curve too was measured worse (2026-11-30, dev seeds 0-27, 168 frames,
    ``benchmarks/rerun_multiview.py``): all three criteria 36.3 -> 35.1 % tracking alone, 36.3 % (mean <= 0.5 mm
    73.8 -> 72.0 %) when the frame is also acquired afresh and the curve the views explain better kept: a wrong
    doubtful curve carried on explains the views as well as the right one (frames with a mean error of 5-11 mm
    where the fresh acquisition had 0.1-1 mm).
    """
    return res.points_mm if res.status == "ok" else None


def _iter_chunk(frames, state, exp, cameras, fit):
    """Process consecutive frames from a tracking state, yielding each frame as it finishes.

    The state is the previous frame's centroids per view (chain) or curve (multiview).
    """
    multiview = exp.reconstruction.method == "multiview"
    sources = [_open_or_unreadable(p) for p in exp.videos]
    try:
        for f in frames:
            images, errors = _read_views(sources, f)
            if multiview:
                res = reconstruct_frame(images, cameras, exp, frame=f, previous_mm=state, read_errors=errors, fit=fit)
                state = _next_curve(res)
            else:
                res = reconstruct_frame(images, cameras, exp, frame=f, prev_centroids=state, read_errors=errors,
                                        fit=fit)
                state = _next_state(state, res)
            yield res
    finally:
        for s in sources:
            s.close()


class _Unreadable:
    """A view whose video this process cannot open: every frame read fails with the reason."""

    def __init__(self, reason: str) -> None:
        self.reason = reason

    def read(self, frame: int):
        raise FrameReadError(f"cannot open the video here ({self.reason})")

    def close(self) -> None:
        pass


def _open_or_unreadable(path):
    """The view's frame source, or (e.g. a cluster worker that does not see the file) an :class:`_Unreadable`."""
    from tendrilkit.io import FrameSource

    try:
        return FrameSource(path)
    except ExperimentError as e:
        return _Unreadable(str(e))
