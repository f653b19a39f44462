"""Figures of the paper from result tables: the only module importing matplotlib and plotly.

Every ``plot_*`` function takes tables or results of :mod:`tendrilkit.sequence`
and returns a figure (``matplotlib.figure.Figure`` or ``plotly.graph_objects.Figure``);
nothing here saves (see :func:`tendrilkit.io.save_figure`) or computes more
than what is drawn.

Matplotlib figures are made as plain ``Figure`` objects, not through pyplot:
they are not kept in pyplot's global list, are not shown twice in a notebook,
and are garbage-collected like any object. Importing this module selects the
non-interactive ``Agg`` backend only when no backend is set (a notebook's
inline backend, or ``MPLBACKEND``, is left alone); it also imports pyplot so
that IPython registers its display of figures.

Determinism: every figure is built under :data:`STYLE` (fixed fonts, sizes,
colours, ``svg.hashsalt``); no timestamps or random ids. Colours follow the
paper: first frame blue and solid (circle), last vermillion and dashed (square),
the others along cividis; tip path black with its XY, YZ, XZ projections
orange, green, sky blue (Okabe-Ito, colour-blind safe); skeleton black,
reprojection sky blue, piece-wise clothoid orange dashed.

Journal sizes: widths :data:`SINGLE_MM` (85 mm) or :data:`DOUBLE_MM`
(180 mm), text 6.5-8 pt at that size, panel letters (a, b, ...), no baked-in
titles unless ``title=`` is given; :func:`tendrilkit.io.save_figure` writes
300 dpi PNG with vector PDF and SVG. Time axes are in minutes.

The figures live by family in sub-modules (all re-exported here, the public
API the notebooks and reports use): ``style`` (rcParams, sizes, colours,
shared helpers), ``views`` (2D views: frames, masks, marks, reprojections),
``curves`` (3D curves and the tip path, matplotlib and plotly), ``pwc``
(piece-wise clothoid fits and penalty searches), ``sequence`` (split points,
curvature/torsion maps, shape change, response, sites) and ``quality``
(reprojection bars, quality over time, overlays, contact sheet, multi-view
decisions).
"""

from __future__ import annotations

# style first: it selects the backend before any figure module imports matplotlib's figure machinery
from tendrilkit.plotting.style import (  # isort: skip
    DOUBLE_MM,
    FIRST_COLOR,
    LAST_COLOR,
    OKABE_ITO,
    PROJECTION_COLORS,
    SINGLE_MM,
    STATUS_COLORS,
    STYLE,
)
from tendrilkit.plotting.curves import (  # isort: skip
    plot_curves_3d_interactive,
    plot_shape_evolution,
    plot_tip_trajectory,
    plot_tip_trajectory_3d_interactive,
    show_interactive,
)
from tendrilkit.plotting.pwc import (  # isort: skip
    plot_grid_search,
    plot_penalty_fits,
    plot_pwc_fit,
)
from tendrilkit.plotting.quality import (  # isort: skip
    plot_contact_sheet,
    plot_frame_overlay,
    plot_multiview_decision,
    plot_quality_over_time,
    plot_reprojection_bars,
)
from tendrilkit.plotting.sequence import (  # isort: skip
    plot_kt_maps,
    plot_kt_maps_sites,
    plot_response_fit,
    plot_shape_change,
    plot_site_comparison,
    plot_split_points,
    plot_split_points_sites,
    plot_tip_trajectory_sites,
)
from tendrilkit.plotting.views import (  # isort: skip
    plot_marks,
    plot_mask_overlay,
    plot_reprojection_overlays,
    plot_view_overlay,
    plot_views,
)

__all__ = [
    "STYLE",
    "SINGLE_MM",
    "DOUBLE_MM",
    "OKABE_ITO",
    "FIRST_COLOR",
    "LAST_COLOR",
    "PROJECTION_COLORS",
    "STATUS_COLORS",
    "plot_curves_3d_interactive",
    "plot_shape_evolution",
    "plot_tip_trajectory",
    "plot_tip_trajectory_3d_interactive",
    "show_interactive",
    "plot_grid_search",
    "plot_penalty_fits",
    "plot_pwc_fit",
    "plot_contact_sheet",
    "plot_frame_overlay",
    "plot_multiview_decision",
    "plot_quality_over_time",
    "plot_reprojection_bars",
    "plot_kt_maps",
    "plot_kt_maps_sites",
    "plot_response_fit",
    "plot_shape_change",
    "plot_site_comparison",
    "plot_split_points",
    "plot_split_points_sites",
    "plot_tip_trajectory_sites",
    "plot_marks",
    "plot_mask_overlay",
    "plot_reprojection_overlays",
    "plot_view_overlay",
    "plot_views",
]
