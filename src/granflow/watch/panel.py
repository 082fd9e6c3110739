"""The terminal side of a watch: a live panel refreshed in place (rich) where the output is a
terminal, and one plain line per event where it is not (a pipe, a file, a test)."""

from __future__ import annotations

import math
import sys

__all__ = ["Panel", "describe"]

_QUIET = ("forecast", "state")


def _value(value, scale, unit, digits=4):
    if value is None or not math.isfinite(value):
        return "-"
    return f"{value * scale:.{digits}g} {unit}"


def _interval(pair, scale, unit):
    low, high = pair if pair else (None, None)
    if low is None and high is None:
        return "-"
    low_text = "-" if low is None else f"{low * scale:.4g}"
    high_text = "open" if high is None else f"{high * scale:.4g}"
    return f"[{low_text}, {high_text}] {unit}"


def describe(record):
    """One line for a log record (the plain output)."""
    where = f"{record['source']}#{record['interval']}" if record.get("interval") else ""
    t = record.get("t")
    at = f" t = {t:.6g} s" if t is not None else ""
    return f"[{record['event']}] {where}{at}: {record.get('message', '')}".rstrip(": ")


def rows(stream):
    """(label, value) rows of the panel for a stream's view."""
    horizon = stream["horizon"]
    lines = [
        ("file", f"{stream['source']} (interval {stream['interval']})"),
        ("forecast", stream["kind"] or "waiting for 12 rows"),
        ("elapsed", _value(stream["t"], 1, "s", 6)),
        ("rows", str(stream["rows"])),
        ("force", _value(stream["force_now"], 1e3, "mN")),
        ("slip", _value(stream["slip_now"], 1e6, "um")),
        ("slip rate", _value(stream["slip_rate"], 1e6, "um/s")),
    ]
    if stream["kind"] == "peak":
        lines += [
            ("peak force", _interval(stream["force_interval"], 1e3, "mN")),
            ("peak time", _interval(stream["peak_time_interval"], 1, "s")),
        ]
        return lines
    probability = stream.get("probability_within_horizon")
    left = stream.get("time_left")
    lines += [
        ("failure at", _value(stream.get("time"), 1, "s", 6)),
        (f"{stream['level']:.0%} interval", _interval(stream.get("time_interval"), 1, "s")),
        ("time left", _value(left, 1, "s")),
        ("F_peak", _interval(stream["force_interval"], 1e3, "mN")),
        (
            f"P(failure within {horizon:g} s)",
            "-" if probability is None else f"{probability:.2f}",
        ),
    ]
    return lines


class Panel:
    """The live panel (a terminal) or plain event lines (anything else).

    Parameters
    ----------
    live : bool, optional
        Force the panel on or off; default: on where stdout is a terminal.
    stream : file, optional
        Where to write; default sys.stdout.
    """

    def __init__(self, live=None, stream=None):
        self.stream = stream or sys.stdout
        self.live = self.stream.isatty() if live is None else live
        self._live = None

    def __enter__(self):
        if self.live:
            try:
                from rich.console import Console
                from rich.live import Live
            except ImportError:
                raise ImportError(
                    "the live panel needs rich: pip install 'granflow[watch]' (or pipe the "
                    "output, for plain lines)"
                ) from None

            console = Console(file=self.stream)
            self._live = Live(console=console, refresh_per_second=4, transient=False)
            self._live.__enter__()
        return self

    def __exit__(self, *exc):
        if self._live is not None:
            self._live.__exit__(*exc)
            self._live = None

    def event(self, record):
        """Say one event (not the routine forecasts) as a line."""
        if record["event"] in _QUIET:
            return
        if self._live is not None:
            self._live.console.print(describe(record), markup=False, highlight=False)
        else:
            print(describe(record), file=self.stream, flush=True)

    def show(self, view):
        """Refresh the panel with the watch's view."""
        if self._live is not None:
            self._live.update(render(view))


def render(view):
    """The panel as a rich renderable."""
    from rich.panel import Panel as Box
    from rich.table import Table
    from rich.text import Text

    stream = view["stream"]
    table = Table.grid(padding=(0, 2))
    table.add_column(style="bold")
    table.add_column()
    if stream is None:
        table.add_row("waiting", "for data")
        return Box(table, title="granflow watch")
    for label, value in rows(stream):
        table.add_row(label, value)
    if stream["kind"] == "failure":
        if stream["alarm"]:
            state = Text(" ALARM: failure likely within the horizon ", style="bold white on red")
        elif stream.get("observed_failure") is not None:
            state = Text(f" failed at {stream['observed_failure']:.6g} s ", style="bold")
        else:
            state = Text(" no alarm ", style="bold black on green")
        table.add_row("alarm", state)
    if stream.get("message"):
        table.add_row("note", Text(stream["message"], style="italic"))
    for notice in view["notices"][-4:]:
        table.add_row(Text(notice["event"], style="dim"), Text(notice["message"], style="dim"))
    return Box(table, title="granflow watch", subtitle=f"threshold {view['threshold']:g}")
