"""The ``fit`` command: refit the piece-wise clothoid to every frame of a ``curves.csv``.

``python -m tendrilkit fit CURVES.csv --out DIR`` calls :func:`run_fit`, which
reads the centrelines (columns of ``../shared/EXPERIMENT_FORMAT.md``: ``frame``,
``time_s``, ``point``, ``x_mm``, ``y_mm``, ``z_mm``), fits each frame with
:func:`tendrilkit.pwc.fit_piecewise_clothoid` and writes, atomically (a
temporary file in ``DIR`` then :func:`os.replace`):

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

A frame that cannot be fitted is a ``failed`` row with the reason; the other
frames go on. A missing or malformed CSV raises
:class:`~tendrilkit.exceptions.ExperimentError` (one line; exit code 2).

The command reads and writes its tables with the standard library's ``csv``
module, in pandas' format (``to_csv(index=False, float_format="%.9g")``: the
same bytes), so that ``python -m tendrilkit fit`` does not pay the import of
pandas (about a second); :func:`fit_curves` and the table helpers used by
``reconstruct`` keep pandas.
"""

from __future__ import annotations

import csv
import math
import os
import tempfile
import time
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from tendrilkit.exceptions import DegenerateCurveError, ExperimentError

if TYPE_CHECKING:  # pandas is imported where a table is made (not by the fit command)
    import pandas as pd

__all__ = ["FitOptions", "FitSummary", "run_fit", "fit_curves", "fit_frame"]

CURVE_COLUMNS = ("frame", "time_s", "point", "x_mm", "y_mm", "z_mm")
METRIC_COLUMNS = (
    "frame", "time_s", "status", "message", "n_points", "length_mm", "penalty_kappa", "penalty_tau",
    "n_kappa", "n_tau", "r2_entire", "r2_base", "r2_tip", "sse_entire_mm2", "sse_base_mm2",
    "sse_tip_mm2", "rmse_mm", "max_error_mm", "tau_undefined_fraction",
)
SEGMENT_COLUMNS = ("frame", "kind", "segment", "s0_mm", "s1_mm", "value_s0", "value_s1")


@dataclass(frozen=True)
class FitOptions:
    """Options of :func:`tendrilkit.pwc.fit_piecewise_clothoid` used by ``fit``.

    Defaults are those of the experiment file's ``fit:`` and ``smoothing:``
    sections (:mod:`tendrilkit.params`); see :func:`from_params`.
    """

    selection: str = "auto"
    criterion: str = "bic"
    target_r2: float = 0.999
    penalty_kappa: float = 0.01
    penalty_tau: float = 0.01
    score: str = "l2"
    smoothing_length_mm: float | None = None
    max_segments: int = 10
    refine: bool = True

    @classmethod
    def from_params(cls, fit, smoothing) -> "FitOptions":
        """From an experiment's ``fit`` (:class:`tendrilkit.params.Fit`) and ``smoothing`` sections."""
        return cls(selection=fit.selection, criterion=getattr(fit, "criterion", "bic"),
                   target_r2=fit.target_r2, penalty_kappa=fit.penalty_kappa, penalty_tau=fit.penalty_tau,
                   score=fit.score, smoothing_length_mm=smoothing.length_mm,
                   max_segments=getattr(fit, "max_segments", 10), refine=getattr(fit, "refine", True))


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


def _read_curves(path: Path) -> pd.DataFrame:
    import pandas as pd

    if not path.exists():
        raise ExperimentError(f"{path}: curves file not found")
    if path.is_dir():
        raise ExperimentError(f"{path}: expected a curves.csv file, got a folder")
    try:
        df = pd.read_csv(path)
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError, OSError) as e:
        raise ExperimentError(f"{path}: cannot read as CSV ({type(e).__name__}: {str(e).splitlines()[0] if str(e) else ''})") from None
    missing = [c for c in ("frame", "point", "x_mm", "y_mm", "z_mm") if c not in df.columns]
    if missing:
        raise ExperimentError(f"{path}: missing column(s) {', '.join(missing)}; expected {', '.join(CURVE_COLUMNS)}")
    if "time_s" not in df.columns:
        df["time_s"] = np.nan
    for c in ("frame", "point", "x_mm", "y_mm", "z_mm", "time_s"):
        conv = pd.to_numeric(df[c], errors="coerce")
        if c in ("frame", "point") and (conv.isna().any() or (conv % 1 != 0).any()):
            bad = df[c][conv.isna() | (conv % 1 != 0)].iloc[0]
            raise ExperimentError(f"{path}: column {c}: expected integers, got {bad!r}")
        df[c] = conv
    if df.empty:
        raise ExperimentError(f"{path}: no rows")
    df["frame"] = df["frame"].astype(int)
    df["point"] = df["point"].astype(int)
    return df


def fit_frame(points_mm: np.ndarray, options: FitOptions | None = None, *, frame: int = 0,
              time_s: float = float("nan")) -> tuple[np.ndarray | None, list[dict], dict]:
    """Fit one frame's centreline; the one code path of ``fit`` and ``reconstruct``.

    Returns ``(fitted (n, 3) mm or None, segment rows, metric row)``: the rows
    of ``pwc_segments.csv`` and ``pwc_metrics.csv`` for this frame. A frame
    that cannot be fitted gives ``None``, no segments and a ``failed`` row.
    """
    from tendrilkit.pwc import fit_piecewise_clothoid  # numba: only once the input is known good

    options = FitOptions() if options is None else options
    pts = np.asarray(points_mm, float)
    row = {c: np.nan for c in METRIC_COLUMNS}
    row.update(frame=int(frame), time_s=float(time_s), n_points=int(len(pts)), message="")
    try:
        if pts.ndim != 2 or pts.shape[1:] != (3,):
            raise DegenerateCurveError(f"expected points of shape (n, 3), got {pts.shape}")
        if not np.all(np.isfinite(pts)):
            raise DegenerateCurveError(f"{int((~np.isfinite(pts)).any(axis=1).sum())} point(s) with missing coordinates")
        if len(pts) < 5:
            raise DegenerateCurveError(f"{len(pts)} point(s); at least 5 are needed")
        fit = fit_piecewise_clothoid(pts, n_points=len(pts), **asdict(options))
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

    mets = pd.DataFrame(rows, columns=list(METRIC_COLUMNS))
    for c in ("n_points", "n_kappa", "n_tau"):
        mets[c] = mets[c].astype("Int64")
    return mets


def fit_curves(curves: pd.DataFrame, options: FitOptions | None = None) -> tuple[pd.DataFrame, pd.DataFrame, pd.DataFrame]:
    """Fit every frame of a curves table; returns ``(pwc_curves, segments, metrics)`` tables."""
    import pandas as pd

    curves_out, seg_rows, met_rows = [], [], []
    for frame, g in curves.sort_values(["frame", "point"]).groupby("frame", sort=True):
        g = g.drop_duplicates("point", keep="first")
        t_s = float(g["time_s"].iloc[0]) if g["time_s"].notna().any() else np.nan
        fitted, segs, row = fit_frame(g[["x_mm", "y_mm", "z_mm"]].to_numpy(float), options, frame=int(frame), time_s=t_s)
        met_rows.append(row)
        seg_rows.extend(segs)
        if fitted is not None:
            curves_out.append(curves_table(int(frame), t_s, fitted))
    pwc = pd.concat(curves_out, ignore_index=True) if curves_out else pd.DataFrame(columns=list(CURVE_COLUMNS))
    segs = pd.DataFrame(seg_rows, columns=list(SEGMENT_COLUMNS))
    return pwc, segs, metrics_table(met_rows)


def _write_atomic(df: pd.DataFrame, path: Path) -> None:
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "w", newline="") as fh:
            df.to_csv(fh, index=False, float_format="%.9g")
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


# ---------------------------------------------------------------- the command's tables without pandas


def _csv_error(path: Path, e: Exception) -> ExperimentError:
    return ExperimentError(f"{path}: cannot read as CSV ({type(e).__name__}: {str(e).splitlines()[0] if str(e) else ''})")


def _number(text: str) -> float:
    try:
        return float(text)
    except ValueError:
        return math.nan


def _read_curve_frames(path: Path) -> list[tuple[int, float, np.ndarray]]:
    """``(frame, time_s, (n, 3) points)`` per frame of a curves.csv, frames and points in order.

    The checks and messages of :func:`_read_curves` (pandas), with the csv
    module: a missing column, a non-integer ``frame`` or ``point``, no rows,
    more fields than the header are errors; a coordinate that is not a number
    is NaN (that frame then fails); for a repeated ``(frame, point)`` the
    first row counts.
    """
    if not path.exists():
        raise ExperimentError(f"{path}: curves file not found")
    if path.is_dir():
        raise ExperimentError(f"{path}: expected a curves.csv file, got a folder")
    try:
        with open(path, newline="", encoding="utf-8") as fh:
            rows = list(csv.reader(fh))
    except (UnicodeDecodeError, OSError, csv.Error) as e:
        raise _csv_error(path, e) from None
    rows = [r for r in rows if r]  # blank lines are skipped (as pandas does)
    if not rows:
        raise ExperimentError(f"{path}: cannot read as CSV (EmptyDataError: No columns to parse from file)")
    header, body = rows[0], rows[1:]
    for i, r in enumerate(body):
        if len(r) > len(header):
            raise ExperimentError(f"{path}: cannot read as CSV (ParserError: Error tokenizing data. C error: "
                                  f"Expected {len(header)} fields in line {i + 2}, saw {len(r)})")
    missing = [c for c in ("frame", "point", "x_mm", "y_mm", "z_mm") if c not in header]
    if missing:
        raise ExperimentError(f"{path}: missing column(s) {', '.join(missing)}; expected {', '.join(CURVE_COLUMNS)}")
    col = {c: header.index(c) for c in CURVE_COLUMNS if c in header}

    def field(r, c):
        j = col.get(c)
        return r[j] if j is not None and j < len(r) else ""

    keys = []
    for c in ("frame", "point"):
        vals = [_number(field(r, c)) for r in body]
        for r, v in zip(body, vals):
            if not math.isfinite(v) or v % 1 != 0:
                raise ExperimentError(f"{path}: column {c}: expected integers, got {field(r, c)!r}")
        keys.append([int(v) for v in vals])
    if not body:
        raise ExperimentError(f"{path}: no rows")
    xyz = np.array([[_number(field(r, "x_mm")), _number(field(r, "y_mm")), _number(field(r, "z_mm"))] for r in body],
                   dtype=float).reshape(-1, 3)
    t = np.array([_number(field(r, "time_s")) for r in body], dtype=float)
    frame, point = np.array(keys[0], dtype=np.int64), np.array(keys[1], dtype=np.int64)
    order = np.lexsort((point, frame))  # stable: the first of repeated (frame, point) rows stays first
    out = []
    bounds = np.flatnonzero(np.diff(frame[order])) + 1
    for g in np.split(order, bounds):
        _, first = np.unique(point[g], return_index=True)
        g = g[np.sort(first)]
        t_s = float(t[g[0]]) if np.any(~np.isnan(t[g])) else math.nan
        out.append((int(frame[g[0]]), t_s, xyz[g]))
    return out


def _cell(v) -> str:
    if v is None or (isinstance(v, float) and math.isnan(v)):
        return ""
    if isinstance(v, (float, np.floating)):
        return "%.9g" % v
    return str(v)


def _write_rows(path: Path, columns, rows, float_columns) -> None:
    """Write a table as pandas' ``to_csv(index=False, float_format="%.9g")`` would (atomically).

    ``float_columns``: the columns pandas would hold as floats (their
    integers written as floats too, e.g. ``1`` as ``1``).
    """
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "w", newline="") as fh:
            w = csv.writer(fh, lineterminator="\n")
            w.writerow(columns)
            for r in rows:
                w.writerow([_cell(float(v)) if (c in float_columns and v is not None and v != "") else _cell(v)
                            for c, v in zip(columns, r)])
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


_METRIC_FLOATS = frozenset(c for c in METRIC_COLUMNS if c not in ("frame", "status", "message", "n_points", "n_kappa", "n_tau"))


def run_fit(curves_csv: Path, out_dir: Path, *, options: FitOptions | None = None) -> FitSummary:
    """Refit the piece-wise clothoid to every frame of ``curves_csv``; write the tables to ``out_dir``.

    Parameters
    ----------
    curves_csv : Path
        A ``curves.csv`` (columns ``frame, time_s, point, x_mm, y_mm, z_mm``).
    out_dir : Path
        Output folder (created).
    options : FitOptions, keyword-only
        Fit options (default: the experiment-file defaults).

    Returns
    -------
    FitSummary

    Raises
    ------
    ExperimentError
        Missing or malformed CSV, or an output folder that cannot be made.
    """
    t0 = time.perf_counter()
    curves_csv, out_dir = Path(curves_csv), Path(out_dir)
    frames = _read_curve_frames(curves_csv)
    try:
        out_dir.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise ExperimentError(f"{out_dir}: cannot create the output folder ({e.strerror or type(e).__name__})") from None
    if not out_dir.is_dir():
        raise ExperimentError(f"{out_dir}: expected an output folder, got a file")
    curve_rows, seg_rows, met_rows = [], [], []
    for frame, t_s, pts in frames:
        fitted, segs, row = fit_frame(pts, options, frame=frame, time_s=t_s)
        met_rows.append([row[c] for c in METRIC_COLUMNS])
        seg_rows.extend([s[c] for c in SEGMENT_COLUMNS] for s in segs)
        if fitted is not None:
            curve_rows.extend([frame, t_s, i, *p] for i, p in enumerate(fitted.tolist()))
    paths = (out_dir / "pwc_curves.csv", out_dir / "pwc_segments.csv", out_dir / "pwc_metrics.csv")
    _write_rows(paths[0], CURVE_COLUMNS, curve_rows, {"time_s", "x_mm", "y_mm", "z_mm"})
    _write_rows(paths[1], SEGMENT_COLUMNS, seg_rows, {"s0_mm", "s1_mm", "value_s0", "value_s1"})
    _write_rows(paths[2], METRIC_COLUMNS, met_rows, _METRIC_FLOATS)
    ok = sum(r[METRIC_COLUMNS.index("status")] == "ok" for r in met_rows)
    return FitSummary(len(met_rows), ok, len(met_rows) - ok, time.perf_counter() - t0, *paths)
