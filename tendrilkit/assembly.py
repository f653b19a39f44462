"""Assembly of the result tables from the per-frame results (EXPERIMENT_FORMAT.md).

:func:`with_temporal_checks` applies the checks against neighbouring frames
over the ordered results, :func:`with_run_checks` those failed by the whole
run (the calibration's world frame), then :func:`assemble_tables` builds every table of
:data:`tendrilkit.pipeline.RESULT_FILES` but ``calibration_markers.csv``,
rows sorted by frame (then point, view, ...). All run once over all frames,
so that none depends on chunks or workers.
"""

from __future__ import annotations

import json

import numpy as np
import pandas as pd

from tendrilkit import schema
from tendrilkit.pipeline import FrameResult
from tendrilkit.schema import quality_columns

__all__ = ["assemble_tables", "with_temporal_checks", "with_run_checks"]


def with_temporal_checks(results: list[FrameResult], verification=None) -> list[FrameResult]:
    """The results with the checks against neighbouring frames applied (:func:`tendrilkit.verify_temporal.temporal_checks`).

    Run at assembly time over the ordered results (so that it does not depend
    on chunks or workers): fills ``length_change_pct``, ``shape_change_mm``
    and ``dt_prev_s`` and turns an ``ok`` frame that jumps into ``doubtful``.
    """
    from dataclasses import replace

    from tendrilkit.verify import Thresholds
    from tendrilkit.verify_temporal import temporal_checks

    th = Thresholds.from_params(verification) if verification is not None else Thresholds()
    results = sorted(results, key=lambda r: r.frame)
    figs, msgs = temporal_checks([r.frame for r in results], [r.time_s for r in results],
                                 [r.points_mm if r.status != "failed" else None for r in results],
                                 [r.status == "ok" for r in results], th)
    out = []
    for r, fig, msg in zip(results, figs, msgs):
        if r.status == "failed":
            out.append(r)
            continue
        status = "doubtful" if (msg or r.status == "doubtful") else "ok"
        out.append(replace(_with_checks(r, msg), status=status, quality={**r.quality, **fig}))
    return out


def _with_checks(r: FrameResult, new: list[str]) -> FrameResult:
    """``r`` with the failed checks ``new`` after its own, before its notes (the message: checks, then notes).

    The notes are what follows the frame's checks in its message. A check may itself hold "; " (a shape
    jump names its parts), so the message is cut after the joined checks, not split on "; ".
    """
    from dataclasses import replace

    head = "; ".join(r.checks)
    rest = r.message[len(head):].removeprefix("; ") if r.message and r.message.startswith(head) else r.message
    own = list(r.checks) + list(new)
    return replace(r, message="; ".join(own + ([rest] if rest else [])), checks=own)


def with_run_checks(results: list[FrameResult], checks: list[str]) -> list[FrameResult]:
    """The results with checks failed by the whole run (the calibration's world frame,
    :mod:`tendrilkit.verify_calibration`) added to every reconstructed frame: ``ok`` becomes ``doubtful``.

    The messages follow the frame's own failed checks, before its notes. No checks: the results unchanged.
    """
    from dataclasses import replace

    if not checks:
        return list(results)
    out = []
    for r in results:
        if r.status == "failed":
            out.append(r)
            continue
        out.append(replace(_with_checks(r, checks), status="doubtful"))
    return out


def assemble_tables(results: list[FrameResult], n_views: int) -> dict[str, pd.DataFrame]:
    """The result tables of a run, by file name (``curves.csv``, ``frames.csv``, ...), from its frames' results.

    Parameters
    ----------
    results : list of FrameResult
        Every selected frame's result (any order).
    n_views : int
        Views of the experiment (the per-view columns of ``frames.csv``).

    Returns
    -------
    dict of str to pandas.DataFrame
    """
    from tendrilkit.fitting import metrics_table

    cur, pwc, rows, rep, dec, segs, mets = [], [], [], [], [], [], []
    qcols = quality_columns(n_views)
    ftable = schema.frames_table(n_views)
    for r in sorted(results, key=lambda r: r.frame):
        row = {"frame": r.frame, "time_s": r.time_s, "status": r.status, "message": r.message}
        row.update({c: (r.quality.get(c) if r.quality else None) for c in qcols})
        rows.append(row)
        for arr, dest in ((r.points_mm, cur), (r.pwc_mm, pwc)):
            if arr is not None:
                n = len(arr)
                dest.append(pd.DataFrame({"frame": r.frame, "time_s": r.time_s, "point": np.arange(n),
                                          "x_mm": arr[:, 0], "y_mm": arr[:, 1], "z_mm": arr[:, 2]}))
        for t in r.reprojection:
            rep.append({"frame": r.frame, **t})
        for d in r.decisions:
            dec.append({**d, "candidates": json.dumps(d.get("candidates"))})
        segs.extend(r.pwc_segments)
        mets.extend(r.pwc_metrics)
    def cat(parts):
        return pd.concat(parts, ignore_index=True) if parts else pd.DataFrame(columns=list(schema.CURVES.columns))

    frames = pd.DataFrame(rows, columns=list(ftable.columns))
    for c in qcols:
        frames[c] = pd.to_numeric(frames[c], errors="coerce")
    for c in ftable.of_kind("bool"):
        frames[c] = frames[c].astype("boolean")
    for c in ftable.of_kind("Int"):
        frames[c] = frames[c].astype("Int64")
    reproj = pd.DataFrame(rep, columns=list(schema.REPROJECTION.columns))
    if len(reproj):
        order = {"base": 0, "tip": 1, "entire": 2}
        reproj = reproj.assign(_o=reproj.section.map(order)).sort_values(["frame", "view", "_o"]).drop(columns="_o")
    ordering = pd.DataFrame(dec, columns=list(schema.ORDERING.columns))
    if len(ordering):
        ordering = ordering.sort_values(["frame", "view", "junction"], kind="stable")
    return {"curves.csv": cat(cur), "pwc_curves.csv": cat(pwc), "frames.csv": frames,
            "reprojection.csv": reproj.reset_index(drop=True), "ordering.csv": ordering.reset_index(drop=True),
            "pwc_segments.csv": pd.DataFrame(segs, columns=list(schema.PWC_SEGMENTS.columns)),
            "pwc_metrics.csv": metrics_table(mets)}
