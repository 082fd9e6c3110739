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

__all__ = [
    "STAGES",
    "Bar",
    "RunProgress",
    "in_jupyter",
    "interactive",
    "progress_bar",
    "silenced",
    "wanted",
]

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
    total: int,
    *,
    progress: bool | None = None,
    desc: str = "",
    unit: str = "it",
    leave: bool = True,
    bar_format: str | None = None,
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
    leave : bool
        Keep the bar on screen when it closes (False: it vanishes, leaving the line to
        what follows).
    bar_format : str, optional
        tqdm's layout of the bar (default tqdm's own).
    """
    if not wanted(progress):
        return _NoBar()
    import warnings

    with warnings.catch_warnings():
        # In Jupyter without ipywidgets tqdm.auto warns once and falls back to the text bar,
        # which works there: the warning would only clutter the cell.
        warnings.simplefilter("ignore")
        from tqdm.auto import tqdm

    return tqdm(
        total=total,
        desc=desc,
        unit=unit,
        file=sys.stderr,
        dynamic_ncols=True,
        leave=leave,
        bar_format=bar_format,
    )


#: The stages of a campaign analysis and the share of its bar each takes [%], from the demo
#: (52 runs, 2 workers): warm, the runs take 4 % of its 22 s, the joint analyses with the
#: forecasts 32 %, the figures 50 %; on a first run the Numba compilation makes the runs
#: 37 % of 60 s. The shares lie between the two. A stage a campaign lacks passes at once.
#: "records" stands for the record families' stages (each named by its manifest ``test``
#: kind in words: "velocity steps", "slide hold slide"), one after the other.
STAGES = (
    ("reading", 8.0),
    ("runs", 20.0),
    ("joint analyses, predictions and forecasts", 27.0),
    ("records", 2.0),
    ("tables", 5.0),
    ("figures", 33.0),
    ("report", 5.0),
)


class RunProgress:
    """The progress of :func:`granflow.analyze` over all its stages (:data:`STAGES`, each
    with its weight): where a person watches (a terminal or Jupyter) one bar from 0 to 100 %
    that names the stage it is in and, during the runs, the last run done; in a log one line
    per stage and per run with the share done (``[ 38%] fitted 12/52: name``); nothing when
    ``quiet``. ``callback(done, total, name)`` is called after each run either way.
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
        self.percent = 0.0
        self._stage: str | None = None
        self._bar: Bar | None = None
        self._weights = dict(STAGES)
        self._order = [name for name, _ in STAGES]

    def _before(self, stage: str) -> float:
        """The share of the bar before ``stage`` [%] (a record family's stage: before the
        records)."""
        stage = stage if stage in self._weights else "records"
        return sum(self._weights[name] for name in self._order[: self._order.index(stage)])

    def _advance(self, percent: float) -> None:
        percent = min(100.0, max(self.percent, percent))
        if self._bar is not None and round(percent) != round(self.percent):
            self._bar.update(round(percent) - round(self.percent))  # whole percents: n <= 100
        self.percent = percent

    def stage(self, name: str) -> None:
        """The analysis enters stage ``name`` (one of :data:`STAGES`, or a record family's):
        the stages before it are done."""
        if self.quiet:
            return
        if self._bar is None and self._stage is None and interactive(self.stream):
            # it vanishes when it closes: "[100%] report: PATH", or an error, takes its line
            self._bar = progress_bar(
                100,
                progress=True,
                desc=name,
                unit="%",
                leave=False,
                bar_format="{desc}: {percentage:3.0f}%|{bar}| {elapsed}{postfix}",
            )
        self._stage = name
        self._advance(self._before(name))
        if self._bar is not None:
            set_description = getattr(self._bar, "set_description_str", None)
            if set_description is not None:
                set_description(name, refresh=True)
        elif name != self._order[0]:  # in a log, a bad manifest stays a one-line error
            print(f"[{self.percent:3.0f}%] {name}", file=self.stream, flush=True)

    def line(self, text: str) -> None:
        """A note of the analysis, on its own line (above the bar where there is one)."""
        if self.quiet:
            return
        write = getattr(self._bar, "write", None)
        if write is not None:
            write(text, file=self.stream)
        else:
            print(text, file=self.stream, flush=True)

    def start(self, total: int) -> None:
        """``total`` runs are about to be analysed (the stage "runs")."""
        self.total, self.done = total, 0
        self.stage("runs")

    def step(self, name: str) -> None:
        """Run ``name`` is done."""
        self.done += 1
        if self.callback is not None:
            self.callback(self.done, self.total, name)
        if self.quiet:
            return
        share = self._weights["runs"] * self.done / max(self.total, 1)
        self._advance(self._before("runs") + share)
        if self._bar is not None:
            self._bar.set_postfix_str(f"{self.done}/{self.total} runs: {name[-40:]}", refresh=False)
        else:
            print(
                f"[{self.percent:3.0f}%] fitted {self.done}/{self.total}: {name}",
                file=self.stream,
                flush=True,
            )

    def finish(self, report: object = None) -> None:
        """The analysis is over: the bar reaches 100 % and closes, and the report's path is
        printed (when there is one)."""
        if self.quiet:
            return
        self._advance(100.0)
        if self._bar is not None:
            self._bar.close()
            self._bar = None
        if report is not None:
            print(f"[100%] report: {report}", file=self.stream, flush=True)

    def close(self) -> None:
        """Close the bar where it stands (after an interruption or an error), so that what
        follows starts a line."""
        if self._bar is not None:
            self._bar.close()
            self._bar = None
