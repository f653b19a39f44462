"""Reconstructions and batches on a Dask cluster (``--scheduler``, tendrilkit/distributed.py).

The same bytes whatever runs the chunks (tendrilkit's pool, a LocalCluster
of 1 or 2 workers, a resumed run, a run whose worker process is killed while
it holds a chunk); a scheduler that cannot be reached is one line and exit
code 2; a process that cannot open a video fails that view of its frames
with the reason. On the 4-frame S3 phantom of ``test_robustness``.
"""

from __future__ import annotations

import os
import shutil
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from tendrilkit import cli
from tendrilkit.distributed import SCHEDULER_ENV, Cluster, SchedulerSpec, parse_scheduler, scheduler_from
from tendrilkit.exceptions import ExperimentError
from tendrilkit.pipeline import RESULT_FILES
from tests.test_robustness import N_FRAMES, phantom_experiment

ROOT = Path(__file__).resolve().parents[1]


def _result_bytes(out: Path) -> dict[str, bytes]:
    """Every result table and per-frame file of a run folder."""
    files = [out / n for n in RESULT_FILES] + sorted((out / "frames").glob("frame_*.json"))
    return {p.relative_to(out).as_posix(): p.read_bytes() for p in files if p.is_file()}


def _reconstruct(exp: Path, out: Path, *extra: str) -> int:
    return cli.main(["reconstruct", str(exp), "--out", str(out), "--quiet", *extra])


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """The phantom and a run on tendrilkit's process pool (2 workers: speculative chunks, verified)."""
    exp = phantom_experiment(tmp_path_factory)
    out = tmp_path_factory.mktemp("dask_reference") / "out"
    assert _reconstruct(exp, out, "--workers", "2", "--scheduler", "pool") == 0
    ref = _result_bytes(out)
    assert len([k for k in ref if k.startswith("frames/")]) == N_FRAMES
    return exp, ref


# ------------------------------------------------------------------ addresses
def test_parse_scheduler():
    assert parse_scheduler("local:2").kind == "local" and parse_scheduler("LOCAL:2").n_workers == 2
    assert parse_scheduler("pool").kind == "pool"
    for text in ("tcp://10.0.0.5:8786", "10.0.0.5:8786", "tls://sched.lab.org:8786", "sched"):
        spec = parse_scheduler(text)
        assert (spec.kind, spec.address) == ("remote", text)
    for bad in ("local", "local:0", "local:x", "local:9999", "", "tcp://a b:1", "host:port", "tcp://"):
        with pytest.raises(ExperimentError, match="scheduler"):
            parse_scheduler(bad)


def test_scheduler_from_the_environment(monkeypatch):
    monkeypatch.delenv(SCHEDULER_ENV, raising=False)
    assert scheduler_from(None) is None
    monkeypatch.setenv(SCHEDULER_ENV, "local:3")
    assert scheduler_from(None).n_workers == 3
    assert scheduler_from("local:1").n_workers == 1  # --scheduler wins
    assert scheduler_from("pool") is None  # tendrilkit's pool despite the environment


def _closed_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_unreachable_scheduler_is_one_line_and_exit_2(tmp_path, capsys, monkeypatch):
    import tendrilkit.distributed as dist

    monkeypatch.setattr(dist, "CONNECT_TIMEOUT_S", 1.0)
    exp = tmp_path / "missing.yaml"  # never read: the scheduler is checked first
    address = f"tcp://127.0.0.1:{_closed_port()}"
    assert _reconstruct(exp, tmp_path / "out", "--scheduler", address) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"tendrilkit: error: scheduler {address}: cannot connect"), err
    monkeypatch.setenv(SCHEDULER_ENV, "local:many")
    assert cli.main(["batch", str(exp), "--reports", str(tmp_path / "r")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "expected local:N" in err[0], err


def test_a_scheduler_without_workers_is_one_clear_error():
    from distributed import LocalCluster

    with LocalCluster(n_workers=0, processes=False, dashboard_address=None) as lc:
        with pytest.raises(ExperimentError, match="no worker connected within 1 s"):
            with Cluster(parse_scheduler(lc.scheduler_address), worker_timeout_s=1.0):
                pass


def test_cluster_rejects_the_pool_spec():
    with pytest.raises(ValueError):
        Cluster(SchedulerSpec("pool"))


# ------------------------------------------------------------------ worker settings (throughput)
_MAPPED = """
import ctypes
import numpy as np
from tendrilkit.dask_worker import _adaptive_malloc_thresholds

class Info(ctypes.Structure):  # glibc's struct mallinfo2
    _fields_ = [(n, ctypes.c_size_t) for n in ("arena", "ordblks", "smblks", "hblks", "hblkhd", "usmblks",
                                                "fsmblks", "uordblks", "fordblks", "keepcost")]

libc = ctypes.CDLL("libc.so.6")
libc.mallinfo2.restype = Info

def mapped():  # bytes in blocks of their own mapping while a float image of a 1080p frame is alive
    frame = np.ones((1080, 1920), np.float64)
    return libc.mallinfo2().hblkhd

print(mapped(), mapped(), _adaptive_malloc_thresholds(), mapped())
"""
FRAME_B = 1080 * 1920 * 8


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="glibc's mallopt")
def test_a_nannys_malloc_trim_threshold_is_undone_in_the_worker():
    """MALLOC_TRIM_THRESHOLD_ (set by Dask's nanny) maps every frame afresh; a worker's setup undoes it."""
    env = {**os.environ, "MALLOC_TRIM_THRESHOLD_": "65536"}
    r = subprocess.run([sys.executable, "-c", _MAPPED], capture_output=True, text=True, cwd=ROOT, env=env, timeout=120)
    assert r.returncode == 0, r.stderr
    first, second, undone, after = r.stdout.split()
    assert int(first) >= FRAME_B and int(second) >= FRAME_B  # the nanny's setting: a fresh mapping each time
    assert undone == "True" and int(after) < FRAME_B  # the frame taken from the heap
    env.pop("MALLOC_TRIM_THRESHOLD_")
    r = subprocess.run([sys.executable, "-c", _MAPPED], capture_output=True, text=True, cwd=ROOT, env=env, timeout=120)
    assert r.returncode == 0, r.stderr
    first, second, undone, after = r.stdout.split()
    assert int(first) >= FRAME_B and int(second) < FRAME_B  # glibc's adaptive threshold
    assert undone == "False"  # left alone


@pytest.mark.slow
def test_local_cluster_workers_keep_glibc_malloc_and_wake_rarely():
    from tendrilkit.distributed import LOCAL_CONFIG

    with Cluster(parse_scheduler("local:1")) as cluster:
        got = cluster.client.run(lambda: (os.environ.get("MALLOC_TRIM_THRESHOLD_"), _config("distributed.worker.profile.enabled"),
                                          _config("distributed.admin.tick.interval")))
        ticks = cluster.client.run_on_scheduler(lambda dask_scheduler: dask_scheduler.periodic_callbacks["tick"].callback_time)
    assert list(got.values()) == [(None, False, LOCAL_CONFIG["distributed.admin.tick.interval"])]
    assert ticks == 1000


def _config(key: str):
    import dask

    return dask.config.get(key)


# ------------------------------------------------------------------ video not readable where the chunk runs
@pytest.mark.slow
def test_a_process_that_cannot_open_a_video_fails_that_view_with_the_reason(reference, tmp_path):
    from tendrilkit.io import read_cameras
    from tendrilkit.params import load_experiment
    from tendrilkit.runner import _iter_chunk

    exp_path, _ = reference
    copy = tmp_path / "exp"
    shutil.copytree(exp_path.parent, copy)
    exp = load_experiment(copy / exp_path.name)
    out = tmp_path / "out"
    assert _reconstruct(copy / exp_path.name, out, "--workers", "1") == 0
    cameras = read_cameras(out / "cameras.json")
    first = Path(exp.videos[0])
    first.rename(first.with_suffix(".gone"))  # as on a worker that does not see this file
    res = list(_iter_chunk([0, 1], None, exp, cameras, False))
    assert [r.frame for r in res] == [0, 1]
    for r in res:
        assert "view 1: FrameReadError: cannot open the video here" in r.message and "video not found" in r.message
    for v in exp.videos[1:]:
        Path(v).rename(Path(v).with_suffix(".gone"))
    res = list(_iter_chunk([2], None, exp, cameras, False))
    assert res[0].status == "failed" and res[0].message.count("cannot open the video here") == exp.n_views


# ------------------------------------------------------------------ same bytes on a cluster
@pytest.mark.slow
def test_local_clusters_and_a_resumed_run_give_the_pools_bytes(reference, tmp_path, capsys):
    exp, ref = reference
    out1 = tmp_path / "local1"
    assert _reconstruct(exp, out1, "--scheduler", "local:1") == 0
    assert "Dask dashboard http" in capsys.readouterr().err
    assert _result_bytes(out1) == ref
    # an interrupted run: half of the frames done, no tables; the same command finishes it
    out2 = tmp_path / "local2"
    shutil.copytree(out1, out2)
    for name in RESULT_FILES:
        (out2 / name).unlink(missing_ok=True)
    for p in sorted((out2 / "frames").glob("frame_*.json"))[1::2]:
        p.unlink()
    assert _reconstruct(exp, out2, "--scheduler", "local:2") == 0
    assert _result_bytes(out2) == ref


@pytest.mark.slow
def test_a_worker_killed_mid_run_loses_nothing_and_changes_nothing(reference, tmp_path):
    from tendrilkit.runner import run_reconstruct

    exp, ref = reference
    killed: list = []
    with Cluster(parse_scheduler("local:2")) as cluster:
        client = cluster.client
        pids = client.run(os.getpid)
        done = threading.Event()

        def kill_a_busy_worker():
            while not done.is_set():
                busy = [w for w, keys in client.processing().items() if keys]
                if busy:
                    os.kill(pids[busy[0]], signal.SIGKILL)
                    killed.append(busy[0])
                    return
                time.sleep(0.02)

        t = threading.Thread(target=kill_a_busy_worker, daemon=True)
        t.start()
        try:
            code = run_reconstruct(exp, tmp_path / "out", workers=cluster.n_workers, progress=False,
                                   executor=cluster.executor).exit_code
        finally:
            done.set()
            t.join()
    assert killed, "no worker held a task"
    assert code == 0
    assert _result_bytes(tmp_path / "out") == ref


@pytest.mark.slow
def test_batch_on_a_local_cluster(tmp_path):
    """A batch's experiments and notebooks as tasks: the reconstruction's bytes and the notebooks' outputs."""
    from tendrilkit.phantom import write_phantom_experiment
    from tests.test_batch import write_test_notebooks

    exp = write_phantom_experiment("S2", tmp_path / "S2", n_frames=3, seed=0)
    nbs = write_test_notebooks(tmp_path / "nbs")
    env = {**os.environ, "TENDRILKIT_PROGRESS": "0", SCHEDULER_ENV: "local:1"}
    r = subprocess.run([sys.executable, "-m", "tendrilkit", "batch", str(exp), "--reports", str(tmp_path / "reports"),
                        "--notebooks", str(nbs)], capture_output=True, text=True, cwd=ROOT, env=env, timeout=900)
    assert r.returncode == 0, (r.stdout, r.stderr)
    assert "Dask dashboard http" in r.stderr
    name = next(p.name for p in (tmp_path / "reports").iterdir() if (p / "results").is_dir())
    rep = tmp_path / "reports" / name
    assert (rep / "00_test.ipynb").is_file() and (rep / "tables" / "frames.csv").is_file()
    assert (tmp_path / "reports" / "comparison" / "figures" / "n.txt").read_text() == "1"
    assert _reconstruct(exp, tmp_path / "direct", "--workers", "1", "--scheduler", "pool") in (0, 1)
    direct = _result_bytes(tmp_path / "direct")
    assert _result_bytes(rep / "results") == direct
