"""Re-run the multi-view reconstruction on the scenes of a generalisation run, each view's evidence cached.

    .venv/bin/python benchmarks/rerun_multiview.py OUT TAG [--seeds 0:28] [--no-fit] [--compare TAG0]
        [--keep-curves] [--set SECTION.KEY=VALUE ...] [--workers 2]

``OUT`` is the ``--out`` folder of ``benchmarks/bench_generalize.py --method
multiview`` (its scenes, of any ``--scene`` kind, and ``result-multiview/cameras.json``). Every processed
frame is reconstructed again with this checkout's :mod:`tendrilkit.multiview`
and :mod:`tendrilkit.mv_acquire` (tracking from the previous frame as the run
does: the chunks of ``reconstruction.chunk_frames``, the previous curve if it
was ``ok``). Each view's evidence (segmentation, skeleton: most of a frame's
cost) is computed once and kept in ``OUT/evidence-cache/`` (pickles; delete
the folder when the evidence code changes; with ``--set segmentation.KEY=VALUE``
in ``OUT/evidence-cache-<those items>/``; the resolved segmentation options are
recorded there, ``segmentation.json``, and a folder made under other options, or
before the record (2026-12-01), is refused: delete it), so a second run measures a change
of the multi-view decisions in a minute or two instead of the generalisation
run's 40-60 s per scene.

Writes ``OUT/rerun-TAG.csv`` (one row per frame: ``scene, frame, status,
message, factors, mean_mm, max_mm, base_mm, tip_mm, ends, within, cause,
pale`` and every check's figure of ``frames.csv``); ``cause`` as :mod:`benchmarks.diagnose_multiview`) and prints the
issue's figures and the causes split by pale / not pale. Compare two tags
with ``--compare TAG_BEFORE`` (the frames that changed).

With ``--no-fit`` the piece-wise clothoid is not fitted (faster; the curves
are the same, but the fit's R2 check is then not applied). Checked 2026-11-30 on dev seeds 0-27 (168 frames) against
``bench_generalize``'s own results: curves equal to 5e-5 mm; statuses equal on
162 of 168 frames: the other 6 were the checks a cached frame skipped (the
tone and colour checks read the images; the frames are now read every time)
and those of the whole run (against the other frames, the world marker's fit;
now applied over each scene): on dev seeds 9780-9789 (60 frames) every status
equals ``bench_generalize``'s.

Seeds 0-9999 only (``bench_generalize``'s rule); this is for development, the
figures that count are ``bench_generalize``'s.
"""

from __future__ import annotations

import argparse
import json
import os
import pickle
import sys
import warnings
from pathlib import Path

import numpy as np
import pandas as pd

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))


def _figures() -> set[str]:
    """The checks' figures kept in the rows (three views' columns of ``frames.csv``)."""
    from tendrilkit.schema import quality_columns

    return set(quality_columns(3))


FIGURES = _figures()


def parse_sets(items: list[str]) -> dict:
    """``SECTION.KEY=VALUE`` items (``--set``) -> {section: {KEY: value}} (ints, floats, true/false, else text).

    Raises ValueError for an item that is not ``SECTION.KEY=VALUE``; the keys and values are
    validated with the experiment (:func:`tendrilkit.params.with_overrides`).
    """
    out: dict = {}
    for item in items:
        key, eq, value = item.partition("=")
        section, dot, name = key.strip().partition(".")
        if not (eq and dot and section and name):
            raise ValueError(f"--set {item!r}: expected SECTION.KEY=VALUE, e.g. segmentation.line_width_px=11")
        low = value.strip().lower()
        if low in ("true", "false"):
            v = low == "true"
        else:
            try:
                v = int(value)
            except ValueError:
                try:
                    v = float(value)
                except ValueError:
                    v = value.strip()
        out.setdefault(section, {})[name] = v
    return out


#: The ``reconstruction`` keys the evidence depends on (:func:`tendrilkit.pipeline.multiview_evidence`)
EVIDENCE_KEYS = ("front_line_contrast",)


def evidence_options(experiment: Path, sets: dict) -> dict:
    """The options the evidence of ``experiment`` is made with, ``sets`` (``--set`` items) applied, today: the
    segmentation's and :data:`EVIDENCE_KEYS` (``reconstruction.KEY``)."""
    from tendrilkit.params import load_experiment, with_overrides

    exp = with_overrides(load_experiment(experiment), sets)
    return {**exp.segmentation.model_dump(mode="json"),
            **{f"reconstruction.{k}": getattr(exp.reconstruction, k) for k in EVIDENCE_KEYS}}


def cache_problem(cache: Path, resolved, *, write: bool = False) -> str | None:
    """Why the evidence in ``cache`` was not made with the options ``resolved`` (:func:`evidence_options`), or None.

    The folder's name holds the ``--set`` items only: the resolved segmentation options are recorded in it
    (``segmentation.json``, written when ``write`` and missing from a folder without evidence), so that evidence made
    under other defaults (segmentation's changed 2026-12-01: local_exclude_dark, line_width_px; the front lines
    came 2026-12-02) is never reused.
    """
    stamp, want = cache / "segmentation.json", json.dumps(resolved, sort_keys=True)
    if stamp.is_file():
        return None if stamp.read_text() == want else (
            f"{cache} holds evidence of other segmentation options ({stamp.read_text()}): delete it")
    if any(cache.glob("*.pkl")):
        return (f"{cache} holds evidence without a record of its segmentation options (made before 2026-12-01, "
                f"when their defaults changed): delete it")
    if write:
        stamp.write_text(want)
    return None


def cache_folder(sets: dict) -> str:
    """The evidence cache's folder name for ``--set`` items ({section: {key: value}}): the evidence depends on the
    segmentation's options and :data:`EVIDENCE_KEYS` only, other items share the default ``evidence-cache``."""
    seg = sorted(f"segmentation.{k}={v}" for k, v in sets.get("segmentation", {}).items())
    seg += sorted(f"reconstruction.{k}={v}" for k, v in sets.get("reconstruction", {}).items() if k in EVIDENCE_KEYS)
    return "evidence-cache" + "".join(f"-{k}" for k in seg)


def scene_experiment(folder: Path):
    """A generalisation run's scene: its experiment (``reconstruction.method`` multiview, as the run's) and the
    cameras the run calibrated (``result-multiview/cameras.json``)."""
    from tendrilkit.io import read_cameras
    from tendrilkit.params import load_experiment

    exp = load_experiment(folder / "scene" / "experiment.yaml")
    exp = exp.model_copy(update={"reconstruction": exp.reconstruction.model_copy(update={"method": "multiview"})})
    return exp, read_cameras(folder / "result-multiview" / "cameras.json")


def rerun_scene(folder: Path, cache: Path, *, fit: bool, sets: dict | None = None) -> list[dict]:
    """Reconstruct every processed frame of one scene again (multiview), evidence from ``cache``.

    ``sets``: {section: {key: value}} replacing the experiment's options (``--set``).
    """
    import tendrilkit.pipeline as pipeline
    from tendrilkit.io import open_views
    from tendrilkit.params import with_overrides
    from tendrilkit.phantom import read_ground_truth
    from tendrilkit.assembly import with_run_checks, with_temporal_checks
    from tendrilkit.runner import _next_curve, _read_views
    from tendrilkit.verify import Thresholds
    from tendrilkit.verify_calibration import world_marker_message

    exp, cameras = scene_experiment(folder)
    if sets:
        exp = with_overrides(exp, sets)  # validated: a mistyped key is an error, not a silent baseline
    res = folder / "result-multiview"
    frames = sorted(int(f) for f in pd.read_csv(res / "frames.csv").frame)
    gt = read_ground_truth(folder / "scene")
    factors = ";".join(json.loads((folder / "scene" / "ground_truth" / "gt_meta.json").read_text())
                       .get("active_factors", []))
    original = pipeline.multiview_evidence
    sources = open_views(list(exp.videos))
    rows, curves, state, results = [], {}, None, []
    try:
        for i, f in enumerate(frames):
            path = cache / f"{folder.name}-{f}.pkl"
            # the frames are read every time: the tone and colour checks read the images (verify_tone)
            images, errors = _read_views(sources, f)  # as the runner reads a frame
            if path.is_file():
                evidence = pickle.loads(path.read_bytes())
            else:
                evidence = original(images, cameras, exp, read_errors=errors)
                path.write_bytes(pickle.dumps(evidence))
            # the frame's evidence, computed once: the multi-view decisions are what a re-run measures
            pipeline.multiview_evidence = lambda *a, _ev=evidence, **k: _ev
            try:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    r = pipeline.reconstruct_frame(images, cameras, exp, frame=f, read_errors=errors, fit=fit,
                                                   previous_mm=None if i % exp.reconstruction.chunk_frames == 0
                                                   else state)
            finally:
                pipeline.multiview_evidence = original
            state = _next_curve(r)
            results.append(r)
    finally:
        for src in sources:
            src.close()
    # the checks of the whole run, as the runner applies them after every frame: the world marker's fit
    # (verify_calibration) and the checks against the other frames (verify_temporal)
    th = Thresholds.from_params(exp.verification)
    markers = pd.read_csv(res / "calibration_markers.csv")
    run_check = world_marker_message(markers, exp.marker.id, th.max_world_marker_px)
    results = with_run_checks(with_temporal_checks(results, exp.verification), [run_check] if run_check else [])
    for r in results:
        if r.points_mm is not None:
            curves[r.frame] = np.asarray(r.points_mm, float)
        rows.append({"scene": folder.name, "frame": r.frame, "status": r.status, "message": r.message,
                     "factors": factors, **{k: v for k, v in (r.quality or {}).items() if k in FIGURES}})
    return rows, curves, gt


def score(rows: list[dict], curves: dict, gt) -> pd.DataFrame:
    """The rows with the distances to the truth and the criteria of :func:`tendrilkit.scoring.score_frames`, and a
    cause."""
    from diagnose_multiview import frame_cause

    from tendrilkit.scoring import score_frames

    t = pd.DataFrame(rows)
    table = pd.concat([pd.DataFrame({"frame": f, "point": range(len(P)), "x_mm": P[:, 0], "y_mm": P[:, 1],
                                     "z_mm": P[:, 2]}) for f, P in curves.items()]) if curves else pd.DataFrame()
    s = score_frames(table, t[["frame", "status", "message"]], gt.curves_table())
    s = s[["frame", "mean_mm", "max_mm", "base_mm", "tip_mm", "miss_mm", "within_ends", "within"]]
    t = t.merge(s.rename(columns={"within_ends": "ends"}), on="frame", how="left")
    t["cause"] = ["" if w else frame_cause(curves.get(int(r.frame)), np.asarray(gt.curves[int(r.frame)], float), r)
                  for w, r in zip(t.within, t.itertuples())]
    t["pale"] = t.factors.str.contains("look=pale")
    return t


def figures(t: pd.DataFrame, tag: str) -> str:
    """One line: the issue's figures (% of frames) and the trust figures."""
    n = max(len(t), 1)
    pct = lambda m: 100.0 * float(np.sum(m)) / n  # noqa: E731
    return (f"{tag}: {len(t)} frames; mean<=0.5 {pct(t.mean_mm <= 0.5):.1f} %, max<=2 {pct(t.max_mm <= 2):.1f} %, "
            f"ends<=2 {pct(t.ends):.1f} % (base {pct(t.base_mm <= 2):.1f}, tip {pct(t.tip_mm <= 2):.1f}), "
            f"all three {pct(t.within):.1f} %, failed {pct(t.status == 'failed'):.1f} %, "
            f"silent {int(((t.status == 'ok') & (t.mean_mm > 1.5)).sum())}, "
            f"ok with max or an end > 2 mm {int(((t.status == 'ok') & ~(t.ends & (t.max_mm <= 2))).sum())}")


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("out", type=Path)
    p.add_argument("tag")
    p.add_argument("--seeds", default=None, help="START:STOP (stop exclusive); default every scene of OUT")
    p.add_argument("--no-fit", action="store_true", help="skip the piece-wise clothoid (faster; see above)")
    p.add_argument("--compare", default=None, help="a previous TAG: print the frames that changed")
    p.add_argument("--keep-curves", action="store_true",
                   help="write each scene's curves to OUT/curves-TAG/SCENE.csv (frame, x_mm, y_mm, z_mm)")
    p.add_argument("--set", action="append", default=[], metavar="SECTION.KEY=VALUE",
                   help="replace an experiment option (e.g. segmentation.line_width_px=11); evidence cached apart")
    p.add_argument("--workers", type=int, default=1, help="scenes re-run at once (at most 2)")
    a = p.parse_args(argv)
    try:
        sets = parse_sets(a.set)
    except ValueError as e:
        p.error(str(e))
    os.environ.setdefault("TENDRILKIT_PROGRESS", "0")
    import cv2

    cv2.setNumThreads(1)
    scenes = sorted((d for d in a.out.glob("*-*") if (d / "result-multiview" / "frames.csv").is_file()),
                    key=lambda d: (d.name.rsplit("-", 1)[0], int(d.name.rsplit("-", 1)[1])))
    if a.seeds:
        start, stop = (int(x) for x in a.seeds.split(":"))
        scenes = [d for d in scenes if start <= int(d.name.rsplit("-", 1)[1]) < stop]
    if any(int(d.name.rsplit("-", 1)[1]) >= 10000 for d in scenes):
        p.error("seeds 10000 and above are reserved for the final benchmark")
    if not scenes:
        p.error(f"no scene with result-multiview/frames.csv in {a.out}")
    if sets:  # every key checked once, before any scene is re-run
        from tendrilkit.exceptions import ExperimentError
        from tendrilkit.params import load_experiment, with_overrides

        try:
            with_overrides(load_experiment(scenes[0] / "scene" / "experiment.yaml"), sets)
        except (ExperimentError, ValueError) as e:
            p.error(f"--set: {e}")
    cache = a.out / cache_folder(sets)
    cache.mkdir(exist_ok=True)
    problem = cache_problem(cache, evidence_options(scenes[0] / "scene" / "experiment.yaml", sets), write=True)
    if problem:
        p.error(problem)
    tables = []

    def keep(d, rows, curves, gt):
        tables.append(score(rows, curves, gt))
        if a.keep_curves:
            (a.out / f"curves-{a.tag}").mkdir(exist_ok=True)
            pd.concat([pd.DataFrame({"frame": f, "x_mm": P[:, 0], "y_mm": P[:, 1], "z_mm": P[:, 2]})
                       for f, P in curves.items()] or [pd.DataFrame(columns=["frame", "x_mm", "y_mm", "z_mm"])]
                      ).to_csv(a.out / f"curves-{a.tag}" / f"{d.name}.csv", index=False)
        print(d.name, flush=True)

    if a.workers > 1:
        from concurrent.futures import ProcessPoolExecutor

        with ProcessPoolExecutor(min(a.workers, 2)) as pool:
            futures = [pool.submit(rerun_scene, d, cache, fit=not a.no_fit, sets=sets) for d in scenes]
            for d, fut in zip(scenes, futures):
                keep(d, *fut.result())
    else:
        for d in scenes:
            keep(d, *rerun_scene(d, cache, fit=not a.no_fit, sets=sets))
    t = pd.concat(tables, ignore_index=True)
    t.to_csv(a.out / f"rerun-{a.tag}.csv", index=False, float_format="%.4f")
    print(figures(t, a.tag))
    wrong = t[t.cause != ""]
    print(wrong.groupby(["cause", "pale"]).size().unstack(fill_value=0).rename(
        columns={False: "not pale", True: "pale"}).to_string())
    if a.compare:
        b = pd.read_csv(a.out / f"rerun-{a.compare}.csv")
        m = b.merge(t, on=["scene", "frame"], suffixes=("_before", "_after"))
        changed = m[(m.status_before != m.status_after) | ((m.tip_mm_before - m.tip_mm_after).abs() > 0.5)
                    | ((m.max_mm_before - m.max_mm_after).abs() > 0.5) | (m.within_before != m.within_after)]
        cols = [f"{c}_{w}" for c in ("status", "mean_mm", "max_mm", "base_mm", "tip_mm") for w in ("before", "after")]
        pd.set_option("display.width", 250)
        print(changed[["scene", "frame"] + cols].round(2).to_string(index=False))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
