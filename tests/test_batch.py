"""The batch runner: notebooks per experiment, resumable, one failure does not stop the others, stable figures.

Runs a tiny notebook collection (one per-experiment notebook that saves a
figure and a table, one cross-site notebook) on a 3-frame phantom, so the
test exercises batch.py itself; the real notebooks are checked by nbval.
"""

from __future__ import annotations

import hashlib
import shutil
import subprocess
import sys
from pathlib import Path

import nbformat
import pytest

from tendrilkit.phantom import write_phantom_experiment

ROOT = Path(__file__).resolve().parents[1]

PER_EXPERIMENT = [
    nbformat.v4.new_markdown_cell("# test notebook"),
    nbformat.v4.new_code_cell('experiment_path: str = ""\nresults_dir: str = ""\nfigures_dir: str = ""',
                              metadata={"tags": ["parameters"]}),
    nbformat.v4.new_code_cell(
        "from pathlib import Path\nfrom tendrilkit import io, params, plotting\n"
        "exp = params.load_experiment(experiment_path)\nres = io.read_results(results_dir)\n"
        "io.save_figure(plotting.plot_shape_evolution(res.curves, title=exp.name), Path(figures_dir) / 'shapes')\n"
        "io.write_csv(res.frames, Path(figures_dir).parent / 'tables' / 'frames.csv')\nprint(len(res.frames))"),
]
CROSS_SITE = [
    nbformat.v4.new_code_cell('experiment_paths: list = []\nresults_dirs: list = []\nfigures_dir: str = ""',
                              metadata={"tags": ["parameters"]}),
    nbformat.v4.new_code_cell("from pathlib import Path\nPath(figures_dir).mkdir(parents=True, exist_ok=True)\n"
                              "(Path(figures_dir) / 'n.txt').write_text(str(len(experiment_paths)))"),
]


def write_test_notebooks(folder: Path) -> Path:
    """A tiny notebook collection in ``folder``: one per-experiment notebook and the cross-site one."""
    folder.mkdir()
    for name, cells in (("00_test.ipynb", PER_EXPERIMENT), ("07_compare_sites.ipynb", CROSS_SITE)):
        nb = nbformat.v4.new_notebook(cells=cells)
        nb.metadata["kernelspec"] = {"name": "python3", "display_name": "Python 3", "language": "python"}
        nbformat.write(nb, str(folder / name))
    return folder


@pytest.fixture(scope="module")
def setup(tmp_path_factory):
    root = tmp_path_factory.mktemp("batch")
    exp = write_phantom_experiment("S2", root / "S2", n_frames=3, seed=0)
    nbs = write_test_notebooks(root / "nbs")
    bad = root / "bad.yaml"
    bad.write_text("name: broken\nfps: fast\n")
    return root, exp, nbs, bad


def _batch(args, nbs):
    return subprocess.run([sys.executable, "-m", "tendrilkit", "batch", *map(str, args), "--notebooks", str(nbs)],
                          capture_output=True, text=True, cwd=ROOT, timeout=600)


def _digest(folder: Path) -> dict:
    return {p.relative_to(folder).as_posix(): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*")) if p.is_file() and p.suffix in (".svg", ".pdf", ".png", ".csv")}


@pytest.mark.slow
def test_batch_runs_resumes_reports_failures_and_is_byte_stable(setup):
    root, exp, nbs, bad = setup
    reports = root / "reports"
    out = _batch([exp, bad, "--reports", reports], nbs)
    assert out.returncode == 1, out.stderr  # one experiment failed
    assert "Traceback" not in out.stdout + out.stderr
    summary = out.stdout
    assert "phantom-S2" in summary and "done" in summary
    assert "bad" in summary and "required key is missing" in summary  # the broken file, with its reason
    rep = reports / "phantom-S2"
    for f in ("00_test.ipynb", "00_test.html", "provenance.json", "results/curves.csv", "figures/shapes.svg",
              "figures/shapes.pdf", "figures/shapes.png", "tables/frames.csv"):
        assert (rep / f).is_file(), f
    assert (reports / "comparison" / "figures" / "n.txt").read_text() == "1"
    # index pages: the batch's, each experiment's (with its notebooks, figures, tables)
    assert 'href="phantom-S2/index.html"' in (reports / "index.html").read_text()
    index = (rep / "index.html").read_text()
    assert 'href="00_test.html"' in index and "figures/shapes.png" in index and "tables/frames.csv" in index
    assert (rep / "tables" / "README.md").is_file()
    page = (rep / "00_test.html").read_text()
    assert str(root) not in page and "https://cdnjs" not in page
    log = (rep / "batch.log").read_text()  # what the run did, not the kernels' start-up chatter
    assert "phantom-S2: reconstructed," in log and "00_test.ipynb executed" in log
    assert "without encryption" not in log
    first = _digest(rep)

    again = _batch([exp, "--reports", reports], nbs)
    assert again.returncode == 0 and "skipped" in again.stdout  # finished work is not redone

    other = root / "reports2"
    third = _batch([exp, "--reports", other], nbs)
    assert third.returncode == 0, third.stderr
    assert _digest(other / "phantom-S2") == first  # same inputs, same bytes (figures, tables, results)

    shutil.rmtree(rep / "figures")
    forced = _batch([exp, "--reports", reports, "--force"], nbs)
    assert forced.returncode == 0 and (rep / "figures" / "shapes.svg").is_file()
    assert _digest(rep) == first
