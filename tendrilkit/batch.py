"""Batch runs: the numbered notebooks of each experiment, executed with papermill.

``python -m tendrilkit batch params/*.yaml`` runs, for every experiment file,

1. ``reconstruct`` into ``reports/<name>/results/`` (resumable frame by frame),
2. every per-experiment notebook ``notebooks/NN_*.ipynb`` (in number order)
   into ``reports/<name>/``, filled with the experiment's parameters,
3. an HTML page per executed notebook and ``provenance.json``; the
   notebooks' kernels log to ``reports/<name>/batch.log``,

experiments in parallel processes, the stages of one experiment in order.
Then the cross-site notebook (``07_compare_sites.ipynb``) runs over every
experiment that finished, into ``reports/comparison/``.

Resumable: an experiment whose ``reports/<name>/.done`` holds the same
fingerprint (experiment file, notebooks, tendrilkit version) is skipped unless
``--force``; every output is written to a temporary file and renamed. One
failed experiment does not stop the others; it is reported with its reason.
Before anything runs, every experiment's ``name`` must be a safe folder
name (:func:`tendrilkit.params.folder_name_problem`: no ``..``, ``.``, path
separators or control characters), not ``comparison`` (the cross-site
folder), and unique in the batch; otherwise exit code 2 naming the files.
Exit code: 0 if every experiment finished, 1 otherwise, 2 for bad input.
"""

from __future__ import annotations

import hashlib
import json
import os
import platform
import subprocess
import sys
import time
import traceback
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

from tendrilkit.exceptions import ExperimentError

def default_notebooks_dir() -> Path:
    """The notebook collection a batch runs when none is given (``batch --notebooks``).

    ``notebooks/`` of the source checkout the package runs from, else
    ``notebooks/`` of the working folder. Raises :class:`ExperimentError`
    when neither exists (an installed package carries no notebooks).
    """
    for d in (Path(__file__).resolve().parents[1] / "notebooks", Path.cwd() / "notebooks"):
        if d.is_dir():
            return d
    raise ExperimentError("batch: no notebooks/ folder next to tendrilkit or in the working folder; expected "
                          "--notebooks DIR (the numbered notebooks, e.g. a clone's notebooks/)")


CROSS_SITE = "07_compare_sites.ipynb"
PROVENANCE_PACKAGES = ("tendrilkit", "numpy", "scipy", "pandas", "opencv-python-headless", "scikit-image",
                       "numba", "matplotlib", "plotly", "papermill", "pydantic")


@dataclass(frozen=True)
class ExperimentOutcome:
    name: str
    experiment: str
    status: str  # done | skipped | failed
    seconds: float
    frames_ok: int = 0
    frames_failed: int = 0
    message: str = ""
    frames_doubtful: int = 0


@dataclass(frozen=True)
class BatchSummary:
    """What :func:`run_batch` did; ``str()`` is the table the command prints."""

    outcomes: tuple[ExperimentOutcome, ...]

    @property
    def exit_code(self) -> int:
        """0 if every experiment finished (or was finished earlier), else 1."""
        return 0 if all(o.status in ("done", "skipped") for o in self.outcomes) else 1

    def __str__(self) -> str:
        return format_summary(list(self.outcomes))


def experiment_notebooks(notebooks: Path) -> list[Path]:
    """The per-experiment notebooks of the folder ``notebooks``, in number order."""
    return sorted(p for p in Path(notebooks).glob("[0-9][0-9]_*.ipynb") if p.name != CROSS_SITE)


def _sha256(paths: list[Path]) -> str:
    h = hashlib.sha256()
    for p in paths:
        h.update(p.name.encode())
        h.update(p.read_bytes())
    return h.hexdigest()


def fingerprint(experiment_path: Path, exp_dict: dict, notebooks: Path) -> str:
    """What decides whether a finished experiment must run again."""
    from tendrilkit import __version__

    h = hashlib.sha256()
    h.update(json.dumps(exp_dict, sort_keys=True, default=str).encode())
    h.update(_sha256(experiment_notebooks(notebooks)).encode())
    h.update(__version__.encode())
    return h.hexdigest()


def git_commit(folder: Path) -> str | None:
    """The commit (``-dirty`` if changed) of the git checkout holding ``folder``, or None."""
    try:
        out = subprocess.run(["git", "rev-parse", "HEAD"], cwd=folder, capture_output=True, text=True, timeout=10)
        if out.returncode != 0:
            return None
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"], cwd=folder,
                               capture_output=True, text=True, timeout=10).stdout.strip()
        return out.stdout.strip() + ("-dirty" if dirty else "")
    except (OSError, subprocess.SubprocessError):
        return None


def package_versions() -> dict[str, str]:
    from importlib.metadata import PackageNotFoundError, version

    out = {"python": platform.python_version()}
    for name in PROVENANCE_PACKAGES:
        try:
            out[name] = version(name)
        except PackageNotFoundError:
            out[name] = "not installed"
    return out


def provenance(exp_dict: dict, experiment_path: Path, notebooks: Path) -> dict:
    """Resolved parameters, package versions and git commit of the notebooks' checkout (no timestamps:
    reports stay byte-stable)."""
    return {
        "experiment_file": str(experiment_path),
        "resolved_parameters": exp_dict,
        "packages": package_versions(),
        "git_commit": git_commit(notebooks),
        "notebooks": [p.name for p in experiment_notebooks(notebooks)],
    }


def execute_notebook(src: Path, dst: Path, parameters: dict, *, cwd: Path, static_dir: Path | None = None) -> None:
    """Run one notebook with papermill into ``dst`` (atomically) and write ``dst`` as HTML beside it.

    Path parameters are passed relative to ``cwd`` (what a reader would type);
    the kernel draws figures inline (``MPLBACKEND`` of this process is not
    passed on), so the notebook and its page show them.
    """
    import papermill as pm

    from tendrilkit.io import atomic_path

    dst.parent.mkdir(parents=True, exist_ok=True)
    parameters = {k: _relative(v, cwd, Path(cwd).resolve().parent) for k, v in parameters.items()}
    saved = os.environ.get("MPLBACKEND")
    os.environ["MPLBACKEND"] = "module://matplotlib_inline.backend_inline"
    try:
        with atomic_path(dst) as tmp:
            tmp_nb = tmp.with_suffix(".ipynb")
            try:
                pm.execute_notebook(str(src), str(tmp_nb), parameters=parameters, kernel_name="python3",
                                    cwd=str(cwd), progress_bar=False, log_output=False)
            finally:
                if tmp_nb.exists():
                    os.replace(tmp_nb, tmp)
    finally:
        if saved is None:
            os.environ.pop("MPLBACKEND", None)
        else:
            os.environ["MPLBACKEND"] = saved
    write_html(dst, static_dir=static_dir)


def _relative(value, cwd: Path, root: Path):
    """A path parameter (or a list of them) inside the project folder ``root``, relative to ``cwd``; other
    values as they are."""
    if isinstance(value, list):
        return [_relative(v, cwd, root) for v in value]
    if isinstance(value, str) and os.path.isabs(value) and Path(value).resolve().is_relative_to(root):
        return os.path.relpath(value, Path(cwd).resolve())
    return value


def write_html(notebook: Path, *, static_dir: Path | None = None) -> Path:
    """The executed notebook as a standalone, offline HTML page (see :mod:`tendrilkit.reports`)."""
    import nbformat

    from tendrilkit.io import write_text
    from tendrilkit.reports import notebook_html, write_plotly_js

    static_dir = Path(static_dir) if static_dir is not None else notebook.parent.parent / "_static"
    nb = nbformat.read(str(notebook), as_version=4)
    body = notebook_html(nb, notebook.parent, static_dir)
    if "Plotly.newPlot" in body:
        write_plotly_js(static_dir)
    out = notebook.with_suffix(".html")
    write_text(body, out)
    return out


def _run_one(experiment_path: str, reports_dir: str, force: bool, notebooks: str) -> ExperimentOutcome:
    """Everything for one experiment; runs in a worker process."""
    notebooks = Path(notebooks)
    os.environ.setdefault("TENDRILKIT_PROGRESS", "0")
    from tendrilkit.io import write_json, write_text
    from tendrilkit.params import experiment_to_dict, load_experiment

    t0 = time.perf_counter()
    path = Path(experiment_path).resolve()
    name = path.stem
    try:
        exp = load_experiment(path)
        name = exp.name
        exp_dict = experiment_to_dict(exp)
        out = Path(reports_dir).resolve() / exp.name
        if out.parent != Path(reports_dir).resolve():  # the name is checked: never outside the reports folder
            raise ExperimentError(f"{path}: name: {exp.name!r} is not a folder name inside {reports_dir}")
        stamp = out / ".done"
        fp = fingerprint(path, exp_dict, notebooks)
        if not force and stamp.is_file() and stamp.read_text().strip() == fp:
            ok, doubtful, failed = _frame_counts(out / "results")
            return ExperimentOutcome(name, str(path), "skipped", time.perf_counter() - t0, ok, failed, "finished earlier",
                                     doubtful)
        if stamp.exists():
            stamp.unlink()
        out.mkdir(parents=True, exist_ok=True)
        _stderr_to(out / "batch.log")
        from tendrilkit.runner import run_reconstruct

        _log(f"{exp.name}: reconstructing {path.name}")
        t = time.perf_counter()
        run_reconstruct(path, out / "results", workers=1, progress=False)  # its summary: from frames.csv below
        ok, doubtful, failed = _frame_counts(out / "results")
        _log(f"{exp.name}: reconstructed, {ok + doubtful + failed} frames: {ok} ok, {doubtful} doubtful, "
             f"{failed} failed ({time.perf_counter() - t:.0f} s)")
        params = {"experiment_path": str(path), "results_dir": str(out / "results"), "figures_dir": str(out / "figures")}
        for nb in experiment_notebooks(notebooks):
            t = time.perf_counter()
            execute_notebook(nb, out / nb.name, params, cwd=notebooks, static_dir=out.parent / "_static")
            _log(f"{exp.name}: {nb.name} executed ({time.perf_counter() - t:.0f} s)")
        write_json(provenance(exp_dict, path, notebooks), out / "provenance.json")
        _finish_pages(out, exp.name)
        _clean_log(out / "batch.log")
        write_text(fp + "\n", stamp)
        ok, doubtful, failed = _frame_counts(out / "results")
        msg = ", ".join(m for m in (f"{doubtful} frame(s) doubtful" if doubtful else "",
                                    f"{failed} frame(s) failed" if failed else "") if m)
        return ExperimentOutcome(name, str(path), "done", time.perf_counter() - t0, ok, failed, msg, doubtful)
    except ExperimentError as e:
        return ExperimentOutcome(name, str(path), "failed", time.perf_counter() - t0, message=str(e))
    except Exception as e:  # one experiment's failure must not stop the others
        last = traceback.extract_tb(e.__traceback__)[-1] if e.__traceback__ else None
        where = f" ({Path(last.filename).name}:{last.lineno})" if last else ""
        first = str(e).strip().splitlines()[0] if str(e).strip() else ""
        return ExperimentOutcome(name, str(path), "failed", time.perf_counter() - t0,
                                 message=f"{e.__class__.__name__}: {first}{where}"[:300])


def _finish_pages(out: Path, title: str) -> None:
    """The README of ``tables/`` and ``index.html`` of one report folder."""
    from tendrilkit.reports import write_experiment_index, write_tables_readme

    if (out / "tables").is_dir():
        write_tables_readme(out / "tables")
    write_experiment_index(out, title=title)


def _stderr_to(path: Path) -> None:
    """Send this worker process's stderr (and its kernels') to ``path``: the terminal keeps the summary."""
    sys.stderr.flush()
    with open(path, "w", encoding="utf-8") as f:
        os.dup2(f.fileno(), 2)


#: what every Jupyter kernel prints at start (jupyter_client's TCP transport): noise in batch.log
_KERNEL_NOISE = ("Kernel is running over TCP without encryption",)


def _log(line: str) -> None:
    """One line of a batch worker's log (its stderr is ``reports/<name>/batch.log``)."""
    sys.stderr.write(line + "\n")
    sys.stderr.flush()


def _clean_log(path: Path) -> None:
    """Drop the kernels' start-up chatter from a finished experiment's ``batch.log``; keep everything else."""
    sys.stderr.flush()
    try:
        lines = path.read_text(encoding="utf-8", errors="replace").splitlines(keepends=True)
    except OSError:
        return
    kept = [ln for ln in lines if not any(n in ln for n in _KERNEL_NOISE)]
    if len(kept) != len(lines):
        with open(path, "r+", encoding="utf-8") as f:  # the same file (our stderr points at it): rewrite in place
            f.write("".join(kept))
            f.truncate()
        os.lseek(2, 0, os.SEEK_END)


def _frame_counts(results: Path) -> tuple[int, int, int]:
    """Frames ``ok``, ``doubtful`` and ``failed`` in a results folder."""
    import pandas as pd

    f = results / "frames.csv"
    if not f.is_file():
        return 0, 0, 0
    st = pd.read_csv(f)["status"]
    return int((st == "ok").sum()), int((st == "doubtful").sum()), int((~st.isin(["ok", "doubtful"])).sum())


def run_comparison(outcomes: list[ExperimentOutcome], reports_dir: Path, notebooks: Path, *,
                   executor=None) -> ExperimentOutcome | None:
    """The cross-site notebook of the folder ``notebooks`` over every finished experiment (in its own process, or a task of ``executor``)."""
    src = Path(notebooks) / CROSS_SITE
    finished = [o for o in outcomes if o.status in ("done", "skipped")]
    if not src.is_file() or not finished:
        return None
    t0 = time.perf_counter()
    out = reports_dir.resolve() / "comparison"
    params = {
        "experiment_paths": [o.experiment for o in finished],
        "results_dirs": [str(reports_dir.resolve() / o.name / "results") for o in finished],
        "figures_dir": str(out / "figures"),
    }
    try:
        if executor is not None:
            executor.submit(_compare_in_worker, str(src), str(out), params).result()
        else:
            with ProcessPoolExecutor(max_workers=1) as pool:  # its own process: the kernel's chatter goes to a log
                pool.submit(_compare_in_worker, str(src), str(out), params).result()
        return ExperimentOutcome("comparison", "", "done", time.perf_counter() - t0)
    except Exception as e:
        first = str(e).strip().splitlines()[0] if str(e).strip() else ""
        return ExperimentOutcome("comparison", "", "failed", time.perf_counter() - t0,
                                 message=f"{e.__class__.__name__}: {first}"[:300])


def _compare_in_worker(src: str, out: str, params: dict) -> None:
    Path(out).mkdir(parents=True, exist_ok=True)
    _stderr_to(Path(out) / "batch.log")
    execute_notebook(Path(src), Path(out) / Path(src).name, params, cwd=Path(src).parent,
                     static_dir=Path(out).parent / "_static")
    _log(f"comparison: {Path(src).name} executed")
    _finish_pages(Path(out), "Comparison of the stimulation sites")
    _clean_log(Path(out) / "batch.log")


def format_summary(outcomes: list[ExperimentOutcome]) -> str:
    rows = [("experiment", "status", "frames ok", "doubtful", "failed", "time", "message")]
    for o in outcomes:
        rows.append((o.name, o.status, str(o.frames_ok), str(o.frames_doubtful), str(o.frames_failed),
                     f"{o.seconds:.0f} s", o.message))
    widths = [max(len(r[i]) for r in rows) for i in range(len(rows[0]) - 1)]
    lines = ["  ".join(c.ljust(w) for c, w in zip(r[:-1], widths)) + "  " + r[-1] for r in rows]
    return "\n".join(lines)


def _worker_signals() -> None:
    import signal

    signal.signal(signal.SIGTERM, signal.SIG_DFL)  # the command line's SIGTERM handler is the parent's only


def check_batch_names(experiments: list[Path]) -> None:
    """Every experiment's ``name`` a safe folder name, not ``comparison``, unique in the batch.

    Reads only each file's ``name`` (a file that does not parse is left to its
    run, which reports it as failed). Raises :class:`ExperimentError` naming
    the file(s) before anything runs.
    """
    from tendrilkit.params import folder_name_problem
    from tendrilkit.safe_yaml import parse_yaml, read_experiment_text, short_repr

    seen: dict[str, Path] = {}
    for p in experiments:
        try:
            data = parse_yaml(read_experiment_text(Path(p)), source=p)
        except ExperimentError:
            continue
        if not isinstance(data, dict) or "name" not in data:
            continue
        name = data["name"]
        problem = folder_name_problem(name) if isinstance(name, str) else "expected a text usable as a folder name"
        if problem:
            raise ExperimentError(f"{p}: name: {problem} (got {short_repr(name)})")
        if name == "comparison":
            raise ExperimentError(f"{p}: name: 'comparison' is the folder of the cross-site notebook; expected "
                                  f"another name")
        if name in seen:
            raise ExperimentError(f"{p}: name: {name!r} is also the name of {seen[name]}; expected a name unique "
                                  f"in the batch (each writes reports/<name>/)")
        seen[name] = Path(p)


def run_batch(experiments: list[Path], reports_dir: Path, *, force: bool = False, workers: int | None = None,
              notebooks: Path | None = None, on_outcome: Callable[[ExperimentOutcome], None] | None = None,
              executor=None) -> BatchSummary:
    """Run every experiment's notebooks into ``reports_dir``; see the module docstring.

    Parameters
    ----------
    experiments : list of Path
        Experiment files.
    reports_dir : Path
        The reports folder (``<name>/`` per experiment, ``comparison/``).
    force : bool, keyword-only
        Run finished experiments again.
    workers : int, optional
        Experiments in parallel (default: every core, at most one per experiment).
    notebooks : Path, optional
        The notebook collection (default: :func:`default_notebooks_dir`).
    on_outcome : callable, optional
        Called with each experiment's :class:`ExperimentOutcome` as it finishes
        (the command line prints a line).
    executor : concurrent.futures.Executor, optional
        Runs the experiments and the cross-site notebook instead of a local
        process pool (e.g. a Dask cluster's, :class:`tendrilkit.distributed.Cluster`).

    Returns
    -------
    BatchSummary
    """
    from tendrilkit.io import check_writable_dir
    from tendrilkit.progress import progress

    if not experiments:
        raise ExperimentError("batch: no experiment files given")
    missing = [p for p in experiments if not Path(p).is_file()]
    if missing:
        raise ExperimentError(f"{missing[0]}: experiment file not found")
    check_batch_names(experiments)
    check_writable_dir(reports_dir)
    notebooks = Path(notebooks).resolve() if notebooks is not None else default_notebooks_dir()
    if not experiment_notebooks(notebooks):
        raise ExperimentError(f"{notebooks}: no numbered notebooks found")
    workers = max(1, min(workers or os.cpu_count() or 1, len(experiments)))
    outcomes: list[ExperimentOutcome] = []
    pool = executor if executor is not None else ProcessPoolExecutor(max_workers=workers, initializer=_worker_signals)
    try:
        futures = [pool.submit(_run_one, str(p), str(reports_dir), force, str(notebooks)) for p in experiments]
        for fut in progress(as_completed(futures), total=len(futures), desc="experiments"):
            o = fut.result()
            outcomes.append(o)
            if on_outcome is not None:
                on_outcome(o)
    except KeyboardInterrupt:  # Ctrl-C or SIGTERM: stop the running experiments too (their finished frames stay)
        if executor is not None:
            for fut in futures:
                fut.cancel()
            raise
        for proc in list(getattr(pool, "_processes", {}).values()):
            proc.terminate()
        pool.shutdown(wait=False, cancel_futures=True)
        raise
    if executor is None:
        pool.shutdown()
    outcomes.sort(key=lambda o: o.name)
    comp = run_comparison(outcomes, Path(reports_dir), notebooks, executor=executor)
    if comp is not None:
        outcomes.append(comp)
    from tendrilkit.reports import write_batch_index

    write_batch_index(reports_dir, [{"name": o.name, "status": o.status, "message": o.message,
                                     "frames": f"{o.frames_ok} / {o.frames_failed}" if o.name != "comparison" else ""}
                                    for o in outcomes])
    return BatchSummary(tuple(outcomes))
