"""The one progress-bar wrapper.

A terminal gets a tqdm bar on stderr; papermill runs, CI and redirected output
get none (set ``TENDRILKIT_PROGRESS=0`` to silence it, ``=1`` to force it).
"""

from __future__ import annotations

import os
import sys
from typing import Iterable, Iterator, TypeVar

T = TypeVar("T")


def progress_enabled() -> bool:
    env = os.environ.get("TENDRILKIT_PROGRESS")
    if env is not None:
        return env not in ("0", "", "false", "no")
    return sys.stderr.isatty()


def progress(items: Iterable[T], *, total: int | None = None, desc: str = "", enabled: bool | None = None) -> Iterator[T]:
    """Iterate over ``items`` with a progress bar when enabled."""
    if enabled is None:
        enabled = progress_enabled()
    if not enabled:
        yield from items
        return
    from tqdm import tqdm

    with tqdm(items, total=total, desc=desc, file=sys.stderr, dynamic_ncols=True, leave=True) as bar:
        yield from bar
