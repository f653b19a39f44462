"""Does verification catch wrong frames without false alarms? Random phantom scenes against their ground truth.

    .venv/bin/python benchmarks/bench_verify.py SEED_FROM SEED_TO [--frames N] [--work DIR]

For every seed (development range 0-9999 only: seeds >= 10000 are the final
benchmark's and are refused), makes ``python -m tendrilkit phantom --scene
random --seed N --frames N`` into ``DIR/<seed>/``, reconstructs it (one
worker) and compares every frame with the truth
(:func:`tendrilkit.evaluation.accuracy_against_truth`). Counts, over frames:

* silent failures: ``ok`` with mean error > 1.5 mm (must be 0);
* false alarms: ``doubtful`` with mean error <= 0.5 mm (at most 5 % of the
  frames within 0.5 mm);
* caught: ``doubtful`` with mean error > 1.5 mm.

Writes ``DIR/verify_frames.csv`` (one row per seed and frame: status,
message, errors and the verification figures) and prints the counts.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import subprocess
import sys
from pathlib import Path

import pandas as pd

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from tendrilkit.evaluation import accuracy_against_truth  # noqa: E402
from tendrilkit.runner import run_reconstruct  # noqa: E402


def run_seed(seed: int, frames: int, work: Path) -> pd.DataFrame:
    d = work / str(seed)
    if not (d / "experiment.yaml").is_file():
        subprocess.run([sys.executable, "-m", "tendrilkit", "phantom", "--scene", "random", "--seed", str(seed),
                        "--frames", str(frames), "--out", str(d)], check=True, capture_output=True)
    with contextlib.redirect_stdout(io.StringIO()):
        run_reconstruct(d / "experiment.yaml", d / "results", workers=1, progress=False)
    f = pd.read_csv(d / "results" / "frames.csv")
    acc = accuracy_against_truth(pd.read_csv(d / "results" / "curves.csv"), pd.read_csv(d / "ground_truth" / "gt_curves.csv"))
    t = f.merge(acc, on="frame", how="left")
    t.insert(0, "seed", seed)
    return t


def summarise(t: pd.DataFrame) -> dict:
    rec = t[t.status != "failed"]
    good = rec.mean_mm <= 0.5
    return {
        "frames": len(t), "ok": int((t.status == "ok").sum()), "doubtful": int((t.status == "doubtful").sum()),
        "failed": int((t.status == "failed").sum()),
        "silent_failures": int(((t.status == "ok") & (t.mean_mm > 1.5)).sum()),
        "ok_between_0.5_and_1.5_mm": int(((t.status == "ok") & (t.mean_mm > 0.5) & (t.mean_mm <= 1.5)).sum()),
        "caught_wrong": int(((t.status == "doubtful") & (t.mean_mm > 1.5)).sum()),
        "false_alarms": int(((t.status == "doubtful") & (t.mean_mm <= 0.5)).sum()),
        "frames_within_0.5_mm": int(good.sum()),
        "false_alarm_rate": float(((t.status == "doubtful") & (t.mean_mm <= 0.5)).sum() / max(int(good.sum()), 1)),
    }


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("seed_from", type=int)
    ap.add_argument("seed_to", type=int, help="exclusive")
    ap.add_argument("--frames", type=int, default=6)
    ap.add_argument("--work", type=Path, default=Path("/tmp/tendrilkit_bench_verify"))
    a = ap.parse_args()
    if a.seed_to > 10000:
        sys.exit("seeds >= 10000 are reserved for the final generalisation benchmark")
    parts = []
    for seed in range(a.seed_from, a.seed_to):
        try:
            parts.append(run_seed(seed, a.frames, a.work))
        except Exception as e:  # noqa: BLE001 - a benchmark: report the seed and go on
            print(f"seed {seed}: {type(e).__name__}: {e}", file=sys.stderr)
            continue
        s = summarise(parts[-1])
        print(f"seed {seed}: {s['ok']} ok, {s['doubtful']} doubtful, {s['failed']} failed; "
              f"silent {s['silent_failures']}, false alarms {s['false_alarms']}", flush=True)
    t = pd.concat(parts, ignore_index=True)
    a.work.mkdir(parents=True, exist_ok=True)
    t.to_csv(a.work / "verify_frames.csv", index=False)
    for k, v in summarise(t).items():
        print(f"{k}: {v}")


if __name__ == "__main__":
    main()
