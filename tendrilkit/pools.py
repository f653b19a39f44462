"""Process pools that end with their parent: the workers' signals and an immediate stop.

Shared by the runner (frames of a reconstruction) and the ``fit`` command
(frames of a curves table): both fork workers that ignore Ctrl-C (the parent
handles it) and are ended at once, with the parent, on Ctrl-C, SIGTERM or an
error.
"""

from __future__ import annotations

import contextlib
import signal
from concurrent.futures import ProcessPoolExecutor

__all__ = ["ignore_interrupts", "stop_pool", "signals_held"]

#: The signals the parent turns into an exception (Ctrl-C, and SIGTERM under ``tendrilkit.cli``).
_HELD = {signal.SIGINT, signal.SIGTERM}


def ignore_interrupts() -> None:
    """A worker's signals: Ctrl-C ignored (the parent handles it), SIGTERM ends it (:func:`stop_pool`)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    if hasattr(signal, "pthread_sigmask"):  # forked under signals_held: the mask is inherited
        signal.pthread_sigmask(signal.SIG_UNBLOCK, _HELD)


@contextlib.contextmanager
def signals_held():
    """Ctrl-C and SIGTERM held back while the pool forks its workers (its first ``submit``), delivered on the way out.

    Python runs the callbacks registered for a fork (``logging``'s lock release among them) as code whose
    exceptions it prints and ignores: a SIGTERM arriving there raised the command's ``Terminated`` into one and
    was lost, and the command went on fitting (``tests/test_fit_command.py``, SIGTERM while the workers start).
    Held, the signal arrives after the forks, where the exception ends the command. Where the platform has no
    signal masks, nothing is held.
    """
    if not hasattr(signal, "pthread_sigmask"):
        yield
        return
    old = signal.pthread_sigmask(signal.SIG_BLOCK, _HELD)
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)


def stop_pool(pool: ProcessPoolExecutor) -> None:
    """Shut ``pool`` down at once: pending jobs cancelled, running workers terminated and joined."""
    procs = list((getattr(pool, "_processes", None) or {}).values())  # no public way to end workers in 3.11
    pool.shutdown(wait=False, cancel_futures=True)
    for p in procs:
        if p.is_alive():
            p.terminate()
    for p in procs:
        p.join()
