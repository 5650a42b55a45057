"""Running a study: choose the samples still to do, send them to workers, write what comes back.

Backends (:class:`Execution`):

- local (default): a ``concurrent.futures.ProcessPoolExecutor`` of ``workers`` processes (default:
  the cores this process may use, :func:`jamlab.threads.usable_cores`), started with ``spawn``
  and with ``OMP/MKL/OPENBLAS_NUM_THREADS=1`` (the environment Dask gives its workers, so local
  and Dask results agree bit for bit);
  ``workers=0`` runs the samples in the driving process (debugging, injected tasks);
- ``scheduler="tcp://HOST:8786"``: an existing ``dask.distributed`` cluster;
- ``cluster="slurm"``: a ``dask_jobqueue.SLURMCluster`` started for the run (``slurm`` options:
  ``jobs``, ``cores``, ``processes``, ``memory``, ``walltime``, ``queue``, ``account``,
  ``job_extra_directives``, ``local_directory``, ``log_directory``), closed at the end; the jobs'
  logs go to ``log_directory`` (default: ``slurm-logs/`` in the run directory).

Whatever the backend, only the driving process writes files, one sample at a time, as results
arrive; a worker's exception becomes a failure record, never an aborted run.
"""

from __future__ import annotations

import contextlib
import dataclasses
import multiprocessing
import os
import time
from collections.abc import Callable, Iterator
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass, field
from typing import Any

from jamlab import validation
from jamlab.runs import physics
from jamlab.runs.seeds import sample_seed
from jamlab.runs.storage import RunDir, check_sample_data
from jamlab.runs.study import SampleKey, Study
from jamlab.runs.tasks import SampleFailure, SampleResult, Task, run_sample
from jamlab.threads import usable_cores

__all__ = ["SINGLE_THREAD_ENV", "Execution", "RunSummary", "die_with_parent", "run_study",
           "slurm_cluster_kwargs"]

SINGLE_THREAD_ENV = {"OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"}
"""The environment of every worker (local, Dask, SLURM): one BLAS/OpenMP thread."""
_SLURM_KEYS = {
    "jobs",
    "cores",
    "processes",
    "memory",
    "walltime",
    "queue",
    "account",
    "job_extra_directives",
    "local_directory",
    "interface",
    "log_directory",
}


@dataclass(frozen=True)
class Execution:
    """How to run (never changes results): at most one of ``scheduler`` and ``cluster``;
    ``workers`` = local processes (``None``: the usable cores) or, with ``cluster``, the jobs' total
    worker count when ``slurm["jobs"]`` is not given."""

    workers: int | None = None
    scheduler: str | None = None
    cluster: str | None = None
    slurm: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if self.workers is not None:
            workers = validation.integer("workers", self.workers, minimum=0)
            object.__setattr__(self, "workers", workers)
        for name in ("scheduler", "cluster"):
            value = getattr(self, name)
            if value is not None and not isinstance(value, str):
                raise ValueError(f"{name} must be a string, got {value!r}")
        if not isinstance(self.slurm, dict):
            raise ValueError(f"[slurm] must be a table, got {self.slurm!r}")
        if self.scheduler is not None and self.cluster is not None:
            raise ValueError("give either --scheduler or --cluster, not both")
        if self.scheduler is not None and "://" not in self.scheduler:
            raise _bad_address(self.scheduler)
        if self.cluster is not None and self.cluster != "slurm":
            raise ValueError(f"unknown cluster {self.cluster!r}: valid clusters are slurm")
        unknown = sorted(set(self.slurm) - _SLURM_KEYS)
        if unknown:
            raise ValueError(
                f"unknown slurm option(s) {', '.join(unknown)}; "
                f"valid: {', '.join(sorted(_SLURM_KEYS))}"
            )
        slurm_cluster_kwargs(self.slurm)  # their values are checked even when not used

    def local_workers(self) -> int:
        """The local worker processes asked for: ``workers``, or the usable cores
        (:func:`jamlab.threads.usable_cores`) when it is not given (0: in-process)."""
        return usable_cores() if self.workers is None else self.workers

    def describe(self, todo: int | None = None) -> str:
        """Where the samples run; with ``todo`` (the samples to run), the local processes are
        counted as started: never more than there are samples. More local processes than usable
        cores are allowed (the results do not depend on it) and said."""
        if self.scheduler:
            return f"dask scheduler {self.scheduler}"
        if self.cluster:
            return "SLURM cluster (dask-jobqueue)"
        if self.workers == 0:
            return "in-process"
        usable = usable_cores()
        processes = self.local_workers()
        if todo is not None:
            processes = max(1, min(processes, todo))
        text = f"{processes} local process{'es' if processes != 1 else ''}"
        if processes > usable:  # allowed (same results), but they share the cores
            text += f" sharing {usable} usable core{'s' if usable != 1 else ''}"
        return text


@dataclass
class RunSummary:
    """What a call to :func:`run_study` did."""

    total: int
    skipped: int
    done: int = 0
    failed: int = 0
    removed_temporaries: int = 0
    resumed: int = 0  # samples resumed from a checkpoint (Study.checkpoint_every)
    seconds: float = 0.0
    failures: list[tuple[SampleKey, str]] = field(default_factory=list)


Outcome = SampleResult | SampleFailure
Item = tuple[SampleKey, int, str | None]  # a sample, its seed and its checkpoint folder
Progress = Callable[[SampleKey, Outcome], None]


def slurm_cluster_kwargs(options: dict[str, Any]) -> tuple[dict[str, Any], int]:
    """``(SLURMCluster keyword arguments, number of jobs)`` from the ``slurm`` options; defaults:
    1 job of 1 core, 1 process, 2 GiB, 01:00:00."""
    opts = dict(options)
    jobs = validation.integer("slurm jobs", opts.pop("jobs", 1), minimum=1)
    kwargs: dict[str, Any] = {
        "cores": validation.integer("slurm cores", opts.pop("cores", 1), minimum=1),
        "processes": validation.integer("slurm processes", opts.pop("processes", 1), minimum=1),
        "memory": str(opts.pop("memory", "2GiB")),
        "walltime": str(opts.pop("walltime", "01:00:00")),
    }
    for name in ("queue", "account", "local_directory", "interface", "log_directory"):
        if opts.get(name) is not None:
            kwargs[name] = opts.pop(name)
    extra = opts.pop("job_extra_directives", None)
    if extra:
        kwargs["job_extra_directives"] = list(extra)
    # the same single-threaded environment as local and Dask workers
    kwargs["job_script_prologue"] = [f"export {k}={v}" for k, v in SINGLE_THREAD_ENV.items()]
    return kwargs, jobs


def die_with_parent(parent: int, poll: float = 0.5) -> None:
    """Make this worker process end when the driving process ``parent`` does, even on SIGKILL
    (which runs no clean-up in the driver): on Linux the kernel sends SIGKILL to the worker
    (``prctl(PR_SET_PDEATHSIG)``); everywhere, a daemon thread checks every ``poll`` seconds
    that the parent is still ``parent`` and exits the process otherwise."""
    import signal
    import sys
    import threading

    if sys.platform.startswith("linux"):
        import ctypes

        with contextlib.suppress(OSError, AttributeError):
            libc = ctypes.CDLL(None, use_errno=True)
            libc.prctl(1, signal.SIGKILL, 0, 0, 0)  # PR_SET_PDEATHSIG = 1
    if os.getppid() != parent:  # the parent died before the prctl took effect
        os._exit(1)

    def watch() -> None:
        while True:
            time.sleep(poll)
            if os.getppid() != parent:
                os._exit(1)

    threading.Thread(target=watch, name="jamlab-parent-watch", daemon=True).start()


def _local_outcomes(
    items: list[Item], study: Study, workers: int, task: Task | None
) -> Iterator[tuple[SampleKey, Outcome]]:
    if workers == 0:
        for key, seed, checkpoint in items:
            yield key, run_sample(study, key, seed, task, checkpoint)
        return
    saved = {k: os.environ.get(k) for k in SINGLE_THREAD_ENV}
    os.environ.update(SINGLE_THREAD_ENV)  # inherited by the spawned workers
    try:
        pool = ProcessPoolExecutor(
            max_workers=workers,
            mp_context=multiprocessing.get_context("spawn"),
            initializer=die_with_parent,
            initargs=(os.getpid(),),
        )
    finally:
        for k, v in saved.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v
    try:
        futures = {
            pool.submit(run_sample, study, key, seed, task, checkpoint): key
            for key, seed, checkpoint in items
        }
        for future in as_completed(futures):
            yield futures[future], future.result()
    finally:
        # on an interrupt, do not wait for the queued samples
        pool.shutdown(wait=True, cancel_futures=True)


def _dask_outcomes(
    items: list[Item], study: Study, client: Any, task: Task | None
) -> Iterator[tuple[SampleKey, Outcome]]:
    from distributed import as_completed as dask_as_completed

    futures = {}
    for key, seed, checkpoint in items:
        name = f"jamlab-sample-{key.phi_label}-{key.n}-{key.index}-{seed}"
        futures[client.submit(run_sample, study, key, seed, task, checkpoint, key=name,
                              pure=False)] = key
    try:
        for future in dask_as_completed(futures):
            key = futures[future]
            try:
                outcome = future.result()
            except Exception as exc:  # noqa: BLE001 - e.g. KilledWorker: recorded as a failure
                outcome = SampleFailure(type(exc).__name__, str(exc), "")
            future.release()
            yield key, outcome
    finally:
        client.cancel(list(futures))


def _bad_address(address: str) -> ValueError:
    """The one-line error for a scheduler address that is not ``tcp://HOST:PORT``-like."""
    return ValueError(f"scheduler must be an address like tcp://HOST:8786, got {address!r}")


def _unreachable(address: str, exc: Exception) -> ValueError:
    """The one-line error for a scheduler nothing answers at."""
    return ValueError(f"cannot reach dask scheduler {address}: {exc}")


def _check_reachable(address: str, timeout: float = 20.0) -> None:
    """``ValueError`` (one line) if nothing accepts a TCP connection at a ``tcp://HOST:PORT``
    scheduler address within ``timeout`` s, so that a run that cannot start writes nothing (its
    manifest would tie the directory to a study no sample was made for). Other protocols are
    left to the dask client."""
    import socket
    from urllib.parse import urlsplit

    parts = urlsplit(address)
    if parts.scheme != "tcp":
        return
    try:
        port = parts.port
    except ValueError:
        port = None
    if parts.hostname is None or port is None:
        raise _bad_address(address)
    try:
        with socket.create_connection((parts.hostname, port), timeout=timeout):
            pass
    except OSError as exc:
        raise _unreachable(address, exc) from None


@contextlib.contextmanager
def _dask_client(execution: Execution) -> Iterator[Any]:
    from distributed import Client

    if execution.scheduler is not None:
        try:
            client = Client(execution.scheduler, timeout="20s")
        except OSError as exc:
            raise _unreachable(execution.scheduler, exc) from None
        with client:
            yield client
        return
    from dask_jobqueue import SLURMCluster

    kwargs, jobs = slurm_cluster_kwargs(execution.slurm)
    with SLURMCluster(**kwargs) as cluster:
        cluster.scale(jobs=jobs)
        with Client(cluster) as client:
            yield client


def _outcomes(
    items: list[Item], study: Study, execution: Execution, task: Task | None
) -> Iterator[tuple[SampleKey, Outcome]]:
    if not items:
        return
    if execution.scheduler is None and execution.cluster is None:
        yield from _local_outcomes(items, study, min(execution.local_workers(), len(items)), task)
        return
    with _dask_client(execution) as client:
        yield from _dask_outcomes(items, study, client, task)


def run_study(
    study: Study,
    out: str | os.PathLike,
    execution: Execution | None = None,
    *,
    retry_failed: bool = True,
    task: Task | None = None,
    progress: Callable[[int, int], Progress] | None = None,
    log: Callable[[str], None] | None = None,
) -> RunSummary:
    """Run (or resume) ``study`` in the run directory ``out``.

    Samples already done are skipped; corrupt, pending and — with ``retry_failed`` (default) —
    failed ones are (re)computed. ``task`` replaces the study's built-in task (it must be
    picklable for process or Dask workers). ``progress(total_todo, skipped)`` returns a callback
    called once per finished sample. Raises :class:`jamlab.runs.storage.RunError` (a
    ``ValueError``) before writing anything if ``out`` cannot hold ``study``.
    """
    execution = execution or Execution()
    start = time.perf_counter()
    study.check_geometry()
    if execution.scheduler is not None:
        _check_reachable(execution.scheduler)  # before the run directory is made
    run = RunDir.open(out, study)
    with run.lock():
        run.start(study)
        removed = run.remove_temporaries()
        states = run.scan(study)
        # a sample written by a driver that stopped before removing its checkpoint
        run.remove_checkpoints([key for key, state in states.items() if state == "done"])
        redo = {"pending", "corrupt"} | ({"failed"} if retry_failed else set())
        todo = [key for key, state in states.items() if state in redo]
        # the built-in physics task saves a sample as it goes where the study asks for it
        checkpointing = study.checkpoint_every > 0 and task is None and study.task == "aqs"
        saved = [key for key in todo if checkpointing and run.checkpoint_dir(key).is_dir()]
        summary = RunSummary(
            total=len(states), skipped=len(states) - len(todo), removed_temporaries=len(removed)
        )
        if log is not None:
            corrupt = sum(1 for s in states.values() if s == "corrupt")
            # the verdict the sample's worker will act on: a damaged checkpoint is redone
            damaged = sum(1 for key in saved if physics.resume_step(run, key, study) == -1)
            log(
                f"{run.path}: {summary.skipped} of {summary.total} samples done, "
                f"{len(todo)} to run ({corrupt} corrupt, {len(removed)} temporary files removed"
                + (f", {len(saved) - damaged} with a checkpoint" if checkpointing else "")
                + (f", {damaged} with a damaged checkpoint (redone from the start)"
                   if damaged else "")
                + f") on {execution.describe(len(todo))}"
            )
        seeds = {key: sample_seed(study.seed, key) for key in todo}
        # the checkpoint folders as absolute paths: workers may run elsewhere (a shared file
        # system, as the SLURM logs need)
        items = [
            (key, seeds[key], str(run.checkpoint_dir(key).resolve()) if checkpointing else None)
            for key in todo
        ]
        callback = progress(len(todo), summary.skipped) if progress is not None else None
        if execution.cluster == "slurm" and "log_directory" not in execution.slurm:
            # the SLURM jobs' logs (dask-worker-JOBID.out/.err) go to the run directory
            slurm = {**execution.slurm, "log_directory": str(run.path.resolve() / "slurm-logs")}
            execution = dataclasses.replace(execution, slurm=slurm)
        for key, outcome in _outcomes(items, study, execution, task):
            if isinstance(outcome, SampleResult):
                try:
                    check_sample_data(outcome.traces, outcome.arrays, key, study)
                except ValueError as exc:
                    outcome = SampleFailure("InvalidResult", f"the task's result: {exc}", "")
            if isinstance(outcome, SampleResult):
                run.write_sample(key, outcome, seeds[key], study)
                run.remove_checkpoints([key])
                summary.done += 1
                summary.resumed += outcome.resumed_from >= 0
            else:
                run.write_failure(key, outcome, seeds[key])
                summary.failed += 1
                summary.failures.append((key, f"{outcome.error_type}: {outcome.message}"))
            if callback is not None:
                callback(key, outcome)
        run.prune_checkpoints()
    summary.seconds = time.perf_counter() - start
    return summary
