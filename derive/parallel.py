"""Run independent tasks on this process, on local threads or worker processes, or on a
Dask cluster — one executor for parameter studies (``derive.simulate_many``) and
stability sweeps (``derive chart stability``).

Threads suit tasks whose time is spent in the C runtime: ctypes releases the GIL for the
length of a call, so a thread per core runs the C in parallel with no process to start
and nothing to pickle (``simulate_many`` measured: ``derive bench sim``).  Processes suit
tasks that spend their time in Python (the stability sweeps' CasADi and NumPy).

Tasks are plain picklable tuples and a module-level function; results come back with
the index of their task, so the caller's arrays do not depend on completion order:
serial, processes and Dask give the same results bit for bit.
"""
from __future__ import annotations

import multiprocessing
import os
import threading
import time
from concurrent.futures import ProcessPoolExecutor, ThreadPoolExecutor, as_completed
from typing import Callable


class ExecutorError(ValueError):
    """A bad executor setting: ``where`` names the option, ``rule`` says what."""

    def __init__(self, where: str, rule: str):
        super().__init__(f"{where}: {rule}")
        self.where, self.rule = where, rule


def _indexed(args):
    fn, index, task = args
    return index, fn(task)


def _chunk(args):
    fn, items = args
    return [(index, fn(task)) for index, task in items]


EXECUTORS = ("processes", "threads")


def run(fn: Callable, tasks, workers: int | None = None, scheduler: str | None = None,
        collect: Callable | None = None, chunk: int = 1, local: str = "processes",
        info: dict | None = None) -> tuple[list, str, int]:
    """Apply ``fn`` to every task; returns (results in task order, executor name, number
    of workers).  ``tasks``: a list, or a function of the number of worker threads that
    will run them (known for a Dask cluster only once connected) returning the list, so
    that a caller can size its tasks to them.  ``collect(index, result)`` is called as
    results arrive (progress).  ``workers``: local workers (default every core; 1: this
    thread), ``local`` says whether they are processes or threads; ``scheduler``: a Dask
    scheduler address instead.  ``chunk``: tasks per process call (cheap tasks).
    ``info``, if given, receives ``tasks`` (how many ran) and, on Dask, ``connect_s``
    (seconds importing Dask and connecting to the scheduler)."""
    if workers is not None and workers < 1:
        raise ExecutorError("--workers", f"must be >= 1 (got {workers})")
    info = {} if info is None else info
    results: list = []

    def plan(slots: int) -> list:
        listed = list(tasks(slots) if callable(tasks) else tasks)
        results[:] = [None] * len(listed)
        info["tasks"] = len(listed)
        return listed

    def got(index, value):
        results[index] = value
        if collect:
            collect(index, value)

    if scheduler:
        n = _dask(fn, plan, scheduler, got, info)
        return results, "dask", n
    if local not in EXECUTORS:
        raise ExecutorError("executor", f"must be one of {', '.join(EXECUTORS)} (got {local!r})")
    listed = plan(1 if workers == 1 else workers or os.cpu_count() or 1)
    if workers == 1 or len(listed) <= 1:
        for index, task in enumerate(listed):
            got(index, fn(task))
        return results, "serial", 1
    n = min(workers or os.cpu_count() or 1, len(listed))
    if local == "threads":
        pool = _threads(n)
        futures = {pool.submit(fn, task): index for index, task in enumerate(listed)}
        for fut in as_completed(futures):
            got(futures[fut], fut.result())
        return results, "threads", n
    # fork: the workers inherit loaded libraries and caches (and need no main guard)
    methods = multiprocessing.get_all_start_methods()
    context = multiprocessing.get_context("fork" if "fork" in methods else "spawn")
    items = list(enumerate(listed))
    batches = [items[k:k + chunk] for k in range(0, len(items), chunk)]
    with ProcessPoolExecutor(max_workers=n, mp_context=context) as pool:
        for fut in as_completed([pool.submit(_chunk, (fn, b)) for b in batches]):
            for index, value in fut.result():
                got(index, value)
    return results, "processes", n


_POOLS: dict = {}
_POOLS_LOCK = threading.Lock()


def _threads(n: int) -> ThreadPoolExecutor:
    """A pool of n threads kept for the process's life: idle threads cost nothing, and
    what each thread made (its runtime sessions, derive.runtime.session.session_for)
    serves the next study too."""
    with _POOLS_LOCK:
        if n not in _POOLS:
            _POOLS[n] = ThreadPoolExecutor(max_workers=n, thread_name_prefix="derive")
        return _POOLS[n]


def _dask(fn: Callable, plan: Callable, scheduler: str, got: Callable, info: dict) -> int:
    """Run on a Dask cluster; returns its number of workers.  ``plan(threads)`` gives the
    tasks once the cluster's worker threads are known."""
    start = time.perf_counter()
    try:
        from distributed import Client
        from distributed import as_completed as dask_completed
    except ImportError:
        raise ExecutorError("--scheduler", "needs Dask: pip install -e '.[cluster]'") from None
    try:
        client = Client(scheduler, timeout="10s")
    except (OSError, TimeoutError, ValueError) as exc:
        raise ExecutorError("--scheduler", f"cannot reach {scheduler} ({exc})") from None
    try:
        threads = client.nthreads()                 # {worker address: its threads}
        info["connect_s"] = time.perf_counter() - start
        tasks = plan(max(sum(threads.values()), 1))
        # the tasks' data scattered to the workers, not embedded in the graph (a study of
        # 10^6 variants sends 60 MB of them: Dask warned of the graph's size)
        data = client.scatter([(fn, k, t) for k, t in enumerate(tasks)], hash=False)
        futures = client.map(_indexed, data, pure=False)
        for fut in dask_completed(futures):
            got(*fut.result())
    finally:
        client.close()
    return max(len(threads), 1)
