"""Where tasks run: a local process pool or a Dask cluster.

Both executors have one method, ``imap_unordered(function, tasks)``, which yields
``(task, outcome)`` as tasks finish, in any order; ``outcome`` is the function's return
value, or the exception that lost the task (a worker process died, the pool broke, the
cluster gave up). Exceptions inside the function itself are the function's business:
:func:`slideplan.experiments.run_task` turns them into result rows.
"""

from __future__ import annotations

import multiprocessing
import os
import threading
import time
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import ProcessPoolExecutor, ThreadPoolExecutor, as_completed
from typing import Any, Protocol

from ..errors import InputError
from .tasks import Task


class TaskExecutor(Protocol):
    """What :func:`slideplan.experiments.run_experiment` needs from an executor."""

    description: str

    def imap_unordered(self, function: Callable[[Task], Any], tasks: Iterable[Task]) -> Iterator[tuple[Task, Any]]:
        """Run ``function(task)`` for every task; yield ``(task, result or exception)`` as they finish."""


class LocalPoolExecutor:
    """Run tasks in a pool of local worker processes or threads (``concurrent.futures``).

    Plans are independent in threads (docs/design.md 9) and the C++ planner, its time parameterization
    and the centre of mass release the GIL, so threads share one parsed robot and scale (two threads
    1.80-1.86x one on 2 cores for plan() alone, docs/benchmarks/threads.md); a task also builds its scene and
    object in Python, which holds the GIL.
    Processes are started with ``spawn``, not ``fork``: the parent runs a progress-bar
    thread, and forking a threaded process can deadlock the child. If a worker process dies
    (e.g. a crash in the C++ core) the pool breaks: every unfinished task comes back with
    the ``BrokenProcessPool`` error, and a resumed run picks them up.

    Args:
        workers: number of workers, >= 1; default: all cores.
        threads: run the workers as threads of this process instead of processes.

    Raises:
        InputError: ``workers`` < 1 (field ``workers``).
    """

    def __init__(self, workers: int | None = None, threads: bool = False) -> None:
        if workers is None:
            workers = os.cpu_count() or 1
        if workers < 1:
            raise InputError(f"must be >= 1, got {workers!r}", field="workers")
        self.workers = workers
        self.threads = threads
        noun = "thread" if threads else "process"
        self.description = f"{workers} local worker {noun if workers == 1 else noun + ('s' if threads else 'es')}"

    def imap_unordered(self, function: Callable[[Task], Any], tasks: Iterable[Task]) -> Iterator[tuple[Task, Any]]:
        """Run ``function(task)`` for every task in the pool (see :class:`TaskExecutor`).

        Closing the iterator early (or Ctrl-C) cancels the tasks not yet started and
        waits for the running ones.
        """
        pool = (
            ThreadPoolExecutor(max_workers=self.workers)
            if self.threads
            else ProcessPoolExecutor(max_workers=self.workers, mp_context=multiprocessing.get_context("spawn"),
                                     initializer=exit_with_parent, initargs=(os.getpid(),))
        )
        try:
            futures = {pool.submit(function, task): task for task in tasks}
            for future in as_completed(futures):
                yield futures[future], _outcome(future)
        finally:
            pool.shutdown(wait=True, cancel_futures=True)


class DaskExecutor:
    """Run tasks on a Dask cluster (``distributed``), one Dask task per planning task.

    Workers must import the same ``slideplan`` (same version, with its compiled core). Any
    number of threads per worker is fine: plans are independent in threads and release the GIL,
    so give a worker one thread per core (``dask worker ADDRESS --nthreads N``).

    Args:
        scheduler: the scheduler address, e.g. ``"tcp://10.0.0.5:8786"``.
    """

    def __init__(self, scheduler: str) -> None:
        self.scheduler = scheduler
        self.description = f"Dask scheduler {scheduler}"

    def imap_unordered(self, function: Callable[[Task], Any], tasks: Iterable[Task]) -> Iterator[tuple[Task, Any]]:
        """Submit every task to the cluster and yield outcomes as they complete (see :class:`TaskExecutor`).

        A task whose workers kept dying comes back as the cluster's error (``KilledWorker``).

        Raises:
            InputError: cannot connect to the scheduler (field ``scheduler``).
        """
        from distributed import Client, as_completed as dask_as_completed

        try:
            client = Client(self.scheduler, timeout="10s")
        except (OSError, ValueError) as error:  # OSError covers connection timeouts
            raise InputError(f"cannot connect to Dask scheduler {self.scheduler!r} ({error})", field="scheduler") from None
        try:
            futures = {
                client.submit(function, task, key=f"slideplan-{task.task_id}", pure=False): task for task in tasks
            }
            for future in dask_as_completed(futures):
                yield futures[future], _outcome(future)
        finally:
            client.close()


def exit_with_parent(parent: int, period_s: float = 1.0) -> None:
    """In a worker process: exit as soon as ``parent`` is no longer this process's parent (it died, even by
    ``kill -9``, and the worker was handed to init). A killed driver must not leave its workers planning on.

    Args:
        parent: the process id of the driver that started the pool.
        period_s: how often to look (s).
    """
    def watch() -> None:
        while os.getppid() == parent:
            time.sleep(period_s)
        os._exit(1)  # no clean-up: the driver that would collect the results is gone

    threading.Thread(target=watch, name="slideplan-exit-with-parent", daemon=True).start()


def _outcome(future) -> Any:
    """The future's result, or the exception that ended it."""
    try:
        return future.result()
    except Exception as error:  # noqa: BLE001 - any failure loses just this task; the caller reports it
        return error
