"""Reconstructions and batches on a Dask cluster (``--scheduler ADDRESS``).

tendrilkit's own process pool stays the default. With a scheduler, the chunks
of consecutive frames of one experiment (``reconstruct``) and the experiments
of a batch (``batch``) are submitted as Dask tasks through a
:class:`concurrent.futures.Executor` (``distributed.Client.get_executor``); the
client keeps writing every result itself, atomically, as without a cluster, so
a run interrupted anywhere resumes with the same command.

Scheduler addresses (:func:`parse_scheduler`):

- ``local:N``: a ``LocalCluster`` of N single-threaded worker processes on
  this machine, started and stopped by the command;
- ``tcp://HOST:PORT`` (or ``HOST:PORT``, any Dask protocol ``PROTO://...``):
  an existing ``dask scheduler`` whose workers see the videos at the same
  paths (a shared drive);
- ``pool``: tendrilkit's own process pool (overrides ``TENDRILKIT_SCHEDULER``).

Without ``--scheduler``, ``$TENDRILKIT_SCHEDULER`` is used when set. A
scheduler that cannot be reached, or that has no worker within the timeout, is
an :class:`~tendrilkit.exceptions.ExperimentError` (one line, exit code 2).
Every worker runs with single-threaded OpenCV and compiles the numba kernels
once when it joins (:class:`tendrilkit.dask_worker.WorkerSetup`), also a worker
restarted after a crash.

A ``local:N`` cluster is started with :data:`LOCAL_CONFIG`: its worker
processes keep glibc's default memory allocator (Dask's nanny otherwise sets
``MALLOC_TRIM_THRESHOLD_``, which turns off glibc's adaptive mmap threshold:
every decoded 1080p frame and its temporaries are then mapped and unmapped
afresh, ten times the page faults and about 40 % more CPU per frame here), and
its processes wake up less often when idle (the event-loop tick, the
statistical profiler and the system monitor cost about 0.1 CPU-s per second
of an idle 2-worker cluster, 0.01 with these settings). Workers of a remote
scheduler are the user's: the README says how to start them alike.

This module imports no Dask until a cluster is used, so a command without
``--scheduler`` does not pay for importing ``distributed`` (about 1 s).
"""

from __future__ import annotations

import logging
import os
import re
from dataclasses import dataclass

from tendrilkit.exceptions import ExperimentError

#: Environment variable read when ``--scheduler`` is not given.
SCHEDULER_ENV = "TENDRILKIT_SCHEDULER"
#: Seconds to wait for the scheduler to answer, and then for a first worker.
CONNECT_TIMEOUT_S = 10.0
WORKER_TIMEOUT_S = 60.0
_MAX_LOCAL_WORKERS = 256
#: Dask settings of a ``local:N`` cluster (scheduler, nannies, workers, client); see the module docstring.
LOCAL_CONFIG = {
    "distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_": None,  # None: not set in the workers
    "distributed.admin.tick.interval": "1s",  # event-loop watchdog (default 20 ms)
    "distributed.worker.profile.enabled": False,  # statistical profiler sampling every 10 ms
    "distributed.admin.system-monitor.interval": "5s",  # dashboard's CPU/memory graphs (default 0.5 s)
    "distributed.worker.memory.monitor-interval": "1s",  # memory limit checks (default 0.1 s)
}
_ADDRESS = re.compile(r"^(?:[a-z][a-z0-9+.-]*://\S+|[^\s/:]+(?::\d{1,5})?)$", re.IGNORECASE)


@dataclass(frozen=True, eq=False)
class SchedulerSpec:
    """A parsed ``--scheduler`` value.

    Attributes
    ----------
    kind : str
        ``"pool"`` (tendrilkit's process pool), ``"local"`` (a LocalCluster
        started here) or ``"remote"`` (an existing scheduler).
    n_workers : int or None
        ``local`` only: worker processes (one thread each).
    address : str or None
        ``remote`` only: the scheduler's address, e.g. ``tcp://10.0.0.5:8786``.
    """

    kind: str
    n_workers: int | None = None
    address: str | None = None


def parse_scheduler(text: str) -> SchedulerSpec:
    """``pool``, ``local:N`` or a scheduler address; anything else is an :class:`ExperimentError`.

    Parameters
    ----------
    text : str
        The ``--scheduler`` value (or ``$TENDRILKIT_SCHEDULER``).

    Returns
    -------
    SchedulerSpec
    """
    value = str(text).strip()
    if value.lower() == "pool":
        return SchedulerSpec("pool")
    if value.lower().startswith("local"):
        m = re.fullmatch(r"local:(\d+)", value, flags=re.IGNORECASE)
        if not m or not 1 <= int(m.group(1)) <= _MAX_LOCAL_WORKERS:
            raise ExperimentError(f"scheduler {value!r}: expected local:N with N workers from 1 to "
                                  f"{_MAX_LOCAL_WORKERS}, e.g. local:2")
        return SchedulerSpec("local", n_workers=int(m.group(1)))
    if not value or not _ADDRESS.match(value):
        raise ExperimentError(f"scheduler {value!r}: expected pool, local:N or a scheduler address such as "
                              f"tcp://HOST:8786")
    return SchedulerSpec("remote", address=value)


def scheduler_from(arg: str | None) -> SchedulerSpec | None:
    """The scheduler to use: ``arg``, else ``$TENDRILKIT_SCHEDULER``; None (or ``pool``): tendrilkit's pool."""
    text = arg if arg is not None else (os.environ.get(SCHEDULER_ENV) or None)
    if text is None:
        return None
    spec = parse_scheduler(text)
    return None if spec.kind == "pool" else spec


class Cluster:
    """A connection to a Dask scheduler (a context manager); see the module docstring.

    Parameters
    ----------
    spec : SchedulerSpec
        ``local`` or ``remote``.
    connect_timeout_s, worker_timeout_s : float, optional
        Seconds to wait for the scheduler, then for a first worker (default
        :data:`CONNECT_TIMEOUT_S`, :data:`WORKER_TIMEOUT_S`).

    Attributes
    ----------
    executor : concurrent.futures.Executor
        Submits tasks to the cluster (``Client.get_executor(pure=False)``);
        its futures are :class:`concurrent.futures.Future`.
    n_workers : int
        Worker threads connected when the run starts (chunk sizes; results do
        not depend on it).
    dashboard_link : str or None
        The Dask dashboard's address, when the scheduler serves one.
    """

    def __init__(self, spec: SchedulerSpec, *, connect_timeout_s: float | None = None,
                 worker_timeout_s: float | None = None) -> None:
        if spec.kind not in ("local", "remote"):
            raise ValueError(f"Cluster: expected a local or remote scheduler, got {spec.kind!r}")
        self.spec = spec
        self.connect_timeout_s = float(CONNECT_TIMEOUT_S if connect_timeout_s is None else connect_timeout_s)
        self.worker_timeout_s = float(WORKER_TIMEOUT_S if worker_timeout_s is None else worker_timeout_s)
        self.client = None
        self._local = None

    def __enter__(self) -> "Cluster":
        import dask
        from distributed import Client, LocalCluster

        try:
            if self.spec.kind == "local":
                with dask.config.set(LOCAL_CONFIG):  # read when the nannies, workers and client are made
                    self._local = LocalCluster(n_workers=self.spec.n_workers, threads_per_worker=1,
                                               processes=True, dashboard_address=":0", silence_logs=logging.ERROR)
                    self.client = Client(self._local)
            else:
                self.client = Client(self.spec.address, timeout=f"{self.connect_timeout_s}s")
        except (OSError, TimeoutError, ValueError) as e:
            self.__exit__(None, None, None)
            where = self.spec.address or f"local:{self.spec.n_workers}"
            reason = " ".join(str(e).split()) or type(e).__name__
            raise ExperimentError(f"scheduler {where}: cannot connect ({reason[:200]}); start one with "
                                  f"`dask scheduler` (and `dask worker ADDRESS`) or use --scheduler local:N") from None
        try:
            self.client.wait_for_workers(1, timeout=self.worker_timeout_s)
        except (OSError, TimeoutError):
            self.__exit__(None, None, None)
            where = self.spec.address or f"local:{self.spec.n_workers}"
            raise ExperimentError(f"scheduler {where}: no worker connected within {self.worker_timeout_s:.0f} s; "
                                  f"start some with `dask worker {where}`") from None
        from tendrilkit.dask_worker import WorkerSetup  # imports distributed: only with a cluster

        self.client.register_plugin(WorkerSetup(), name=WorkerSetup.name)
        return self

    def __exit__(self, *exc) -> None:
        if self.client is not None:
            self.client.close()
            self.client = None
        if self._local is not None:
            self._local.close()
            self._local = None

    @property
    def executor(self):
        return self.client.get_executor(pure=False)

    @property
    def n_workers(self) -> int:
        return max(1, sum(self.client.nthreads().values()))

    @property
    def dashboard_link(self) -> str | None:
        try:
            info = self.client.scheduler_info()
            port = (info.get("services") or {}).get("dashboard")
        except (OSError, TimeoutError):
            return None
        return self.client.dashboard_link if port else None
