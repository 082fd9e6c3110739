"""Figures to files: :func:`save_figure` writes PNG and SVG atomically and reproducibly."""

from __future__ import annotations

import os
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from granflow.errors import InvalidParameterError

if TYPE_CHECKING:
    from matplotlib.figure import Figure

    from granflow._typing import PathLike

__all__ = ["save_figure"]

#: Resolution of the PNG files written by :func:`save_figure` [dots per inch].
PNG_DPI = 150


# --------------------------------------------------------------------------- saving


def _figure_of(figure):
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

    if isinstance(figure, Figure):
        return figure
    if isinstance(figure, Axes):
        return figure.figure
    if isinstance(figure, np.ndarray | list | tuple) and len(figure):
        first = np.ravel(np.asarray(figure, dtype=object))[0]
        if isinstance(first, Axes):
            return first.figure
    raise InvalidParameterError(
        f"figure must be a matplotlib Figure (or Axes), got {type(figure).__name__}"
    )


def _atomic_save(figure, path, **options):
    """Write to a temporary file beside ``path``, then rename it (no half-written figure)."""
    from granflow._files import write_atomic

    write_atomic(path, lambda temporary: figure.savefig(temporary, **options))


def save_figure(figure: Figure, directory: PathLike, stem: str) -> dict[str, Path]:
    """Save a figure as ``DIRECTORY/STEM.png`` (150 dpi) and ``DIRECTORY/STEM.svg``.

    The files are written atomically and carry no date, so saving the same figure twice
    gives the same files. The figure is not closed (the caller closes it).

    Parameters
    ----------
    figure : matplotlib.figure.Figure
        The figure (an Axes, or an array of Axes as the plot functions return, stands for
        its figure).
    directory : str or os.PathLike
        Output folder; made (with its parents) when missing.
    stem : str
        File name without extension; no path separators.

    Returns
    -------
    dict
        ``{"png": Path, "svg": Path}``.

    Raises
    ------
    InvalidParameterError
        If ``figure`` is not a Figure or Axes, ``directory`` not a path, or ``stem`` empty,
        not a string or holding a path separator.
    """
    import matplotlib

    figure = _figure_of(figure)
    if not isinstance(directory, str | os.PathLike):
        raise InvalidParameterError(
            f"directory must be a path (str or os.PathLike), got {type(directory).__name__}"
        )
    if not isinstance(stem, str) or not stem or stem in (".", ".."):
        raise InvalidParameterError(f"stem must be a non-empty file name, got {stem!r}")
    if any(sep in stem for sep in ("/", "\\", os.sep)):
        raise InvalidParameterError(f"stem must be a file name without a folder, got {stem!r}")
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    paths = {"png": directory / f"{stem}.png", "svg": directory / f"{stem}.svg"}
    _atomic_save(figure, paths["png"], format="png", dpi=PNG_DPI, metadata={"Software": None})
    with matplotlib.rc_context({"svg.hashsalt": stem, "svg.fonttype": "path"}):
        _atomic_save(figure, paths["svg"], format="svg", metadata={"Date": None})
    return paths
