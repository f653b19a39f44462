"""The one progress-bar wrapper.

A terminal gets a tqdm bar on stderr; papermill runs, CI and redirected output
get none (tqdm's own test: ``disable=None`` hides the bar when stderr is not a
terminal). ``TENDRILKIT_PROGRESS=0`` silences it, ``=1`` forces it.
"""

from __future__ import annotations

import os
import sys
from typing import Iterable, Iterator, TypeVar

T = TypeVar("T")


def progress_setting(value: str | None = None) -> bool | None:
    """``TENDRILKIT_PROGRESS`` (or ``value``) as True/False, or None when unset (tqdm decides: a terminal or not).

    Examples
    --------
    >>> progress_setting("0"), progress_setting("1")
    (False, True)
    """
    env = os.environ.get("TENDRILKIT_PROGRESS") if value is None else value
    if env is None:
        return None
    return env not in ("0", "", "false", "no")


def progress(items: Iterable[T], *, total: int | None = None, desc: str = "", enabled: bool | None = None) -> Iterator[T]:
    """Iterate over ``items`` with a progress bar on stderr.

    ``enabled``: True or False forces it; None follows ``TENDRILKIT_PROGRESS``
    (:func:`progress_setting`), else tqdm's own rule (shown on a terminal only).

    Examples
    --------
    >>> list(progress(range(3), enabled=False))
    [0, 1, 2]
    """
    if enabled is None:
        enabled = progress_setting()
    from tqdm import tqdm

    with tqdm(items, total=total, desc=desc, file=sys.stderr, dynamic_ncols=True, leave=True,
              disable=None if enabled is None else not enabled) as bar:
        yield from bar
