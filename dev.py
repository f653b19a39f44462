#!/usr/bin/env python3
"""Set up tendrilkit's environment and run its main jobs, with only python3 present.

    python3 dev.py demo     # environment + the four phantom experiments, reconstructed, with reports
    python3 dev.py test     # environment + the whole test suite (pytest and notebook checks)
    python3 dev.py setup    # environment only (.venv/ from environment.lock)

The environment is ``.venv/`` installed from the hash-pinned ``environment.lock``
(with uv when it can be installed, else with pip ``--require-hashes``). It is
reused while the lock file is unchanged.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import subprocess
import sys
import time
import venv
from pathlib import Path

ROOT = Path(__file__).resolve().parent
VENV = ROOT / ".venv"
LOCK = ROOT / "environment.lock"
STAMP = VENV / ".lock-sha256"
PY = VENV / "bin" / "python"
UV_VERSION = "0.13.9"


def _say(msg: str) -> None:
    print(f"[dev] {msg}", flush=True)


def _run(cmd: list[str], **kw) -> int:
    return subprocess.call([str(c) for c in cmd], cwd=ROOT, **kw)


def _make_venv() -> None:
    try:
        venv.EnvBuilder(with_pip=True, clear=True).create(VENV)
    except Exception as e:  # Debian without python3-venv: ensurepip is missing
        if shutil.which("apt-get") and os.geteuid() == 0:
            _say(f"python3 -m venv failed ({e.__class__.__name__}); installing Debian's python3-venv")
            subprocess.call(["apt-get", "update", "-qq"])
            v = f"{sys.version_info.major}.{sys.version_info.minor}"
            if subprocess.call(["apt-get", "install", "-y", "-qq", "python3-venv", f"python{v}-venv"]) != 0:
                subprocess.check_call(["apt-get", "install", "-y", "-qq", "python3-venv"])
            venv.EnvBuilder(with_pip=True, clear=True).create(VENV)
        else:
            sys.exit(f"[dev] cannot create a virtual environment ({e}); install Debian's python3-venv")


#: Fits a few seeded curves, so that numba compiles the piece-wise clothoid's kernels into their on-disk
#: caches once, here, instead of in a user's first ``fit`` or ``reconstruct`` (about 20 s of CPU, paid by
#: every worker process that starts before the caches exist); about a second when they exist.
WARM_NUMBA = """
from tendrilkit.pwc import fit_piecewise_clothoid
from tendrilkit.pwc.datasets import random_pwc_curve
for seed in (1, 2):
    fit_piecewise_clothoid(random_pwc_curve(seed).points_mm)
"""


def _warm_numba() -> None:
    t0 = time.perf_counter()
    if _run([PY, "-c", WARM_NUMBA], env=dict(os.environ, TENDRILKIT_PROGRESS="0")) != 0:
        _say("warning: compiling numba's kernels failed; they will be compiled at first use")
    else:
        _say(f"numba's kernels ready ({time.perf_counter() - t0:.0f} s; compiled into their caches the first time)")


def setup() -> None:
    digest = hashlib.sha256(LOCK.read_bytes()).hexdigest()
    if PY.exists() and STAMP.exists() and STAMP.read_text().strip() == digest:
        _say("environment is up to date (.venv)")
        _warm_numba()
        return
    _say("creating .venv from environment.lock")
    _make_venv()
    env = dict(os.environ, UV_PYTHON_DOWNLOADS="never", PIP_DISABLE_PIP_VERSION_CHECK="1")
    ok = _run([PY, "-m", "pip", "install", "-q", f"uv=={UV_VERSION}"], env=env) == 0
    if ok:
        # --compile-bytecode: with PYTHONDONTWRITEBYTECODE set (common), nothing is ever cached, and every
        # process would compile numba, pandas and scipy from source (about 1.5 s of start-up per command)
        ok = _run([VENV / "bin" / "uv", "pip", "sync", "-q", "--compile-bytecode", "--python", PY, "--require-hashes",
                   LOCK], env=env) == 0
    if not ok:
        _say("uv unavailable; installing with pip --require-hashes (slower)")
        if _run([PY, "-m", "pip", "install", "-q", "--require-hashes", "-r", LOCK], env=env) != 0:
            sys.exit("[dev] installing environment.lock failed")
    # the project itself, from this checkout (notebooks run from notebooks/ still import it)
    site = subprocess.check_output([str(PY), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"], text=True).strip()
    Path(site, "tendrilkit-checkout.pth").write_text(str(ROOT) + "\n")
    _run([PY, "-m", "ipykernel", "install", "--sys-prefix", "--name", "python3"], stdout=subprocess.DEVNULL)
    STAMP.write_text(digest + "\n")
    _say("environment ready")
    _warm_numba()


def demo() -> int:
    setup()
    params = sorted(str(p.relative_to(ROOT)) for p in (ROOT / "params").glob("phantom_S*.yaml"))
    _say("generating the four phantom experiments (skipped when present)")
    if _run([PY, "-m", "tendrilkit", "phantom", "--site", "all", "--out", "data/phantoms"]) != 0:
        return 1
    _say("running the batch: " + " ".join(params))
    return _run([PY, "-m", "tendrilkit", "batch", *params, "--reports", "reports"])


def _ensure_chromium() -> None:
    """Debian's chromium for the browser check of the report pages: installed when root with apt-get, else skipped."""
    if shutil.which("chromium") or shutil.which("chromium-browser"):
        return
    if shutil.which("apt-get") and os.geteuid() == 0:
        _say("installing Debian's chromium (the report pages are checked in a headless browser)")
        env = dict(os.environ, DEBIAN_FRONTEND="noninteractive")
        if subprocess.call(["apt-get", "install", "-y", "-qq", "chromium"], env=env, stdout=subprocess.DEVNULL) != 0:
            _say("chromium could not be installed; the browser check will be skipped")
    else:
        _say("no chromium (and not root with apt-get): the browser check of the report pages will be skipped")


def test() -> int:
    setup()
    _ensure_chromium()
    env = dict(os.environ, TENDRILKIT_PROGRESS="0", MPLBACKEND="Agg")
    # tendrilkit: the docstrings' Examples run too (--doctest-modules)
    return _run([PY, "-m", "pytest", "-q", "-p", "no:cacheprovider", "tests", "notebooks", "tendrilkit",
                 "--doctest-modules", "--nbval-lax", "-n", "2", "--dist", "loadfile"], env=env)


def main(argv: list[str]) -> int:
    cmds = {"setup": lambda: (setup(), 0)[1], "demo": demo, "test": test}
    if len(argv) != 1 or argv[0] not in cmds:
        print(__doc__.strip())
        return 2
    return cmds[argv[0]]()


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
