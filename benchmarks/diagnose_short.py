"""What the views show beyond the tip of the curves that stop short (census of the ``stops short`` frames).

    .venv/bin/python benchmarks/diagnose_short.py OUT TAG [--seeds 1040:1080] [--csv FILE]

``OUT`` a folder of ``benchmarks/rerun_multiview.py`` run with ``--keep-curves`` under ``TAG`` (its
``rerun-TAG.csv`` and ``curves-TAG/``) and a filled evidence cache. For each frame whose cause is
``stops short``: the true centreline beyond the point nearest the curve's tip (``missing_mm``), sampled every
0.5 mm and read in every view as the multi-view fit reads it (:func:`tendrilkit.mv_acquire.point_costs`):

``on``      the view sees the place within ``ON_PX`` of its skeleton, not the board
``claimed`` on, but at a skeleton pixel the curve explains already (the extension takes new pixels only)
``dark``    seen, on dark pixels but off the skeleton (merged with a leaf edge, a crossing, a wide blob)
``board``   seen, the view shows the board there (a pale tendril the segmentation missed)
``covered`` deep inside a wide dark region (a leaf, the stem over or under it)
``out``     outside the view's ROI or in its keep-out box

and what stops the curve 0.5-3 mm beyond its tip (``at_tip``): ``2 views on`` (the evidence goes on: a rule
stopped the extension), ``claimed`` (two views on only with explained pixels: a coil over itself), else the
states of the views there. ``first2_mm``: how far beyond the tip two views see the tendril again on new
pixels (NaN: never). Diagnosis only.

Census (2026-12-01, main 4b08771, ``rerun_multiview.py --no-fit --keep-curves``; dev 1040-1079: 60 frames stop
short, 9240-9299: 65), by the first step's rule and ``at_tip``: the width rule stopped the tip (``wide``, left to
that rule's work) 21 / 19 frames; one view or more showing the board (pale tendrils) 9 / 29: on 9240-9299 one view's
board while two see the tendril on (9243, 9250, 9252, 9270, 9286: ``BOARD_VETO_VIEWS`` 2 would pass them) and two or
three views' board over a pale stretch of 6-19 mm that curves (9277, 9294: the tendril comes out again 41-80 degrees
off the tip's tangent), median 105 mm missing; a coil over itself (``claimed``) 9 / 6, median 52 / 16 mm missing
(1056: one view sees the coil end-on, its projection within 0.6 px of another pass over all the missing part, the
other two cross it at the stop); covered in two views, seen in one 8 / 0 (1073: a leaf over 10 mm in two views);
the rest 13 / 11 (1068: the width rule, then one view's board; 1044 frame 1: the extension's former 60 mm budget).
5 / 3 of them follow an ``ok`` frame (tracking follows ``ok`` frames only), whose curve reached 2-7 mm further in 5
(the tip trimmed back: 1047, 1065, 1077, 9281, 9293; 1056 frame 4's was itself 13 mm short) and was right where tracking was lost and the frame acquired
stopped 64 / 99 mm short (1068, 9282); none stopped at the length cap: a short acquisition is flagged, and the next
frame is acquired afresh, uncapped.
Tried on single frames and not kept: steps one view sees while the others cannot (covered, outside, dark off their
skeleton): the tip drifts in depth (1073 frame 0: 4.7 mm off after 6 mm allowed, 19.8 mm after 12) or runs past the
tip (9244 frame 2: 8 mm); a gap where two views show the board crossed to a place all three see on (straight chords
do not reach a curving pale stretch); a tracked curve below its prior length refined and extended again (9281 frame
3: tip 7.3 -> 10.2 mm off, max 1.4 -> 5.1 mm). On dev 1040-1079: ``mv_acquire.CROSSING_MM`` 4 -> 8 mm, all three
42.1 -> 42.1 % (1 frame better, 2 worse: max 2.7 -> 23.8 and 10.6 -> 18.2 mm).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import pandas as pd

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))

STATES = ("on", "claimed", "dark", "board", "covered", "out")


def view_states(evidence, P: np.ndarray, body: np.ndarray | None) -> np.ndarray:
    """(V, n) index into :data:`STATES` of each view at each point."""
    from tendrilkit.geometry import resample_polyline
    from tendrilkit.mv_acquire import ON_PX, _on_crop_mask, claim, point_costs

    d, seen, near, bg, cov = point_costs(evidence, P, nearest=True, covered=True)
    claims = claim(evidence, None, resample_polyline(body, step=0.25)) if body is not None and len(body) >= 2 else None
    out = np.full(d.shape, 5, int)
    for v, ev in enumerate(evidence):
        dark = _on_crop_mask(ev.foreground, ev.offset_xy, ev.camera.project(P))
        on = seen[v] & (d[v] <= ON_PX) & ~bg[v]
        cl = on & (near[v] >= 0) & claims[v][np.maximum(near[v], 0)] if claims is not None else np.zeros_like(on)
        st = np.where(cov[v], 4, 5)
        st = np.where(seen[v] & bg[v], 3, st)
        st = np.where(seen[v] & ~bg[v] & dark & ~on, 2, st)
        st = np.where(seen[v] & ~bg[v] & ~dark & ~on, 3, st)
        st = np.where(cl, 1, st)
        st = np.where(on & ~cl, 0, st)
        out[v] = st
    return out


def stop_rule(evidence, X: np.ndarray) -> str:
    """Which of :func:`tendrilkit.multiview.adjust_tip`'s conditions (:func:`~tendrilkit.multiview.step_conditions`)
    leaves no direction of its first step from the curve's tip with two views on, at 0.5, 1.5 and 3 mm: each
    dropped alone (``board``: the board's veto, ``claims``: explained pixels, ``advance``: a step along a line of
    sight, ``wide``: pixels wider than the tendril); ``several``: only all dropped together; ``evidence``: none of
    them (fewer than two views on); ``goes on``: a direction has two views on (a later step, or the refinement,
    stopped it). Explained pixels count here whatever the tracked prior length (the extension ignores them up to it)."""
    from tendrilkit.geometry import arc_length, resample_polyline
    from tendrilkit.mv_acquire import claim, cone_directions
    from tendrilkit.multiview import reference_widths, step_conditions

    s = arc_length(X)
    t = X[-1] - X[np.searchsorted(s, s[-1] - 2.0)]
    t = t / max(np.linalg.norm(t), 1e-9)
    body = X[s <= s[-1] - 3.0]
    claims = claim(evidence, None, resample_polyline(body, step=0.25)) if len(body) >= 2 else None
    ref = reference_widths(X, evidence)
    dirs = cone_directions(t, 30.0, 3)
    out = []
    for step in (0.5, 1.5, 3.0):
        c = step_conditions(evidence, X[-1], X[-1] + step * dirs, ref)
        near = c["near"]
        cl = np.zeros_like(c["on"])
        if claims is not None:
            for v, cv in enumerate(claims):
                cl[v] = (near[v] >= 0) & cv[np.maximum(near[v], 0)]
        vetoes = {"board": c["board"], "claims": cl, "advance": ~c["advance"], "wide": c["wide"]}

        def ok(*dropped):
            on = c["on"].copy()
            for name, veto in vetoes.items():
                if name not in dropped:
                    on &= ~veto
            return bool((on.sum(axis=0) >= 2).any())

        if ok():
            out.append("goes on")
        else:
            alone = [name for name in vetoes if ok(name)]
            out.append(alone[0] if alone else ("several" if ok(*vetoes) else "evidence"))
    return "/".join(out)


def main(argv: list[str] | None = None) -> int:
    from diagnose_beam import cached_frames

    from tendrilkit.geometry import arc_length, resample_polyline

    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("out", type=Path)
    p.add_argument("tag")
    p.add_argument("--seeds", default="0:10000")
    p.add_argument("--cause", default="stops short")
    p.add_argument("--csv", type=Path)
    p.add_argument("--rows", help="the causes of this tag's rerun csv (default TAG's; the same code's curves)")
    a = p.parse_args(argv)
    start, stop = (int(x) for x in a.seeds.split(":"))
    if stop > 10000:
        p.error("seeds 10000 and above are reserved for the final benchmark")
    runs = pd.read_csv(a.out / f"rerun-{a.rows or a.tag}.csv", keep_default_na=False, na_values=[""])
    want = runs[runs.cause == a.cause]
    want_keys = set(zip(want.scene, want.frame))
    rows = []
    curves_cache: dict = {}
    for scene, f, evidence, base, truth in cached_frames(a.out, start, stop):
        if (scene, f) not in want_keys:
            continue
        if scene not in curves_cache:
            cv = pd.read_csv(a.out / f"curves-{a.tag}" / f"{scene}.csv")
            curves_cache = {scene: {int(k): g[["x_mm", "y_mm", "z_mm"]].to_numpy(float) for k, g in cv.groupby("frame")}}
        X = curves_cache[scene][f]
        r = want[(want.scene == scene) & (want.frame == f)].iloc[0]
        T = resample_polyline(truth, step=0.5)
        sT = arc_length(T)
        j0 = int(np.argmin(np.linalg.norm(T - X[-1], axis=1)))
        beyond = T[j0 + 1:]
        sX = arc_length(X)
        st = view_states(evidence, beyond, X[sX <= sX[-1] - 3.0])
        n_new = (st == 0).sum(axis=0)
        n_any = (st <= 1).sum(axis=0)
        sb = sT[j0 + 1:] - sT[j0]
        near_tip = (sb >= 0.5) & (sb <= 3.0)
        if np.median(n_new[near_tip]) >= 2:
            at_tip = "2 views on"
        elif np.median(n_any[near_tip]) >= 2:
            at_tip = "claimed"
        else:
            # the views' commonest state there
            at_tip = "/".join(STATES[int(np.bincount(st[v][near_tip], minlength=6).argmax())] for v in range(len(st)))
        again = np.flatnonzero((n_new >= 2) & (sb > 3.0))
        row = {"scene": scene, "frame": f, "status": r.status, "rule": stop_rule(evidence, X), "missing_mm": float(sT[-1] - sT[j0]),
               "tip_mm": r.tip_mm, "length_mm": float(sX[-1]), "true_mm": float(sT[-1]), "at_tip": at_tip,
               "first2_mm": float(sb[again[0]]) if len(again) else np.nan,
               "two_on_frac": float(np.mean(n_new >= 2)),
               "factors": r.factors}
        for v in range(len(st)):
            row[f"v{v + 1}"] = " ".join(f"{STATES[k][:3]}{np.mean(st[v] == k):.2f}" for k in range(6)
                                        if np.mean(st[v] == k) >= 0.1)
        rows.append(row)
    t = pd.DataFrame(rows)
    if a.csv:
        t.to_csv(a.csv, index=False)
    pd.set_option("display.width", 250)
    pd.set_option("display.max_colwidth", 60)
    print(t.drop(columns=["factors"]).to_string(index=False, float_format=lambda x: f"{x:.1f}"))
    print(t.at_tip.value_counts().to_string())
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
