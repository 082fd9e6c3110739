"""Fits of many curves at once, over local processes or a Dask cluster
(:class:`granflow._parallel.Executor`)."""

from __future__ import annotations

import warnings
from collections.abc import Iterable
from typing import TYPE_CHECKING, Any

import numpy as np

from granflow._parallel import Executor, check_jobs
from granflow._progress import progress_bar, wanted
from granflow.errors import ConvergenceWarning, GranflowError, InvalidParameterError
from granflow.model.run import Run

if TYPE_CHECKING:
    from granflow._typing import ArrayLike

__all__ = ["fit_many"]


def _portable(data):
    """A Run as a picklable tuple (its metadata mapping cannot cross a process boundary)."""
    if isinstance(data, Run):
        columns = {
            name: np.asarray(getattr(data, name)) for name in ("t", "slip", "velocity", "force")
        }
        return ("run", columns, data.control, dict(data.meta))
    return data


def _fit_item(item):
    """Fit one (data, options) item; returns the FitResult or the GranflowError raised."""
    from granflow.fitting.single import fit

    data, options = item
    if isinstance(data, tuple) and len(data) == 4 and data[0] == "run":
        _, columns, control, meta = data
        data = Run(control=control, meta=meta, **columns)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ConvergenceWarning)
            return fit(data, **options)
    except GranflowError as exc:
        return exc


def fit_many(
    datasets: Iterable[Run | tuple[ArrayLike, ArrayLike]],
    *,
    jobs: int = 2,
    errors: str = "raise",
    scheduler: Any = None,
    progress: bool | None = None,
    **options: Any,
) -> list[Any]:
    """Fit many curves over local processes (or a Dask cluster), in the order given.

    Parameters
    ----------
    datasets : iterable
        Items :func:`fit` accepts (Runs or pairs of arrays).
    jobs : int
        Worker processes (1: in this process, no pool).
    errors : {"raise", "return"}
        On a curve that cannot be fitted, raise its error, or put the exception in its place
        in the returned list and go on with the rest.
    scheduler : str or distributed.Client, optional
        A Dask scheduler address or client to fit on instead of local processes (the extra
        ``granflow[dask]``).
    **options
        Keyword arguments of :func:`fit`, the same for every curve.

    Returns
    -------
    list of FitResult (or of the exceptions, with ``errors="return"``)

    Examples
    --------
    >>> import numpy as np, granflow
    >>> p = granflow.Params(3e-3, 4e4, 10e-3, 2e-7)
    >>> x = np.linspace(1e-6, 5e-4, 400)
    >>> curves = [(x, granflow.friction_slip(x, p.replace(Fd=Fd))) for Fd in (8e-3, 10e-3)]
    >>> [round(r.params["Fd"] * 1e3, 3) for r in granflow.fit_many(curves, jobs=1)]
    [8.0, 10.0]
    """
    if errors not in ("raise", "return"):
        raise InvalidParameterError(f"errors must be 'raise' or 'return', got {errors!r}")
    jobs = check_jobs(jobs)
    items = [(_portable(data), options) for data in datasets]
    with Executor(jobs, scheduler) as executor:
        if wanted(progress):
            results = _with_bar(executor, items)
        else:
            results = executor.map(_fit_item, items, chunksize=max(1, len(items) // (4 * jobs)))
    if errors == "raise":
        for index, result in enumerate(results):
            if isinstance(result, Exception):
                raise type(result)(f"dataset {index}: {result}") from result
    return results


def _with_bar(executor, items):
    """The fits of ``items`` in input order, a bar counting them as they finish."""
    results = [None] * len(items)
    bar = progress_bar(len(items), progress=True, desc="fitting", unit="curve")
    try:
        for position, result in executor.run(_fit_item, items):
            results[position] = result
            bar.update()
    finally:
        bar.close()
    return results
