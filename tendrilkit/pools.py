"""Process pools that end with their parent: the workers' signals and an immediate stop.

Shared by the runner (frames of a reconstruction) and the ``fit`` command
(frames of a curves table): both fork workers that ignore Ctrl-C (the parent
handles it) and are ended at once, with the parent, on Ctrl-C, SIGTERM or an
error.
"""

from __future__ import annotations

import signal
from concurrent.futures import ProcessPoolExecutor

__all__ = ["ignore_interrupts", "stop_pool"]


def ignore_interrupts() -> None:
    """A worker's signals: Ctrl-C ignored (the parent handles it), SIGTERM ends it (:func:`stop_pool`)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)


def stop_pool(pool: ProcessPoolExecutor) -> None:
    """Shut ``pool`` down at once: pending jobs cancelled, running workers terminated and joined."""
    procs = list((getattr(pool, "_processes", None) or {}).values())  # no public way to end workers in 3.11
    pool.shutdown(wait=False, cancel_futures=True)
    for p in procs:
        if p.is_alive():
            p.terminate()
    for p in procs:
        p.join()
