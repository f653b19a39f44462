"""numba's on-disk caches of tendrilkit's compiled functions, kept true to the sources.

numba keys each cached function on its own source file only (its time and
size): a compiled function that calls a compiled function of another module
(``pwc.refine._lm_evaluate`` calls ``frenet._integrate`` and
``geometry.rigid_fit``) keeps running the old code after that module changed,
until its own file changes (a merge, a checkout or an edit of the callee alone
leaves the caller's cache as it was). :func:`drop_stale_caches`, run when
tendrilkit is imported, drops a module's cache files when one of the compiled
modules it imports (from the package, transitively) is newer than they are;
numba compiles them again at their next call.

Stdlib only (it runs at every ``import tendrilkit``): when no source file
changed since the last check (the time of ``__pycache__/numba_checked``),
it costs a look at the files' times.
"""

from __future__ import annotations

import os
import re
from pathlib import Path

__all__ = ["drop_stale_caches"]

#: The file whose modification time says when the caches were last checked against the sources.
CHECKED = "numba_checked"


def drop_stale_caches(package_dir: str | Path) -> list[Path]:
    """Drop the numba cache files of the package's modules that import a changed compiled module.

    A module's cache files (``__pycache__/<module>.*.nbi`` and ``.nbc``) are dropped when a
    compiled module (one that mentions ``njit``) among those it imports from the package
    (``from PACKAGE.x import ...``, ``import PACKAGE.x``; followed through compiled modules) was
    modified after the oldest of its cache index files. Nothing is done when ``NUMBA_CACHE_DIR``
    is set or the package's folder cannot be written (numba keeps the caches elsewhere then);
    housekeeping only, it never raises.

    Returns
    -------
    list of Path
        The cache files removed.
    """
    if os.environ.get("NUMBA_CACHE_DIR") or not os.access(package_dir, os.W_OK):  # caches elsewhere
        return []
    try:
        return _drop(Path(package_dir))
    except Exception:  # noqa: BLE001 - a check of caches must never stop an import
        return []


def _source_times(root: str) -> dict[str, int]:
    """Every ``.py`` file under ``root`` (``__pycache__`` left out) and its modification time, ns."""
    out = {}
    for folder, dirs, files in os.walk(root):
        dirs[:] = [d for d in dirs if d != "__pycache__"]
        for f in files:
            if f.endswith(".py"):
                path = os.path.join(folder, f)
                out[path] = os.stat(path).st_mtime_ns
    return out


def _drop(root: Path) -> list[Path]:
    checked = root / "__pycache__" / CHECKED
    try:
        last = checked.stat().st_mtime_ns
    except FileNotFoundError:
        last = -1
    times = _source_times(str(root))
    if times and max(times.values()) <= last:  # nothing changed since the last check
        return []
    mtime = {Path(p): t for p, t in times.items()}
    sources = sorted(mtime)
    pattern = re.compile(rb"^[ \t]*(?:from[ \t]+(" + re.escape(root.name.encode()) + rb"(?:\.\w+)*)[ \t]+import"
                         rb"|import[ \t]+(" + re.escape(root.name.encode()) + rb"(?:\.\w+)*))", re.M)
    compiled, imports = set(), {}
    for p in sources:
        text = p.read_bytes()
        if b"njit" in text:
            compiled.add(p)
            imports[p] = [_module_file(root, (a or b).decode()) for a, b in pattern.findall(text)]

    def closure(p: Path) -> set[Path]:
        seen, todo = {p}, [p]
        while todo:
            for q in imports.get(todo.pop(), []):
                if q in compiled and q not in seen:
                    seen.add(q)
                    todo.append(q)
        return seen

    removed = []
    for p in sorted(compiled):
        cache_dir = p.parent / "__pycache__"
        index = list(cache_dir.glob(f"{p.stem}.*.nbi"))
        if not index:
            continue
        oldest = min(i.stat().st_mtime_ns for i in index)
        if any(mtime[q] > oldest for q in closure(p)):
            for f in index + list(cache_dir.glob(f"{p.stem}.*.nbc")):
                f.unlink(missing_ok=True)
                removed.append(f)
    checked.parent.mkdir(exist_ok=True)
    checked.touch()
    return removed


def _module_file(root: Path, dotted: str) -> Path | None:
    """The file of module ``dotted`` (``PACKAGE.a.b``) under ``root``: ``a/b.py`` or ``a/b/__init__.py``."""
    parts = dotted.split(".")[1:]
    base = root.joinpath(*parts)
    if base.with_suffix(".py").is_file():
        return base.with_suffix(".py")
    init = base / "__init__.py"
    return init if init.is_file() else None
