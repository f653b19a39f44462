"""What runs in every Dask worker when it joins (``--scheduler``): :class:`WorkerSetup`.

Imported only when a cluster is used (:class:`tendrilkit.distributed.Cluster`),
as it imports ``distributed``.
"""

from __future__ import annotations

import os
import sys

from distributed.diagnostics.plugin import WorkerPlugin


class WorkerSetup(WorkerPlugin):
    """Run on every worker when it joins: single-threaded OpenCV, numba kernels compiled (as the pool's workers)."""

    name = "tendrilkit-setup"

    def setup(self, worker) -> None:
        import cv2

        from tendrilkit.runner import _warm_up

        cv2.setNumThreads(1)
        _adaptive_malloc_thresholds()
        _warm_up(True)


#: glibc's ``mallopt`` parameters, and the largest values of its adaptive thresholds.
_M_TRIM_THRESHOLD, _M_MMAP_THRESHOLD = -1, -3
_MMAP_THRESHOLD_B = 32 * 2**20  # glibc's largest adaptive mmap threshold (64-bit)
_TRIM_THRESHOLD_B = 2 * _MMAP_THRESHOLD_B  # what glibc sets with it


def _adaptive_malloc_thresholds() -> bool:
    """In a worker whose nanny set ``MALLOC_TRIM_THRESHOLD_`` (glibc): frame-sized blocks reused, not re-mapped.

    The variable turns glibc's adaptive mmap threshold off, so every block of
    128 kB or more (a decoded frame, its masks and temporaries) is mapped and
    unmapped afresh, page faults included. The thresholds are set to the
    largest values glibc's adaptive rule would reach (mmap 32 MiB, trim twice
    that): a remote ``dask worker`` started with the default settings; a
    ``local:N`` cluster does not set the variable (unless the user's
    environment does). Returns whether they were set.
    """
    if "MALLOC_TRIM_THRESHOLD_" not in os.environ or not sys.platform.startswith("linux"):
        return False
    import ctypes

    try:
        mallopt = ctypes.CDLL("libc.so.6").mallopt
    except (OSError, AttributeError):  # not glibc (e.g. musl): nothing to undo
        return False
    mallopt.argtypes, mallopt.restype = [ctypes.c_int, ctypes.c_int], ctypes.c_int
    return bool(mallopt(_M_MMAP_THRESHOLD, _MMAP_THRESHOLD_B)) and bool(mallopt(_M_TRIM_THRESHOLD, _TRIM_THRESHOLD_B))
