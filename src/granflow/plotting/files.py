"""Figures to files: :func:`save_figure` writes PNG, SVG and PDF atomically and reproducibly."""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from granflow.errors import InvalidParameterError

if TYPE_CHECKING:
    from matplotlib.figure import Figure, SubFigure

    from granflow._typing import PathLike

__all__ = ["FIGURE_FORMATS", "check_formats", "figure_of", "save_figure"]

#: Resolution of the PNG files written by :func:`save_figure` [dots per inch].
PNG_DPI = 150


# --------------------------------------------------------------------------- saving


def figure_of(figure: Any) -> Figure | SubFigure:
    """The Figure of a Figure, an Axes or an array of Axes (InvalidParameterError else)."""
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


#: zlib level of the PNG files: 3 writes a page of small multiples in 0.8 s rather than
#: 1.3 s (level 6, PIL's default) for a file 15 % larger.
PNG_COMPRESSION = 3


def _atomic_save(figure, path, **options):
    """Write to a temporary file beside ``path``, then rename it (no half-written figure)."""
    from granflow._files import write_atomic

    write_atomic(path, lambda temporary: figure.savefig(temporary, **options))


#: The formats :func:`save_figure` writes.
FIGURE_FORMATS = ("png", "svg", "pdf")


def check_formats(formats: str | Sequence[str], name: str = "formats") -> tuple[str, ...]:
    """``formats`` as a tuple of known figure formats (lower case, no repeats), or
    InvalidParameterError naming ``name``."""
    if isinstance(formats, str):
        formats = [part for part in formats.split(",") if part.strip()]
    try:
        found = tuple(dict.fromkeys(str(f).strip().lower().lstrip(".") for f in formats))
    except TypeError:
        raise InvalidParameterError(
            f"{name} must be a sequence of {', '.join(FIGURE_FORMATS)}, got {formats!r}"
        ) from None
    unknown = [f for f in found if f not in FIGURE_FORMATS]
    if unknown or not found:
        raise InvalidParameterError(
            f"{name} must name one or more of {', '.join(FIGURE_FORMATS)}, got {formats!r}"
        )
    return found


def save_figure(
    figure: Figure | Any, directory: PathLike, stem: str, formats: Sequence[str] = ("png", "svg")
) -> dict[str, Path]:
    """Save a figure as ``DIRECTORY/STEM.png`` (150 dpi), ``.svg`` and ``.pdf``.

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
    formats : sequence of {"png", "svg", "pdf"} or str
        The formats to write (``"png,pdf"`` is read as a list); each is drawn once.

    Returns
    -------
    dict
        ``{format: Path}`` for each format written.

    Raises
    ------
    InvalidParameterError
        If ``figure`` is not a Figure or Axes, ``directory`` not a path, or ``stem`` empty,
        not a string or holding a path separator.
    """
    import matplotlib

    whole = figure_of(figure)
    if not isinstance(directory, str | os.PathLike):
        raise InvalidParameterError(
            f"directory must be a path (str or os.PathLike), got {type(directory).__name__}"
        )
    if not isinstance(stem, str) or not stem or stem in (".", ".."):
        raise InvalidParameterError(f"stem must be a non-empty file name, got {stem!r}")
    if any(sep in stem for sep in ("/", "\\", os.sep)):
        raise InvalidParameterError(f"stem must be a file name without a folder, got {stem!r}")
    formats = check_formats(formats)
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    paths = {suffix: directory / f"{stem}.{suffix}" for suffix in formats}
    if "png" in paths:
        _atomic_save(
            whole,
            paths["png"],
            format="png",
            dpi=PNG_DPI,
            metadata={"Software": None},
            pil_kwargs={"compress_level": PNG_COMPRESSION},
        )
    if "svg" in paths:
        with matplotlib.rc_context({"svg.hashsalt": stem, "svg.fonttype": "path"}):
            _atomic_save(whole, paths["svg"], format="svg", metadata={"Date": None})
    if "pdf" in paths:
        _atomic_save(
            whole, paths["pdf"], format="pdf", metadata={"CreationDate": None, "Producer": None}
        )
    return paths
