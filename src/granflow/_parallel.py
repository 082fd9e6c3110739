"""The one way granflow runs work in parallel: local processes or a Dask cluster.

:class:`Executor` serves :func:`granflow.fit_many`, :func:`granflow.stability_map` and
:func:`granflow.analyze`. ``map`` returns results in the order of the input; ``run`` yields
them as each task finishes (so that they can be saved at once) together with the task's
position, so that callers order them by their input, never by completion. With one job (or
one task, unless the executor isolates) everything runs in this process, with no pool.
"""

import copyreg
from types import MappingProxyType

from granflow.errors import InvalidParameterError


def _mapping_proxy(mapping):
    """Rebuild a read-only mapping after pickling."""
    return MappingProxyType(mapping)


def _reduce_mapping_proxy(proxy):
    return _mapping_proxy, (dict(proxy),)


# Tasks and their results may hold read-only mappings (the options of a simulation or a
# stability map): pickle them by value, so that they travel to and from the workers.
copyreg.pickle(MappingProxyType, _reduce_mapping_proxy)


def check_jobs(jobs, name="jobs"):
    """``jobs`` as a positive int, or an :class:`InvalidParameterError` naming it."""
    import numbers

    if isinstance(jobs, bool) or not isinstance(jobs, numbers.Integral) or jobs < 1:
        raise InvalidParameterError(f"{name} must be a positive integer, got {jobs!r}")
    return int(jobs)


class Executor:
    """Tasks over local processes or a Dask cluster; use as a context manager.

    Parameters
    ----------
    jobs : int
        Local worker processes (1: in this process).
    scheduler : str or distributed.Client, optional
        A Dask scheduler address (``"tcp://host:8786"``) or a client; overrides ``jobs``.
    isolate : bool
        With local workers, send every task to them, even a task alone (which otherwise
        runs in this process): what the tasks load stays out of this process.
    """

    def __init__(self, jobs=1, scheduler=None, *, isolate=False):
        self.jobs = check_jobs(jobs)
        self.scheduler = scheduler
        self.isolate = bool(isolate)
        self._pool = None
        self._client = None
        self._own_client = False
        self._futures = []
        if scheduler is not None:
            self._connect(scheduler)

    def _connect(self, scheduler):
        try:
            from distributed import Client
        except ImportError as exc:
            raise ImportError(
                "--scheduler needs Dask distributed: install the extra with "
                "`pip install granflow[dask]`"
            ) from exc
        if isinstance(scheduler, Client):
            self._client = scheduler
        else:
            self._client = Client(scheduler, timeout="30s")
            self._own_client = True

    @property
    def description(self):
        if self._client is not None:
            return f"dask {self._client.scheduler.address}"
        return f"local, {self.jobs} process{'es' if self.jobs > 1 else ''}"

    def _local_pool(self):
        if self._pool is None:
            from concurrent.futures import ProcessPoolExecutor

            self._pool = ProcessPoolExecutor(max_workers=self.jobs, initializer=_worker_init)
        return self._pool

    def run(self, function, tasks):
        """Yield ``(position, result or exception)`` for each task, in completion order."""
        if not tasks:
            return
        if self._client is not None:
            from distributed import as_completed

            futures = self._client.map(function, tasks, pure=False)
            self._futures = futures
            where = {future.key: position for position, future in enumerate(futures)}
            for future in as_completed(futures):
                yield where[future.key], _outcome(future.result)
            return
        if self.jobs == 1 or (len(tasks) == 1 and not self.isolate):
            for position, task in enumerate(tasks):
                yield position, function(task)
            return
        from concurrent.futures import as_completed

        pool = self._local_pool()
        futures = {pool.submit(function, task): position for position, task in enumerate(tasks)}
        self._futures = list(futures)
        for future in as_completed(futures):
            yield futures[future], _outcome(future.result)

    def call(self, function, argument):
        """``function(argument)`` on a local worker, so that what it loads stays there (with
        one job, or a Dask cluster, in this process; whether or not the executor isolates);
        an exception it raises is raised here. A worker that dies under it (killed for
        memory, say) leaves the task to this process, with new workers for what follows."""
        if self._client is not None or self.jobs == 1:
            return function(argument)
        from concurrent.futures.process import BrokenProcessPool

        try:
            return self._local_pool().submit(function, argument).result()
        except BrokenProcessPool:
            self.recycle()
            return function(argument)

    def recycle(self):
        """End the local workers: the next tasks go to new ones, started from this process
        as it is then (forked, where that is the start method), so that what one stage's
        tasks loaded (pandas for reading, the compiled kernels for fitting, matplotlib for
        drawing) does not pile up in the workers of the next. Nothing changes on a Dask
        cluster or with one job."""
        if self._pool is not None:
            self._pool.shutdown(wait=True)
            self._pool = None
            self._futures = []

    def map(self, function, items, chunksize=1):
        """``[function(item) for item in items]``, on the same workers, in input order."""
        items = list(items)
        if self._client is not None:
            return self._client.gather(self._client.map(function, items, pure=False))
        if self.jobs == 1 or not items or (len(items) == 1 and not self.isolate):
            return [function(item) for item in items]
        return list(self._local_pool().map(function, items, chunksize=chunksize))

    def __enter__(self):
        return self

    def __exit__(self, *exc_info):
        self.close()

    def close(self):
        for future in self._futures:
            future.cancel()
        if self._pool is not None:
            self._pool.shutdown(wait=True, cancel_futures=True)
        if self._client is not None and self._own_client:
            self._client.close()


def _worker_init():
    """Workers leave Ctrl-C to the main process, which stops the pool cleanly, and end on
    SIGTERM: a forked worker would otherwise inherit the handler with which the command line
    turns SIGTERM into an interruption of the main process (and raise it inside a task)."""
    import signal

    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)


def _outcome(result):
    try:
        return result()
    except Exception as exc:  # a worker that died: report the run, do not keep the result
        return exc
