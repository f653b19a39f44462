"""numba's caches kept true to the sources (tendrilkit._numba_cache): a compiled caller of a changed compiled module."""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

from tendrilkit._numba_cache import CHECKED, drop_stale_caches

REPO = Path(__file__).resolve().parents[1]


def _package(tmp_path: Path) -> Path:
    pkg = tmp_path / "pkg"
    (pkg / "__pycache__").mkdir(parents=True)
    (pkg / "sub" / "__pycache__").mkdir(parents=True)
    (pkg / "__init__.py").write_text("")
    (pkg / "sub" / "__init__.py").write_text("")
    (pkg / "a.py").write_text("from numba import njit\nfrom pkg.sub.b import g\n")  # calls b's compiled g
    (pkg / "sub" / "b.py").write_text("from numba import njit\nimport pkg.d\n")
    (pkg / "c.py").write_text("import pkg.a\n")  # not compiled
    (pkg / "d.py").write_text("from numba import njit\n")
    (pkg / "e.py").write_text("from numba import njit\n")  # compiled, imports nothing
    caches = {"a": ["a.f-3.py311.nbi", "a.f-3.py311.1.nbc"], "b": ["b.g-3.py311.nbi", "b.g-3.py311.1.nbc"],
              "e": ["e.h-2.py311.nbi"]}
    now = time.time_ns()
    for name, files in caches.items():
        for f in files:
            path = (pkg / "sub" if name == "b" else pkg) / "__pycache__" / f
            path.write_bytes(b"")
            os.utime(path, ns=(now - 50 * 10**9, now - 50 * 10**9))
    (pkg / "__pycache__" / "a.cpython-311.pyc").write_bytes(b"")
    for p in pkg.rglob("*.py"):
        os.utime(p, ns=(now - 100 * 10**9, now - 100 * 10**9))
    return pkg


def _future(path: Path) -> None:
    t = time.time_ns() + 10 * 10**9
    os.utime(path, ns=(t, t))


def test_caches_older_than_an_imported_compiled_module_are_dropped(tmp_path, monkeypatch):
    monkeypatch.delenv("NUMBA_CACHE_DIR", raising=False)
    pkg = _package(tmp_path)
    assert drop_stale_caches(pkg) == []  # every cache newer than the sources: kept, the check recorded
    assert (pkg / "__pycache__" / CHECKED).is_file()
    _future(pkg / "c.py")  # a module that is not compiled: no cache depends on it
    assert drop_stale_caches(pkg) == []
    _future(pkg / "d.py")  # imported by b, which a imports: a's and b's caches, not e's
    removed = sorted(p.name for p in drop_stale_caches(pkg))
    assert removed == ["a.f-3.py311.1.nbc", "a.f-3.py311.nbi", "b.g-3.py311.1.nbc", "b.g-3.py311.nbi"]
    assert (pkg / "__pycache__" / "e.h-2.py311.nbi").is_file()
    assert (pkg / "__pycache__" / "a.cpython-311.pyc").is_file()
    assert drop_stale_caches(pkg) == []  # checked: nothing more until a source changes again


def test_nothing_is_done_with_numba_cache_dir_set(tmp_path, monkeypatch):
    pkg = _package(tmp_path)
    _future(pkg / "d.py")
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path / "elsewhere"))
    assert drop_stale_caches(pkg) == []
    assert (pkg / "__pycache__" / "a.f-3.py311.nbi").is_file()


def test_a_compiled_caller_runs_its_changed_callee(tmp_path):
    """Without the check, numba would load ``a.f``'s cache and run ``b.g``'s old code (it checks ``a.py`` only)."""
    pkg = tmp_path / "pkg"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("from tendrilkit._numba_cache import drop_stale_caches\n"
                                     "drop_stale_caches(__path__[0])\n")
    (pkg / "a.py").write_text("from numba import njit\nfrom pkg.b import g\n\n\n@njit(cache=True)\n"
                              "def f(x):\n    return g(x) + 1.0\n")
    callee = "from numba import njit\n\n\n@njit(cache=True)\ndef g(x):\n    return {} * x\n"
    (pkg / "b.py").write_text(callee.format("2.0"))
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(tmp_path), str(REPO)])}
    env.pop("NUMBA_CACHE_DIR", None)

    def run() -> str:
        return subprocess.run([sys.executable, "-c", "from pkg.a import f; print(f(1.0))"], cwd=tmp_path, env=env,
                              capture_output=True, text=True, check=True).stdout.strip()

    assert run() == "3.0"
    assert any((pkg / "__pycache__").glob("a.f-*.nbi"))  # compiled and cached
    assert run() == "3.0"
    (pkg / "b.py").write_text(callee.format("5.0"))  # the callee changes, its caller's file does not
    _future(pkg / "b.py")
    assert run() == "6.0"
