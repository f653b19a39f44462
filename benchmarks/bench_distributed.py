"""tendrilkit's process pool against a Dask LocalCluster (issue 16).

    .venv/bin/python benchmarks/bench_distributed.py               # everything (10-30 min on a loaded machine)
    .venv/bin/python benchmarks/bench_distributed.py --rounds 1 --batch-frames 10

Needs ``data/phantoms`` (``python -m tendrilkit phantom --site all --out data/phantoms``).

1. Per-task overhead: empty tasks through each executor (tendrilkit's pool
   of 2 processes, LocalCluster of 1 and of 2 single-threaded workers),
   submitted all at once and waited for: wall seconds per task; and the bytes
   every chunk task ships (its pickled arguments: experiment and cameras).
2. One 60-frame experiment (``params/phantom_S3.yaml``, the default
   method): the frame loop of ``reconstruct`` (calibration reused, no contact
   sheet) with the pool (2 processes), LocalCluster 1 and LocalCluster 2,
   interleaved in rounds (each round runs every mode, the order rotated), so
   that the other jobs of a shared machine load every mode alike. Frames/s
   per mode (median over rounds) and the ratio cluster/pool (target: the
   2-worker cluster at most 20 % slower than the pool). Every run's tables are
   checked byte-identical to the first.
3. A 4-experiment batch (the four site phantoms, ``--batch-frames`` frames
   each): RECONSTRUCTION ONLY (no notebooks), one task per experiment as
   ``batch`` submits them, on each executor: frames/s.
4. Growth to 10 machines: per-task overhead x tasks, and the video data each
   worker reads (its chunks' frames of the three views, with the decode from
   the previous key frame that a seek costs).

Figure 2 is printed twice. 2a: the frame loop on executors started once
beforehand (cluster start-up excluded: spawning the workers, importing,
compiling the kernels once per worker), frames/s and CPU seconds per frame of
the workers and of the client; this is the issue's throughput figure. 2b: the
whole command a user types (``python -m tendrilkit reconstruct ... --scheduler
pool|local:1|local:2``, the calibration reused), start-up included, wall and CPU
seconds of the command and all its processes. Start-up is also printed alone.

Measured (2026-11-30 00:35, idle machine, load 0.6; a fresh clone with its environment;
--rounds 2 --batch-frames 15): start-up pool 0.0 s, local:1 1.7 s, local:2 1.4 s; per-task
overhead pool 0.12 ms, local:1 3.45 ms, local:2 2.70 ms; 2a pool 10.88, local:1 7.12, local:2
10.86 frames/s (local:2 / pool 1.00; worker CPU s/frame 0.160, 0.139, 0.163); 2b pool 7.26,
local:1 4.67, local:2 5.94 frames/s (local:2 / pool 1.22, start-up included); batch pool 7.71,
local:1 5.41, local:2 7.76 frames/s. Tables byte-identical across modes. Before the worker
settings of tendrilkit.distributed (Dask's MALLOC_TRIM_THRESHOLD_, skan's uncached kernels,
no compiled bytecode) local:2 was 1.30 x the pool on the idle machine.

Prints the load average before and after: figures on a shared machine are
upper bounds; compare the ratios, measured in the same run.
"""

from __future__ import annotations

import argparse
import os
import pickle
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
os.environ.setdefault("TENDRILKIT_PROGRESS", "0")

import psutil  # noqa: E402  (a dependency of distributed)

from tendrilkit.distributed import Cluster, parse_scheduler  # noqa: E402
from tendrilkit.pipeline import RESULT_FILES  # noqa: E402
from tendrilkit.runner import _MAX_CHUNK, _own_pool, run_reconstruct  # noqa: E402

SITES = ["S1", "S2", "S3", "S4"]


def _noop(i: int) -> int:
    return i


def _per_task_s(executor, n: int) -> float:
    [f.result() for f in [executor.submit(_noop, i) for i in range(8)]]  # warm: connections, imports
    t = time.perf_counter()
    [f.result() for f in [executor.submit(_noop, i) for i in range(n)]]
    return (time.perf_counter() - t) / n


def _calibrated(exp: Path, base: Path) -> Path:
    """A run folder holding only the calibration of ``exp`` (made once; the timed runs reuse it)."""
    out = base / f"calib_{exp.stem}"
    if not out.is_dir():
        run_reconstruct(exp, out, workers=1, progress=False, fit=True, contact_sheet=False,
                        overrides={"frames": {"stop": 1}})
    return out


def _fresh(calib: Path, dest: Path) -> Path:
    if dest.exists():
        shutil.rmtree(dest)
    dest.mkdir(parents=True)
    for name in ("cameras.json", "calibration_markers.csv"):
        shutil.copy2(calib / name, dest / name)
    (dest / "frames").mkdir()
    shutil.copy2(calib / "frames" / "calibration_stamp.json", dest / "frames" / "calibration_stamp.json")
    return dest


def _tables(out: Path) -> dict[str, bytes]:
    return {n: (out / n).read_bytes() for n in RESULT_FILES if (out / n).is_file()}


def _cpu_s(pids: list[int]) -> float:
    """User + system CPU seconds used so far by these processes."""
    return sum(sum(psutil.Process(p).cpu_times()[:2]) for p in pids)


def _command(exp: Path, out: Path, mode: str) -> tuple[float, float]:
    """Wall and CPU seconds (the command and its workers) of ``python -m tendrilkit reconstruct``, start-up included."""
    sched = ["--scheduler", "pool", "--workers", "2"] if mode == "pool" else ["--scheduler", mode]
    env = {**os.environ, "TENDRILKIT_PROGRESS": "0"}
    env.pop("TENDRILKIT_SCHEDULER", None)
    c0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    t = time.perf_counter()
    r = subprocess.run([sys.executable, "-m", "tendrilkit", "reconstruct", str(exp), "--out", str(out), "--quiet",
                        *sched], cwd=ROOT, env=env, capture_output=True, text=True)
    wall = time.perf_counter() - t
    c1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    if r.returncode not in (0, 1):
        raise RuntimeError(f"{mode}: reconstruct exited {r.returncode}: {r.stderr.strip()[-300:]}")
    return wall, (c1.ru_utime - c0.ru_utime) + (c1.ru_stime - c0.ru_stime)


def _reconstruct_task(exp: str, out: str, stop: int) -> int:
    """One experiment of the batch figure (a task): its reconstruction in the task's process."""
    os.environ["TENDRILKIT_PROGRESS"] = "0"
    import cv2

    cv2.setNumThreads(1)
    return run_reconstruct(exp, out, workers=1, progress=False, contact_sheet=False,
                           overrides={"frames": {"stop": stop}}).exit_code


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=2, help="interleaved rounds of the 60-frame experiment")
    ap.add_argument("--batch-frames", type=int, default=20, help="frames per experiment of the batch figure")
    ap.add_argument("--tasks", type=int, default=200, help="empty tasks for the per-task overhead")
    args = ap.parse_args()
    exps = {s: ROOT / "params" / f"phantom_{s}.yaml" for s in SITES}
    if not (ROOT / "data" / "phantoms" / "S3" / "view1.mp4").is_file():
        print("bench_distributed: data/phantoms/S3 missing: python -m tendrilkit phantom --site all --out data/phantoms",
              file=sys.stderr)
        return 2
    print(f"load average (1, 5, 15 min) before: {os.getloadavg()}, cores: {os.cpu_count()}")
    base = Path(tempfile.mkdtemp(prefix="bench_distributed_"))
    try:
        calib = {s: _calibrated(e, base) for s, e in exps.items()}
        t = time.perf_counter()
        pool = _own_pool(2, True)
        pool_start = time.perf_counter() - t
        executors = {"pool": pool}
        clusters = {}
        starts = {"pool": pool_start}
        for name in ("local:1", "local:2"):
            t = time.perf_counter()
            clusters[name] = Cluster(parse_scheduler(name)).__enter__()
            starts[name] = time.perf_counter() - t
            executors[name] = clusters[name].executor
        workers = {"pool": 2, "local:1": 1, "local:2": 2}
        [f.result() for f in [pool.submit(_noop, i) for i in range(4)]]  # the pool's processes exist
        pids = {"pool": list(pool._processes), **{k: list(c.client.run(os.getpid).values()) for k, c in clusters.items()}}
        print("start-up s (once per command): " + ", ".join(f"{k} {v:.1f}" for k, v in starts.items()))

        # 1. per-task overhead
        over = {k: _per_task_s(ex, args.tasks) for k, ex in executors.items()}
        print(f"\n1. per-task overhead ({args.tasks} empty tasks, all submitted then waited): "
              + ", ".join(f"{k} {v * 1e3:.2f} ms" for k, v in over.items()))
        from tendrilkit.io import read_cameras
        from tendrilkit.params import load_experiment

        e3 = load_experiment(exps["S3"])
        cams = read_cameras(calib["S3"] / "cameras.json")
        ship = len(pickle.dumps((list(range(8)), [None] * 3, e3, cams, True)))
        print(f"   bytes shipped per chunk task (pickled arguments): {ship}")

        # 2. the 60-frame experiment, interleaved
        modes = list(executors)
        times: dict[str, list[float]] = {m: [] for m in modes}
        cpu_w: dict[str, list[float]] = {m: [] for m in modes}
        cpu_c: dict[str, list[float]] = {m: [] for m in modes}
        ref = None
        n_frames = None
        for r in range(args.rounds):
            order = modes[r % len(modes):] + modes[:r % len(modes)]
            for m in order:
                out = _fresh(calib["S3"], base / f"S3_{m.replace(':', '')}")
                w0, c0, t = _cpu_s(pids[m]), time.process_time(), time.perf_counter()
                run_reconstruct(exps["S3"], out, workers=workers[m], progress=False, contact_sheet=False,
                                executor=executors[m])
                times[m].append(time.perf_counter() - t)
                cpu_c[m].append(time.process_time() - c0)
                cpu_w[m].append(_cpu_s(pids[m]) - w0)
                tabs = _tables(out)
                n_frames = len(list((out / "frames").glob("frame_*.json")))
                if ref is None:
                    ref = tabs
                elif tabs != ref:
                    print(f"   MISMATCH: {m} round {r} tables differ from the first run", file=sys.stderr)
                    return 1
        print(f"\n2. one {n_frames}-frame experiment (S3, default method), {args.rounds} interleaved rounds, "
              f"tables byte-identical across modes: yes")
        print("   a. the frame loop on running executors (start-up excluded: started once above); CPU: the workers' "
              "processes, and the client's (for local:N also the scheduler's and the nannies')")
        med = {m: statistics.median(v) for m, v in times.items()}
        for m in modes:
            print(f"   {m:8s} {n_frames / med[m]:6.2f} frames/s  (runs s: {', '.join(f'{x:.1f}' for x in times[m])}); "
                  f"CPU s/frame: workers {statistics.median(cpu_w[m]) / n_frames:.3f}, "
                  f"client {statistics.median(cpu_c[m]) / n_frames:.3f}")
        for m in ("local:1", "local:2"):
            print(f"   {m} / pool time ratio: {med[m] / med['pool']:.2f}")
        # b. what a user's command costs: python -m tendrilkit reconstruct, start-up and imports included
        cmd: dict[str, list[tuple[float, float]]] = {m: [] for m in modes}
        for r in range(args.rounds):
            order = modes[r % len(modes):] + modes[:r % len(modes)]
            for m in order:
                out = _fresh(calib["S3"], base / f"cmd_S3_{m.replace(':', '')}")
                cmd[m].append(_command(exps["S3"], out, m))
                if _tables(out) != ref:
                    print(f"   MISMATCH: the {m} command's tables differ from the first run", file=sys.stderr)
                    return 1
        print(f"   b. the whole command `python -m tendrilkit reconstruct ... --scheduler MODE` (calibration reused; "
              f"start-up, imports, tables and contact sheet included), {args.rounds} interleaved rounds; CPU: the "
              f"command and all its processes")
        cmed = {m: statistics.median(w for w, _ in v) for m, v in cmd.items()}
        for m in modes:
            print(f"   {m:8s} {n_frames / cmed[m]:6.2f} frames/s  (runs s: {', '.join(f'{w:.1f}' for w, _ in cmd[m])}); "
                  f"CPU s: {statistics.median(c for _, c in cmd[m]):.1f}")
        for m in ("local:1", "local:2"):
            print(f"   {m} / pool time ratio (whole command): {cmed[m] / cmed['pool']:.2f}")

        # 3. a 4-experiment batch, reconstruction only
        bt = {}
        for m in modes:
            ex = executors[m] if m != "pool" else ProcessPoolExecutor(max_workers=2)
            outs = [_fresh(calib[s], base / f"batch_{s}_{m.replace(':', '')}") for s in SITES]
            t = time.perf_counter()
            [f.result() for f in [ex.submit(_reconstruct_task, str(exps[s]), str(o), args.batch_frames)
                                  for s, o in zip(SITES, outs)]]
            bt[m] = time.perf_counter() - t
            if m == "pool":
                ex.shutdown()
        n_b = 4 * args.batch_frames
        print(f"\n3. batch of 4 experiments x {args.batch_frames} frames, RECONSTRUCTION ONLY (no notebooks), "
              f"one task per experiment: " + ", ".join(f"{m} {n_b / v:.2f} frames/s" for m, v in bt.items()))

        # 4. growth to 10 machines
        video_bytes = sum(p.stat().st_size for p in e3.videos)
        per_frame_b = video_bytes / n_frames
        per_frame_s = statistics.median(cpu_w["local:2"]) / n_frames  # worker CPU-s per frame (not the loaded wall time)
        n = 27_000  # one experiment of the paper's design: 15 min at 30 fps
        for machines, cores in ((10, 2), (10, 16)):
            w = machines * cores
            size = min(_MAX_CHUNK, max(2, -(-n // (4 * w))))  # as runner._chunks
            tasks = -(-n // size)
            print(f"\n4. {machines} machines x {cores} cores ({w} workers), one 27,000-frame experiment: chunks of "
                  f"{size} frames, {tasks} tasks; scheduling {tasks} x {over['local:2'] * 1e3:.1f} ms = "
                  f"{tasks * over['local:2']:.0f} s of client time against {n * per_frame_s / w:.0f} s of "
                  f"computing per worker ({per_frame_s:.2f} worker CPU-s/frame measured here); shipped "
                  f"{tasks * ship / 1e6:.1f} MB of task arguments; each worker reads ~{n / w * per_frame_b / 1e6:.0f} MB "
                  f"of video (phantom {per_frame_b / 1e3:.0f} kB/frame for three views; 1080p H.264 recordings are "
                  f"larger) plus at most one key-frame interval decoded per chunk start")
        print(f"\nload average after: {os.getloadavg()}")
        for c in clusters.values():
            c.__exit__(None, None, None)
        pool.shutdown(wait=False, cancel_futures=True)
    finally:
        shutil.rmtree(base, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
