"""The data the reference notebooks were executed on, rebuilt before nbval checks them.

A short S3 phantom (deterministic: same bytes every time) and its
reconstruction, in ``data/nbval/S3/``. Built once per machine (under a file
lock, as pytest-xdist workers start together) and reused while its stamp
matches.
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


def pytest_sessionstart(session):
    if any("notebooks" in str(a) or str(a).endswith(".ipynb") for a in session.config.args):
        build_nbval_data()
