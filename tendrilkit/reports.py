"""Report pages a reader can open offline: HTML of executed notebooks, index pages, table READMEs.

What :func:`notebook_html` makes of an executed notebook (``reports/<name>/NN_*.ipynb``):

- one parameters cell: papermill's injected cell is kept (the values this run
  used), the notebook's default ``parameters`` cell is dropped;
- no test markers (``# NBVAL_CHECK_OUTPUT`` lines are removed from the
  inputs; the notebooks keep them for nbval);
- no absolute paths: the repository's and the reports' folders are written
  relative to the page;
- offline: the CDN scripts of nbconvert's template (require.js, MathJax,
  the mermaid loader) are removed and plotly.js is loaded from one shared copy beside the reports
  (``reports/_static/plotly.min.js``, :func:`write_plotly_js`), only on pages
  with an interactive figure;
- the page's title is the notebook's first heading.

:func:`write_experiment_index` and :func:`write_batch_index` write
``reports/<name>/index.html`` and ``reports/index.html``;
:func:`write_tables_readme` the README of a ``tables/`` folder. Every write
goes through :mod:`tendrilkit.io` (atomic, readable by the group).
"""

from __future__ import annotations

import html
import os
import re
from pathlib import Path
from typing import Mapping, Sequence

import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
STATIC = "_static"
PLOTLY_JS = "plotly.min.js"
NBVAL_MARKER = re.compile(r"^[ \t]*# ?NBVAL_[A-Z_]+[ \t]*\n?", re.MULTILINE)
_CDN_SCRIPT = re.compile(r"<script[^>]*\bsrc=\"https?://[^\"]*\"[^>]*>\s*</script>\s*", re.IGNORECASE)
_MERMAID = re.compile(r"<script type=\"module\">(?:(?!</script>).)*?mermaid(?:(?!</script>).)*</script>\s*", re.DOTALL)
_MATHJAX_CONFIG = re.compile(r"<!-- (Load mathjax|MathJax configuration) -->\s*|<script type=\"text/x-mathjax-config\">.*?</script>\s*",
                             re.DOTALL)

#: What the columns of the tables mean (tables/README.md); a column not here is listed without a description.
COLUMN_DOCS: dict[str, str] = {
    "frame": "video frame, 0-based",
    "view": "camera view, 1-based as in the experiment file",
    "time_s": "time since the first frame (the stimulus), s",
    "time_min": "time since the first frame (the stimulus), min",
    "x_mm": "world x (the world marker's frame), mm", "y_mm": "world y, mm", "z_mm": "world z, mm",
    "step_mm": "distance from the previous frame's tip, mm",
    "path_mm": "cumulative tip path length, mm",
    "displacement_mm": "distance from the first frame's tip, mm",
    "mean_mm": "mean distance of corresponding points to the first frame (no alignment), mm",
    "rms_mm": "RMS of the same distances, mm", "max_mm": "largest of the same distances, mm",
    "shape_mm": "mean distance to the first frame after the best rigid alignment (change of shape), mm",
    "tip_displacement_mm": "tip's distance to the first frame's tip, mm",
    "base_shift_mm": "base point's distance to the first frame's, mm",
    "length_mm": "length of the centreline, mm",
    "region": "quarter of the tendril, S1 (base) ... S4 (tip)",
    "u0": "start of the region, fraction of the length (0 base)", "u1": "end of the region, fraction of the length",
    "deformation_mm": "RMS change of the region's shape between first and last frame (aligned), mm",
    "dkappa_per_mm": "mean absolute change of curvature over the region, 1/mm",
    "dtau_per_mm": "mean absolute change of torsion over the region, 1/mm",
    "share": "region's share of the summed deformation (0-1)",
    "responsive": "deformation at least 1 mm",
    "mean_base_px": "mean error over the base quarter, px", "mean_tip_px": "mean error over the tip quarter, px",
    "mean_entire_px": "mean error over the whole tendril, px",
    "std_base_px": "standard deviation over the base quarter, px", "std_tip_px": "standard deviation over the tip quarter, px",
    "std_entire_px": "standard deviation over the whole tendril, px",
    "penalty_kappa": "curvature penalty (dimensionless)", "penalty_tau": "torsion penalty (dimensionless)",
    "n_kappa": "curvature segments", "n_tau": "torsion segments",
    "r2_entire": "R² of the rebuilt 3D curve, whole tendril", "r2_base": "R², base quarter", "r2_tip": "R², tip quarter",
    "sse_entire_mm2": "sum of squared distances, whole tendril, mm²", "sse_base_mm2": "same, base quarter, mm²",
    "sse_tip_mm2": "same, tip quarter, mm²",
    "experiment": "experiment name", "site": "stimulation site (S1 base ... S4 tip)",
    "responded": "a lasting change of shape of at least 2 mm above the noise",
    "onset_min": "response onset (first movement) after the stimulus, min",
    "stable_min": "shape stable after the stimulus, min",
    "onset_s": "response onset after the stimulus, s", "stable_s": "shape stable after the stimulus, s",
    "amplitude_mm": "final change of shape, mm",
    "most_responsive_region": "the quarter whose shape changed most",
    "max_deformation_mm": "that quarter's deformation, mm",
    "stimulated_region_deformation_mm": "deformation of the quarter that was stimulated, mm",
    "tip_path_mm": "tip path length (median-filtered), mm", "tip_straightness": "net / path length of the tip (0-1)",
    "n_frames_ok": "frames reconstructed", "n_frames_excluded": "frames failed or excluded",
    "true_onset_min": "phantom: the generator's onset, min", "true_stable_min": "phantom: the generator's stabilisation, min",
    "onset_10pct_min": "the 10 %-of-plateau rule's onset, min", "stable_10pct_min": "the 10 %-of-plateau rule's stabilisation, min",
    "kind": "kappa (curvature) or tau (torsion)", "s_norm": "position along the tendril, 0 base, 1 tip",
    "s_mm": "arc length from the base, mm", "point": "point index along the centreline, 0 = base",
}

#: Decimals kept per column suffix (tables for readers, :func:`for_readers`).
_DECIMALS = (("_mm2", 4), ("_px", 2), ("_mm", 2), ("_min", 2), ("_per_mm", 5), ("r2_", 5), ("share", 3),
             ("straightness", 3), ("u0", 3), ("u1", 3), ("s_norm", 3), ("penalty_", 4))


def for_readers(df: pd.DataFrame) -> pd.DataFrame:
    """A table as readers want it: ``time_s`` also in minutes, values rounded to meaningful digits.

    ``*_s`` columns of times become ``*_min`` (2 decimals); mm to 0.01 mm,
    px to 0.01 px, R² to 5 decimals, curvatures (1/mm) to 5 decimals.
    """
    out = df.copy()
    for c in list(out.columns):
        if c in ("time_s", "onset_s", "stable_s") and pd.api.types.is_numeric_dtype(out[c]):
            out.insert(out.columns.get_loc(c) + 1, c[:-2] + "_min", out[c] / 60.0)
            if c != "time_s":
                out = out.drop(columns=c)
    for c in out.columns:
        if not pd.api.types.is_float_dtype(out[c]):
            continue
        if c == "time_s":
            out[c] = out[c].round(1)
            continue
        for key, dec in _DECIMALS:
            if key in c:
                out[c] = out[c].round(dec)
                break
    return out


def write_table(df: pd.DataFrame, path: str | Path) -> None:
    """Write ``for_readers(df)`` as CSV (no trailing float noise)."""
    from tendrilkit.io import write_csv

    write_csv(for_readers(df), path, float_format="%.10g")


def write_tables_readme(folder: str | Path) -> Path:
    """``tables/README.md``: every CSV of the folder with its columns explained."""
    from tendrilkit.io import write_text

    folder = Path(folder)
    lines = ["# Tables", "", "Every CSV of this folder and what its columns mean (units in the names:",
             "`_mm` millimetres, `_px` pixels, `_min` minutes, `_s` seconds, `_per_mm` 1/mm).", ""]
    for csv in sorted(folder.glob("*.csv")):
        cols = list(pd.read_csv(csv, nrows=0).columns)
        lines += [f"## {csv.name}", "", "| column | meaning |", "|---|---|"]
        lines += [f"| `{c}` | {COLUMN_DOCS.get(c, '')} |" for c in cols]
        lines.append("")
    out = folder / "README.md"
    write_text("\n".join(lines), out)
    return out


# ------------------------------------------------------------------ notebook pages
def _relative_paths(text: str, page_dir: Path) -> str:
    """Absolute paths of this repository (and of the page's folder, the reports and their parent) relative to the page."""
    here = page_dir.resolve()
    for base in sorted({ROOT, here, here.parent, here.parent.parent}, key=lambda p: -len(str(p))):
        if len(base.parts) < 3:  # never rewrite "/" or a top-level folder such as /tmp
            continue
        rel = os.path.relpath(base, page_dir.resolve())
        text = text.replace(str(base) + os.sep, "" if rel == "." else rel + "/").replace(str(base), rel)
    return text


def _title(nb) -> str:
    for cell in nb.cells:
        if cell.cell_type == "markdown":
            for line in cell.source.splitlines():
                if line.startswith("# "):
                    return line[2:].strip()
    return "tendrilkit report"


def clean_notebook(nb, page_dir: Path):
    """The notebook as the page shows it (module notes); returns a modified copy."""
    import copy

    nb = copy.deepcopy(nb)
    injected = any("injected-parameters" in c.metadata.get("tags", []) for c in nb.cells)
    cells = []
    for cell in nb.cells:
        tags = cell.metadata.get("tags", [])
        if injected and "parameters" in tags:
            continue
        if cell.cell_type == "code":
            cell.source = NBVAL_MARKER.sub("", cell.source)
            if "injected-parameters" in tags:  # paths inside the repository are relative to notebooks/ already
                cell.source = _relative_paths(cell.source.replace("# Parameters\n", "# Parameters of this run\n"),
                                              page_dir)
            for out in cell.get("outputs", []):
                if "text" in out:
                    out["text"] = _relative_paths(out["text"], page_dir)
                for mime in ("text/plain", "text/html"):
                    if mime in out.get("data", {}):
                        v = out["data"][mime]
                        out["data"][mime] = _relative_paths("".join(v) if isinstance(v, list) else v, page_dir)
        cells.append(cell)
    nb.cells = cells
    nb.metadata["title"] = nb.metadata.get("title") or _title(nb)
    return nb


def notebook_html(nb, page_dir: Path, static_dir: Path) -> str:
    """The standalone, offline HTML page of an executed notebook (module notes)."""
    from nbconvert import HTMLExporter

    nb = clean_notebook(nb, page_dir)
    exporter = HTMLExporter(exclude_input_prompt=True, exclude_output_prompt=True)
    body, _ = exporter.from_notebook_node(nb, resources={"metadata": {"name": nb.metadata["title"]}})
    body = _CDN_SCRIPT.sub("", body)
    body = _MATHJAX_CONFIG.sub("", body)
    body = _MERMAID.sub("", body)  # nbconvert's loader of mermaid diagrams (from a CDN); the notebooks have none
    if "Plotly.newPlot" in body:
        rel = os.path.relpath(Path(static_dir).resolve() / PLOTLY_JS, page_dir.resolve())
        body = body.replace("</head>", f'<script src="{html.escape(rel)}"></script>\n</head>', 1)
    return body


def write_plotly_js(static_dir: str | Path) -> Path:
    """One shared offline copy of plotly.js (the version installed) in ``static_dir``."""
    from plotly.offline import get_plotlyjs

    from tendrilkit.io import write_text

    path = Path(static_dir) / PLOTLY_JS
    text = get_plotlyjs()
    if not path.is_file() or path.stat().st_size != len(text.encode()):
        write_text(text, path)
    return path


# ------------------------------------------------------------------ index pages
_CSS = """body{font-family:system-ui,sans-serif;max-width:1100px;margin:2em auto;padding:0 1em;color:#222}
h1{font-size:1.6em}h2{font-size:1.2em;margin-top:1.6em;border-bottom:1px solid #ddd}
.figs{display:flex;flex-wrap:wrap;gap:14px}.fig{width:250px;font-size:.85em}
.fig img{width:250px;border:1px solid #ddd;background:#fff}td,th{padding:2px 10px;text-align:left}
a{color:#0a58ca}"""


def _page(title: str, body: str) -> str:
    return (f"<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>{html.escape(title)}</title>"
            f"<style>{_CSS}</style></head>\n<body>\n<h1>{html.escape(title)}</h1>\n{body}\n</body></html>\n")


def _link(href: str, text: str) -> str:
    return f'<a href="{html.escape(href)}">{html.escape(text)}</a>'


def _notebook_titles(folder: Path) -> list[tuple[str, str]]:
    import nbformat

    rows = []
    for nbp in sorted(folder.glob("[0-9][0-9]_*.ipynb")):
        try:
            title = _title(nbformat.read(str(nbp), as_version=4))
        except Exception:  # a damaged notebook still gets its link
            title = nbp.stem
        rows.append((nbp.stem, title))
    return rows


def _figures_html(folder: Path, prefix: str = "figures/") -> str:
    items = []
    for png in sorted(folder.glob("*.png")):
        others = " · ".join(_link(prefix + png.with_suffix(s).name, s[1:].upper())
                            for s in (".pdf", ".svg") if png.with_suffix(s).is_file())
        items.append(f'<div class="fig"><a href="{html.escape(prefix + png.name)}"><img src="{html.escape(prefix + png.name)}" '
                     f'alt="{html.escape(png.stem)}"></a><br>{html.escape(png.stem)}{f" ({others})" if others else ""}</div>')
    for h in sorted(folder.glob("*.html")):
        items.append(f'<div class="fig">{_link(prefix + h.name, h.stem + " (interactive)")}</div>')
    return f'<div class="figs">{"".join(items)}</div>' if items else "<p>No figures.</p>"


def _tables_html(folder: Path, prefix: str = "tables/") -> str:
    rows = [f"<li>{_link(prefix + c.name, c.name)}</li>" for c in sorted(folder.glob("*.csv"))]
    if (folder / "README.md").is_file():
        rows.append(f"<li>{_link(prefix + 'README.md', 'README.md (what the columns mean)')}</li>")
    return f"<ul>{''.join(rows)}</ul>" if rows else "<p>No tables.</p>"


def write_experiment_index(folder: str | Path, *, title: str, summary: str = "") -> Path:
    """``<folder>/index.html``: the notebooks' pages, every figure (thumbnails), tables and results."""
    from tendrilkit.io import write_text

    folder = Path(folder)
    parts = [f"<p>{html.escape(summary)}</p>" if summary else "", "<p>" + _link("../index.html", "all experiments") + "</p>",
             "<h2>Notebooks</h2><ol>"]
    parts += [f"<li>{_link(stem + '.html', t)} ({_link(stem + '.ipynb', 'notebook')})</li>"
              for stem, t in _notebook_titles(folder)]
    parts.append("</ol><h2>Figures</h2>")
    parts.append(_figures_html(folder / "figures"))
    parts.append("<h2>Tables</h2>" + _tables_html(folder / "tables"))
    extra = [p for p in ("results", "provenance.json", "batch.log") if (folder / p).exists()]
    if extra:
        parts.append("<h2>Run</h2><ul>" + "".join(f"<li>{_link(p + ('/' if (folder / p).is_dir() else ''), p)}</li>"
                                                   for p in extra) + "</ul>")
    out = folder / "index.html"
    write_text(_page(title, "\n".join(parts)), out)
    return out


def write_batch_index(reports_dir: str | Path, rows: Sequence[Mapping[str, str]]) -> Path:
    """``reports/index.html``: one line per experiment (status, link) and the cross-site comparison."""
    from tendrilkit.io import write_text

    reports_dir = Path(reports_dir)
    body = ["<p>Each experiment's page lists its notebooks (as HTML pages), figures (PNG, PDF, SVG) and "
            "tables (CSV, with a README of the columns). The pages work offline.</p>",
            "<table><tr><th>experiment</th><th>status</th><th>frames ok / failed</th><th>note</th></tr>"]
    for r in rows:
        name = str(r.get("name", ""))
        link = _link(f"{name}/index.html", name) if (reports_dir / name / "index.html").is_file() else html.escape(name)
        body.append(f"<tr><td>{link}</td><td>{html.escape(str(r.get('status', '')))}</td>"
                    f"<td>{html.escape(str(r.get('frames', '')))}</td><td>{html.escape(str(r.get('message', '')))}</td></tr>")
    body.append("</table>")
    out = reports_dir / "index.html"
    write_text(_page("tendrilkit reports", "\n".join(body)), out)
    return out


# ------------------------------------------------------------------ what report figures need from the videos
def reprojection_panels(exp, results, frames: Sequence[int]) -> list[list[dict]]:
    """Per frame and view: the image, the ordered skeleton, the reconstruction and PWC curve projected.

    The input of :func:`tendrilkit.plotting.plot_reprojection_overlays`. A
    view whose skeleton cannot be extracted keeps its image and projections
    (``skeleton_xy`` None).
    """
    from tendrilkit.exceptions import FrameError
    from tendrilkit.io import read_frames
    from tendrilkit.skeleton import process_view

    from tendrilkit.options import stage_options

    seg_opts, order_opts = stage_options(exp, "segmentation"), stage_options(exp, "ordering")
    rows = []
    for f in frames:
        f = int(f)
        images = read_frames(exp, f)
        curves = {}
        for key, table in (("reprojected_xy", results.curves), ("pwc_xy", results.pwc_curves)):
            if table is not None:
                P = table[table["frame"] == f].sort_values("point")[["x_mm", "y_mm", "z_mm"]].to_numpy(float)
                curves[key] = P if len(P) else None
        row = []
        for img, marks, cam in zip(images, exp.views, results.cameras):
            try:
                skel = process_view(img, roi=marks.roi, keep_out=marks.keep_out, base_point_xy=marks.base_point,
                                    frame=f, view=marks.view, segmentation=seg_opts,
                                    ordering=order_opts).points_xy
            except FrameError:
                skel = None
            panel = {"image": img, "roi": marks.roi, "skeleton_xy": skel, "label": f"frame {f}, view {marks.view}"}
            for key, P in curves.items():
                panel[key] = cam.project(P) if P is not None else None
            row.append(panel)
        rows.append(row)
    return rows
