"""Progress bars that work in a terminal and in Jupyter (tqdm's auto mode), or stay silent.

Every long loop of granflow (:func:`granflow.analyze`, :func:`granflow.stability_map`,
:func:`granflow.fit_many`, :func:`granflow.sample_posterior`) takes ``progress``: True shows
a bar, False shows none, None (the default) shows one when the session is interactive (stderr
is a terminal, or the code runs in a Jupyter kernel). Inside :func:`silenced` (what
:func:`granflow.analyze` does around its own stages) no inner loop shows a bar, so a campaign
shows exactly one. In Jupyter the bar is a widget when ipywidgets is installed and a text bar
otherwise. tqdm is imported only when a bar is shown.
"""

from __future__ import annotations

import contextlib
import contextvars
import sys
from collections.abc import Callable, Iterator
from typing import IO, Any, Protocol

from granflow.errors import InvalidParameterError

__all__ = ["Bar", "RunProgress", "in_jupyter", "interactive", "progress_bar", "silenced", "wanted"]

_SILENCED: contextvars.ContextVar[bool] = contextvars.ContextVar(
    "granflow_progress_silenced", default=False
)


class Bar(Protocol):
    """What granflow uses of a tqdm bar."""

    def update(self, n: float = 1) -> Any: ...

    def set_postfix_str(self, s: str = "", refresh: bool = True) -> Any: ...

    def close(self) -> Any: ...


class _NoBar:
    """A bar that shows nothing."""

    def update(self, n: float = 1) -> None:
        return None

    def set_postfix_str(self, s: str = "", refresh: bool = True) -> None:
        return None

    def close(self) -> None:
        return None


def in_jupyter() -> bool:
    """Whether this code runs in a Jupyter kernel (IPython's shell over ZeroMQ); IPython is
    not imported to find out."""
    ipython = sys.modules.get("IPython")
    if ipython is None:
        return False
    shell = ipython.get_ipython()
    return type(shell).__name__ == "ZMQInteractiveShell"


def interactive(stream: IO[str] | None = None) -> bool:
    """Whether a person is watching: a Jupyter kernel runs this code, or ``stream`` (default
    stderr) is a terminal."""
    if in_jupyter():
        return True
    stream = sys.stderr if stream is None else stream
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError):  # no isatty, or a closed stream
        return False


def wanted(progress: bool | None) -> bool:
    """Whether to show a bar for ``progress`` (True, False, or None for :func:`interactive`);
    never inside :func:`silenced`."""
    if progress is not None and not isinstance(progress, bool):
        raise InvalidParameterError(
            f"progress must be True, False or None (automatic), got {progress!r}"
        )
    if _SILENCED.get():
        return False
    return interactive() if progress is None else progress


@contextlib.contextmanager
def silenced() -> Iterator[None]:
    """No progress bars in the code this block runs (on this thread or task)."""
    token = _SILENCED.set(True)
    try:
        yield
    finally:
        _SILENCED.reset(token)


def progress_bar(
    total: int, *, progress: bool | None = None, desc: str = "", unit: str = "it"
) -> Bar:
    """A bar of ``total`` steps on stderr (tqdm's auto mode), or one that shows nothing.

    Parameters
    ----------
    total : int
        Steps to come.
    progress : bool or None
        True: show it; False: do not; None: show it when :func:`interactive`.
    desc, unit : str
        The label before the bar and the name of a step.
    """
    if not wanted(progress):
        return _NoBar()
    import warnings

    with warnings.catch_warnings():
        # In Jupyter without ipywidgets tqdm.auto warns once and falls back to the text bar,
        # which works there: the warning would only clutter the cell.
        warnings.simplefilter("ignore")
        from tqdm.auto import tqdm

    return tqdm(total=total, desc=desc, unit=unit, file=sys.stderr, dynamic_ncols=True)


class RunProgress:
    """The progress of :func:`granflow.analyze`: one bar over the runs where a person watches
    (a terminal or Jupyter), one line per run in a log, nothing when ``quiet``; the stage
    lines ("figures", ...) in all but quiet. ``callback(done, total, name)`` is called after
    each run either way.
    """

    def __init__(
        self,
        quiet: bool,
        callback: Callable[[int, int, str], object] | None,
        stream: IO[str] | None = None,
    ) -> None:
        self.quiet = quiet
        self.callback = callback
        self.stream = sys.stderr if stream is None else stream
        self.total = 0
        self.done = 0
        self._bar: Bar | None = None

    def line(self, text: str) -> None:
        """A stage of the analysis, on its own line."""
        if not self.quiet:
            print(text, file=self.stream, flush=True)

    def start(self, total: int) -> None:
        """``total`` runs are about to be analysed."""
        self.total, self.done = total, 0
        if not self.quiet and total and interactive(self.stream):
            self._bar = progress_bar(total, progress=True, desc="analysing", unit="run")

    def step(self, name: str) -> None:
        """Run ``name`` is done."""
        self.done += 1
        if self.callback is not None:
            self.callback(self.done, self.total, name)
        if self.quiet:
            return
        if self._bar is not None:
            self._bar.set_postfix_str(name[-40:], refresh=False)
            self._bar.update()
        else:
            print(f"fitted {self.done}/{self.total}: {name}", file=self.stream, flush=True)

    def finish(self) -> None:
        """Close the bar (also after an interruption), so that what follows starts a line."""
        if self._bar is not None:
            self._bar.close()
            self._bar = None
