"""Where tasks run: a local process pool or a Dask cluster.

Both executors have one method, ``imap_unordered(function, tasks)``, which yields
``(task, outcome)`` as tasks finish, in any order; ``outcome`` is the function's return
value, or the exception that lost the task (a worker process died, the pool broke, the
cluster gave up). Exceptions inside the function itself are the function's business:
:func:`slideplan.experiments.run_task` turns them into result rows.
"""

from __future__ import annotations

import contextlib
import hashlib
import multiprocessing
import os
import shutil
import tempfile
import threading
import time
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path
from concurrent.futures import ProcessPoolExecutor, ThreadPoolExecutor, as_completed
from concurrent.futures.process import BrokenProcessPool
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
    (killed, or a crash in the C++ core) the pool breaks and fails every unfinished task, its
    neighbours' too: those not yet started run again in a fresh pool, and those that had started
    each in a pool of its own, where a task that kills its worker again comes back with the
    ``BrokenProcessPool`` error (a resumed run picks it up).

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
        if self.threads:
            yield from self._run(ThreadPoolExecutor(max_workers=self.workers), function, list(tasks), None)
            return
        # Batches of (tasks, workers): a broken pool's tasks that had not started run again together; those
        # that had (the dead worker's, its neighbours') each alone, so that one that kills its worker each
        # time is lost alone.
        rounds, started = [(list(tasks), self.workers)], Path(tempfile.mkdtemp(prefix="slideplan-started-"))
        try:
            while rounds:
                batch, workers = rounds.pop(0)
                broken = []
                with contextlib.closing(self._run(self._processes(workers), function, batch, started)) as outcomes:
                    for task, outcome in outcomes:
                        if isinstance(outcome, BrokenProcessPool) and len(batch) > 1:
                            broken.append(task)
                        else:
                            yield task, outcome
                suspects = [task for task in broken if (started / task_key(task)).exists()]
                idle = [task for task in broken if task not in suspects]
                if broken and not suspects:  # no task had started (a worker that cannot start): no retry helps
                    for task in broken:
                        yield task, BrokenProcessPool("the pool broke before any of its tasks started")
                    continue
                rounds = [([task], 1) for task in suspects] + [(idle, workers)] * bool(idle) + rounds
        finally:
            shutil.rmtree(started, ignore_errors=True)

    def _processes(self, workers: int) -> ProcessPoolExecutor:
        return ProcessPoolExecutor(max_workers=workers, mp_context=multiprocessing.get_context("spawn"),
                                   initializer=exit_with_parent, initargs=(os.getpid(),))

    @staticmethod
    def _run(pool, function, tasks: list, started: Path | None) -> Iterator[tuple[Task, Any]]:
        try:
            if started is None:
                futures = {pool.submit(function, task): task for task in tasks}
            else:
                futures = {pool.submit(_marked, function, task, str(started / task_key(task))): task for task in tasks}
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


def task_key(task) -> str:
    """A file name for ``task``: its id, or its hash (tasks of other kinds, e.g. demos' episodes)."""
    key = getattr(task, "task_id", None)
    return str(key) if key is not None else hashlib.sha256(repr(task).encode()).hexdigest()[:16]


def _marked(function: Callable[[Any], Any], task: Any, mark: str) -> Any:
    """In a worker: ``function(task)``, the file ``mark`` written first (the task started)."""
    Path(mark).touch()
    return function(task)


def _outcome(future) -> Any:
    """The future's result, or the exception that ended it."""
    try:
        return future.result()
    except Exception as error:  # noqa: BLE001 - any failure loses just this task; the caller reports it
        return error
