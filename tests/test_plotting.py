"""Every plotting function returns a figure; saved files are byte-stable."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from matplotlib.figure import Figure

from tendrilkit import io, plotting as pl
from tendrilkit import sequence as sq
from tendrilkit.schema import REPROJECTION, SECTIONS

from tests.test_sequence import make_sequence


@pytest.fixture(scope="module")
def seq():
    curves, segments = make_sequence(n_frames=45, noise_mm=0.2, seed=2, n=40)
    change = sq.shape_change(curves)
    return {
        "curves": curves,
        "segments": segments,
        "split": sq.split_points(segments, points=40),
        "maps": sq.curvature_torsion_maps(segments, n_s=30),
        "traj": sq.tip_trajectory(curves),
        "change": change,
        "response": sq.response_times(change),
    }


def _rep():
    rows = [(f, v, s, 1.0 + f / 100 + v, 0.3) for f in (0, 100, 199) for v in (1, 2, 3) for s in SECTIONS]
    return pd.DataFrame(rows, columns=list(REPROJECTION.require("frame", "view", "section", "mean_px", "std_px")))


def _sites():
    return pd.DataFrame({
        "experiment": ["a", "b", "c", "d"], "site": ["S1", "S2", "S3", "S4"],
        "responded": [False, True, True, True], "onset_s": [np.nan, 170.0, 160.0, 150.0],
        "stable_s": [np.nan, 700.0, 720.0, 760.0], "amplitude_mm": [0.8, 12.0, 25.0, 30.0],
        "tip_path_mm": [5.0, 40.0, 80.0, 90.0],
    })


def _matplotlib_figures(seq, only=None):
    img = np.zeros((60, 80, 3), np.uint8)
    img[:, :, 2] = 120
    makers = {
        "split": lambda: pl.plot_split_points(seq["split"]),
        "split_point": lambda: pl.plot_split_points(seq["split"], y="point", title="S3"),
        "maps": lambda: pl.plot_kt_maps(seq["maps"]),
        "tip": lambda: pl.plot_tip_trajectory(seq["traj"]),
        "evolution": lambda: pl.plot_shape_evolution(seq["curves"], max_frames=5),
        "change": lambda: pl.plot_shape_change(seq["change"], seq["response"]),
        "bars": lambda: pl.plot_reprojection_bars(sq.table1(_rep())),
        "sites": lambda: pl.plot_site_comparison(_sites()),
        "overlay": lambda: pl.plot_view_overlay(
            img, roi=[5, 5, 60, 40], keep_out=[0, 0, 10, 10], base_point_xy=[8, 30],
            centerline_xy=np.c_[np.linspace(8, 60, 20), np.full(20, 30.0)],
            reprojected_xy=np.c_[np.linspace(8, 60, 20), np.full(20, 31.0)]),
    }
    return {k: m() for k, m in makers.items() if only is None or k == only}


def test_matplotlib_functions_return_figures(seq):
    figs = _matplotlib_figures(seq)
    for name, fig in figs.items():
        assert isinstance(fig, Figure), name
        assert fig.axes, name
    # the response is drawn: onset and stable lines in the legend
    labels = [t.get_text() for t in figs["change"].axes[0].get_legend().get_texts()]
    assert any(s.startswith("onset") for s in labels) and any(s.startswith("stable") for s in labels)
    # tip figure: 3D path + three projections, in the paper's colours
    assert len(figs["tip"].axes) == 4
    assert figs["tip"].axes[1].lines[0].get_color() == pl.PROJECTION_COLORS["XY"]
    # journal sizes: 85 or 180 mm wide, panel letters
    for name, fig in figs.items():
        if name != "overlay":
            assert round(fig.get_figwidth() * 25.4) in (85, 180), name
    assert "a" in [t.get_text() for t in figs["bars"].axes[0].texts]


def test_plotly_functions(seq):
    go = pytest.importorskip("plotly.graph_objects")
    f1 = pl.plot_tip_trajectory_3d_interactive(seq["traj"])
    assert isinstance(f1, go.Figure)
    assert [t.name for t in f1.data] == ["tip", "XY", "YZ", "XZ", "first", "last"]
    pwc = seq["curves"].copy()
    f2 = pl.plot_curves_3d_interactive(seq["curves"], pwc, frames=[0, 10, 23])
    assert [t.name for t in f2.data] == ["frame 0", "PWC 0", "frame 10", "PWC 10", "frame 23", "PWC 23"]
    assert f2.data[0].line.color == pl.FIRST_COLOR.lower() and f2.data[-2].line.color == pl.LAST_COLOR.lower()
    assert f2.data[-2].line.dash == "dash"  # first and last differ by more than colour


def test_maps_with_a_failed_frame_and_no_response():
    curves, segments = make_sequence(n_frames=6, noise_mm=0.3, seed=4, static=True, n=30)
    frames = pd.DataFrame({"frame": range(6), "time_s": np.arange(6) * 20.0,
                           "status": ["ok", "ok", "failed", "ok", "ok", "ok"]})
    with pytest.warns(UserWarning):
        maps = sq.curvature_torsion_maps(segments, n_s=10, frames=frames)
    assert isinstance(pl.plot_kt_maps(maps), Figure)
    change = sq.shape_change(curves)
    fig = pl.plot_shape_change(change, sq.response_times(change))
    assert "no response" in [t.get_text() for t in fig.axes[0].texts]


def test_bad_input_names_argument():
    with pytest.raises(ValueError, match="traj: missing column"):
        pl.plot_tip_trajectory(pd.DataFrame({"x_mm": [0.0]}))
    with pytest.raises(ValueError, match="image_bgr"):
        pl.plot_view_overlay(np.zeros((2, 2, 4)), roi=[0, 0, 1, 1], keep_out=None, base_point_xy=[0, 0])


@pytest.mark.slow
def test_saved_files_are_byte_identical(seq, tmp_path):
    # every format on a 2D figure; SVG (the format kept in reports' git) on 3D and mesh figures
    for name, formats in (("change", None), ("tip", ("svg",)), ("maps", ("svg",))):
        blobs = []
        for k in range(2):  # a fresh figure each time
            fig = _matplotlib_figures(seq, name)[name]
            paths = io.save_figure(fig, tmp_path / f"{name}{k}", formats=formats)
            assert [p.suffix for p in paths] == [f".{f}" for f in formats or ("svg", "pdf", "png")]
            blobs.append([p.read_bytes() for p in paths])
        assert blobs[0] == blobs[1], name
        svg = blobs[0][0].decode()
        assert "<dc:date>" not in svg
    with pytest.raises(ValueError, match="formats"):
        io.save_figure(_matplotlib_figures(seq, "sites")["sites"], tmp_path / "x", formats=("jpg",))


def test_plotly_html_is_byte_identical(seq, tmp_path):
    pytest.importorskip("plotly")
    a = io.save_figure(pl.plot_tip_trajectory_3d_interactive(seq["traj"]), tmp_path / "tip", formats=("html", "json"))
    b1 = [p.read_bytes() for p in a]
    a = io.save_figure(pl.plot_tip_trajectory_3d_interactive(seq["traj"]), tmp_path / "tip", formats=("html", "json"))
    assert [p.read_bytes() for p in a] == b1
    assert b'id="tip"' in b1[0] and b"cdn.plot.ly" not in b1[0][:2000]
    with pytest.raises(ValueError, match="static export"):
        io.save_figure(pl.plot_tip_trajectory_3d_interactive(seq["traj"]), tmp_path / "tip", formats=("svg",))


def test_error_bars_never_below_zero():
    rows = [(0, v, s, 0.2, 0.9) for v in (1, 2) for s in SECTIONS]
    cols = REPROJECTION.require("frame", "view", "section", "mean_px", "std_px")
    fig = pl.plot_reprojection_bars(sq.table1(pd.DataFrame(rows, columns=list(cols))))
    for ax in fig.axes:
        for coll in ax.collections:  # the error bars' vertical segments
            for seg in getattr(coll, "get_segments", lambda: [])():
                assert np.min(np.asarray(seg)[:, 1]) >= -1e-12
        assert ax.get_ylim()[0] == 0


def test_composites_and_paper_figures(seq):
    split, maps, traj, curves = seq["split"], seq["maps"], seq["traj"], seq["curves"]
    figs = [pl.plot_split_points_sites({"S1": split, "S2": split}),
            pl.plot_kt_maps_sites({"S1": maps, "S2": maps}, {"S1": curves, "S2": curves}),
            pl.plot_tip_trajectory_sites({"S1": traj, "S2": traj})]
    assert len(figs[1].axes) >= 6  # morphology row + curvature + torsion per site (+ colour bars)
    img = np.zeros((60, 80, 3), np.uint8)
    line = np.c_[np.linspace(8, 60, 20), np.full(20, 30.0)]
    panel = {"image": img, "roi": [5, 5, 60, 40], "skeleton_xy": line, "reprojected_xy": line + 1,
             "pwc_xy": line + 2, "label": "frame 0, view 1"}
    figs.append(pl.plot_reprojection_overlays([[panel, panel, panel]] * 3))
    assert len(figs[-1].axes) == 9
    figs.append(pl.plot_views([{"image": img, "roi": [5, 5, 60, 40], "keep_out": [0, 0, 5, 5],
                                "base_point_xy": [8, 30], "centerline_xy": line, "label": f"view {v}"}
                               for v in (1, 2, 3)]))
    assert len(figs[-1].axes) == 3  # every view, not only the last
    regions = pd.DataFrame({"experiment": ["a"] * 4 + ["b"] * 4, "region": ["S1", "S2", "S3", "S4"] * 2,
                            "deformation_mm": [0.1, 0.2, 0.3, 0.1, 0.5, 3.0, 6.0, 2.0]})
    sites = _sites().iloc[:2]
    figs.append(pl.plot_site_comparison(sites, regions))
    texts = [t.get_text() for t in figs[-1].axes[1].texts]
    assert any("3 min" in t for t in texts) and any("12 min" in t for t in texts)
    for f in figs:
        assert isinstance(f, Figure)


def _qc_frames():
    n = 8
    f = pd.DataFrame({"frame": np.arange(n), "time_s": np.arange(n) * 15.0,
                      "status": ["ok", "ok", "doubtful", "ok", "failed", "ok", "ok", "ok"], "message": ""})
    for v in (1, 2, 3):
        f[f"on_tendril_frac_v{v}"] = np.where(f.status == "doubtful", 0.6, 1.0)
        f[f"coverage_frac_v{v}"] = 0.99
        f[f"base_px_v{v}"] = 0.5
    f["length_change_pct"] = 0.1
    f.loc[f.status == "failed", [c for c in f.columns if c.endswith(("_v1", "_v2", "_v3"))]] = np.nan
    return f


def test_quality_over_time_shades_doubtful_and_failed_frames():
    from tendrilkit.verify import Thresholds

    f = _qc_frames()
    fig = pl.plot_quality_over_time(f, thresholds=Thresholds(), title="qc")
    ax = fig.axes[0]
    spans = [p for p in ax.patches if p.get_label() in ("doubtful frame", "failed frame")]
    assert sorted(p.get_label() for p in spans) == ["doubtful frame", "failed frame"]
    assert fig._suptitle.get_text() == "qc: 6 ok, 1 doubtful, 1 failed"


def test_shape_change_is_not_bridged_over_excluded_frames():
    curves, _ = make_sequence(n_frames=8, noise_mm=0.1, seed=2, n=30)
    f = _qc_frames()
    with pytest.warns(UserWarning):
        change = sq.shape_change(curves, frames=f)
    fig = pl.plot_shape_change(change, frames=f)
    ax = fig.axes[0]
    y = [ln for ln in ax.lines if ln.get_label().startswith("shape change")][0].get_ydata()
    assert len(y) == 6 + 2 and np.isnan(y).sum() == 2          # a gap at frame 2 and one at frame 4
    assert {p.get_label() for p in ax.patches} >= {"doubtful frame", "failed frame"}
    assert isinstance(pl.plot_split_points(pd.DataFrame({"frame": [0, 1], "kind": ["kappa", "tau"],
                                                         "s_norm": [0.2, 0.5]}), frames=f), Figure)


def test_contact_sheet_and_frame_overlay():
    from tendrilkit.overlay import ViewOverlay, contact_frames, draw_overlay_bgr

    crop = np.full((60, 80, 3), 230, np.uint8)
    xy = np.c_[np.linspace(5, 70, 20), np.linspace(5, 50, 20)]
    views = [ViewOverlay(crop, np.array([100, 50]), xy, xy + 1, np.array([5.0, 5.0])) for _ in range(3)]
    fig = pl.plot_contact_sheet([(3, "ok", "", views), (7, "doubtful", "precision: view 2 has 41 % (limit 95 %)", views)])
    assert len(fig.axes) == 6
    assert isinstance(pl.plot_frame_overlay(views, status="doubtful", title="frame 7"), Figure)
    f = _qc_frames()
    assert contact_frames(f, max_doubtful=8, n_ok=3) == [0, 2, 3, 7]  # ok frames 0, 1, 3, 5, 6, 7: first, middle, last
    img = draw_overlay_bgr(views, status="doubtful", label="frame 7", height_px=120)
    assert img.shape[0] == 120 and img.shape[1] % 2 == 0 and img.dtype == np.uint8


@pytest.mark.parametrize("module", ['tendrilkit.plotting', 'tendrilkit.plotting.curves', 'tendrilkit.plotting.pwc', 'tendrilkit.plotting.quality', 'tendrilkit.plotting.sequence', 'tendrilkit.plotting.style', 'tendrilkit.plotting.views'])
def test_docstring_examples_run(module):
    """The Examples of the tendrilkit.plotting docstrings (what ``pytest --doctest-modules`` runs)."""
    import doctest
    import importlib

    res = doctest.testmod(importlib.import_module(module), optionflags=doctest.ELLIPSIS)
    assert res.failed == 0, f"{res.failed} of {res.attempted} docstring example(s) of {module} failed"
