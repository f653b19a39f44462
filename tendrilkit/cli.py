"""Command line: ``python -m tendrilkit COMMAND ...``.

Every user mistake (:class:`~tendrilkit.exceptions.ExperimentError`) is printed
as one line ``tendrilkit: error: ...`` and the command exits with code 2; no
traceback. ``reconstruct`` exits with 0 when every frame is ``ok`` and 1 when
some are ``doubtful`` or ``failed``, ``fit`` with 1 when some failed (the run
still completes); a result that cannot be written (disk full, quota,
read-only) exits with 74 (one line; finished frames kept); Ctrl-C exits with
130 and SIGTERM with 143 (one line; finished frames kept). Warnings are one
line each, ``tendrilkit: warning: ...``.
Each command's body lives in the library; this module only parses arguments
and reports.
"""

from __future__ import annotations

import argparse
import contextlib
import errno
import os
import signal
import sys
import warnings
from pathlib import Path

from tendrilkit.exceptions import ExperimentError, OutputWriteError

#: Exit codes of every command (README, "Exit codes").
EXIT_OK, EXIT_FRAMES_FAILED, EXIT_INPUT, EXIT_WRITE, EXIT_INTERRUPTED, EXIT_TERMINATED = 0, 1, 2, 74, 130, 143
_ACCEPT = {"calibration": {"max_corner_rms_px": None}}


class Terminated(KeyboardInterrupt):
    """SIGTERM, handled as Ctrl-C (finished frames kept), exit code 143."""


def _cmd_phantom(args: argparse.Namespace) -> int:
    from tendrilkit.phantom import PhantomError, write_phantom_experiment

    if args.scene is not None:
        if args.site is not None:
            raise ExperimentError("phantom: give --site or --scene, not both")
        from tendrilkit.phantom import write_scene_experiment

        try:
            path = write_scene_experiment(Path(args.out), seed=args.seed, scene=args.scene, n_frames=args.frames)
        except PhantomError as e:
            raise ExperimentError(str(e)) from None
        print(f"{args.scene} seed {args.seed}: {path}")
        return 0
    if args.site is None:
        raise ExperimentError("phantom: expected --site S1|S2|S3|S4|all or --scene NAME")
    sites = ["S1", "S2", "S3", "S4"] if args.site == "all" else [args.site]
    for site in sites:
        out = Path(args.out) if len(sites) == 1 else Path(args.out) / site
        path = write_phantom_experiment(site, out, n_frames=args.frames, seed=args.seed)
        print(f"{site}: {path}")
    return 0


def _cmd_calibrate(args: argparse.Namespace) -> int:
    from tendrilkit.extrinsics import calibrate_to_dir

    summary = calibrate_to_dir(Path(args.experiment), Path(args.out),
                               overrides=_ACCEPT if args.accept_calibration else None)
    print(summary)
    return 0


def _cluster(args: argparse.Namespace):
    """``--scheduler`` (or ``$TENDRILKIT_SCHEDULER``): a connected Dask cluster, or None for tendrilkit's pool."""
    from tendrilkit.distributed import Cluster, scheduler_from

    spec = scheduler_from(args.scheduler)
    return contextlib.nullcontext() if spec is None else Cluster(spec)


def _announce(cluster) -> None:
    if cluster is not None and cluster.dashboard_link:
        print(f"tendrilkit: Dask dashboard {cluster.dashboard_link}", file=sys.stderr, flush=True)


def _cmd_reconstruct(args: argparse.Namespace) -> int:
    _single_threaded_blas()
    from tendrilkit.runner import run_reconstruct

    with _cluster(args) as cluster:
        _announce(cluster)
        summary = run_reconstruct(Path(args.experiment), Path(args.out),
                                  workers=cluster.n_workers if cluster else args.workers, progress=not args.quiet,
                                  overrides=_ACCEPT if args.accept_calibration else None,
                                  executor=cluster.executor if cluster else None)
    print(summary)  # the command's last line
    return summary.exit_code


def _cmd_overlay(args: argparse.Namespace) -> int:
    from tendrilkit.qc import run_overlay

    summary = run_overlay(Path(args.experiment), Path(args.results), video=args.video, sheet=args.sheet,
                          fps=args.fps, height_px=args.height)
    print(summary)
    return 0


def _single_threaded_blas() -> None:
    """One BLAS thread unless the user chose otherwise (set before numpy is first imported, else nothing).

    The fit's matrices are small (a few hundred rows, tens of columns): a second
    BLAS thread costs more in hand-overs than it saves (on the site phantoms' curves
    about a fifth more CPU on a busy machine), and the results are the same. The
    same holds for ``reconstruct`` and ``batch``, whose parallelism is one process
    per worker or experiment.
    """
    if "numpy" in sys.modules:  # in-process (tests, notebooks): too late, and not ours to change
        return
    for var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ.setdefault(var, "1")


#: Optional packages numba imports when they are installed, for features the fit never uses: ``coverage``
#: (numba's report of compiled lines to a running coverage measurement) and ``cffi`` (cffi functions called
#: from compiled code). Both are in the environment (nbval needs coverage, jupyter cffi); numba's start
#: with them costs the fit command about a tenth of a second more (``benchmarks/bench_pwc.py --command-csv``).
NUMBA_EXTRAS = ("coverage", "cffi")


@contextlib.contextmanager
def _without_numba_extras():
    """Inside: numba, if first imported here, finds :data:`NUMBA_EXTRAS` missing (unless already imported).

    Only a process that has not imported numba yet is changed (a command run from the shell; in a
    test or notebook numba is usually loaded already, and a package already imported, e.g. coverage
    under ``pytest --cov``, is never hidden). The packages are importable again on the way out;
    numba keeps the decision it made (cffi functions and coverage of compiled lines are off in
    this process).
    """
    hidden = [] if "numba" in sys.modules else [n for n in NUMBA_EXTRAS if n not in sys.modules]
    for name in hidden:
        sys.modules[name] = None  # an import of it raises ImportError, which numba takes as "not installed"
    try:
        yield
    finally:
        for name in hidden:
            if sys.modules.get(name, 0) is None:
                del sys.modules[name]


def _blas_without_scipy_linalg() -> None:
    """Load scipy's BLAS and LAPACK Cython modules without running ``scipy.linalg``'s ``__init__``.

    numba's first compiled call sets up its CPU target, which checks for BLAS by importing
    ``scipy.linalg.cython_blas``; that import runs ``scipy.linalg``'s ``__init__`` (its whole API
    and scipy's array-API layer, which imports ``numpy.f2py``, ``numpy.ma``, ``numpy.testing``):
    about 0.2 s of the fit command's start (of 0.3 s numba's set-up), for a package the fit never
    calls (the compiled kernels take BLAS and LAPACK from those two modules). Here the two modules
    are imported under a bare ``scipy.linalg`` (only its ``__path__``), which is dropped at once:
    numba's imports find the modules loaded, and a later ``import scipy.linalg`` imports the
    package in full, as usual, except that the two are not its attributes (``from scipy.linalg
    import cython_blas`` and ``import scipy.linalg.cython_blas as cb`` work, the attribute
    ``scipy.linalg.cython_blas`` does not; nothing here reads it, and the command's process ends
    with the fit). Only in a process that has imported neither numba nor ``scipy.linalg`` (a
    command run from the shell); otherwise nothing.
    """
    if "numba" in sys.modules or "scipy.linalg" in sys.modules:
        return
    import types

    try:
        import scipy
    except ImportError:  # numba reports the missing BLAS itself
        return
    bare = types.ModuleType("scipy.linalg")
    bare.__path__ = [os.path.join(os.path.dirname(scipy.__file__), "linalg")]
    sys.modules["scipy.linalg"] = bare
    try:
        import scipy.linalg.cython_blas  # noqa: F401
        import scipy.linalg.cython_lapack  # noqa: F401
    except ImportError:  # a scipy built otherwise: numba's own import decides
        for name in ("scipy.linalg.cython_blas", "scipy.linalg.cython_lapack"):
            sys.modules.pop(name, None)
    finally:
        if sys.modules.get("scipy.linalg") is bare:
            del sys.modules["scipy.linalg"]
        if scipy.__dict__.get("linalg") is bare:
            del scipy.linalg


@contextlib.contextmanager
def _without_cyclic_gc():
    """Inside: Python's cyclic garbage collector off (reference counting frees as usual); on the way out
    the objects then alive are frozen (``gc.freeze``: never walked again) and the collector is on again
    if it was.

    The fit command's collections (about 270 young, 25 middle and two full over a 100-frame run, and
    one more at the interpreter's exit) walk the objects numba creates at its import and set-up, which
    live as long as the process: 50-100 ms of the command, for nothing: its fits leave no cyclic garbage
    (none over 100 frames after the first; a run leaves about 500 objects, from its reading and
    writing, with one worker or two; frozen with the rest). Without the freeze, the first collection
    after this would walk every object made inside.
    """
    import gc

    was_on = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        gc.freeze()
        if was_on:
            gc.enable()


def _cmd_fit(args: argparse.Namespace) -> int:
    _single_threaded_blas()
    with _without_numba_extras(), _without_cyclic_gc():
        _blas_without_scipy_linalg()
        from tendrilkit.fitting import run_fit

        summary = run_fit(Path(args.curves), Path(args.out), workers=args.workers)  # None: every core
    print(summary)
    return 0 if summary.n_failed == 0 else 1  # as reconstruct: 1 when some frames failed


def _cmd_batch(args: argparse.Namespace) -> int:
    _single_threaded_blas()  # experiments run in parallel processes (and their notebooks' kernels inherit it)
    from tendrilkit.batch import run_batch

    def report(o) -> None:  # each experiment as it finishes, on stderr (the table goes to stdout)
        print(f"{o.name}: {o.status}{' - ' + o.message if o.message else ''}", file=sys.stderr, flush=True)

    with _cluster(args) as cluster:
        _announce(cluster)
        summary = run_batch([Path(p) for p in args.experiments], Path(args.reports), force=args.force,
                            workers=cluster.n_workers if cluster else args.workers,
                            notebooks=Path(args.notebooks) if args.notebooks else None,
                            on_outcome=report, executor=cluster.executor if cluster else None)
    print(summary)
    return summary.exit_code


_ACCEPT_HELP = ("use the calibration even if marker corners reproject beyond calibration.max_corner_rms_px "
                "(same as max_corner_rms_px: null)")


_SCHEDULER_HELP = ("run on a Dask cluster: tcp://HOST:PORT of a `dask scheduler`, local:N (a local cluster of N "
                   "workers) or pool (tendrilkit's process pool; the default, unless $TENDRILKIT_SCHEDULER is set)")


def _cmd_intrinsics(args: argparse.Namespace) -> int:
    from tendrilkit.intrinsics import run_intrinsics

    code, report = run_intrinsics(Path(args.source), args.board, view=args.view, write=args.write,
                                  max_frames=args.max_frames)
    print(report)
    return code


def _cmd_marks(args: argparse.Namespace) -> int:
    from tendrilkit.marks import run_marks

    code, report = run_marks(Path(args.experiment), Path(args.out) if args.out else None)
    print(report)
    return code


def _cmd_check(args: argparse.Namespace) -> int:
    from tendrilkit.preflight import run_check

    code, report = run_check(Path(args.experiment))
    print(report)
    return code


def _cmd_init(args: argparse.Namespace) -> int:
    from tendrilkit.marks import run_init

    code, report = run_init([Path(v) for v in args.videos], Path(args.out), marker_id=args.marker_id,
                            marker_mm=args.marker_mm, dictionary=args.dictionary,
                            intrinsics=[Path(p) for p in args.intrinsics] if args.intrinsics else None,
                            force=args.force)
    print(report)
    return code


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="tendrilkit", description="3D shape of tendrils from three calibrated views (Fan et al., IJCV 2025).")
    sub = p.add_subparsers(dest="command", required=True)

    ph = sub.add_parser("phantom", help="generate a synthetic experiment with exact ground truth")
    ph.add_argument("--site", choices=["S1", "S2", "S3", "S4", "all"], default=None,
                    help="a site phantom (the demo's four experiments)")
    ph.add_argument("--scene", default=None, metavar="NAME",
                    help="a random scene like a real recording: 'random' (factors drawn from --seed), a preset "
                         "switching one factor, or presets joined by '+' switched on together, e.g. "
                         "coil+over_stem+tip_leaf (see README: Random scenes)")
    ph.add_argument("--out", required=True, help="output folder")
    ph.add_argument("--frames", type=int, default=None, help="sequence length (default: the phantom's default)")
    ph.add_argument("--seed", type=int, default=0)
    ph.set_defaults(func=_cmd_phantom)

    ca = sub.add_parser("calibrate", help="camera poses from the world marker; writes cameras.json")
    ca.add_argument("experiment")
    ca.add_argument("--out", required=True)
    ca.add_argument("--accept-calibration", action="store_true", help=_ACCEPT_HELP)
    ca.set_defaults(func=_cmd_calibrate)

    re_ = sub.add_parser("reconstruct", help="calibrate, segment, order, match, triangulate and fit every frame")
    re_.add_argument("experiment")
    re_.add_argument("--out", required=True)
    re_.add_argument("--workers", type=int, default=None, help="processes for frames (default: all cores)")
    re_.add_argument("--quiet", action="store_true", help="no progress bar")
    re_.add_argument("--accept-calibration", action="store_true", help=_ACCEPT_HELP)
    re_.add_argument("--scheduler", default=None, metavar="ADDRESS", help=_SCHEDULER_HELP)
    re_.set_defaults(func=_cmd_reconstruct)

    ov = sub.add_parser("overlay", help="the reconstruction projected onto the views: a video and/or a contact sheet")
    ov.add_argument("experiment")
    ov.add_argument("results", help="the reconstruct run's folder")
    ov.add_argument("--video", default=None, help="write every frame's overlay to this .mp4/.avi")
    ov.add_argument("--sheet", default=None, help="write a contact sheet PNG (default without --video: "
                                                  "RESULTS/qc_contact_sheet.png)")
    ov.add_argument("--fps", type=float, default=4.0, help="video frame rate (playback)")
    ov.add_argument("--height", type=int, default=480, help="height of each view in the video, px")
    ov.set_defaults(func=_cmd_overlay)

    fi = sub.add_parser("fit", help="refit the piece-wise clothoid to every frame of a curves.csv")
    fi.add_argument("curves")
    fi.add_argument("--out", required=True)
    fi.add_argument("--workers", type=int, default=None, help="processes for frames (default: all cores)")
    fi.set_defaults(func=_cmd_fit)

    ba = sub.add_parser("batch", help="run the notebooks of each experiment into reports/<experiment>/")
    ba.add_argument("experiments", nargs="+")
    ba.add_argument("--reports", default="reports")
    ba.add_argument("--force", action="store_true", help="rerun finished experiments")
    ba.add_argument("--workers", type=int, default=None)
    ba.add_argument("--notebooks", default=None, help="notebook collection to run (default: notebooks/)")
    ba.add_argument("--scheduler", default=None, metavar="ADDRESS", help=_SCHEDULER_HELP)
    ba.set_defaults(func=_cmd_batch)
    it = sub.add_parser("intrinsics", help="calibrate one camera (K, distortion) from a video of a board")
    it.add_argument("source", help="video or folder of numbered images of the board")
    it.add_argument("--board", required=True,
                    help="charuco:SQUARES_X,SQUARES_Y,SQUARE_MM,MARKER_MM,DICT or checkerboard:COLS,ROWS,SQUARE_MM (inner corners)")
    it.add_argument("--view", type=int, default=1, help="view number of the cameras: entry (default 1)")
    it.add_argument("--write", default=None, help="fill the entry into this experiment file (or a new intrinsics file)")
    it.add_argument("--max-frames", type=int, default=200, help="frames looked at, spread over the video")
    it.set_defaults(func=_cmd_intrinsics)

    mk = sub.add_parser("marks", help="draw the marks on the first frame of every view and suggest missing or doubtful ones")
    mk.add_argument("experiment")
    mk.add_argument("--out", default=None, help="folder of the pictures (default: marks/ beside the experiment file)")
    mk.set_defaults(func=_cmd_marks)

    ck = sub.add_parser("check", help="preflight: videos, marker, poses, marks and a trial reconstruction, in seconds")
    ck.add_argument("experiment")
    ck.set_defaults(func=_cmd_check)

    ini = sub.add_parser("init", help="a template experiment file from the videos, marks suggested")
    ini.add_argument("videos", nargs="+", help="one video (or image folder) per view, in view order")
    ini.add_argument("--out", required=True, help="the experiment file to write")
    ini.add_argument("--marker-id", type=int, default=815)
    ini.add_argument("--marker-mm", type=float, default=24.0, help="side of the world marker's black square, mm")
    ini.add_argument("--dictionary", default="DICT_ARUCO_ORIGINAL")
    ini.add_argument("--intrinsics", nargs="+", default=None, help="files written by `intrinsics --write`, one per view")
    ini.add_argument("--force", action="store_true", help="overwrite an existing file")
    ini.set_defaults(func=_cmd_init)
    return p


def _on_sigterm(signum, frame) -> None:
    raise Terminated()


def _show_warning(message, category, filename, lineno, file=None, line=None) -> None:
    text = " ".join(str(message).split())
    print(f"tendrilkit: warning: {text}", file=sys.stderr, flush=True)


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        old_term = signal.signal(signal.SIGTERM, _on_sigterm)
    except ValueError:  # not the main thread: SIGTERM keeps its handler
        old_term = None
    try:
        with warnings.catch_warnings():
            warnings.showwarning = _show_warning
            return int(args.func(args) or 0)
    except ExperimentError as e:
        print(f"tendrilkit: error: {e}", file=sys.stderr)
        return EXIT_INPUT
    except OutputWriteError as e:
        print(f"tendrilkit: error: {e}; finished frames are kept: free space (or fix the folder) and run the same "
              f"command again", file=sys.stderr)
        return EXIT_WRITE
    except OSError as e:
        if e.errno not in (errno.ENOSPC, errno.EDQUOT, errno.EROFS, errno.EFBIG):
            raise
        where = f"{e.filename}: " if e.filename else ""
        print(f"tendrilkit: error: {where}cannot write ({e.strerror}); finished frames are kept: free space and run "
              f"the same command again", file=sys.stderr)
        return EXIT_WRITE
    except Terminated:
        print("tendrilkit: terminated (SIGTERM); finished frames are kept, run the same command again to continue",
              file=sys.stderr)
        return EXIT_TERMINATED
    except KeyboardInterrupt:
        print("tendrilkit: interrupted; finished frames are kept, run the same command again to continue", file=sys.stderr)
        return EXIT_INTERRUPTED
    finally:
        if old_term is not None:
            signal.signal(signal.SIGTERM, old_term)
