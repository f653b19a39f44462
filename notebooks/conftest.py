"""The data the reference notebooks were executed on, rebuilt before nbval checks them.

A short S3 phantom (deterministic: same bytes every time) and its
reconstruction, in ``data/nbval/S3/``. Built once per machine (under a file
lock, as pytest-xdist workers start together) and reused while its stamp
matches.

The notebooks' default parameters read the demo's outputs (``params/`` and
``reports/``); under nbval their ``parameters`` cell is rewritten to read this
10-frame phantom instead (:func:`nbval_parameters`), the data their reference
outputs were made from (``python notebooks/conftest.py`` re-executes them).
"""

from __future__ import annotations

import fcntl
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "data" / "nbval"
NBVAL_FRAMES = 10
#: demo path (as the notebooks' defaults spell it) -> the nbval data
NBVAL_PATHS = {
    "../params/phantom_S3.yaml": "../data/nbval/S3/experiment.yaml",
    "../reports/phantom-S3/": "../data/nbval/S3/",
    "../reports/comparison/": "../data/nbval/comparison/",
}


def build_nbval_data() -> Path:
    DATA.mkdir(parents=True, exist_ok=True)
    exp = DATA / "S3" / "experiment.yaml"
    with open(DATA / ".lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        env = dict(os.environ, TENDRILKIT_PROGRESS="0")
        run = [sys.executable, "-m", "tendrilkit"]
        subprocess.run(run + ["phantom", "--site", "S3", "--frames", str(NBVAL_FRAMES), "--out", str(DATA / "S3")],
                       check=True, cwd=ROOT, env=env, stdout=subprocess.DEVNULL)
        # reconstruct resumes: finished frames are reused, so a rebuilt checkout costs nothing
        subprocess.run(run + ["reconstruct", str(exp), "--out", str(DATA / "S3" / "results"), "--quiet"],
                       check=True, cwd=ROOT, env=env, stdout=subprocess.DEVNULL)
    return exp


def _nbval_value(v):
    if isinstance(v, list):  # the cross-site notebook: only the S3 phantom exists here
        return [_nbval_value(x) for x in v if "S3" in str(x)]
    if isinstance(v, str):
        for demo, nbval in NBVAL_PATHS.items():
            v = v.replace(demo, nbval)
    return v


def nbval_parameters(source: str) -> str:
    """A ``parameters`` cell's source with the demo's paths replaced by the nbval data's."""
    ns: dict = {}
    exec(source, {}, ns)
    return "\n".join(f"{k} = {_nbval_value(v)!r}" for k, v in ns.items())


def pytest_sessionstart(session):
    if any("notebooks" in str(a) or str(a).endswith(".ipynb") for a in session.config.args):
        build_nbval_data()


def pytest_collection_modifyitems(session, config, items):
    for item in items:
        cell = getattr(item, "cell", None)
        if cell is not None and "parameters" in cell.get("metadata", {}).get("tags", []):
            cell.source = nbval_parameters(cell.source)


def reexecute(paths: list[Path]) -> None:
    """Execute the reference notebooks in place on the nbval data (their defaults kept), figures inline."""
    import nbformat
    from nbclient import NotebookClient

    build_nbval_data()
    os.environ["MPLBACKEND"] = "module://matplotlib_inline.backend_inline"
    os.environ["TENDRILKIT_PROGRESS"] = "0"
    for p in paths:
        nb = nbformat.read(str(p), as_version=4)
        params = [c for c in nb.cells if "parameters" in c.metadata.get("tags", [])]
        defaults = [c.source for c in params]
        for c in params:
            c.source = nbval_parameters(c.source)
        NotebookClient(nb, kernel_name="python3", timeout=600, resources={"metadata": {"path": str(p.parent)}}).execute()
        for c, d in zip(params, defaults):
            c.source = d
        for c in nb.cells:  # no run-specific metadata in the reference notebooks
            c.metadata.pop("execution", None)
        nbformat.write(nb, str(p))
        print(f"executed {p.name}", flush=True)


if __name__ == "__main__":
    here = Path(__file__).resolve().parent
    reexecute([here / a for a in sys.argv[1:]] or sorted(here.glob("[0-9][0-9]_*.ipynb")))
