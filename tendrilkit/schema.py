"""Every result file's columns and their types: EXPERIMENT_FORMAT.md in code.

One :class:`Table` per result file (and per table of the sequence
analyses): the columns in the order they are written and the kind of each.
Writers (:func:`tendrilkit.io.write_result`), readers
(:func:`tendrilkit.io.read_results`) and the analyses
(:mod:`tendrilkit.sequence`) take the names from here; nothing else spells a
column list. Extend a table only by adding columns at its end (the files are
an interface: a column is never renamed).

Kinds
-----
``int``
    Integer, never empty (frame, view, point indices: 0-based except
    ``view``, 1-based as in the experiment file).
``Int``
    Integer or empty (pandas ``Int64``: a count of a failed frame).
``float``
    Real number or empty (NaN); units in the column name (``_mm``, ``_px``,
    ``_s``, ``_pct``) or dimensionless.
``bool``
    ``True``/``False`` or empty.
``str``
    Text, possibly empty.

Examples
--------
>>> CURVES.columns
('frame', 'time_s', 'point', 'x_mm', 'y_mm', 'z_mm')
>>> CURVES.kind("x_mm")
'float'
>>> REPROJECTION.require("frame", "mean_px")
('frame', 'mean_px')
>>> frames_columns(1)[:5]
('frame', 'time_s', 'status', 'message', 'views_used')
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = [
    "KINDS", "Table", "CURVES", "PWC_CURVES", "REPROJECTION", "ORDERING", "PWC_SEGMENTS", "PWC_METRICS",
    "CALIBRATION_MARKERS", "FRAMES_HEAD", "frames_table", "frames_columns", "quality_columns",
    "FRAME_RECORD_KEYS", "FRAME_FILE_KEYS", "RESULT_TABLES",
    "SHAPE_CHANGE", "SPLIT_POINTS", "SEGMENT_COUNTS", "TIP_TRAJECTORY", "REGION_RESPONSE", "TABLE1",
    "TABLE3", "SITE_COMPARISON", "SECTIONS", "STATUSES",
]

#: The kinds a column may have (module notes).
KINDS = ("int", "Int", "float", "bool", "str")
#: Sections of a curve in the reprojection tables (paper Table 1: base and tip quarters, entire).
SECTIONS = ("base", "tip", "entire")
#: A frame's status in ``frames.csv`` and ``pwc_metrics.csv``.
STATUSES = ("ok", "doubtful", "failed")


@dataclass(frozen=True)
class Table:
    """The columns of one table, in order, with their kinds.

    Attributes
    ----------
    name : str
        The file name (``curves.csv``) or, for an analysis table, the
        function that makes it.
    columns : tuple of str
        Column names in the order they are written.
    kinds : tuple of str
        The kind of each column (one of :data:`KINDS`), same order.
    """

    name: str
    columns: tuple[str, ...]
    kinds: tuple[str, ...]

    def __post_init__(self) -> None:
        if len(self.columns) != len(self.kinds):
            raise ValueError(f"{self.name}: {len(self.columns)} columns but {len(self.kinds)} kinds")
        bad = [k for k in self.kinds if k not in KINDS]
        if bad:
            raise ValueError(f"{self.name}: unknown kind(s) {bad}; expected one of {KINDS}")
        if len(set(self.columns)) != len(self.columns):
            raise ValueError(f"{self.name}: a column is listed twice")

    def kind(self, column: str) -> str:
        """The kind of ``column``; a column not in the table is a ``KeyError`` naming it."""
        try:
            return self.kinds[self.columns.index(column)]
        except ValueError:
            raise KeyError(f"{self.name}: no column {column!r}; columns are {', '.join(self.columns)}") from None

    def require(self, *columns: str) -> tuple[str, ...]:
        """``columns``, checked to be columns of this table (what an analysis reads of it)."""
        for c in columns:
            self.kind(c)
        return tuple(columns)

    def of_kind(self, *kinds: str) -> tuple[str, ...]:
        """The columns of the given kinds, in table order."""
        return tuple(c for c, k in zip(self.columns, self.kinds) if k in kinds)


def _table(name: str, *pairs: tuple[str, str]) -> Table:
    return Table(name, tuple(c for c, _ in pairs), tuple(k for _, k in pairs))


# ------------------------------------------------------------ result files of reconstruct / fit
_CURVE = (("frame", "int"), ("time_s", "float"), ("point", "int"),
          ("x_mm", "float"), ("y_mm", "float"), ("z_mm", "float"))
#: ``curves.csv``: the reconstructed centreline, point 0 = base, world frame, mm.
CURVES = _table("curves.csv", *_CURVE)
#: ``pwc_curves.csv``: the piece-wise clothoid registered onto the centreline (same columns).
PWC_CURVES = _table("pwc_curves.csv", *_CURVE)
#: ``reprojection.csv``: distance of the projected centreline to each view's skeleton (paper Table 1).
REPROJECTION = _table("reprojection.csv", ("frame", "int"), ("view", "int"), ("section", "str"),
                      ("mean_px", "float"), ("std_px", "float"), ("max_px", "float"), ("n_points", "int"))
#: ``ordering.csv``: the skeleton ordering's decisions at junctions (``candidates``: JSON list of [branch, angle]).
ORDERING = _table("ordering.csv", ("frame", "int"), ("view", "int"), ("junction", "int"),
                  ("junction_x_px", "float"), ("junction_y_px", "float"), ("candidates", "str"),
                  ("chosen", "int"), ("method", "str"))
#: ``pwc_segments.csv``: the piece-wise linear laws, ``kind`` kappa or tau, values 1/mm.
PWC_SEGMENTS = _table("pwc_segments.csv", ("frame", "int"), ("kind", "str"), ("segment", "int"),
                      ("s0_mm", "float"), ("s1_mm", "float"), ("value_s0", "float"), ("value_s1", "float"))
#: ``pwc_metrics.csv``: one row per frame of the fit (paper Table 3 figures).
PWC_METRICS = _table(
    "pwc_metrics.csv", ("frame", "int"), ("time_s", "float"), ("status", "str"), ("message", "str"),
    ("n_points", "Int"), ("length_mm", "float"), ("penalty_kappa", "float"), ("penalty_tau", "float"),
    ("n_kappa", "Int"), ("n_tau", "Int"), ("r2_entire", "float"), ("r2_base", "float"), ("r2_tip", "float"),
    ("sse_entire_mm2", "float"), ("sse_base_mm2", "float"), ("sse_tip_mm2", "float"), ("rmse_mm", "float"),
    ("max_error_mm", "float"), ("tau_undefined_fraction", "float"))
#: ``calibration_markers.csv``: the markers of the rig, their residuals and positions (world frame, mm).
CALIBRATION_MARKERS = _table(
    "calibration_markers.csv", ("view", "int"), ("marker_id", "int"), ("stage", "str"), ("mean_px", "float"),
    ("max_px", "float"), ("n_corners", "int"), ("x_mm", "float"), ("y_mm", "float"), ("z_mm", "float"),
    ("length_mm", "float"))

#: The first columns of ``frames.csv``, whatever the number of views.
FRAMES_HEAD = _table("frames.csv", ("frame", "int"), ("time_s", "float"), ("status", "str"), ("message", "str"))
def quality_columns(n_views: int) -> list[str]:
    """The quality columns of ``frames.csv`` (after :data:`FRAMES_HEAD`), in order, for ``n_views`` views.

    ``views_used`` (views whose 2D stage succeeded), ``n_matched`` (reference
    points matched and triangulated), ``base_extended`` (the curve was
    extended to the triangulated base marks), ``length_mm`` (centreline length),
    ``reproj_mean_px_v<i>`` / ``reproj_std_px_v<i>`` / ``reproj_max_px_v<i>``
    (distance of the projected centreline to view i's skeleton, entire
    tendril), ``tri_err_px_v<i>`` (mean reprojection error of the matched
    points at triangulation), ``pwc_r2``, ``pwc_sse_mm2``, ``pwc_rmse_mm``,
    ``pwc_segments_kappa``, ``pwc_segments_tau``, ``n_crossings_v<i>``; then
    the checks of :mod:`tendrilkit.verify`: ``views_checked``,
    ``length_change_pct``, ``shape_change_mm``, ``dt_prev_s`` and per view
    ``on_tendril_frac_v<i>``, ``off_tendril_max_px_v<i>``,
    ``skeleton_mean_px_v<i>``, ``coverage_frac_v<i>``,
    ``tip_continuation_px_v<i>``, ``base_on_tendril_frac_v<i>``, ``base_px_v<i>``.
    """
    cols = ["views_used", "n_matched", "base_extended", "length_mm"]
    for v in range(1, n_views + 1):
        cols += [f"reproj_mean_px_v{v}", f"reproj_std_px_v{v}", f"reproj_max_px_v{v}"]
    cols += [f"tri_err_px_v{v}" for v in range(1, n_views + 1)]
    cols += ["pwc_r2", "pwc_sse_mm2", "pwc_rmse_mm", "pwc_segments_kappa", "pwc_segments_tau"]
    cols += [f"n_crossings_v{v}" for v in range(1, n_views + 1)]
    from tendrilkit.verify import VERIFY_COLUMNS_FRAME, view_columns  # the checks own their columns

    cols += list(VERIFY_COLUMNS_FRAME) + view_columns(n_views)
    return cols


def frames_table(n_views: int) -> Table:
    """``frames.csv`` of a run with ``n_views`` views: :data:`FRAMES_HEAD` then :func:`quality_columns`."""
    q = quality_columns(n_views)
    ints = {"views_used", "views_checked", "n_matched", "pwc_segments_kappa", "pwc_segments_tau"}
    ints |= {f"n_crossings_v{v}" for v in range(1, n_views + 1)}
    kinds = ["Int" if c in ints else "bool" if c == "base_extended" else "float" for c in q]
    return Table("frames.csv", FRAMES_HEAD.columns + tuple(q), FRAMES_HEAD.kinds + tuple(kinds))


def frames_columns(n_views: int) -> tuple[str, ...]:
    """The columns of ``frames.csv`` for ``n_views`` views, in order."""
    return frames_table(n_views).columns


#: The CSV files of a ``reconstruct`` run with a fixed layout (``frames.csv``: :func:`frames_table`).
RESULT_TABLES = {t.name: t for t in (CURVES, PWC_CURVES, REPROJECTION, ORDERING, PWC_SEGMENTS, PWC_METRICS,
                                     CALIBRATION_MARKERS)}

#: Keys of a finished frame's result in ``frames/frame_NNNNNN.json`` (``FrameResult.to_json``), in order.
FRAME_RECORD_KEYS = ("frame", "time_s", "status", "message", "points_mm", "pwc_mm", "quality", "reprojection",
                     "decisions", "centroids", "n_components", "pwc_segments", "pwc_metrics", "checks")
#: Keys of a ``frames/frame_NNNNNN.json`` file (:func:`tendrilkit.io.write_frame_record`), in order.
FRAME_FILE_KEYS = ("fingerprint", "frame", "checksum", "result")

# ------------------------------------------------------------ tables of the sequence analyses
#: :func:`tendrilkit.sequence.shape_change`.
SHAPE_CHANGE = _table("shape_change", ("frame", "int"), ("time_s", "float"), ("mean_mm", "float"),
                      ("rms_mm", "float"), ("max_mm", "float"), ("shape_mm", "float"),
                      ("tip_displacement_mm", "float"), ("base_shift_mm", "float"), ("length_mm", "float"))
#: :func:`tendrilkit.sequence.split_points` (``time_s`` and ``point`` added when asked).
SPLIT_POINTS = _table("split_points", ("frame", "int"), ("kind", "str"), ("s_mm", "float"), ("s_norm", "float"))
#: :func:`tendrilkit.sequence.segment_counts`.
SEGMENT_COUNTS = _table("segment_counts", ("frame", "int"), ("n_kappa", "int"), ("n_tau", "int"))
#: :func:`tendrilkit.sequence.tip_trajectory`.
TIP_TRAJECTORY = _table("tip_trajectory", ("frame", "int"), ("time_s", "float"), ("x_mm", "float"),
                        ("y_mm", "float"), ("z_mm", "float"), ("step_mm", "float"), ("path_mm", "float"),
                        ("displacement_mm", "float"))
#: :func:`tendrilkit.sequence.region_response`.
REGION_RESPONSE = _table("region_response", ("region", "str"), ("u0", "float"), ("u1", "float"),
                         ("displacement_mm", "float"), ("deformation_mm", "float"), ("dkappa_per_mm", "float"),
                         ("dtau_per_mm", "float"), ("share", "float"), ("responsive", "bool"))
#: :func:`tendrilkit.sequence.table1` and ``table2`` (paper Tables 1 and 2).
TABLE1 = _table("table1", ("frame", "int"), ("view", "int"),
                *[(f"{stat}_{sec}_px", "float") for stat in ("mean", "std") for sec in SECTIONS])
#: :func:`tendrilkit.sequence.table3` (paper Table 3): ``frame`` then the fit figures present, in this order.
TABLE3 = _table("table3", ("frame", "int"), ("penalty_kappa", "float"), ("penalty_tau", "float"),
                ("n_kappa", "Int"), ("n_tau", "Int"), ("r2_entire", "float"), ("r2_base", "float"),
                ("r2_tip", "float"), ("sse_entire_mm2", "float"), ("sse_base_mm2", "float"),
                ("sse_tip_mm2", "float"))
#: :func:`tendrilkit.sequence.compare_sites`: one row per experiment.
SITE_COMPARISON = _table(
    "compare_sites", ("experiment", "str"), ("site", "str"), ("responded", "bool"), ("onset_s", "float"),
    ("stable_s", "float"), ("amplitude_mm", "float"), ("tip_displacement_mm", "float"),
    ("most_responsive_region", "str"), ("max_deformation_mm", "float"), ("tip_path_mm", "float"),
    ("tip_straightness", "float"), ("n_frames_ok", "int"), ("n_frames_excluded", "int"))
