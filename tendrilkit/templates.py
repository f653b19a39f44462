"""Experiment files as text: the template of ``init``, the entries that ``intrinsics``
and ``marks`` print, and the in-place edit of a file's ``cameras:`` block.

:mod:`tendrilkit.params` reads and validates experiment files; this module
writes their text, so that a user's own lines and comments survive. Edits
are made on the text: only the ``cameras:`` item of the view concerned is
replaced (the comments between items, and every other section, are kept; a
comment *inside* the replaced item is lost). A ``cameras:`` section written in
flow style on one line (``cameras: [{...}, {...}]``) is rewritten as a block,
one item per line. Every edit is checked by reading the result back.
"""

from __future__ import annotations

import os
import re
import textwrap
from pathlib import Path

import numpy as np
import yaml

from tendrilkit.exceptions import ExperimentError

__all__ = ["camera_entry", "set_camera_entry", "views_block", "experiment_template"]


def _num(x: float, digits: int = 6) -> str:
    v = float(x)
    if v == 0:
        return "0.0"
    return repr(float(f"{v:.{digits}g}"))


def camera_entry(view: int, K: np.ndarray, dist: np.ndarray) -> str:
    """One ``cameras:`` item in flow style, e.g. ``- {view: 1, fx: 1750.2, ...}``."""
    K = np.asarray(K, float)
    d = ", ".join(_num(v, 5) for v in np.asarray(dist, float).ravel()[:5])
    return (f"- {{view: {int(view)}, fx: {_num(K[0, 0], 8)}, fy: {_num(K[1, 1], 8)}, cx: {_num(K[0, 2], 7)}, "
            f"cy: {_num(K[1, 2], 7)}, dist: [{d}]}}")


_TOP = re.compile(r"^[^\s#]")


def _block(lines: list[str], key: str) -> tuple[int, int] | None:
    """Line range ``[start, end)`` of a top-level ``key:`` section (end: the next top-level line)."""
    pat = re.compile(rf"^{re.escape(key)}\s*:")
    start = next((i for i, ln in enumerate(lines) if pat.match(ln)), None)
    if start is None:
        return None
    end = start + 1
    while end < len(lines) and not (lines[end].strip() and not lines[end][0].isspace() and lines[end][0] != "-"):
        end += 1
    # trailing blank / comment-only lines at column 0 belong to what follows
    while end - 1 > start and (not lines[end - 1].strip()):
        end -= 1
    return start, end


def set_camera_entry(text: str | None, view: int, K: np.ndarray, dist: np.ndarray, *, note: str = "",
                     where: str = "the file") -> str:
    """Put view ``view``'s intrinsics into a YAML text's ``cameras:`` list.

    Parameters
    ----------
    text : str or None
        The file's text; None: a new intrinsics file holding only ``cameras:``.
    view : int
        1-based; the item with this ``view:`` is replaced, or one is inserted
        in view order.
    K : (3, 3) float array
    dist : (5,) float array
    note : str
        A comment put after the item (image size, board, error).
    where : str
        The file's name, for messages.

    Returns
    -------
    str
        The new text.

    Raises
    ------
    ExperimentError
        The text is not YAML, or its ``cameras:`` is not a list.
    """
    item = camera_entry(view, K, dist) + (f"  # {note}" if note else "")
    if text is None:
        return ("# Camera intrinsics from `python -m tendrilkit intrinsics` (OpenCV model, pixels;\n"
                "# dist = k1, k2, p1, p2, k3). Use with `python -m tendrilkit init --intrinsics FILE ...`\n"
                "# or paste the item under an experiment file's cameras:.\n"
                f"cameras:\n  {item}\n")
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError:
        raise ExperimentError(f"{where}: not a YAML file; paste the entry under cameras: by hand") from None
    if data is not None and not isinstance(data, dict):
        raise ExperimentError(f"{where}: expected a mapping of keys at the top level; paste the entry by hand")
    lines = text.splitlines(keepends=True)
    if lines and not lines[-1].endswith("\n"):
        lines[-1] += "\n"
    rng = _block(lines, "cameras")
    if rng is None:
        new = "".join(lines) + f"cameras:\n  {item}\n"
    else:
        s, e = rng
        head = lines[s]
        after = head.split(":", 1)[1].split("#", 1)[0].strip()
        cams = (data or {}).get("cameras")
        if cams is not None and not isinstance(cams, list):
            raise ExperimentError(f"{where}: cameras: expected a list of entries, got {type(cams).__name__}")
        if after:  # flow style: rewrite the whole section as a block
            items = [c for c in (cams or []) if not (isinstance(c, dict) and c.get("view") == view)]
            body = []
            for c in items:
                body.append("  - " + yaml.safe_dump(c, default_flow_style=True, sort_keys=False).strip() + "\n")
            pos = sum(1 for c in items if isinstance(c, dict) and isinstance(c.get("view"), int) and c["view"] < view)
            body.insert(pos, f"  {item}\n")
            new = "".join(lines[:s]) + "cameras:\n" + "".join(body) + "".join(lines[e:])
        else:
            starts = [i for i in range(s + 1, e) if lines[i].lstrip().startswith("- ") or lines[i].strip() == "-"]
            indent = re.match(r"^(\s*)", lines[starts[0]]).group(1) if starts else "  "
            starts = [i for i in starts if re.match(r"^(\s*)", lines[i]).group(1) == indent]
            spans = []
            for j, i0 in enumerate(starts):
                i1 = starts[j + 1] if j + 1 < len(starts) else e
                while i1 - 1 > i0 and (not lines[i1 - 1].strip() or lines[i1 - 1].lstrip().startswith("#")):
                    i1 -= 1
                try:
                    parsed = yaml.safe_load(textwrap.dedent("".join(lines[i0:i1])))
                    v = parsed[0].get("view") if isinstance(parsed, list) and isinstance(parsed[0], dict) else None
                except (yaml.YAMLError, IndexError, AttributeError):
                    v = None
                spans.append((i0, i1, v))
            hit = [sp for sp in spans if sp[2] == view]
            if hit:
                i0, i1, _ = hit[0]
                new_lines = lines[:i0] + [f"{indent}{item}\n"] + lines[i1:]
            else:
                before = [sp for sp in spans if isinstance(sp[2], int) and sp[2] < view]
                at = before[-1][1] if before else (spans[0][0] if spans else s + 1)
                new_lines = lines[:at] + [f"{indent}{item}\n"] + lines[at:]
            new = "".join(new_lines)
    try:
        check = yaml.safe_load(new)
        ok = any(isinstance(c, dict) and c.get("view") == view and abs(float(c.get("fx")) - float(K[0][0])) < 1e-3 * float(K[0][0])
                 for c in check.get("cameras", []))
    except (yaml.YAMLError, AttributeError, TypeError, ValueError):
        ok = False
    if not ok:
        raise ExperimentError(f"{where}: could not fill the cameras: entry of view {view} automatically; "
                              "paste the printed entry by hand")
    return new


def views_block(marks: list[dict], *, notes: list[str] | None = None) -> str:
    """The ``views:`` section for marks ``[{view, roi, keep_out, base_point}, ...]`` (one line per view)."""
    out = ["views:"]
    for i, m in enumerate(marks):
        parts = [f"view: {int(m['view'])}"]
        if m.get("roi") is not None:
            parts.append(f"roi: {[int(v) for v in m['roi']]}")
        if m.get("keep_out") is not None:
            parts.append(f"keep_out: {[int(v) for v in m['keep_out']]}")
        if m.get("base_point") is not None:
            parts.append(f"base_point: {[round(float(v), 1) for v in m['base_point']]}")
        line = "  - {" + ", ".join(parts) + "}"
        if notes and notes[i]:
            line += f"  # {notes[i]}"
        out.append(line)
    return "\n".join(out)


def experiment_template(out_path: str | Path, videos: list[str | Path], infos: list[dict], *,
                        marker: dict, cameras: list[dict | None], views: list[dict] | None,
                        view_notes: list[str] | None = None, name: str | None = None) -> str:
    """The text of a new experiment file (``python -m tendrilkit init``), every key commented.

    Parameters
    ----------
    out_path : path
        Where it will be written (video paths are made relative to its folder).
    videos : list of path
    infos : list of dict
        Per video ``width``, ``height``, ``frames`` and ``fps`` (None for image folders).
    marker : dict
        ``dictionary``, ``id``, ``length_mm``.
    cameras : list of (dict or None)
        Per view ``fx, fy, cx, cy, dist`` from an intrinsics file, or None: a
        placeholder (``fx: 0``) that ``reconstruct`` refuses with a message.
    views : list of dict or None
        Suggested marks (see :func:`views_block`); None: left for ``marks``.
    """
    out_path = Path(out_path)
    base = out_path.resolve().parent
    rel = [os.path.relpath(Path(v).resolve(), base) for v in videos]
    if name is None:
        name = out_path.stem if out_path.stem not in ("experiment", "exp") else base.name
    name = re.sub(r'[/\\:*?"<>|\s]+', "-", name).strip("-") or "experiment"
    fps_set = {round(i["fps"], 3) for i in infos if i.get("fps")}
    fps = infos[0]["fps"] if infos and infos[0].get("fps") else None
    L = []
    L.append(f"# Experiment file made by `python -m tendrilkit init` from {len(videos)} videos.")
    L.append("# Keys: ../shared/EXPERIMENT_FORMAT.md and tendrilkit/params.py; every other option has a default.")
    L.append("# Next: fill the cameras (intrinsics), check the marks (`python -m tendrilkit marks THIS_FILE`),")
    L.append("# then `python -m tendrilkit check THIS_FILE` and `python -m tendrilkit reconstruct THIS_FILE --out results/`.")
    L.append(f"{f'name: {name}':<32}# used for output folder names")
    L.append(f"{'# stimulation_site: S3':<32}# optional: S1..S4 (base -> tip), used by the reports")
    L.append(f"{'videos:':<32}# one per view, in view order (paths relative to this file)")
    for r, inf in zip(rel, infos):
        L.append(f"  - {r}    # {inf['width']}x{inf['height']}, {inf['frames']} frames"
                 + (f", {inf['fps']:g} fps in the file" if inf.get("fps") else ""))
    if fps is None:
        L.append(f"{'fps: 1.0':<32}# TODO frames per second of the recording (image folders carry none)")
    else:
        note = "" if len(fps_set) <= 1 else f"  (the videos disagree: {sorted(fps_set)})"
        L.append(f"{f'fps: {fps:g}':<32}# frames per second as stored in the video{note}; "
                 "for a time-lapse put the capture rate (e.g. 0.2 = one frame every 5 s)")
    L.append(f"{f'reference_view: {min(2, len(videos))}':<32}# 1-based: the view the others are matched to "
             "(the middle camera)")
    L.append("frames: {start: 0, stop: null, step: 1}  # 0-based, stop exclusive (null: to the end)")
    L.append(f"{'cameras:':<32}# intrinsics per view, pixels; dist = OpenCV k1, k2, p1, p2, k3")
    for v, c in enumerate(cameras):
        if c is None:
            L.append(f"  - {{view: {v + 1}, fx: 0, fy: 0, cx: 0, cy: 0, dist: [0, 0, 0, 0, 0]}}   # PLACEHOLDER: run "
                     f"`python -m tendrilkit intrinsics BOARD_VIDEO_{v + 1} --board ... --view {v + 1} --write THIS_FILE`")
        else:
            L.append("  " + camera_entry(v + 1, np.array([[c["fx"], 0, c["cx"]], [0, c["fy"], c["cy"]], [0, 0, 1]]),
                                         np.asarray(c.get("dist", [0] * 5), float)))
    L.append(f"marker: {{dictionary: {marker['dictionary']}, id: {int(marker['id'])}, length_mm: {float(marker['length_mm']):g}}}"
             "   # the ArUco marker that defines the world frame (black square's side, mm)")
    L.append("# views: per view, on the first processed frame, pixels: roi [x, y, w, h] = the region the tendril")
    L.append("# moves in; keep_out [x, y, w, h] = the box over the junction of tendril and stem (background);")
    L.append("# base_point [x, y] = where the tendril leaves the stem. Suggested by `python -m tendrilkit marks`;")
    L.append("# look at the pictures it draws before trusting them.")
    if views:
        L.append(views_block(views, notes=view_notes))
    else:
        L.append("views:")
        for v in range(len(videos)):
            L.append(f"  - {{view: {v + 1}}}   # TODO: run `python -m tendrilkit marks THIS_FILE`")
    L.append(f"{'points: 200':<32}# points per reconstructed curve")
    return "\n".join(L) + "\n"
