"""Suggested marks (ROI, keep-out box, base point) from the videos themselves.

``python -m tendrilkit marks EXPERIMENT.yaml`` draws the marks on the first
processed frame of every view and suggests those that are missing or
doubtful; ``python -m tendrilkit init VIDEOS... --out FILE`` writes a new
experiment file with suggested marks.

The tendril is *the thin dark structure that moves and hangs from the stem*.
:func:`suggest_view_marks`, per view, on a few frames spread over the
selected frames (the first processed frame first):

1. dark pixels: the segmentation's grey image (blue channel or HSV) below
   Otsu's threshold of the first frame;
2. what moved: pixels dark in some frames but not in all;
3. the tendril's half-width ``w``: the distance transform of the dark
   pixels that moved (90th percentile);
4. thick structures (stem, node, leaves, markers): the dark pixels' opening
   with a disk of radius ``1.5 w + 1``; thin = dark minus (thick grown 1 px);
5. the tendril in each frame: the thin components that overlap what moved;
   its swept region is their union;
6. ``roi``: the swept region's box grown by ``margin_px`` (40 px, or 8 % of
   the image's smaller side if more); ``base_point``: the centre of the
   place where the first frame's tendril touches a thick structure, the
   one around which least moved (the visible emergence: where the tendril
   starts behind the stem, e.g. on a node's far side, is not seen);
   ``keep_out``: a box around that place,
   grown until, outside it, the tendril stays 2 px away from every thick
   structure in every sampled frame.

The suggestion is then tried: :func:`tendrilkit.segmentation.segment_view`
with the suggested marks must pick the tendril on the first frame.
:func:`assess_marks` says why a user's marks are doubtful (the tendril
leaves the ROI, the base point picks another component, the keep-out box
does not separate the tendril from the stem).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from tendrilkit.exceptions import TendrilLostError
from tendrilkit.segmentation import grey_image, segment_view

__all__ = ["ViewSuggestion", "ViewReview", "suggest_view_marks", "assess_marks", "review_marks", "review_block",
           "run_marks", "run_init"]

#: Frames sampled per view.
N_SAMPLES = 8


@dataclass(frozen=True, eq=False)
class ViewSuggestion:
    """Suggested marks of one view.

    Attributes
    ----------
    roi, keep_out : [x, y, w, h] int lists or None
    base_point : [x, y] float list or None
    tendril0 : (H, W) bool array
        The tendril found on the first frame.
    swept : (H, W) bool array
        Union of the tendril over the sampled frames.
    thick0 : (H, W) bool array
        Thick dark structures of the first frame (stem, node, leaves, markers).
    width_px : float
        Estimated tendril width, px.
    problem : str
        Empty when the suggestion holds; else why it failed or is doubtful.
    """

    roi: list | None
    keep_out: list | None
    base_point: list | None
    tendril0: np.ndarray
    swept: np.ndarray
    thick0: np.ndarray
    width_px: float
    problem: str = ""


def _disk(r: int) -> np.ndarray:
    r = max(int(r), 1)
    return cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * r + 1, 2 * r + 1))


def _box_of(mask: np.ndarray) -> tuple[int, int, int, int]:
    ys, xs = np.nonzero(mask)
    return int(xs.min()), int(ys.min()), int(xs.max()), int(ys.max())


def suggest_view_marks(frames_bgr: list[np.ndarray], *, channel: str = "blue", margin_px: int | None = None,
                       segmentation: dict | None = None) -> ViewSuggestion:
    """Suggest the marks of one view from a few of its frames.

    Parameters
    ----------
    frames_bgr : list of (H, W, 3) uint8 arrays
        The first processed frame first, then frames spread over the sequence.
    channel : {"blue", "hsv"}
        The segmentation's grey image (:func:`tendrilkit.segmentation.grey_image`).
    margin_px : int, optional
        Margin of the ROI around the swept region (default: 40 px or 8 % of
        the image's smaller side, whichever is larger).
    segmentation : dict, optional
        Keyword options of :func:`tendrilkit.segmentation.segment_view` for
        the trial segmentation (``threshold``, ``opening_radius_px``, ...).

    Returns
    -------
    ViewSuggestion
        With ``problem`` set (and marks None) when nothing thin moved.
    """
    if len(frames_bgr) < 2:
        raise ValueError(f"frames_bgr: expected at least 2 frames, got {len(frames_bgr)}")
    greys = [grey_image(np.asarray(f), channel=channel) for f in frames_bgr]
    H, W = greys[0].shape
    thr, _ = cv2.threshold(greys[0], 0, 255, cv2.THRESH_BINARY | cv2.THRESH_OTSU)
    small = np.ones((3, 3), np.uint8)
    dark = [cv2.morphologyEx((g < thr).astype(np.uint8), cv2.MORPH_OPEN, small) for g in greys]
    always = np.logical_and.reduce([d.astype(bool) for d in dark])
    ever = np.logical_or.reduce([d.astype(bool) for d in dark])
    moved = cv2.morphologyEx((ever & ~always).astype(np.uint8), cv2.MORPH_OPEN, small)
    n, lab, stats, _ = cv2.connectedComponentsWithStats(moved, connectivity=8)
    moved = np.isin(lab, np.flatnonzero(stats[:, cv2.CC_STAT_AREA] >= 30)[1:] if n > 1 else []) & (lab > 0)
    empty = np.zeros((H, W), bool)
    if moved.sum() < 50:
        return ViewSuggestion(None, None, None, empty, empty, empty, 0.0,
                              "nothing dark moved over the sampled frames: choose frames (frames:) in which the "
                              "tendril moves, or mark the view by hand")
    dts = [cv2.distanceTransform(d, cv2.DIST_L2, 5) for d in dark]
    vals = np.concatenate([dt[moved & d.astype(bool)] for dt, d in zip(dts, dark)])
    half = float(np.percentile(vals, 90)) if vals.size else 3.0
    r_thick = int(np.ceil(1.5 * half)) + 1
    thick = [cv2.morphologyEx(d, cv2.MORPH_OPEN, _disk(r_thick)) for d in dark]
    tendrils = []
    for d, tk in zip(dark, thick):
        thin = d.astype(bool) & ~cv2.dilate(tk, small).astype(bool)
        n, lab = cv2.connectedComponents(thin.astype(np.uint8), connectivity=8)
        hit = np.bincount(lab[moved & thin], minlength=n)
        size = np.bincount(lab.ravel(), minlength=n)
        keep = np.flatnonzero((hit >= 20) & (hit >= 0.05 * size))
        keep = keep[keep > 0]
        tendrils.append(np.isin(lab, keep))
    t0, th0 = tendrils[0], thick[0].astype(bool)
    swept = np.logical_or.reduce(tendrils)
    if t0.sum() < 20:
        return ViewSuggestion(None, None, None, t0, swept, th0, 2 * half,
                              "no thin moving structure on the first frame: is the tendril in this view?")
    m = int(margin_px) if margin_px is not None else max(40, int(0.08 * min(H, W)))
    x0, y0, x1, y1 = _box_of(swept)
    rx0, ry0 = max(x0 - m, 0), max(y0 - m, 0)
    rx1, ry1 = min(x1 + m, W - 1), min(y1 + m, H - 1)
    roi = [rx0, ry0, rx1 - rx0 + 1, ry1 - ry0 + 1]

    # where the first frame's tendril touches a thick structure; the base moves least
    contact = t0 & cv2.dilate(thick[0], _disk(2)).astype(bool)
    n, lab = cv2.connectedComponents(contact.astype(np.uint8), connectivity=8)
    if n <= 1:
        return ViewSuggestion(roi, None, None, t0, swept, th0, 2 * half,
                              "the tendril touches no thicker structure (stem) in the first frame: "
                              "mark base_point and keep_out by hand")
    near = cv2.dilate(moved.astype(np.uint8), _disk(int(3 * half) + 2)).astype(bool)
    best, score = 1, None
    for k in range(1, n):
        pix = lab == k
        s = (float(near[pix].mean()), -int(pix.sum()))
        if score is None or s < score:
            best, score = k, s
    ys, xs = np.nonzero(lab == best)
    # the visible emergence; the true base may lie a little further, hidden by the stem
    base = [float(np.round(xs.mean(), 1)), float(np.round(ys.mean(), 1))]
    bx0, by0, bx1, by1 = xs.min() - 2, ys.min() - 2, xs.max() + 2, ys.max() + 2
    ring = _disk(2)
    for _ in range(40):
        grow = False
        for t, tk in zip(tendrils, thick):
            box = np.zeros((H, W), bool)
            box[max(by0, 0):by1 + 1, max(bx0, 0):bx1 + 1] = True
            touch = cv2.dilate((t & ~box).astype(np.uint8), ring).astype(bool) & tk.astype(bool) & ~box
            # only touches near the base count (the tendril may cross a leaf far away)
            touch &= _near_box(H, W, (bx0, by0, bx1, by1), int(6 * half) + 6)
            if touch.any():
                tx0, ty0, tx1, ty1 = _box_of(touch)
                bx0, by0, bx1, by1 = min(bx0, tx0), min(by0, ty0), max(bx1, tx1), max(by1, ty1)
                grow = True
        if not grow:
            break
    bx0, by0 = max(int(bx0), 0), max(int(by0), 0)
    keep_out = [bx0, by0, int(min(bx1, W - 1)) - bx0 + 1, int(min(by1, H - 1)) - by0 + 1]
    problem = ""
    ok, why = _try_marks(frames_bgr[0], roi, keep_out, base, t0, th0, channel, segmentation)
    if not ok:
        problem = f"the suggested marks do not pick the tendril out on the first frame ({why}): check this view by eye"
    return ViewSuggestion(roi, keep_out, base, t0, swept, th0, 2 * half, problem)


def _near_box(H: int, W: int, box, pad: int) -> np.ndarray:
    x0, y0, x1, y1 = box
    m = np.zeros((H, W), bool)
    m[max(int(y0) - pad, 0):int(y1) + pad + 1, max(int(x0) - pad, 0):int(x1) + pad + 1] = True
    return m


def _try_marks(image, roi, keep_out, base, tendril0, thick0, channel, segmentation) -> tuple[bool, str]:
    """Segment the first frame with these marks: does it pick the tendril, and only it?"""
    opts = dict(segmentation or {})
    opts.pop("channel", None)
    try:
        seg = segment_view(image, roi=roi, keep_out=keep_out, base_point_xy=base, channel=channel, **opts)
    except (TendrilLostError, ValueError) as e:
        return False, str(e)
    x, y = seg.roi_offset_xy
    h, w = seg.mask_roi.shape
    t = tendril0[y:y + h, x:x + w]
    picked = seg.mask_roi
    inter = float((picked & t).sum())
    if inter < 0.5 * max(t.sum(), 1):
        return False, f"the component at the base point covers {100 * inter / max(t.sum(), 1):.0f} % of the tendril"
    th = thick0[y:y + h, x:x + w].copy()
    if keep_out is not None:
        kx, ky, kw, kh = keep_out
        th[max(ky - y, 0):max(ky + kh - y, 0), max(kx - x, 0):max(kx + kw - x, 0)] = False
    stem = float((picked & th).sum())
    if stem > 0.2 * max(picked.sum(), 1):
        return False, f"{100 * stem / picked.sum():.0f} % of the picked component is thick (stem or leaf): the keep-out box does not separate them"
    return True, ""


def assess_marks(marks: dict, suggestion: ViewSuggestion, image_bgr: np.ndarray, *, channel: str = "blue",
                 segmentation: dict | None = None) -> dict[str, str]:
    """Why a user's marks of one view are doubtful: ``{key: reason}`` (empty: they hold).

    ``marks``: ``roi``, ``keep_out``, ``base_point`` (None = missing).
    """
    out: dict[str, str] = {}
    for key in ("roi", "base_point"):
        if marks.get(key) is None:
            out[key] = "missing"
    if out and marks.get("keep_out") is None:
        out["keep_out"] = "missing"
    if suggestion.problem and suggestion.roi is None:
        return out
    sw = suggestion.swept
    if marks.get("roi") is not None and sw.any():
        x, y, w, h = marks["roi"]
        inside = sw[max(y, 0):max(y + h, 0), max(x, 0):max(x + w, 0)].sum()
        frac = 1 - inside / sw.sum()
        if frac > 0.005:
            out["roi"] = f"{100 * frac:.1f} % of the tendril's swept region lies outside it"
    if marks.get("base_point") is not None and suggestion.base_point is not None:
        d = float(np.hypot(*(np.asarray(marks["base_point"], float) - suggestion.base_point)))
        reach = 4 * suggestion.width_px + 10
        if d > reach:
            out.setdefault("base_point", f"{d:.0f} px from where the tendril leaves the stem")
    if not out and marks.get("roi") is not None and marks.get("base_point") is not None:
        ok, why = _try_marks(image_bgr, marks["roi"], marks.get("keep_out"), marks["base_point"],
                             suggestion.tendril0, suggestion.thick0, channel, segmentation)
        if not ok:
            out["keep_out" if "thick" in why else "base_point"] = why
    if marks.get("keep_out") is None and suggestion.keep_out is not None and "keep_out" not in out:
        ok, why = (True, "")
        if marks.get("roi") is not None and marks.get("base_point") is not None:
            ok, why = _try_marks(image_bgr, marks["roi"], None, marks["base_point"], suggestion.tendril0,
                                 suggestion.thick0, channel, segmentation)
        if not ok:
            out["keep_out"] = f"missing, and without it {why}"
    return out


# ------------------------------------------------------------------ commands
def _sample_indices(n_frames: int, start: int, stop: int | None, step: int, k: int = N_SAMPLES) -> list[int]:
    stop = n_frames if stop is None else min(stop, n_frames)
    sel = list(range(start, stop, step))
    if not sel:
        return [start]
    pick = np.unique(np.linspace(0, len(sel) - 1, min(k, len(sel))).round().astype(int))
    return [sel[i] for i in pick]


def _read_samples(src, indices: list[int]) -> list[np.ndarray]:
    from tendrilkit.exceptions import FrameReadError

    out = []
    for i in indices:
        try:
            out.append(src.read(i))
        except FrameReadError:
            continue
    return out


def suggest_for_videos(videos: list[Path], *, start: int = 0, stop: int | None = None, step: int = 1,
                       channel: str = "blue", segmentation: dict | None = None):
    """Per view: (first frame, suggestion, video info) for a list of videos."""
    from tendrilkit.io import FrameSource

    out = []
    for v, path in enumerate(videos):
        with FrameSource(path) as src:
            info = {"width": src.width, "height": src.height, "frames": src.frame_count, "fps": src.fps}
            idx = _sample_indices(src.frame_count, start, stop, step)
            frames = _read_samples(src, idx)
        if len(frames) < 2:
            out.append((frames[0] if frames else None, None, info))
            continue
        out.append((frames[0], suggest_view_marks(frames, channel=channel, segmentation=segmentation), info))
    return out


@dataclass(frozen=True, eq=False)
class ViewReview:
    """One view's marks after review: ``image`` (first processed frame, BGR), ``user`` and
    ``final`` marks (dicts of ``roi``, ``keep_out``, ``base_point``), ``suggestion``
    (:class:`ViewSuggestion` or None), ``changed`` (what was suggested and why) and
    ``line`` (the report's line)."""

    view: int
    image: np.ndarray | None
    user: dict
    final: dict
    suggestion: ViewSuggestion | None
    changed: list
    line: str


def review_marks(exp) -> list[ViewReview]:
    """Every view's marks checked against the suggestion (the ``marks`` command without files).

    ``exp``: an experiment loaded with ``marks_optional=True``. The final
    marks keep the user's where they hold and take the suggestion where they
    are missing or doubtful; when the mix does not pick the tendril out on
    the first frame, the view takes the whole suggestion.
    """
    seg = exp.segmentation.model_dump()
    res = suggest_for_videos(list(exp.videos), start=exp.frames.start, stop=exp.frames.stop, step=exp.frames.step,
                             channel=exp.segmentation.channel, segmentation=seg)
    out = []
    for v, (img, sug, _info) in enumerate(res):
        mk = exp.views[v]
        user = {"roi": list(mk.roi) if mk.roi else None, "keep_out": list(mk.keep_out) if mk.keep_out else None,
                "base_point": list(mk.base_point) if mk.base_point else None}
        if sug is None or img is None:
            out.append(ViewReview(v + 1, img, user, dict(user), None, [],
                                  f"view {v + 1}: cannot read two frames to compare; marks left as they are"))
            continue
        issues = assess_marks(user, sug, img, channel=exp.segmentation.channel, segmentation=seg)
        new = dict(user)
        changed = []
        if sug.roi is not None:
            for key, why in issues.items():
                val = getattr(sug, key)
                if val is not None:
                    new[key] = val
                    changed.append(f"{key} suggested ({why})")
        if changed and all(new[k] is not None for k in ("roi", "base_point")):
            ok, why = _try_marks(img, new["roi"], new["keep_out"], new["base_point"], sug.tendril0, sug.thick0,
                                 exp.segmentation.channel, seg)
            if not ok:  # your marks and the suggestion do not fit together: take the whole suggestion
                new = {"roi": sug.roi, "keep_out": sug.keep_out, "base_point": sug.base_point}
                changed = [f"all marks suggested (yours mixed with the suggestion: {why})"] + changed
        parts = []
        if sug.problem:
            parts.append(sug.problem)
        if changed:
            parts.append("; ".join(changed))
        elif issues:
            parts.append("; ".join(f"{k}: {w}" for k, w in issues.items()) + " (no suggestion)")
        line = f"view {v + 1}: " + ("; ".join(parts) if parts else "marks OK")
        out.append(ViewReview(v + 1, img, user, new, sug, changed if changed or not issues else ["doubtful"], line))
    return out


def review_block(reviews: list[ViewReview]) -> str:
    """The ``views:`` block of reviewed marks, suggestions commented."""
    from tendrilkit.templates import views_block

    notes = []
    for r in reviews:
        if r.changed and r.changed[0].startswith("all"):
            notes.append("suggested: roi, keep_out, base_point")
        elif r.changed and r.changed != ["doubtful"]:
            notes.append("suggested: " + ", ".join(c.split(" ")[0] for c in r.changed))
        else:
            notes.append("")
    return views_block([{"view": r.view, **r.final} for r in reviews], notes=notes)


def run_marks(experiment_path: str | Path, out_dir: str | Path | None = None) -> tuple[int, str]:
    """``python -m tendrilkit marks``: pictures of the marks and the ``views:`` block to paste.

    Returns ``(exit_code, report)``: 0 when every view's marks hold as they
    are, 1 when some are missing or doubtful (the block then holds the
    suggestions for those; the pictures show them, the user's own dashed).
    """
    from tendrilkit.io import check_writable_dir, save_figure
    from tendrilkit.params import load_experiment
    from tendrilkit.plotting import plot_marks

    exp = load_experiment(experiment_path, marks_optional=True)
    out = check_writable_dir(Path(out_dir) if out_dir is not None else Path(exp.source).parent / "marks")
    reviews = review_marks(exp)
    lines = []
    for r in reviews:
        lines.append(r.line)
        if r.image is None:
            continue
        fig = plot_marks(r.image, roi=r.final["roi"], keep_out=r.final["keep_out"], base_point_xy=r.final["base_point"],
                         previous=r.user if r.changed else None,
                         swept_mask=r.suggestion.swept if r.suggestion is not None else None,
                         title=f"{exp.name}, view {r.view}, frame {exp.frames.start}")
        paths = save_figure(fig, out / f"view{r.view}", formats=("png",))
        lines.append(f"  picture: {paths[0]}")
    any_change = any(r.changed for r in reviews)
    lines.append("paste into the experiment file (replacing its views:):" if any_change else
                 "the views: block as it stands:")
    lines.append(review_block(reviews))
    return (1 if any_change else 0), "\n".join(lines)


def run_init(videos: list[Path], out: Path, *, marker_id: int = 815, marker_mm: float = 24.0,
             dictionary: str = "DICT_ARUCO_ORIGINAL", intrinsics: list[Path] | None = None,
             force: bool = False) -> tuple[int, str]:
    """``python -m tendrilkit init``: a commented experiment file from the videos, marks suggested.

    Returns ``(0, report)``; raises :class:`ExperimentError` (exit 2) for an
    existing file without ``force``, unreadable videos or intrinsics files.
    """
    import cv2 as _cv2

    from tendrilkit.exceptions import ExperimentError
    from tendrilkit.io import write_text
    from tendrilkit.params import load_intrinsics_file
    from tendrilkit.templates import experiment_template

    out = Path(out)
    if out.exists() and not force:
        raise ExperimentError(f"{out}: already exists; choose another --out or add --force")
    if len(videos) < 2:
        raise ExperimentError(f"videos: expected at least 2 (one per view), got {len(videos)}")
    if not dictionary.startswith("DICT_") or not hasattr(_cv2.aruco, dictionary):
        raise ExperimentError(f"--dictionary: expected a cv2.aruco dictionary name such as DICT_ARUCO_ORIGINAL, got {dictionary!r}")
    if not marker_mm > 0:
        raise ExperimentError(f"--marker-mm: expected the marker's side in mm (> 0), got {marker_mm}")
    cams: list = [None] * len(videos)
    if intrinsics:
        if len(intrinsics) != len(videos):
            raise ExperimentError(f"--intrinsics: expected one file per video ({len(videos)}), got {len(intrinsics)}")
        for v, f in enumerate(intrinsics):
            entries = load_intrinsics_file(f)
            c = next((e for e in entries if e.view == v + 1), entries[0])
            cams[v] = {"fx": c.fx, "fy": c.fy, "cx": c.cx, "cy": c.cy, "dist": list(c.dist)}
    res = suggest_for_videos(videos)
    infos = [r[2] for r in res]
    views, notes, lines = [], [], []
    for v, (_img, sug, _info) in enumerate(res):
        if sug is None or sug.roi is None:
            views.append({"view": v + 1})
            notes.append("TODO: " + (sug.problem if sug is not None else "too few frames") + "; mark by hand")
            lines.append(f"view {v + 1}: no marks suggested ({notes[-1]})")
        else:
            views.append({"view": v + 1, "roi": sug.roi, "keep_out": sug.keep_out, "base_point": sug.base_point})
            notes.append("suggested" + (f"; DOUBTFUL: {sug.problem}" if sug.problem else ""))
            lines.append(f"view {v + 1}: marks suggested" + (f" (doubtful: {sug.problem})" if sug.problem else ""))
    sizes = {(i["width"], i["height"]) for i in infos}
    counts = {i["frames"] for i in infos}
    if len(sizes) > 1 or len(counts) > 1:
        lines.append("note: the videos differ in " + " and ".join(
            w for w, s in (("size", sizes), ("frame count", counts)) if len(s) > 1) + "; `check` will say how")
    text = experiment_template(out, videos, infos, marker={"dictionary": dictionary, "id": marker_id,
                                                           "length_mm": marker_mm},
                               cameras=cams, views=views, view_notes=notes)
    write_text(text, out)
    if any(c is None for c in cams):
        lines.append("cameras: placeholders (fx: 0) left: run `python -m tendrilkit intrinsics BOARD_VIDEO --board ... "
                     f"--view N --write {out}` for each view")
    lines.append(f"wrote {out}; next: `python -m tendrilkit marks {out}` to see the marks, then `check`")
    return 0, "\n".join(lines)
