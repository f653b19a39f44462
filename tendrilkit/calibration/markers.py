"""ArUco markers: the world marker's corners and detection with corners refined from the marker's edges."""

from __future__ import annotations

import functools
import warnings

import cv2
import numpy as np

from tendrilkit.camera import Camera
from tendrilkit.geometry import marker_corners

__all__ = ["CORNER_SIGMA_PX", "REFINE_METHODS", "ambiguous_marker_ids", "average_detections", "corner_sigma_px",
           "corner_weight", "detect_markers"]

#: Corner refinement methods of :func:`detect_markers`.
REFINE_METHODS = ("grid", "edges", "subpix", "contour", "apriltag", "none")


# ------------------------------------------------------------------- detection
def _dictionary(name: str):
    if not isinstance(name, str) or not name.startswith("DICT_") or not hasattr(cv2.aruco, name):
        raise ValueError(f"dictionary: expected a cv2.aruco predefined dictionary name such as DICT_ARUCO_ORIGINAL, got {name!r}")
    return cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, name))


@functools.cache
def ambiguous_marker_ids(dictionary: str) -> frozenset[int]:
    """Ids of ``dictionary`` whose cells look the same turned by 90 or 180 degrees.

    A detector cannot tell which corner of such a marker is its first: it
    reports the corners in one of the turns, 100+ px from where a pose
    expects them (marker 1023 of ``DICT_ARUCO_ORIGINAL``, symmetric under a
    half turn, the only one of its 1024). :func:`detect_markers` leaves them
    out; no phantom places them.

    >>> sorted(ambiguous_marker_ids("DICT_ARUCO_ORIGINAL"))
    [1023]
    """
    dic = _dictionary(dictionary)
    out = set()
    for mid in range(len(dic.bytesList)):
        bits = cv2.aruco.generateImageMarker(dic, mid, dic.markerSize + 2, borderBits=1) > 127
        if any(np.array_equal(bits, np.rot90(bits, k)) for k in (1, 2, 3)):
            out.add(mid)
    return frozenset(out)


def _grey(image: np.ndarray) -> np.ndarray:
    img = np.asarray(image)
    if img.ndim == 3 and img.shape[2] == 3:
        return cv2.cvtColor(img, cv2.COLOR_BGR2GRAY)
    if img.ndim == 3 and img.shape[2] == 1:
        return img[:, :, 0]
    if img.ndim == 2:
        return img
    raise ValueError(f"image_bgr: expected a (height, width, 3) BGR or (height, width) grey image, got shape {img.shape}")


def _line_intersection(l1: np.ndarray, l2: np.ndarray) -> np.ndarray:
    """Point where two lines ``(a, b, c)`` (``a x + b y = c``) meet."""
    A = np.array([l1[:2], l2[:2]])
    return np.linalg.solve(A, np.array([l1[2], l2[2]]))


def _crossings(g: np.ndarray, base: np.ndarray, n: np.ndarray, centre: np.ndarray, half: float,
               rising: bool) -> tuple[np.ndarray, np.ndarray]:
    """Sub-pixel edge offsets along ``n`` ((2,), or (k, 2) one per profile) of profiles through ``base + o n``.

    Each profile spans ``centre +- half`` px (0.25 px steps); the edge is where
    it crosses half-way between its dark and bright ends (the last such
    crossing, dark to bright along ``n`` if ``rising``, else bright to dark),
    interpolated linearly. Returns the offsets (k,) (NaN: no clear edge) and
    the profiles' mid levels (k,).
    """
    offs = np.arange(-half, half + 1e-9, 0.25)
    o = centre[:, None] + offs[None, :]
    nn = n[:, None, :] if n.ndim == 2 else n[None, None, :]  # one direction, or one per profile
    pts = base[:, None, :] + o[:, :, None] * nn
    prof = cv2.remap(g, pts[..., 0].astype(np.float32), pts[..., 1].astype(np.float32), cv2.INTER_LINEAR,
                     borderMode=cv2.BORDER_REPLICATE)
    if not rising:
        prof = prof[:, ::-1]
        o = o[:, ::-1]
    k = max(2, len(offs) // 6)
    lo, hi = prof[:, :k].mean(axis=1), prof[:, -k:].mean(axis=1)
    mid = (lo + hi) / 2
    above = prof >= mid[:, None]
    up = ~above[:, :-1] & above[:, 1:]
    has = up.any(axis=1) & ((hi - lo) > 20)
    q = up.shape[1] - 1 - np.argmax(up[:, ::-1], axis=1)
    rows = np.arange(len(base))
    y0, y1 = prof[rows, q], prof[rows, q + 1]
    with np.errstate(divide="ignore", invalid="ignore"):
        edge = o[rows, q] + (mid - y0) / (y1 - y0) * (o[rows, q + 1] - o[rows, q])
    edge[~(has & np.isfinite(edge))] = np.nan
    return edge, mid


def _refine_corners_edges(grey: np.ndarray, corners_xy: np.ndarray, *, cells: int,
                          camera: Camera | None, iterations: int = 3,
                          bias: float | None = None) -> tuple[np.ndarray, float, int] | None:
    """Corners (4, 2) from straight lines fitted to the marker's four sides.

    Along each side, away from the corners, intensity profiles across the edge
    give sub-pixel edge points where the profile crosses half-way between the
    black border and the white surround (unbiased for a symmetric blur of a
    linear image). With a ``camera`` the edge points are undistorted before the
    line fit, so the lines are straight in the pinhole image; the corners are
    distorted back. Returns None when the edges cannot be measured (the caller
    keeps its own corners).

    A camera's non-linear response (gamma), defocus in a non-linear domain or
    ink spread moves every edge of the black square outwards or inwards by the
    same amount ``b`` (a dilation), which scales the marker and so the whole
    rig (1 % of scale is about 10 px at the tendril). ``b`` is measured and
    removed: where the interior cell next to the black border is white, the
    border's inner edge is found too; the border is one cell wide (its width
    in pixels from the homography of the current corners), so
    ``b = (measured width - cell width) / 2``, the median over all such places
    (at least 10, else ``b`` = 0); a given ``bias`` is used instead.
    Returns ``(corners, b, number of places)``.
    """
    g = grey.astype(np.float32)
    c = np.asarray(corners_xy, dtype=float).copy()
    c0 = c.copy()
    h, w = g.shape
    U = marker_corners(1.0)[:, :2]  # unit square, marker x right, y up
    for _ in range(iterations):
        side = np.linalg.norm(np.roll(c, -1, axis=0) - c, axis=1)
        if side.min() < 12:
            return None
        cell = side.mean() / cells
        half = float(np.clip(0.45 * cell, 1.5, 5.0))  # profile half-length: stays in one cell
        H = cv2.getPerspectiveTransform(U.astype(np.float32), c.astype(np.float32))
        centre = c.mean(axis=0)
        sides = []
        widths = []
        for i in range(4):
            a, b = c[i], c[(i + 1) % 4]
            L = np.linalg.norm(b - a)
            d = (b - a) / L
            n = np.array([d[1], -d[0]])
            if np.dot((a + b) / 2 - centre, n) < 0:
                n = -n  # outward
            t = np.linspace(0.12, 0.88, max(8, int(0.76 * L)))
            base = a[None, :] + (t * L)[:, None] * d[None, :]
            if base.min() < half + 2 or base[:, 0].max() > w - half - 3 or base[:, 1].max() > h - half - 3:
                return None
            outer, mid = _crossings(g, base, n, np.zeros(len(t)), half, rising=True)
            # cell width across the border at each sample, from the homography
            Pu = U[i][None, :] + t[:, None] * (U[(i + 1) % 4] - U[i])[None, :]
            inward = -(U[i] + U[(i + 1) % 4]) / np.linalg.norm(U[i] + U[(i + 1) % 4])
            p0 = cv2.perspectiveTransform(Pu[None].astype(np.float64), H)[0]
            p1 = cv2.perspectiveTransform((Pu + inward / cells)[None].astype(np.float64), H)[0]
            cell_px = (p0 - p1) @ n
            # inner edge of the border where the neighbouring interior cell is white
            tc = t * cells
            j = np.floor(tc)
            cand = (j >= 1) & (j <= cells - 2) & ((tc - j) > 0.2) & ((tc - j) < 0.8)
            if cand.any():
                probe = base[cand] - 1.5 * cell_px[cand, None] * n[None, :]
                val = cv2.remap(g, probe[:, 0:1].astype(np.float32), probe[:, 1:2].astype(np.float32),
                                cv2.INTER_LINEAR).ravel()
                white = val > mid[cand]
                idx = np.flatnonzero(cand)[white]
                if idx.size:
                    inner, _ = _crossings(g, base[idx], n, -cell_px[idx], half, rising=False)
                    widths.append((outer[idx] - inner) - cell_px[idx])
            sides.append((base, n, outer))
        dil = np.concatenate(widths) / 2 if widths else np.array([])
        dil = dil[np.isfinite(dil)]
        b_used = bias if bias is not None else (float(np.median(dil)) if dil.size >= 10 else 0.0)
        lines = []
        poor = False
        for base, n, outer in sides:
            ok = np.isfinite(outer)
            if ok.sum() < 6:
                return None
            n_samples = len(outer)
            p = base[ok] + (outer[ok] - b_used)[:, None] * n[None, :]
            if camera is not None:
                p = camera.undistort_points(p)
            # total least squares line, one pass of outlier rejection
            for _pass in range(2):
                m = p.mean(axis=0)
                _, _, vt = np.linalg.svd(p - m, full_matrices=False)
                nrm = vt[1]
                r = (p - m) @ nrm
                mad = np.median(np.abs(r - np.median(r))) * 1.4826
                keep = np.abs(r) <= max(3 * mad, 0.3)
                if keep.all() or keep.sum() < 6:
                    break
                p = p[keep]
            r = (p - p.mean(axis=0)) @ nrm
            poor |= len(p) < 0.5 * n_samples or float(np.sqrt(np.mean(r ** 2))) > 0.35
            lines.append(np.array([nrm[0], nrm[1], nrm @ m]))
        new = np.array([_line_intersection(lines[(i - 1) % 4], lines[i]) for i in range(4)])
        if camera is not None:
            new = camera.distort_points(new)
        # OpenCV's corner can be pulled several pixels by something dark touching
        # the marker; the lines are not, but they must stay near the quad
        if not np.all(np.isfinite(new)) or np.abs(new - c0).max() > max(3.0, 0.2 * side.mean()):
            return None
        c = new
    if poor:  # lines through too few or too scattered edge points: keep OpenCV's corners
        return None
    return c, (float(np.median(dil)) if dil.size else np.nan), int(dil.size)


def _marker_cells(dic, marker_id: int, cells: int) -> np.ndarray:
    """Colours (cells, cells) bool (True: white) of a marker's cells, row 0 at its top, border included."""
    img = cv2.aruco.generateImageMarker(dic, int(marker_id), 10 * cells, borderBits=1)
    return img[5::10, 5::10] > 127


def _grid_edges(white: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Every straight piece of edge between a black and a white cell, the white surround included.

    Returns ``(a, b, n)``: the pieces' ends (m, 2) and (m, 2) in the unit marker's
    coordinates (x right, y up, the black square ``[-0.5, 0.5]^2``) and the unit
    normal (m, 2) pointing from the black cell to the white one.
    """
    cells = white.shape[0]
    padded = np.ones((cells + 2, cells + 2), bool)
    padded[1:-1, 1:-1] = white
    a, b, n = [], [], []
    for r in range(cells + 2):  # vertical pieces, between columns c and c + 1 of the padded grid
        for c in range(cells + 1):
            if padded[r, c] != padded[r, c + 1] and 1 <= r <= cells:
                x = -0.5 + c / cells
                y0, y1 = 0.5 - r / cells, 0.5 - (r - 1) / cells
                a.append((x, y0)); b.append((x, y1)); n.append((1.0, 0.0) if padded[r, c + 1] else (-1.0, 0.0))
    for r in range(cells + 1):  # horizontal pieces, between rows r and r + 1
        for c in range(1, cells + 1):
            if padded[r, c] != padded[r + 1, c]:
                y = 0.5 - r / cells
                x0, x1 = -0.5 + (c - 1) / cells, -0.5 + c / cells
                a.append((x0, y)); b.append((x1, y)); n.append((0.0, 1.0) if padded[r, c] else (0.0, -1.0))
    return np.array(a), np.array(b), np.array(n)


def _map_h(H: np.ndarray, p: np.ndarray) -> np.ndarray:
    """(n, 2) points through the homography ``H`` (as the side refinement maps them)."""
    return cv2.perspectiveTransform(np.asarray(p, np.float64)[None], np.asarray(H, np.float64))[0]


def _refine_corners_grid(grey: np.ndarray, corners_xy: np.ndarray, white: np.ndarray, *, camera: Camera | None,
                         bias: float) -> np.ndarray | None:
    """Corners (4, 2) from one homography fitted to every black-white edge of the marker.

    The marker's cells have known geometry: besides its four sides, every edge
    between a black and a white inner cell is a straight line at a known place
    in the marker. Sub-pixel edge points are measured along all of them (as
    for the sides, ``bias`` the measured dilation of the black), undistorted,
    and the homography from the unit marker to the pinhole image minimising
    their distances to the mapped lines is found (Gauss-Newton from the
    corners' homography, one pass of outlier rejection); the corners are the
    homography's images of the unit square's. Returns None when too few edge
    points are measured.
    """
    cells = white.shape[0]
    g = grey.astype(np.float32)
    h, w = g.shape
    U = marker_corners(1.0)[:, :2]
    und = camera.undistort_points(corners_xy) if camera is not None else np.asarray(corners_xy, float)
    H = cv2.getPerspectiveTransform(U.astype(np.float32), und.astype(np.float32)).astype(float)
    side = float(np.mean(np.linalg.norm(np.roll(und, -1, 0) - und, axis=1)))
    cell = side / cells
    if cell < 4.0:
        return None
    half = float(np.clip(0.45 * cell, 1.5, 5.0))
    ea, eb, en = _grid_edges(white)
    k = max(2, int(0.6 * cell))
    t = np.linspace(0.2, 0.8, k)
    P = (ea[:, None, :] + t[None, :, None] * (eb - ea)[:, None, :]).reshape(-1, 2)
    N = np.repeat(en, k, axis=0)
    line_n = np.repeat(np.abs(en), k, axis=0)  # the piece's line: line_n . p = line_c (marker units)
    line_c = np.sum(line_n * P, axis=1)
    eps = 0.25 / cells
    q0, q1 = _map_h(H, P), _map_h(H, P + eps * N)
    if camera is not None:
        q0, q1 = camera.distort_points(q0), camera.distort_points(q1)
    d = q1 - q0
    n_img = d / np.linalg.norm(d, axis=1, keepdims=True)
    inside = np.all((q0 > half + 2) & (q0 < np.array([w, h]) - half - 3), axis=1)
    off, _ = _crossings(g, q0, n_img, np.zeros(len(q0)), half, rising=True)
    ok = inside & np.isfinite(off)
    if ok.sum() < 40:
        return None
    pts = q0[ok] + (off[ok] - bias)[:, None] * n_img[ok]
    if camera is not None:
        pts = camera.undistort_points(pts)
    ln = np.column_stack([line_n[ok], -line_c[ok]])  # homogeneous lines (3,) in marker units
    keep = np.ones(len(pts), bool)
    p = H.ravel()[:8] / H[2, 2]
    for _pass in range(2):
        for _it in range(8):
            Hc = np.append(p, 1.0).reshape(3, 3)
            r, J = _line_residuals(Hc, pts[keep], ln[keep])
            step = np.linalg.lstsq(J, -r, rcond=None)[0]
            p = p + step
            if np.abs(step).max() < 1e-12 * max(1.0, np.abs(p).max()):
                break
        Hc = np.append(p, 1.0).reshape(3, 3)
        r, _ = _line_residuals(Hc, pts, ln)
        mad = 1.4826 * np.median(np.abs(r[keep] - np.median(r[keep])))
        new = np.abs(r) <= max(3 * mad, 0.3)
        if np.array_equal(new, keep) or new.sum() < 40:
            break
        keep = new
    c = _map_h(np.append(p, 1.0).reshape(3, 3), U)
    if camera is not None:
        c = camera.distort_points(c)
    if not np.all(np.isfinite(c)) or np.abs(c - corners_xy).max() > 1.0:
        return None
    return c


def _line_residuals(H: np.ndarray, pts: np.ndarray, lines: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Distances (m,) px of image points to the images ``H^-T l`` of marker lines ``l`` (m, 3), and
    their Jacobian (m, 8) with respect to H's first eight entries (``H[2, 2]`` = 1), numerically."""
    def res(hv):
        Hm = np.append(hv, 1.0).reshape(3, 3)
        li = lines @ np.linalg.inv(Hm)  # rows: (H^-T l)^T = l^T H^-1
        return (np.sum(li[:, :2] * pts, axis=1) + li[:, 2]) / np.linalg.norm(li[:, :2], axis=1)

    hv = H.ravel()[:8]
    r = res(hv)
    J = np.empty((len(r), 8))
    for i in range(8):
        dh = 1e-7 * max(1.0, abs(hv[i]))
        e = np.zeros(8)
        e[i] = dh
        J[:, i] = (res(hv + e) - res(hv - e)) / (2 * dh)
    return r, J


def detect_markers(image_bgr: np.ndarray, dictionary: str, *, refine: str = "grid",
                   camera: Camera | None = None) -> dict[int, np.ndarray]:
    """ArUco markers of one image: ``{marker_id: corners (4, 2) px}``.

    Parameters
    ----------
    image_bgr : (height, width, 3) uint8 array
        The frame (a grey (height, width) image is accepted too).
    dictionary : str
        A ``cv2.aruco`` predefined dictionary name, e.g. ``DICT_ARUCO_ORIGINAL``.
    refine : {"grid", "edges", "subpix", "contour", "apriltag", "none"}, keyword-only
        Corner refinement. ``edges``: OpenCV's ``CORNER_REFINE_SUBPIX``
        corners, then straight lines fitted to sub-pixel edge points of each side
        (see Notes); ``grid`` (the default): then one homography fitted to edge
        points on every black-white edge of the cells (``_refine_corners_grid``;
        a marker whose cells are under 4 px keeps its ``edges`` corners); the
        others are OpenCV's ``CORNER_REFINE_*`` methods alone.
    camera : Camera, optional, keyword-only
        With it, the ``edges`` refinement fits the sides in undistorted
        coordinates (lens distortion bends straight edges).

    Returns
    -------
    dict
        Corners in OpenCV order (top-left, top-right, bottom-right, bottom-left
        of the marker), observed (distorted) pixels, x = column. An id detected
        twice in the image is ambiguous and left out (with a warning), and so
        is an id of :func:`ambiguous_marker_ids`.

    Notes
    -----
    On frames rendered through the IJCV25 rig with lens distortion, blur 0.7-2 px
    and noise (benchmarks/bench_calibration.py ``corners``), the mean corner
    error is 0.013-0.022 px (max 0.05) with ``edges``, against 0.2-0.57 px for
    ``subpix``, 0.84-0.92 for ``contour`` and 0.66-0.70 for ``apriltag``
    (OpenCV's corners are biased, mostly outwards or inwards). A corner from
    two lines through ~100 edge points each averages the noise that a local
    corner fit sees, and the dilation correction (see ``_refine_corners_edges``)
    keeps it unbiased under a non-linear response (gamma 2.2: 0.01 px).
    It costs ~60 ms per 1920x1080 frame.

    ``grid`` on random phantom scenes (``bench_calibration.py scenes``): the
    corners' rms error against the truth falls by about a quarter (e.g. 0.035
    -> 0.029 px, 0.061 -> 0.040 px) and the calibrated rig's worst view on the
    tendril improves most where few, small markers carry it.
    """
    if refine not in REFINE_METHODS:
        raise ValueError(f"refine: expected one of {', '.join(REFINE_METHODS)}, got {refine!r}")
    dic = _dictionary(dictionary)
    grey = _grey(image_bgr)
    params = cv2.aruco.DetectorParameters()
    method = {"grid": cv2.aruco.CORNER_REFINE_SUBPIX, "edges": cv2.aruco.CORNER_REFINE_SUBPIX, "subpix": cv2.aruco.CORNER_REFINE_SUBPIX,
              "contour": cv2.aruco.CORNER_REFINE_CONTOUR, "apriltag": cv2.aruco.CORNER_REFINE_APRILTAG,
              "none": cv2.aruco.CORNER_REFINE_NONE}[refine]
    params.cornerRefinementMethod = method
    detector = cv2.aruco.ArucoDetector(dic, params)
    corners, ids, _ = detector.detectMarkers(grey)
    out: dict[int, np.ndarray] = {}
    if ids is None:
        return out
    ids = ids.ravel().astype(int)
    uniq, counts = np.unique(ids, return_counts=True)
    dup = set(uniq[counts > 1].tolist())
    if dup:
        warnings.warn(f"marker id(s) {sorted(dup)} detected more than once in one image; left out", stacklevel=2)
    symmetric = set(ids.tolist()) & ambiguous_marker_ids(dictionary)
    if symmetric:
        warnings.warn(f"marker id(s) {sorted(symmetric)} look the same turned (their corners' order is unknown); "
                      "left out", stacklevel=2)
        dup |= symmetric
    cells = dic.markerSize + 2
    found = {int(m): np.asarray(c, dtype=float).reshape(4, 2) for m, c in zip(ids, corners) if m not in dup}
    if refine not in ("edges", "grid"):
        return dict(sorted(found.items()))
    refined = {m: _refine_corners_edges(grey, c, cells=cells, camera=camera) for m, c in found.items()}
    # a marker with too few white cells along its border takes the image's dilation
    biases = [r[1] for r in refined.values() if r is not None and r[2] >= 10]
    for m, c in found.items():
        r = refined[m]
        bias = r[1] if r is not None and r[2] >= 10 else (float(np.median(biases)) if biases else 0.0)
        if r is not None and r[2] < 10 and biases:
            r = _refine_corners_edges(grey, c, cells=cells, camera=camera, bias=bias)
        out[m] = c if r is None else r[0]
        if refine == "grid" and r is not None:
            g = _refine_corners_grid(grey, r[0], _marker_cells(dic, m, cells), camera=camera, bias=bias)
            if g is not None:
                out[m] = g
    return dict(sorted(out.items()))



def average_detections(detections: list[dict[int, np.ndarray]], *, tol_px: float = 0.5) -> dict[int, np.ndarray]:
    """One view's markers over several frames of a static rig: ``{marker_id: corners (4, 2) px}``.

    The markers and cameras do not move between the frames, while sensor
    noise, flicker, motion blur and compression differ from frame to frame:
    the mean of a marker's corners over the frames that show it averages
    them out (their error falls about as one over the square root of the
    frames). A frame whose corners of that marker lie further than
    ``max(tol_px, 3 sigma)`` from the median corners (``sigma`` from the
    frames' median deviation) is left out of the mean (something passing over
    the marker, a frame of another scene); a marker seen in one frame only
    keeps that frame's corners.

    Parameters
    ----------
    detections : list of dict
        :func:`detect_markers` of each frame, ``{marker_id: corners (4, 2) px}``.
    tol_px : float, keyword-only
        Smallest deviation from the median corners (px, largest over the four
        corners) that leaves a frame out.

    Returns
    -------
    dict
        Every marker seen in at least one frame, sorted by id.

    Examples
    --------
    >>> c = np.array([[0.0, 0.0], [10.0, 0.0], [10.0, 10.0], [0.0, 10.0]])
    >>> out = average_detections([{7: c + 0.1}, {7: c - 0.1}, {7: c + 5.0}, {}])
    >>> np.round(out[7][0], 3).tolist()
    [0.0, 0.0]
    """
    if not detections:
        raise ValueError("detections: expected the markers of at least one frame")
    out: dict[int, np.ndarray] = {}
    for m in sorted(set().union(*[set(d) for d in detections])):
        C = np.array([d[m] for d in detections if m in d], dtype=float)  # (k, 4, 2)
        med = np.median(C, axis=0)
        dev = np.linalg.norm(C - med[None], axis=2).max(axis=1)
        keep = dev <= max(tol_px, 3.0 * 1.4826 * float(np.median(dev)))
        out[m] = C[keep].mean(axis=0)
    return out


#: The ``grid`` corners' error (px, per coordinate) on a marker of 100 px side seen face-on, corners averaged
#: over 5 frames, measured against the generator's true corners (``bench_calibration.py corner-noise``; see
#: :func:`corner_sigma_px`).
CORNER_SIGMA_PX = 0.014
#: How the corner error grows with the marker's foreshortening in the image (its aspect ratio) ...
CORNER_SIGMA_ASPECT_POWER = 3.0
#: ... above this aspect ratio (markers on the board seen obliquely, up to 1.35 in the site phantoms, keep
#: the face-on error).
CORNER_SIGMA_ASPECT_FREE = 1.35


def corner_sigma_px(corners_xy: np.ndarray) -> float:
    """The expected error (px, per coordinate) of a detected marker's corners, from their shape in the image.

    ``CORNER_SIGMA_PX * sqrt(100 / side) * max(1, aspect / CORNER_SIGMA_ASPECT_FREE) ** CORNER_SIGMA_ASPECT_POWER``
    with ``side`` the quadrilateral's mean side (px) and ``aspect`` the ratio of its longer to its shorter
    mid-line (1 face-on; 2-3.7 for a card seen at a glancing angle). The corners come from edge points along
    every cell edge (:func:`detect_markers`), as many as the marker is large, so their error falls as one over
    the square root of the side; a foreshortened marker has fewer, blurrier edge points across its short
    direction.

    Measured (``benchmarks/bench_calibration.py corner-noise``: dev seeds 0-69, 960 marker observations, the
    corners averaged over 5 frames as ``calibration.average_frames`` does, against the generator's true
    corners): per-coordinate rms 0.0132 px scaled to a side of 100 px for aspect ratios under 1.35 (927
    observations; median 0.010, 1 % of corners beyond 0.042 px; 0.014 under 1.4); over 1.35 (33, aspect up
    to 3.7, cards at a glancing angle) the error divided by this model has a median 0.9 times the face-on one
    and a heavier tail (rms 1.8 times). A single frame's corners are noisier: the adjustment's residuals
    then show it (:func:`~tendrilkit.calibration.bundle.bundle_adjust` takes the larger).

    Parameters
    ----------
    corners_xy : (4, 2) float array
        The corners, px.

    Returns
    -------
    float

    Examples
    --------
    >>> sq = np.array([[0.0, 0.0], [100.0, 0.0], [100.0, 100.0], [0.0, 100.0]])
    >>> bool(np.isclose(corner_sigma_px(sq), CORNER_SIGMA_PX))
    True
    >>> corner_sigma_px(sq * [1.0, 0.4]) > 3 * CORNER_SIGMA_PX
    True
    """
    return float(10.0 * CORNER_SIGMA_PX / corner_weight(corners_xy))


def corner_weight(corners_xy: np.ndarray) -> float:
    """``10 * CORNER_SIGMA_PX / corner_sigma_px``: the square root of the marker's mean side (px), divided by
    the foreshortening factor (1 up to an aspect ratio of ``CORNER_SIGMA_ASPECT_FREE``).

    What the bundle adjustment weighs a marker's corner residuals by (scaled to a root mean square of 1).

    Examples
    --------
    >>> corner_weight(np.array([[0.0, 0.0], [64.0, 0.0], [64.0, 64.0], [0.0, 64.0]]))
    8.0
    """
    c = np.asarray(corners_xy, float).reshape(4, 2)
    side = max(float(np.mean(np.linalg.norm(np.roll(c, -1, axis=0) - c, axis=1))), 1.0)
    m1 = float(np.linalg.norm((c[1] + c[2]) / 2 - (c[0] + c[3]) / 2))
    m2 = float(np.linalg.norm((c[2] + c[3]) / 2 - (c[0] + c[1]) / 2))
    aspect = max(m1, m2) / max(min(m1, m2), 1e-9)
    return float(np.sqrt(side) / max(1.0, aspect / CORNER_SIGMA_ASPECT_FREE) ** CORNER_SIGMA_ASPECT_POWER)
