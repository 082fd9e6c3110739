"""Splitting large array evaluations over threads.

The compiled kernels release the GIL (``nogil=True``), and so does NumPy, so plain Python
threads run them in parallel without Numba's own threading layer (which is neither
thread-safe nor fork-safe in its default form). Arrays below ``MIN_CHUNK`` points per
thread are evaluated in the calling thread. The thread count defaults to the number of
cores and can be set with the environment variable ``GRANFLOW_NUM_THREADS`` or
:func:`set_num_threads`.
"""

import itertools
import os
from concurrent.futures import ThreadPoolExecutor

MIN_CHUNK = 1 << 16

_state = {"threads": max(1, int(os.environ.get("GRANFLOW_NUM_THREADS", os.cpu_count() or 1)))}
_pool: dict[int, ThreadPoolExecutor] = {}


def set_num_threads(threads):
    """Use at most ``threads`` threads for large model evaluations (1 disables threading)."""
    threads = int(threads)
    if threads < 1:
        raise ValueError(f"threads must be at least 1, got {threads}")
    _state["threads"] = threads


def get_num_threads():
    """The number of threads used for large model evaluations."""
    return _state["threads"]


def chunks(size):
    """[(start, stop), ...] covering range(size): one chunk unless the array is large."""
    count = max(1, min(_state["threads"], size // MIN_CHUNK))
    edges = [size * i // count for i in range(count + 1)]
    return list(itertools.pairwise(edges))


def map_chunks(function, bounds):
    """[function(start, stop) for each chunk], run on a shared thread pool."""
    workers = len(bounds)
    pool = _pool.get(workers)
    if pool is None:
        pool = _pool[workers] = ThreadPoolExecutor(workers, thread_name_prefix="granflow")
    return list(pool.map(lambda bound: function(*bound), bounds))
