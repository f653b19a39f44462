"""The only module that touches the disk: frames in, result files out.

Frames come from a video file (any container OpenCV reads) or a folder of
numbered images (``000000.png``, ...: the images sorted by the number at the
end of their names, frame ``k`` is the ``k``-th; a gap in the numbers is no
missing frame, so files named by timestamps work). Result files are written
atomically: to a temporary file in the same folder, then renamed over the
target, so an interrupted run never leaves a half-written file; they get the
permissions the user's umask gives a new file (``0o666 & ~umask``). A write
that fails (disk full...) raises :class:`OutputWriteError` naming the file.
"""

from __future__ import annotations

import errno
import hashlib
import json
import os
import re
import tempfile
from dataclasses import dataclass
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING, Iterator

import numpy as np

from tendrilkit.exceptions import ExperimentError, FrameReadError, OutputWriteError
from tendrilkit.schema import FRAMES_HEAD, RESULT_TABLES, Table, frames_table

if TYPE_CHECKING:  # cv2, the camera (numba) and pandas are imported where frames, cameras or tables are
    import cv2  # read: the fit command reads and writes its tables without them (io.columns), and its
    import pandas as pd  # start-up is part of its time

    from tendrilkit.camera import Camera

IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff")
#: A video read jumping forward by at most this many frames steps over them with
#: ``grab()`` (no BGR image made); a longer jump, or one backwards, seeks.
MAX_GRAB_FRAMES = 64


class FrameSource:
    """Random access to the frames of one view (video file or image folder).

    Frames are BGR ``uint8`` arrays of shape ``(height, width, 3)``.
    Reading frames in increasing order with gaps (``frames.step`` > 1) steps
    over the skipped frames of a video with ``grab()`` (no image made), up to
    :data:`MAX_GRAB_FRAMES` ahead; an image folder reads only the frames asked.
    Opening checks the source and raises :class:`ExperimentError` naming the
    file when it is not a readable video; reading a frame that is missing or
    broken raises :class:`FrameReadError` (the frame fails, the run goes on).
    """

    def __init__(self, path: str | Path) -> None:
        import cv2

        self.path = Path(path)
        self._cap: cv2.VideoCapture | None = None
        self._next = 0
        self._files: list[Path] | None = None
        if not self.path.exists():
            raise ExperimentError(f"{self.path}: video not found")
        if not (self.path.is_dir() or self.path.is_file()):  # a device or a pipe (/dev/zero) would never end
            raise ExperimentError(f"{self.path}: expected a video file or a folder of numbered images, got a "
                                  f"special file")
        if self.path.is_dir():
            files = [p for p in self.path.iterdir() if p.suffix.lower() in IMAGE_SUFFIXES]
            numbered = [(int(m.group(1)), p) for p in files if (m := re.search(r"(\d+)$", p.stem))]
            if not numbered:
                raise ExperimentError(f"{self.path}: expected a folder of numbered images (000000.png, ...), found none")
            # frame k is the k-th image in the order of the numbers (then names): never a list up to the
            # largest number (images named by timestamps)
            numbered.sort(key=lambda t: (t[0], t[1].name))
            self._files = [p for _, p in numbered]
            first = self._files[0]
            img = cv2.imread(str(first), cv2.IMREAD_COLOR)
            if img is None:
                raise ExperimentError(f"{first}: cannot decode the image")
            self.height, self.width = img.shape[:2]
            self.frame_count = len(self._files)
            self.fps = None
        else:
            cap = cv2.VideoCapture(str(self.path))
            ok, img = (cap.read() if cap.isOpened() else (False, None))
            if not ok or img is None:
                cap.release()
                raise ExperimentError(f"{self.path}: not a video OpenCV can decode")
            self.height, self.width = img.shape[:2]
            self.frame_count = int(cap.get(cv2.CAP_PROP_FRAME_COUNT))
            fps = cap.get(cv2.CAP_PROP_FPS)
            self.fps = float(fps) if fps and fps > 0 else None
            self._cap = cap
            self._next = 1
            self._first = img

    def read(self, index: int) -> np.ndarray:
        """Frame ``index`` (0-based) as BGR uint8 (height, width, 3)."""
        import cv2

        if index < 0:
            raise FrameReadError(f"{self.path.name}: frame {index} is negative")
        if self._files is not None:
            if index >= len(self._files):
                raise FrameReadError(f"{self.path.name}: frame {index} is missing (the folder has {len(self._files)} images)")
            img = cv2.imread(str(self._files[index]), cv2.IMREAD_COLOR)
            if img is None:
                raise FrameReadError(f"{self._files[index].name}: frame {index} cannot be decoded")
            if img.shape[:2] != (self.height, self.width):
                raise FrameReadError(f"{self._files[index].name}: frame {index} is {img.shape[1]}x{img.shape[0]}, expected {self.width}x{self.height}")
            return img
        if self._cap is None:
            raise FrameReadError(f"{self.path.name}: frame {index} cannot be read (the source is closed)")
        if index == 0 and self._first is not None and self._next == 1:
            return self._first.copy()
        if 0 < self._next < index <= self._next + MAX_GRAB_FRAMES:
            # a short jump forward (frames.step > 1): step over the frames with grab(),
            # which demuxes (and, for inter-frame codecs, decodes) without converting
            # them to BGR images; a seek would decode again from the previous key frame
            while self._next < index:
                if not self._cap.grab():
                    self._next = -1
                    raise FrameReadError(f"{self.path.name}: frame {index} cannot be read (the video has {self.frame_count} frames)")
                self._next += 1
        elif index != self._next:
            self._cap.set(cv2.CAP_PROP_POS_FRAMES, index)
        ok, img = self._cap.read()
        if not ok or img is None:
            self._next = -1
            raise FrameReadError(f"{self.path.name}: frame {index} cannot be read (the video has {self.frame_count} frames)")
        self._next = index + 1
        return img

    def close(self) -> None:
        if self._cap is not None:
            self._cap.release()
            self._cap = None

    def __enter__(self) -> "FrameSource":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def open_views(paths: list[Path]) -> list[FrameSource]:
    """One :class:`FrameSource` per view; the first unreadable one raises."""
    sources: list[FrameSource] = []
    try:
        for p in paths:
            sources.append(FrameSource(p))
    except ExperimentError:
        for s in sources:
            s.close()
        raise
    return sources


def write_video(frames, path: str | Path, *, fps: float = 10.0) -> int:
    """Write BGR uint8 frames as a video (``.mp4``: mp4v, ``.avi``: MJPG) or, for a
    path without a suffix, a folder of numbered PNG images (``000000.png``, ...).

    Returns the number of frames written. The file appears only when complete.
    """
    import cv2

    path = Path(path)
    n = 0
    if not path.suffix:
        path.mkdir(parents=True, exist_ok=True)
        for n, img in enumerate(frames, start=1):
            with atomic_path(path / f"{n - 1:06d}.png") as tmp:
                if not cv2.imwrite(str(tmp.with_suffix(".png")), img):
                    raise ExperimentError(f"{path}: cannot write frame {n - 1}")
                tmp.with_suffix(".png").replace(tmp)
        return n
    fourcc = {".mp4": "mp4v", ".mov": "mp4v", ".avi": "MJPG"}.get(path.suffix.lower())
    if fourcc is None:
        raise ExperimentError(f"{path}: expected a .mp4, .mov or .avi file, or a folder (no suffix)")
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.stem}.partial{path.suffix}")
    writer = None
    try:
        for img in frames:
            if writer is None:
                writer = cv2.VideoWriter(str(tmp), cv2.VideoWriter_fourcc(*fourcc), float(fps), (img.shape[1], img.shape[0]))
                if not writer.isOpened():
                    raise ExperimentError(f"{path}: OpenCV cannot write {fourcc} video here")
            writer.write(img)
            n += 1
    finally:
        if writer is not None:
            writer.release()
    if n:
        tmp.replace(path)
    return n


# ---------------------------------------------------------------- atomic writes
def current_umask() -> int:
    """The process's umask (read without changing it where /proc allows)."""
    try:
        with open("/proc/self/status", encoding="ascii") as f:
            for line in f:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except (OSError, ValueError):
        pass
    old = os.umask(0o022)
    os.umask(old)
    return old


#: errno values that mean "the output cannot be written" (not a bug): exit code 74.
WRITE_ERRNOS = (errno.ENOSPC, errno.EDQUOT, errno.EROFS, errno.EACCES, errno.EPERM, errno.EIO, errno.EFBIG)


def write_error(path: Path, e: OSError) -> OutputWriteError:
    """The one-line error of a failed write of ``path``."""
    why = e.strerror or str(e) or type(e).__name__
    return OutputWriteError(f"{path}: cannot write ({why})")


@contextmanager
def atomic_path(path: str | Path) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; on success rename it over ``path``.

    The file gets the mode a new file gets under the umask (``0o666 & ~umask``;
    ``mkstemp`` alone makes it 0600). An ``OSError`` of the disk (full, quota,
    read-only, permission) becomes :class:`OutputWriteError` naming ``path``;
    the previous file, if any, is left as it was.
    """
    path = Path(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
        os.close(fd)
    except OSError as e:
        raise write_error(path, e) from None
    tmp_path = Path(tmp)
    try:
        try:
            yield tmp_path
            os.chmod(tmp_path, 0o666 & ~current_umask())
            os.replace(tmp_path, path)
        except OutputWriteError:
            raise
        except OSError as e:
            if e.errno in WRITE_ERRNOS:
                raise write_error(path, e) from None
            raise
    finally:
        if tmp_path.exists():
            tmp_path.unlink()


#: How every result CSV prints a float: ``None``, the shortest text that reads back as the same
#: double (Python's ``repr``), so no law loses a digit at any magnitude (README "Results").
FLOAT_FORMAT: str | None = None


def write_csv(df: pd.DataFrame, path: str | Path, *, float_format: str | None = FLOAT_FORMAT) -> None:
    """Write a table atomically, without index, floats as :data:`FLOAT_FORMAT` (exact round trip).

    ``float_format`` (e.g. ``"%.10g"``) is for tables meant for readers, not for result files.
    """
    with atomic_path(path) as tmp:
        df.to_csv(tmp, index=False, float_format=float_format, lineterminator="\n")


def _check_columns(got: tuple[str, ...], table: Table) -> None:
    if got != table.columns:
        missing = [c for c in table.columns if c not in got]
        extra = [c for c in got if c not in table.columns]
        why = (f"missing {missing}" if missing else f"unexpected {extra}" if extra else "columns out of order")
        raise ValueError(f"{table.name}: columns differ from tendrilkit.schema ({why})")


def write_result(df: pd.DataFrame, path: str | Path, table: Table) -> None:
    """Write a result table atomically, after checking its columns against its schema.

    Parameters
    ----------
    df : DataFrame
        Columns exactly ``table.columns``, in that order.
    path : path of the CSV file
    table : :class:`tendrilkit.schema.Table`

    Raises
    ------
    ValueError
        When the columns differ from the schema's (a bug of the producer, not
        of the user's input): names the table and the first difference.
    """
    _check_columns(tuple(map(str, df.columns)), table)
    write_csv(df, path)


def write_json(obj, path: str | Path) -> None:
    """Write JSON atomically, keys in the given order, 2-space indent."""
    with atomic_path(path) as tmp:
        tmp.write_text(json.dumps(obj, indent=2) + "\n", encoding="utf-8")


def write_text(text: str, path: str | Path) -> None:
    with atomic_path(path) as tmp:
        tmp.write_text(text, encoding="utf-8")


def read_text(path: str | Path) -> str:
    """A text file (UTF-8); a missing or unreadable file is an :class:`ExperimentError`."""
    path = Path(path)
    try:
        return path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as e:
        raise ExperimentError(f"{path}: cannot read the file ({e.__class__.__name__})") from None


def read_csv(path: str | Path, *, required: tuple[str, ...] = (), table: Table | None = None) -> pd.DataFrame:
    """Read a result table; a missing file or column is an :class:`ExperimentError`.

    With ``table`` (a :class:`tendrilkit.schema.Table`), every column of the
    schema is required and its ``float`` columns are read as floats (a column
    whose values all print as integers stays a float column).
    """
    path = Path(path)
    if table is not None:
        required = tuple(required) + tuple(c for c in table.columns if c not in required)
    if not path.is_file():
        raise ExperimentError(f"{path}: file not found")
    import pandas as pd

    try:
        df = pd.read_csv(path)
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError) as e:
        raise ExperimentError(f"{path}: not a readable CSV table ({str(e).splitlines()[0]})") from None
    missing = [c for c in required if c not in df.columns]
    if missing:
        raise ExperimentError(f"{path}: missing column(s) {', '.join(missing)}; expected {', '.join(required)}")
    return _floats_as_float(df, table) if table is not None else df


def _floats_as_float(df: pd.DataFrame, table: Table) -> pd.DataFrame:
    """``df`` with the ``float`` columns of ``table`` it has as float (a column of whole numbers
    written by another program, or a table without rows, is read with another type)."""
    for c in table.of_kind("float"):
        if c in df.columns and (df[c].dtype.kind in "iu" or len(df) == 0):
            df[c] = df[c].astype(float)
    return df


def check_writable_dir(path: str | Path) -> Path:
    """Create ``path`` if needed and check that files can be written in it.

    The error names what is wrong: an existing file where the folder should
    be, a file among its parents, or a parent that does not accept new files.
    """
    path = Path(path)
    if path.exists() and not path.is_dir():
        raise ExperimentError(f"{path}: output folder cannot be made: an existing file has this name; "
                              f"expected a folder (or a new name)")
    parent = path
    while not parent.exists() and parent != parent.parent:
        parent = parent.parent
    if parent != path and not parent.is_dir():
        raise ExperimentError(f"{path}: output folder cannot be made: {parent} is a file, not a folder")
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise ExperimentError(f"{path}: output folder cannot be made: {parent} does not accept new folders "
                              f"({e.strerror or type(e).__name__}); expected a folder where you can write") from None
    try:
        fd, tmp = tempfile.mkstemp(prefix=".write-test.", dir=path)
        os.close(fd)
        os.unlink(tmp)
    except OSError as e:
        raise ExperimentError(f"{path}: output folder cannot be written ({e.strerror or type(e).__name__})") from None
    return path


# ------------------------------------------------------------ resume records
def file_stamp(path: str | Path, *, sample_bytes: int = 1 << 16, n_samples: int = 16) -> dict:
    """What identifies an input file or image folder cheaply, for resuming.

    A file: its size, modification time (ns) and the SHA-256 of ``n_samples``
    blocks of ``sample_bytes`` spread evenly over it (first and last block
    included): a file replaced by another of the same size is noticed. A
    folder: the same for every file in it (sorted by name; the blocks are 4 kB
    from the start and the end of each file).
    """
    path = Path(path)
    if not (path.is_dir() or path.is_file()):
        raise ExperimentError(f"{path}: expected a video file or a folder of numbered images, got a special file")
    if path.is_dir():
        h = hashlib.sha256()
        for f in sorted(path.iterdir()):
            if f.is_file():
                st = f.stat()
                h.update(f"{f.name}\0{st.st_size}\0{st.st_mtime_ns}\0".encode())
                h.update(_sampled_digest(f, st.st_size, 4096, 2).encode())
        return {"folder": True, "digest": h.hexdigest()}
    st = path.stat()
    return {"bytes": st.st_size, "mtime_ns": st.st_mtime_ns,
            "sample_sha256": _sampled_digest(path, st.st_size, sample_bytes, n_samples)}


def _sampled_digest(path: Path, size: int, block: int, n: int) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        if size <= block * n:
            h.update(f.read())
        else:
            for k in range(n):
                f.seek((size - block) * k // (n - 1))
                h.update(f.read(block))
    return h.hexdigest()


def _result_checksum(fingerprint: str, frame: int, result: dict) -> str:
    text = json.dumps({"fingerprint": fingerprint, "frame": int(frame), "result": result}, sort_keys=True,
                      allow_nan=True)
    return hashlib.sha256(text.encode()).hexdigest()


def write_frame_record(path: str | Path, fingerprint: str, frame: int, result: dict) -> None:
    """One finished frame's file: the run's fingerprint, the frame number, the result and their checksum.

    Compact JSON (one line): written for every frame, read back only by a
    resumed run; the indented form costs twice the time (Python's JSON
    encoder is compiled only without indentation).
    """
    record = {"fingerprint": fingerprint, "frame": int(frame),
              "checksum": _result_checksum(fingerprint, frame, result), "result": result}
    with atomic_path(path) as tmp:
        tmp.write_text(json.dumps(record, separators=(",", ":")) + "\n", encoding="utf-8")


def read_frame_record(path: str | Path, fingerprint: str, frame: int) -> dict | None:
    """The result stored for ``frame`` by a run of ``fingerprint``, or None.

    None when the file is missing, unreadable, truncated, of another run, of
    another frame (a file copied over another) or edited (the checksum does
    not verify): the frame is then recomputed.
    """
    try:
        path = Path(path)
        if not path.is_file() or path.stat().st_size > 50_000_000:
            return None
        d = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    if not isinstance(d, dict) or d.get("fingerprint") != fingerprint or d.get("frame") != frame:
        return None
    result = d.get("result")
    if not isinstance(result, dict) or result.get("frame") != frame:
        return None
    try:
        if d.get("checksum") != _result_checksum(fingerprint, frame, result):
            return None
    except (TypeError, ValueError):
        return None
    return result


# ---------------------------------------------------------------- cameras.json
def write_cameras(cameras: list[Camera], path: str | Path, *, quality: list[dict] | None = None) -> None:
    """``cameras.json``: one object per view, view order (EXPERIMENT_FORMAT.md).

    ``quality``: per view, extra keys appended to its object (the rig's
    assessment, ``CalibrationResult.view_quality``: ``rig_spread_px``,
    ``rig_flagged``); readers ignore keys they do not know.
    """
    entries = [cam.to_dict(i + 1) for i, cam in enumerate(cameras)]
    for e, q in zip(entries, quality or []):
        e.update(q)
    write_json(entries, path)


def read_cameras(path: str | Path) -> list[Camera]:
    from tendrilkit.camera import Camera

    path = Path(path)
    if not path.is_file():
        raise ExperimentError(f"{path}: cameras file not found")
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
        return [Camera.from_dict(d) for d in sorted(data, key=lambda d: d["view"])]
    except (json.JSONDecodeError, UnicodeDecodeError, KeyError, TypeError, ValueError, AttributeError):
        raise ExperimentError(f"{path}: not a cameras.json file (expected a JSON list of objects with view, K, "
                              f"dist, R, t_mm)") from None


# ------------------------------------------------------ the authors' data layout
def read_ijcv25_extrinsics(path: str | Path) -> dict[str, np.ndarray]:
    """One ``CamExtrPara_Corners*.csv`` of the authors (see data/ijcv25_rig/README.md).

    Returns arrays with one row per video frame: ``frame`` (n,), ``marker_id``
    (n,), ``corners_xy`` (n, 4, 2) pixels, ``R`` (n, 3, 3) marker-to-camera
    rotation and ``t_mm`` (n, 3) marker-to-camera translation in mm.
    """
    path = Path(path)
    if not path.is_file():
        raise ExperimentError(f"{path}: extrinsics file not found")
    expected = "expected rows of 22 comma-separated numbers (ijcv25 layout, data/ijcv25_rig/README.md)"
    if path.stat().st_size > 100_000_000:
        raise ExperimentError(f"{path}: not an ijcv25 extrinsics CSV (larger than 100 MB); {expected}")
    # the messages name the file and what was expected, never its content (it may be any file)
    try:
        a = np.loadtxt(path, delimiter=",", ndmin=2)
    except (ValueError, UnicodeDecodeError):
        raise ExperimentError(f"{path}: not an ijcv25 extrinsics CSV; {expected}") from None
    if a.ndim != 2 or a.shape[1] != 22 or a.shape[0] == 0:
        raise ExperimentError(f"{path}: {expected}, got {a.shape[0]} rows of {a.shape[1] if a.ndim == 2 else 0}")
    if not np.all(np.isfinite(a)):
        raise ExperimentError(f"{path}: {expected}; found a value that is not a finite number")
    M = a[:, 13:22].reshape(-1, 3, 3)
    return {
        "frame": a[:, 0].astype(int),
        "marker_id": a[:, 1].astype(int),
        "corners_xy": a[:, 2:10].reshape(-1, 4, 2),
        "R": np.transpose(M, (0, 2, 1)),
        "t_mm": -a[:, 10:13] * 1000.0,
    }


def read_ijcv25_intrinsics(path: str | Path) -> dict:
    """The rig's ``intrinsics.yaml`` as a mapping (image_size, fps, marker, cameras)."""
    import yaml

    return yaml.safe_load(Path(path).read_text(encoding="utf-8"))


# ---------------------------------------------------------------- figures
#: Metadata that makes matplotlib's files byte-stable (no dates, fixed software).
_FIGURE_METADATA = {
    "svg": {"Date": None, "Creator": "tendrilkit"},
    "pdf": {"CreationDate": None, "ModDate": None, "Creator": "tendrilkit", "Producer": "tendrilkit"},
    "png": {"Software": "tendrilkit"},
}


def save_figure(fig, stem: str | Path, *, formats: tuple[str, ...] | None = None, dpi: float = 300.0) -> list[Path]:
    """Save a figure of :mod:`tendrilkit.plotting` as ``stem.<format>``, byte-stable, atomically.

    Parameters
    ----------
    fig : matplotlib Figure or plotly Figure
    stem : path without suffix
    formats : tuple of str, optional
        matplotlib: any of ``svg, pdf, png`` (default all three); plotly:
        ``html`` (default; plotly.js embedded, works offline, fixed div id) and
        ``json``. Static plotly export needs a browser and is not offered.
    dpi : float
        Raster resolution (png), and the resolution of rasterised parts of svg/pdf.

    Returns
    -------
    list of Path, the files written.

    Notes
    -----
    Identical figures give identical bytes: ``svg.hashsalt`` fixed, no date
    in SVG/PDF metadata, fixed ``Software`` in PNG; plotly HTML gets a div id
    derived from the file name instead of a random one.
    """
    stem = Path(stem)
    out: list[Path] = []
    if hasattr(fig, "savefig"):  # matplotlib
        import matplotlib  # lazy: io does not draw, it only asks the figure to write itself

        fmts = tuple(formats) if formats is not None else ("svg", "pdf", "png")
        bad = [f for f in fmts if f not in _FIGURE_METADATA]
        if bad:
            raise ValueError(f"formats: {bad} not supported for a matplotlib figure; expected svg, pdf, png")
        with matplotlib.rc_context({"svg.hashsalt": "tendrilkit", "svg.fonttype": "path", "pdf.fonttype": 42}):
            for fmt in fmts:
                path = stem.with_name(f"{stem.name}.{fmt}")
                with atomic_path(path) as tmp:
                    fig.savefig(tmp, format=fmt, dpi=dpi, metadata=_FIGURE_METADATA[fmt])
                out.append(path)
    elif hasattr(fig, "to_html"):  # plotly
        fmts = tuple(formats) if formats is not None else ("html",)
        bad = [f for f in fmts if f not in ("html", "json")]
        if bad:
            raise ValueError(f"formats: {bad} not supported for a plotly figure (no static export here); expected html, json")
        for fmt in fmts:
            path = stem.with_name(f"{stem.name}.{fmt}")
            if fmt == "html":
                div_id = re.sub(r"[^A-Za-z0-9_-]", "-", stem.name) or "figure"
                text = fig.to_html(include_plotlyjs=True, full_html=True, div_id=div_id)
            else:
                text = fig.to_json(pretty=True)
            write_text(text, path)
            out.append(path)
    else:
        raise TypeError(f"fig must be a matplotlib or plotly figure, got {type(fig).__name__}")
    return out


@dataclass(frozen=True, eq=False)
class Results:
    """The result files of one ``reconstruct`` (or ``fit``) run; absent tables are ``None``.

    Tables as written (EXPERIMENT_FORMAT.md and the README): ``curves``,
    ``pwc_curves``, ``frames``, ``reprojection``, ``ordering``,
    ``pwc_segments``, ``pwc_metrics``, ``calibration_markers``; ``cameras``
    from ``cameras.json``.
    """

    folder: Path
    curves: pd.DataFrame | None
    pwc_curves: pd.DataFrame | None
    frames: pd.DataFrame | None
    reprojection: pd.DataFrame | None
    ordering: pd.DataFrame | None
    pwc_segments: pd.DataFrame | None
    pwc_metrics: pd.DataFrame | None
    calibration_markers: pd.DataFrame | None
    cameras: list[Camera] | None


def read_results(folder: str | Path) -> Results:
    """Read every result table present in ``folder``."""
    folder = Path(folder)
    if not folder.is_dir():
        raise ExperimentError(f"{folder}: results folder not found (run `python -m tendrilkit reconstruct` first)")

    def opt(name: str) -> pd.DataFrame | None:
        p = folder / f"{name}.csv"
        if not p.is_file():
            return None
        if name != "frames":
            return read_csv(p, table=RESULT_TABLES[p.name])
        df = read_csv(p, table=FRAMES_HEAD)  # its quality columns depend on the number of views
        n_views = sum(str(c).startswith("tri_err_px_v") for c in df.columns)
        return _floats_as_float(df, frames_table(n_views))

    cams = folder / "cameras.json"
    return Results(
        folder=folder,
        curves=opt("curves"),
        pwc_curves=opt("pwc_curves"),
        frames=opt("frames"),
        reprojection=opt("reprojection"),
        ordering=opt("ordering"),
        pwc_segments=opt("pwc_segments"),
        pwc_metrics=opt("pwc_metrics"),
        calibration_markers=opt("calibration_markers"),
        cameras=read_cameras(cams) if cams.is_file() else None,
    )


def read_frames(exp, frame: int) -> list[np.ndarray]:
    """Frame ``frame`` (0-based) of every view of an experiment, BGR uint8."""
    sources = open_views(list(exp.videos))
    try:
        return [s.read(frame) for s in sources]
    finally:
        for s in sources:
            s.close()


def read_first_frames(exp) -> list[np.ndarray]:
    """The first processed frame (``frames.start``) of every view: where the marks are made."""
    return read_frames(exp, exp.frames.start)
