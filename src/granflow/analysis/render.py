"""Figures rendered in parallel, through the one executor (:class:`granflow._parallel.Executor`).

A figure is described by its place in a list of figure specs, ``(name, title, draw)`` with
``draw() -> (figure, caption)``, that a module-level function builds from picklable arguments
(:func:`granflow.analysis.outputs._figure_specs` from the campaign's result and joint stage).
Each job carries that function, its arguments and a position, so it pickles without the
specs' closures: a worker rebuilds the specs (cheap: no drawing), draws its one figure,
saves it with ``save`` into a private temporary folder and sends the files' bytes back. The
main process writes them into the figure folder, each atomically; so the workers need no
access to the output folder (a Dask cluster's do not have it) and a figure that fails in a
worker costs only itself.

Rendering is deterministic (no dates in the files, SVG ids salted by the figure's name), so
the files are the same whichever process draws them and however many there are.
"""

import itertools
import os
import pickle
import tempfile
import warnings
from dataclasses import dataclass, field
from pathlib import Path

from granflow._files import write_atomic

__all__ = ["FigureJob", "render_figures"]


@dataclass(frozen=True)
class FigureJob:
    """One figure to draw and save, picklable.

    Attributes
    ----------
    build : callable
        A module-level function: ``build(*args)`` returns the list of ``(name, title, draw)``.
    args : tuple or bytes
        Its arguments, or their pickle (pickled once for all the jobs of a call, rather
        than once per job: a campaign's result and joint stage are megabytes).
    position : int
        Which spec of the list this job draws.
    save : callable
        A module-level function ``save(figure, directory, stem, **options)`` that writes the
        figure's files and returns ``{suffix: path}`` (:func:`granflow.plotting.save_figure`).
    options : dict
        Keyword arguments for ``save``.
    token : str
        Names the arguments: a worker that already unpickled them for an earlier job of
        the same call reuses them.
    """

    build: object
    args: object
    position: int
    save: object
    options: dict = field(default_factory=dict)
    token: str = ""


_UNPICKLED: dict[str, object] = {}  # token -> arguments, in a worker: the last call's only
_CALLS = itertools.count()


def render_figures(build, args, folder, executor=None, *, save=None, **options):
    """Draw and save every figure ``build(*args)`` describes, through ``executor``.

    Parameters
    ----------
    build : callable
        A module-level function returning the list of ``(name, title, draw)``.
    args : tuple
        Its (picklable) arguments; pickled once for all the jobs when they go to other
        processes.
    folder : pathlib.Path
        Where the files go (made when missing).
    executor : granflow._parallel.Executor, optional
        Runs the jobs (default: one after the other in this process).
    save : callable, optional
        Writes one figure (default :func:`granflow.plotting.save_figure`).
    **options
        Keyword arguments for ``save``.

    Returns
    -------
    list
        For each spec in order: ``(caption, {suffix: file name})`` when it was drawn, or the
        reason it could not be drawn (a str).
    """
    if save is None:
        from granflow.plotting import save_figure as save
    count = len(build(*args))
    args = tuple(args)
    elsewhere = executor is not None and (executor.jobs > 1 or executor.scheduler is not None)
    if elsewhere and count > 1:  # pickled once here, not once per job
        args = pickle.dumps(args, protocol=pickle.HIGHEST_PROTOCOL)
    token = f"{os.getpid()}-{next(_CALLS)}"
    jobs = [
        FigureJob(build, args, position, save, dict(options), token) for position in range(count)
    ]
    if executor is None:
        outcomes = dict(enumerate(map(_render, jobs)))
    else:
        outcomes = dict(executor.run(_render, jobs))
    folder = Path(folder)
    out = []
    for position in range(count):
        outcome = outcomes[position]
        if isinstance(outcome, Exception):  # the worker itself failed
            out.append(f"{type(outcome).__name__}: {outcome}")
            continue
        if isinstance(outcome, str):
            out.append(outcome)
            continue
        caption, files = outcome
        folder.mkdir(parents=True, exist_ok=True)
        names = {}
        for suffix, (name, content) in files.items():
            write_atomic(folder / name, lambda temporary, c=content: Path(temporary).write_bytes(c))
            names[suffix] = name
        out.append((caption, names))
    return out


def _render(job):
    """Draw one figure: ``(caption, {suffix: (file name, bytes)})``, or why it failed (str)."""
    import matplotlib.pyplot as plt

    name, _, draw = job.build(*_arguments(job))[job.position]
    before = set(plt.get_fignums())
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            drawn, caption = draw()
            with tempfile.TemporaryDirectory(prefix="granflow-figure-") as temporary:
                paths = job.save(drawn, temporary, name, **job.options)
                files = {
                    suffix: (Path(path).name, Path(path).read_bytes())
                    for suffix, path in paths.items()
                }
    except Exception as exc:  # a figure that fails must not cost the results
        return f"{type(exc).__name__}: {exc}"
    finally:  # close what this figure opened, never the caller's own figures
        for number in set(plt.get_fignums()) - before:
            plt.close(number)
    return caption, files


def _arguments(job):
    """The job's arguments, unpickled once per worker and call."""
    if not isinstance(job.args, bytes):
        return job.args
    found = _UNPICKLED.get(job.token)
    if found is None:
        found = pickle.loads(job.args)
        _UNPICKLED.clear()
        _UNPICKLED[job.token] = found
    return found
