"""Report pages: offline, clean, figures inside; and rendered by a real (headless) browser.

A small notebook (a matplotlib figure shown and saved, an interactive 3D view, a
test marker, a table) runs through the batch's own executor
(:func:`tendrilkit.batch.execute_notebook`), then its HTML page is checked as
text and, where Debian's ``chromium`` is installed, as a browser renders it.
"""

from __future__ import annotations

import os
import re
import shutil
import stat
import subprocess
import tempfile
from pathlib import Path

import nbformat
import pytest

from tendrilkit import batch, reports

CELLS = [
    nbformat.v4.new_markdown_cell("# 99 · A test page\n\nWith a figure and a 3D view."),
    nbformat.v4.new_code_cell('out_dir: str = ""', metadata={"tags": ["parameters"]}),
    nbformat.v4.new_code_cell(
        "from pathlib import Path\nimport pandas as pd\nfrom tendrilkit import io, plotting, reports\n"
        "tip = pd.DataFrame({'frame': [0, 1, 2], 'time_s': [0.0, 60.0, 120.0], 'x_mm': [0.0, 1.0, 3.0],\n"
        "                    'y_mm': [0.0, 2.0, 2.5], 'z_mm': [0.0, 1.0, 4.0]})\n"
        "reports.write_table(tip, Path(out_dir) / 'tables' / 'tip.csv')\n"
        "print('results in', Path(out_dir).resolve())\n"
        "fig = plotting.plot_tip_trajectory(tip)\nio.save_figure(fig, Path(out_dir) / 'figures' / 'tip')\nfig"),
    nbformat.v4.new_code_cell("plotting.show_interactive(plotting.plot_tip_trajectory_3d_interactive(tip), name='tip')"),
    nbformat.v4.new_code_cell("# NBVAL_CHECK_OUTPUT\nprint('rows:', len(tip))"),
]


@pytest.fixture(scope="module")
def page(tmp_path_factory):
    root = tmp_path_factory.mktemp("pages")
    src = root / "nbs" / "99_test.ipynb"
    src.parent.mkdir()
    nb = nbformat.v4.new_notebook(cells=CELLS)
    nb.metadata["kernelspec"] = {"name": "python3", "display_name": "Python 3", "language": "python"}
    nbformat.write(nb, str(src))
    out = root / "reports" / "exp"
    batch.execute_notebook(src, out / "99_test.ipynb", {"out_dir": str(out)}, cwd=src.parent,
                           static_dir=root / "reports" / "_static")
    reports.write_tables_readme(out / "tables")
    reports.write_experiment_index(out, title="exp")
    return out / "99_test.html"


@pytest.mark.slow
def test_page_is_offline_clean_and_shows_its_figures(page):
    text = page.read_text()
    assert not re.search(r"<script[^>]+src=\"https?://", text), "a script from the internet"
    assert "cdnjs" not in text and "cdn.plot.ly" not in text and "import(\"http" not in text
    assert "NBVAL_CHECK_OUTPUT" not in text
    assert str(page.parents[2]) not in text and "/tmp/" not in text  # no absolute paths (printed or injected)
    assert "Parameters of this run" in text  # papermill's cell, relative paths
    assert text.count("<div class=\"jp-Cell jp-CodeCell") == 4  # the notebook's default parameters cell is not shown
    assert "<title>99 · A test page</title>" in text
    assert re.search(r"<img[^>]+src=\"data:image/png;base64,[A-Za-z0-9+/]{1000}", text), "no figure in the page"
    assert '<script src="../_static/plotly.min.js"></script>' in text
    assert (page.parent.parent / "_static" / "plotly.min.js").stat().st_size > 1_000_000
    assert "Plotly.newPlot" in text
    # the table for readers: time in minutes too, README of its columns; files readable by the group
    tip = (page.parent / "tables" / "tip.csv").read_text().splitlines()
    assert tip[0].startswith("frame,time_s,time_min,")
    assert "time_min" in (page.parent / "tables" / "README.md").read_text()
    umask = os.umask(0)
    os.umask(umask)
    for p in (page, page.parent / "tables" / "tip.csv", page.parent / "figures" / "tip.png", page.parent / "index.html"):
        assert stat.S_IMODE(p.stat().st_mode) == 0o666 & ~umask, p  # 0644 under the usual umask 022
    index = (page.parent / "index.html").read_text()
    assert 'href="99_test.html"' in index and 'src="figures/tip.png"' in index and "tables/tip.csv" in index


def _chromium() -> str | None:
    return shutil.which("chromium") or shutil.which("chromium-browser")


@pytest.mark.skipif(_chromium() is None, reason="Debian's chromium is not installed (dev.py test installs it as root "
                                                 "with apt-get); the browser check is skipped")
def test_page_renders_in_a_browser(page):
    with tempfile.TemporaryDirectory() as profile:
        run = subprocess.run([_chromium(), "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic",
                              "--no-first-run", "--disable-background-networking", "--disable-component-update",
                              "--disable-sync", f"--user-data-dir={profile}", "--enable-logging=stderr", "--v=0",
                              "--virtual-time-budget=15000", "--dump-dom", page.as_uri()],
                             capture_output=True, text=True, timeout=180, env=dict(os.environ, HOME=profile))
    dom = run.stdout
    assert run.returncode == 0, run.stderr[-2000:]
    assert "Plotly is not defined" not in run.stderr
    assert re.search(r"<img[^>]+src=\"data:image/png;base64,", dom)
    # plotly ran: its container was built inside the figure's div (3D: a WebGL canvas or the no-WebGL notice)
    div = dom[dom.index('id="tk-tip"'):]
    assert 'class="plot-container plotly"' in div[:5000] or "svg-container" in div[:5000], div[:1500]
