"""Check that this checkout's piece-wise clothoid fits equal another checkout's, number for number.

    .venv/bin/python benchmarks/pwc_identity.py --baseline /tmp/old [--csv RUN/curves.csv] [--extra 200] [--old-dump F]

Fits, with both checkouts (each in a fresh process started in its folder, so that each loads its own
``tendrilkit``), every frame of ``--csv`` (a reconstruction's curves.csv, as the fit command cuts it) and the
seeded noisy ground-truth curves of ``benchmarks/bench_pwc.py`` (seeds 1000-1039, 5000-5099 and
2000-2000+extra), and compares every output of :class:`tendrilkit.pwc.PWCFit`: every array's dtype, shape
and bytes (the laws, the frames, the points, the registration, the candidates table, ...) and every scalar,
recursively through its dataclasses. Prints how many fits were compared, how many differ, and the largest
absolute difference of a number; exits 1 if any differs. Also compares the fit command's three tables
(``--workers 1``) byte for byte on ``--csv``. ``--old-dump F``: the baseline's fits kept in ``F`` (made at
the first run, read at the next ones: a change checked in half the time). Run it after every change of the
fit (issue 17: a speed-up keeps the fits bit-identical); a clean baseline: ``git clone -q . /tmp/old``.
"""

from __future__ import annotations

import argparse
import os
import pickle
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]

_DUMP = """
import dataclasses, os, pickle, sys
import numpy as np
sys.path.insert(0, os.getcwd())
from tendrilkit.pwc import fit_piecewise_clothoid
from tendrilkit.pwc.datasets import random_pwc_curve

def flat(x, name, out):
    if dataclasses.is_dataclass(x):
        for f in dataclasses.fields(x):
            flat(getattr(x, f.name), name + "." + f.name, out)
    elif isinstance(x, np.ndarray):
        out[name] = (x.dtype.str, x.shape, x.tobytes())
    elif isinstance(x, (float, int, bool, str, np.floating, np.integer, np.bool_)) or x is None:
        out[name] = x
    else:
        raise TypeError(name + ": " + type(x).__name__)

curves = {{}}
csv = {csv!r}
if csv:
    from tendrilkit.fitting import _read_curves
    cv = _read_curves(__import__("pathlib").Path(csv))
    order = np.lexsort((cv.point, cv.frame))
    fr, xyz = cv.frame[order], cv.xyz_mm[order]
    for f in np.unique(fr):
        curves["csv frame %d" % f] = np.ascontiguousarray(xyz[fr == f])
for seed in {seeds}:
    curves["seed %d" % seed] = random_pwc_curve(seed).points_mm
res = {{}}
for name, P in curves.items():
    out = {{}}
    flat(fit_piecewise_clothoid(P), "fit", out)
    res[name] = out
with open({dump!r}, "wb") as fh:
    pickle.dump(res, fh)
"""


def _dump(cwd: Path, csv: str, seeds: list[int], dump: Path) -> dict:
    env = {**os.environ, "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
    subprocess.run([sys.executable, "-c", _DUMP.format(csv=csv, seeds=seeds, dump=str(dump))], cwd=cwd,
                   check=True, env=env)
    with open(dump, "rb") as fh:
        return pickle.load(fh)


def _diff(a, b) -> float | None:
    """None where equal (the same bits); else the largest absolute difference (inf: not comparable)."""
    if isinstance(a, tuple):
        if a == b:
            return None
        if a[0] != b[0] or a[1] != b[1]:
            return float("inf")
        x, y = np.frombuffer(a[2], a[0]), np.frombuffer(b[2], b[0])
        if x.dtype.kind not in "fiub":
            return float("inf")
        same_nan = np.isnan(x) & np.isnan(y) if x.dtype.kind == "f" else np.zeros(x.shape, bool)
        d = np.abs(x.astype(float) - y.astype(float))
        d[same_nan] = 0.0
        return float(np.max(d)) if d.size else 0.0
    if a == b or (isinstance(a, float) and isinstance(b, float) and np.isnan(a) and np.isnan(b)):
        return None
    try:
        return abs(float(a) - float(b))
    except (TypeError, ValueError):
        return float("inf")


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--baseline", type=Path, required=True, help="a checkout of the code to compare with")
    ap.add_argument("--csv", type=Path, default=None, help="a reconstruction's curves.csv: its frames too")
    ap.add_argument("--extra", type=int, default=200, help="seeded curves from 2000 (development seeds)")
    ap.add_argument("--old-dump", type=Path, default=None,
                    help="keep the baseline's fits in this file (read it if it exists: the same options)")
    args = ap.parse_args()
    seeds = [*range(1000, 1040), *range(5000, 5100), *range(2000, 2000 + args.extra)]
    csv = str(args.csv.resolve()) if args.csv else ""
    with tempfile.TemporaryDirectory() as tmp:
        if args.old_dump is not None and args.old_dump.is_file():
            with open(args.old_dump, "rb") as fh:
                old = pickle.load(fh)
        else:
            old = _dump(args.baseline.resolve(), csv, seeds, args.old_dump or Path(tmp) / "old.pkl")
        new = _dump(REPO, csv, seeds, Path(tmp) / "new.pkl")
        differ, worst = [], 0.0
        if set(old) != set(new):  # a kept --old-dump made with other options
            print(f"the two sides fitted different curves ({len(old)} and {len(new)}); compared: the common ones")
            old = {k: v for k, v in old.items() if k in new}
        for name in old:
            ds = {k: _diff(old[name][k], new[name].get(k)) for k in old[name]}
            ds = {k: v for k, v in ds.items() if v is not None}
            if set(new[name]) != set(old[name]):
                ds["fields"] = float("inf")
            if ds:
                k = max(ds, key=ds.get)
                differ.append((name, k, ds[k]))
                worst = max(worst, ds[k])
        n_numbers = sum(np.frombuffer(v[2], v[0]).size if isinstance(v, tuple) else 1
                        for r in old.values() for v in r.values())
        print(f"{len(old)} fits compared ({n_numbers} numbers): {len(old) - len(differ)} identical, "
              f"{len(differ)} differ; largest absolute difference {worst:.3g}")
        for name, k, d in differ[:20]:
            print(f"  {name}: {k} differs by {d:.3g}")
        same_files = True
        if args.csv:
            outs = {}
            for side, cwd in (("old", args.baseline.resolve()), ("new", REPO)):
                out = Path(tmp) / side
                subprocess.run([sys.executable, "-m", "tendrilkit", "fit", csv, "--out", str(out), "--workers", "1"],
                               cwd=cwd, check=True, capture_output=True)
                outs[side] = out
            for f in ("pwc_curves.csv", "pwc_segments.csv", "pwc_metrics.csv"):
                same = (outs["old"] / f).read_bytes() == (outs["new"] / f).read_bytes()
                same_files &= same
                print(f"fit command's {f}: {'identical' if same else 'DIFFERENT'}")
    return 1 if differ or not same_files else 0


if __name__ == "__main__":
    raise SystemExit(main())
