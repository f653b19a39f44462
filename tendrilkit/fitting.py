"""The ``fit`` command: refit the piece-wise clothoid to every frame of a ``curves.csv``.

``python -m tendrilkit fit CURVES.csv --out DIR`` calls :func:`run_fit`, which
reads the centrelines (columns of ``../shared/EXPERIMENT_FORMAT.md``: ``frame``,
``time_s``, ``point``, ``x_mm``, ``y_mm``, ``z_mm``), fits each frame with
:func:`tendrilkit.pwc.fit_piecewise_clothoid` and writes, with the one writer
of every result file (:func:`tendrilkit.io.write_result`: atomic, columns of
:mod:`tendrilkit.schema`, floats at :data:`tendrilkit.io.FLOAT_FORMAT`):

``pwc_curves.csv``
    The same columns: the fitted curve registered onto each frame's
    centreline, as many points as the frame has (point ``i`` of the fit
    corresponds to the centreline resampled at uniform chord length, which is
    point ``i`` itself for a ``curves.csv`` written by ``reconstruct``).
``pwc_segments.csv``
    One row per segment: ``frame``, ``kind`` (``kappa`` or ``tau``),
    ``segment`` (0 = base), ``s0_mm``, ``s1_mm`` (arc length from the base),
    ``value_s0``, ``value_s1`` (curvature or torsion at both ends, 1/mm).
``pwc_metrics.csv``
    One row per frame: ``frame``, ``time_s``, ``status`` (``ok``/``failed``),
    ``message``, ``n_points``, ``length_mm``, ``penalty_kappa``,
    ``penalty_tau`` (dimensionless, see :mod:`tendrilkit.pwc`), ``n_kappa``,
    ``n_tau`` (segments), ``r2_entire``, ``r2_base``, ``r2_tip``,
    ``sse_entire_mm2``, ``sse_base_mm2``, ``sse_tip_mm2``, ``rmse_mm``,
    ``max_error_mm``, ``tau_undefined_fraction`` (no timings: the tables of
    the same input are the same bytes; ``FitSummary.seconds`` has the time).

A frame that cannot be fitted is a ``failed`` row with the reason (fewer than
8 points, an empty cell); the other frames go on. A missing or malformed CSV
raises :class:`~tendrilkit.exceptions.ExperimentError` (one line; exit code
2): a missing column, text where a number is expected, a point listed twice
in a frame (a frame given twice), a coordinate beyond 1e6 mm or infinite, a
frame of more than 5000 points (:mod:`tendrilkit.limits`).
"""

from __future__ import annotations

import itertools
import time
from dataclasses import dataclass
from pathlib import Path

from typing import TYPE_CHECKING

import numpy as np

from tendrilkit import limits as L
from tendrilkit.schema import CURVES, PWC_CURVES, PWC_METRICS, PWC_SEGMENTS
from tendrilkit.exceptions import DegenerateCurveError, ExperimentError

if TYPE_CHECKING:  # pandas only for the table API (fit_curves, metrics_table): the fit command reads and
    import pandas as pd  # writes without it (its import is a tenth of the command's time)

__all__ = ["FitSummary", "run_fit", "fit_curves", "fit_frame"]

#: Largest curves.csv read, bytes (10,000 frames of 200 points are about 120 MB).
MAX_CURVES_BYTES = 2_000_000_000


@dataclass(frozen=True)
class FitSummary:
    """What :func:`run_fit` did."""

    n_frames: int
    n_ok: int
    n_failed: int
    seconds: float
    curves_csv: Path
    segments_csv: Path
    metrics_csv: Path

    def __str__(self) -> str:
        return (f"fitted {self.n_ok}/{self.n_frames} frames in {self.seconds:.2f} s"
                f" ({self.n_failed} failed): {self.curves_csv.parent}")


#: Cells pandas reads as missing (``pandas.read_csv``'s default ``na_values``): read as NaN here too.
_NA_CELLS = frozenset({"", "#N/A", "#N/A N/A", "#NA", "-1.#IND", "-1.#QNAN", "-NaN", "-nan", "1.#IND", "1.#QNAN",
                       "<NA>", "N/A", "NA", "NULL", "NaN", "None", "n/a", "nan", "null"})


@dataclass(frozen=True, eq=False)
class _Curves:
    """A curves.csv's rows as arrays, in file order: ``frame``, ``point`` (m,) int; ``time_s`` (m,) float
    (NaN where missing); ``xyz_mm`` (m, 3) float."""

    frame: np.ndarray
    point: np.ndarray
    time_s: np.ndarray
    xyz_mm: np.ndarray


def _number(cell: str) -> float | None:
    """The number in a cell (NaN for a missing one), or None for text."""
    if cell in _NA_CELLS:
        return np.nan
    if "_" in cell:  # Python reads 1_000; a CSV reader does not
        return None
    try:
        return float(cell)
    except ValueError:
        return None


def _plain_numbers(cells) -> np.ndarray | None:
    """A column of numbers as floats, when every cell is one that :func:`_number` reads as ``float`` does (the
    usual curves.csv: ``float`` in one pass, without a call per cell); None for any other column, read cell by
    cell: a missing (empty) cell, text, a ``_``, pandas' NA words or any NaN written out.
    """
    if "_" in "".join(cells):
        return None
    try:
        conv = np.array(list(map(float, cells)), dtype=float)
    except ValueError:
        return None
    return None if np.isnan(conv).any() else conv


def _numeric_table(path: Path) -> tuple[list[str], np.ndarray] | None:
    """A curves.csv whose every cell is a plain number, in one pass: its header and its rows as an (m, k) float
    array; None for any other file, which :func:`read_rows` and the cells' checks read (and report).

    The file's lines as :func:`read_rows` splits them here: no quote, no carriage return, no NUL, no ``_`` below
    the header (Python's ``float`` reads 1_000, numpy's reader does not), every line but the empty ones (skipped by both) with the
    header's fields. Then numpy's reader (``np.loadtxt``, in C: a third of the time of ``float`` cell by cell),
    which reads a cell with ``PyOS_string_to_double`` as ``float`` does, the same numbers: a cell it cannot read
    (text, an empty cell) or NaN anywhere (pandas' NA words, NaN written out) and the file is left to the cells'
    reading.
    """
    try:
        text = path.read_bytes().decode("utf-8-sig")
    except (UnicodeDecodeError, OSError):
        return None
    if any(ch in text for ch in ("\"", "\r", "\x00")):
        return None
    lines = [line for line in text.split("\n") if line]
    if len(lines) < 2 or any("_" in line for line in lines[1:]):  # the header's names have some
        return None
    header = lines[0].split(",")
    commas = len(header) - 1
    if any(line.count(",") != commas for line in lines):
        return None
    try:
        numbers = np.loadtxt(lines[1:], delimiter=",", comments=None, quotechar=None, dtype=float, ndmin=2,
                             encoding=None)
    except ValueError:
        return None
    if numbers.shape != (len(lines) - 1, len(header)) or np.isnan(numbers).any():
        return None
    return header, numbers


def _checked_column(path: Path, c: str, conv: np.ndarray) -> np.ndarray:
    """Column ``c`` of a curves.csv read as floats (NaN where missing), checked: frame and point integers
    0..MAX_FRAME, coordinates finite within MAX_LENGTH_MM (the first row out of range named)."""
    if c in ("frame", "point"):
        with np.errstate(invalid="ignore"):
            bad = np.isnan(conv) | (conv % 1 != 0) | (conv < 0) | (conv > L.MAX_FRAME)
        if bad.any():
            row = int(np.flatnonzero(bad)[0])
            raise ExperimentError(f"{path}: column {c}, row {row + 2} of the file: expected an integer 0.."
                                  f"{L.MAX_FRAME}, got {float(conv[row])!r}")
    elif c != "time_s":
        big = ~np.isnan(conv) & ~(np.abs(conv) <= L.MAX_LENGTH_MM)
        if big.any():
            row = int(np.flatnonzero(big)[0])
            raise ExperimentError(f"{path}: column {c}, row {row + 2} of the file: {conv[row]:g} mm; expected "
                                  f"a finite coordinate within {L.MAX_LENGTH_MM:g} mm")
    return conv


def _read_curves(path: Path) -> _Curves:
    """Read and check a curves.csv (:func:`_numeric_table` or :func:`tendrilkit.io.columns.read_rows`, and numpy:
    pandas' import alone is a tenth of the fit command's time)."""
    if not path.exists():
        raise ExperimentError(f"{path}: curves file not found")
    if path.is_dir():
        raise ExperimentError(f"{path}: expected a curves.csv file, got a folder")
    if not path.is_file():  # a device or a pipe (/dev/zero) would never end
        raise ExperimentError(f"{path}: expected a curves.csv file, got a special file")
    if path.stat().st_size > MAX_CURVES_BYTES:
        raise ExperimentError(f"{path}: larger than {MAX_CURVES_BYTES // 1_000_000_000} GB; expected a curves.csv "
                              f"(split it by frames)")
    from tendrilkit.io.columns import read_rows

    table = _numeric_table(path)
    if table is not None:  # every cell a plain number: read in one pass
        header, numbers = table
        n_rows = numbers.shape[0]
    else:
        header, body = read_rows(path)
        n_rows = len(body)
    missing = [c for c in ("frame", "point", "x_mm", "y_mm", "z_mm") if c not in header]
    if missing:
        raise ExperimentError(f"{path}: missing column(s) {', '.join(missing)}; expected {', '.join(CURVES.columns)}")
    if table is None:
        columns = list(itertools.zip_longest(*body, fillvalue=""))  # the cells by column; short rows padded
    cols = {}
    for c in ("frame", "point", "x_mm", "y_mm", "z_mm", "time_s"):
        if c not in header:  # time_s only
            cols[c] = np.full(n_rows, np.nan)
            continue
        j = header.index(c)
        if table is not None:
            cols[c] = _checked_column(path, c, np.ascontiguousarray(numbers[:, j]))
            continue
        cells = columns[j] if j < len(columns) else ("",) * len(body)  # "": a missing cell, read as NaN
        conv = _plain_numbers(cells)
        if conv is None:  # missing cells, text, NaN written out: cell by cell
            values = [_number(cell) for cell in cells]
            text = [i for i, v in enumerate(values) if v is None]  # a cell that is there but is not a number
            if text:
                raise ExperimentError(f"{path}: column {c}, row {text[0] + 2} of the file: text where a number is "
                                      f"expected")
            conv = np.array(values, dtype=float)
        cols[c] = _checked_column(path, c, conv)
    if not n_rows:
        raise ExperimentError(f"{path}: no rows")
    frame, point = cols["frame"].astype(np.int64), cols["point"].astype(np.int64)
    key = frame * (L.MAX_FRAME + 1) + point
    _, first = np.unique(key, return_index=True)
    if first.size < key.size:  # the first row (in file order) whose frame and point came before
        dup = int(np.setdiff1d(np.arange(key.size), first)[0])
        raise ExperimentError(f"{path}: frame {int(frame[dup])}: point {int(point[dup])} is listed twice (the frame "
                              f"given twice?); expected each frame's points once")
    frames, counts = np.unique(frame, return_counts=True)
    if counts.max() > L.MAX_POINTS:
        f = int(frames[np.argmax(counts)])
        raise ExperimentError(f"{path}: frame {f}: {int(counts.max())} points; expected at most {L.MAX_POINTS} per "
                              f"frame (resample the curve)")
    return _Curves(frame, point, cols["time_s"], np.column_stack([cols["x_mm"], cols["y_mm"], cols["z_mm"]]))


def _distinct_rows(pts: np.ndarray) -> int:
    """How many distinct rows (finite floats) ``pts`` (n, 3) has: ``len(np.unique(pts, axis=0))`` (rows
    equal as numbers, 0.0 as -0.0), by sorting the rows and counting changes: a sixth of its time (it
    ran for every frame)."""
    if len(pts) < 2:
        return len(pts)
    s = pts[np.lexsort(pts.T[::-1])]
    return 1 + int(np.count_nonzero((s[1:] != s[:-1]).any(axis=1)))


def fit_frame(points_mm: np.ndarray, options: dict | None = None, *, frame: int = 0,
              time_s: float = float("nan")) -> tuple[np.ndarray | None, list[dict], dict]:
    """Fit one frame's centreline; the one code path of ``fit`` and ``reconstruct``.

    ``options``: keyword options of :func:`tendrilkit.pwc.fit_piecewise_clothoid`
    (an experiment's are ``tendrilkit.options.stage_options(exp, "fit")``;
    None: its defaults).

    Returns ``(fitted (n, 3) mm or None, segment rows, metric row)``: the rows
    of ``pwc_segments.csv`` and ``pwc_metrics.csv`` for this frame. A frame
    that cannot be fitted gives ``None``, no segments and a ``failed`` row.
    """
    from tendrilkit.pwc import fit_piecewise_clothoid  # numba: only once the input is known good

    options = {} if options is None else dict(options)
    pts = np.asarray(points_mm, float)
    row = {c: np.nan for c in PWC_METRICS.columns}
    row.update(frame=int(frame), time_s=float(time_s), n_points=int(len(pts)), message="")
    try:
        if pts.ndim != 2 or pts.shape[1:] != (3,):
            raise DegenerateCurveError(f"expected points of shape (n, 3), got {pts.shape}")
        if not np.all(np.isfinite(pts)):
            raise DegenerateCurveError(f"{int((~np.isfinite(pts)).any(axis=1).sum())} point(s) with missing coordinates")
        n_distinct = _distinct_rows(pts)
        if n_distinct < L.MIN_FIT_POINTS:
            raise DegenerateCurveError(f"curve has {n_distinct} distinct point(s); at least {L.MIN_FIT_POINTS} "
                                       f"are needed")
        fit = fit_piecewise_clothoid(pts, n_points=len(pts), **options)
    except (DegenerateCurveError, ValueError, np.linalg.LinAlgError, FloatingPointError) as e:
        row.update(status="failed", message=f"{type(e).__name__}: {e}")
        return None, [], row
    sc = fit.scores
    row.update(
        status="ok", length_mm=float(fit.s_mm[-1]), penalty_kappa=fit.penalty_kappa,
        penalty_tau=fit.penalty_tau, n_kappa=fit.n_segments_kappa, n_tau=fit.n_segments_tau,
        r2_entire=sc.r2_entire, r2_base=sc.r2_base, r2_tip=sc.r2_tip, sse_entire_mm2=sc.sse_entire_mm2,
        sse_base_mm2=sc.sse_base_mm2, sse_tip_mm2=sc.sse_tip_mm2, rmse_mm=sc.rmse_mm,
        max_error_mm=sc.max_error_mm, tau_undefined_fraction=float(1.0 - fit.frames.tau_defined.mean()),
    )
    segs = [{"frame": int(frame), **r} for r in fit.segments()]
    return np.asarray(fit.points_mm, float), segs, row


def curves_table(frame: int, time_s: float, points_mm: np.ndarray) -> pd.DataFrame:
    """One frame's points as rows of ``curves.csv`` / ``pwc_curves.csv``."""
    import pandas as pd

    n = len(points_mm)
    return pd.DataFrame({"frame": int(frame), "time_s": time_s, "point": np.arange(n),
                         "x_mm": points_mm[:, 0], "y_mm": points_mm[:, 1], "z_mm": points_mm[:, 2]})


def metrics_table(rows: list[dict]) -> pd.DataFrame:
    import pandas as pd

    mets = pd.DataFrame(rows, columns=list(PWC_METRICS.columns))
    for c in PWC_METRICS.of_kind("Int"):
        mets[c] = mets[c].astype("Int64")
    return mets


#: The fit command's frames per worker below which a worker is not started (its fork and hand-over
#: cost about a frame's fit).
MIN_FRAMES_PER_WORKER = 8

#: Chunks of consecutive frames per worker (:func:`_fit_in_pool`).
CHUNKS_PER_WORKER = 16


def _fit_cut(frames: np.ndarray, times: np.ndarray, xyz: np.ndarray, cuts: list[tuple[int, int]],
             options: dict | None) -> list[tuple]:
    """``fit_frame`` of each frame ``frames[a:b]`` of the sorted arrays, ``(a, b)`` in ``cuts`` (in a worker too)."""
    out = []
    for a, b in cuts:
        f = int(frames[a])
        t_s = float(times[a]) if np.any(~np.isnan(times[a:b])) else np.nan
        out.append((f, t_s, *fit_frame(xyz[a:b], options, frame=f, time_s=t_s)))
    return out


def _fit_in_pool(frames, times, xyz, cuts, options, workers):
    """The frames' fits over ``workers`` forked processes, in frame order (each fit is the one of one process).

    The first frame is fitted here first: numba's compiled kernels are then loaded once, and the
    forked workers inherit them. Chunks of consecutive frames, about :data:`CHUNKS_PER_WORKER` per worker
    (a fit costs 10-80 ms: small chunks keep every worker busy to the end; a chunk's hand-over costs
    well under a millisecond).
    """
    import multiprocessing as mp
    from concurrent.futures import ProcessPoolExecutor

    from tendrilkit.pools import ignore_interrupts, signals_held, stop_pool

    done = _fit_cut(frames, times, xyz, cuts[:1], options)
    rest = cuts[1:]
    size = max(1, -(-len(rest) // (CHUNKS_PER_WORKER * workers)))
    chunks = [rest[i:i + size] for i in range(0, len(rest), size)]
    pool = ProcessPoolExecutor(workers, mp_context=mp.get_context("fork"), initializer=ignore_interrupts)
    try:
        jobs = []
        with signals_held():  # the workers are forked at the first submit
            for c in chunks:  # each job gets its frames' rows only
                a0, b1 = c[0][0], c[-1][1]
                jobs.append(pool.submit(_fit_cut, frames[a0:b1], times[a0:b1], xyz[a0:b1],
                                        [(a - a0, b - a0) for a, b in c], options))
        for job in jobs:
            done.extend(job.result())
    except BaseException:  # Ctrl-C, SIGTERM or an error: the workers end with the parent
        stop_pool(pool)
        raise
    pool.shutdown()
    return done


def _fit_arrays(frame: np.ndarray, point: np.ndarray, time_s: np.ndarray, xyz_mm: np.ndarray,
                options: dict | None, workers: int = 1) -> tuple[dict, list[dict], list[dict]]:
    """Fit every frame of a curves table given as arrays (rows in any order).

    The frames are cut from the arrays sorted by frame and point and the fitted curves gathered
    at the end (a table per frame cost about as much as a tenth of a fit). ``workers`` > 1:
    over that many forked processes (where the platform forks; at least
    :data:`MIN_FRAMES_PER_WORKER` frames each), the same results. Returns
    ``(pwc_curves columns, segment rows, metric rows)``.
    """
    import multiprocessing as mp

    order = np.lexsort((point, frame))
    frames, xyz, times = frame[order], xyz_mm[order], time_s[order]
    starts = np.flatnonzero(np.r_[True, frames[1:] != frames[:-1]]) if frames.size else np.zeros(0, int)
    ends = np.r_[starts[1:], frames.size]
    cuts = [(int(a), int(b)) for a, b in zip(starts, ends)]
    workers = min(int(workers), len(cuts) // MIN_FRAMES_PER_WORKER)
    if workers > 1 and "fork" in mp.get_all_start_methods():
        fits = _fit_in_pool(frames, times, xyz, cuts, options, workers)
    else:
        fits = _fit_cut(frames, times, xyz, cuts, options)
    out_frames, out_times, out_points, seg_rows, met_rows = [], [], [], [], []
    for f, t_s, fitted, segs, row in fits:
        met_rows.append(row)
        seg_rows.extend(segs)
        if fitted is not None:
            out_frames.append(f)
            out_times.append(t_s)
            out_points.append(fitted)
    counts = [len(p) for p in out_points]
    pts = np.concatenate(out_points) if out_points else np.zeros((0, 3))
    pwc = {"frame": np.repeat(np.array(out_frames, dtype=np.int64), counts),
           "time_s": np.repeat(np.array(out_times, dtype=float), counts),
           "point": np.concatenate([np.arange(n) for n in counts]) if counts else np.zeros(0, np.int64),
           "x_mm": pts[:, 0], "y_mm": pts[:, 1], "z_mm": pts[:, 2]}
    return pwc, seg_rows, met_rows


def fit_curves(curves: pd.DataFrame, options: dict | None = None) -> tuple[pd.DataFrame, pd.DataFrame, pd.DataFrame]:
    """Fit every frame of a curves table; returns ``(pwc_curves, segments, metrics)`` tables."""
    import pandas as pd

    pwc, seg_rows, met_rows = _fit_arrays(curves["frame"].to_numpy(), curves["point"].to_numpy(),
                                          curves["time_s"].to_numpy(float),
                                          curves[["x_mm", "y_mm", "z_mm"]].to_numpy(float), options)
    pwc = pd.DataFrame(pwc) if len(pwc["frame"]) else pd.DataFrame(columns=list(PWC_CURVES.columns))
    segs = pd.DataFrame(seg_rows, columns=list(PWC_SEGMENTS.columns))
    return pwc, segs, metrics_table(met_rows)


def _row_columns(rows: list[dict], table) -> dict:
    return {c: [r[c] for r in rows] for c in table.columns}


def run_fit(curves_csv: Path, out_dir: Path, *, options: dict | None = None, workers: int | None = 1) -> FitSummary:
    """Refit the piece-wise clothoid to every frame of ``curves_csv``; write the tables to ``out_dir``.

    Parameters
    ----------
    curves_csv : Path
        A ``curves.csv`` (columns ``frame, time_s, point, x_mm, y_mm, z_mm``).
    out_dir : Path
        Output folder (created).
    options : dict, keyword-only
        Keyword options of :func:`tendrilkit.pwc.fit_piecewise_clothoid`
        (default: its defaults, which are the experiment file's).
    workers : int or None, keyword-only
        Processes for the frames (forked; None: every core, the command's default, as
        :func:`tendrilkit.runner.run_reconstruct`). The same tables whatever the number.

    Returns
    -------
    FitSummary

    Raises
    ------
    ExperimentError
        Missing or malformed CSV, or an output folder that cannot be made.
    """
    import os

    t0 = time.perf_counter()
    curves_csv, out_dir = Path(curves_csv), Path(out_dir)
    workers = max(1, int(workers) if workers is not None else (os.cpu_count() or 1))
    from tendrilkit.io import check_writable_dir
    from tendrilkit.io.columns import write_columns

    c = _read_curves(curves_csv)
    check_writable_dir(out_dir)
    pwc, seg_rows, met_rows = _fit_arrays(c.frame, c.point, c.time_s, c.xyz_mm, options, workers)
    paths = (out_dir / "pwc_curves.csv", out_dir / "pwc_segments.csv", out_dir / "pwc_metrics.csv")
    tables = (pwc, _row_columns(seg_rows, PWC_SEGMENTS), _row_columns(met_rows, PWC_METRICS))
    for columns, p, table in zip(tables, paths, (PWC_CURVES, PWC_SEGMENTS, PWC_METRICS)):
        write_columns(columns, p, table)
    ok = sum(r["status"] == "ok" for r in met_rows)
    return FitSummary(len(met_rows), ok, len(met_rows) - ok, time.perf_counter() - t0, *paths)
