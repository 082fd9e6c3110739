"""One watch from start to end: the loop that polls the source, forecasts, logs, shows and
serves, until the data end (``until_end``) or Ctrl-C.

Ctrl-C (SIGINT) and SIGTERM only set a flag: the loop finishes the step it is in, writes a
last ``"stopped"`` record and closes the log, so the log is always whole lines.
"""

from __future__ import annotations

import signal
import threading
from dataclasses import dataclass
from pathlib import Path

from granflow.errors import InvalidParameterError

__all__ = ["Options", "run"]

#: Longest wait between two polls [s] (file events wake the loop sooner).
POLL = 0.5


@dataclass(frozen=True)
class Options:
    """What ``granflow watch`` was asked to do (besides the engine's
    :class:`~granflow.watch.engine.Settings`).

    Attributes
    ----------
    path : pathlib.Path
        The export, or the folder of exports.
    log : pathlib.Path
        The JSON-lines log.
    serve : str or None
        ``[HOST:]PORT`` of the live page.
    on_alarm : str or None
        The command run when an alarm is raised.
    replay : bool
        Play a finished record as if it were being written.
    speed : float
        Record seconds per wall second of a replay.
    until_end : bool
        Stop at the end of a finished file or of the replay.
    stall : float
        Seconds without new data after which the data have stopped [s].
    live : bool or None
        The terminal panel on or off (None: where stdout is a terminal).
    """

    path: Path
    log: Path
    serve: str | None = None
    on_alarm: str | None = None
    replay: bool = False
    speed: float = 1.0
    until_end: bool = False
    stall: float = 30.0
    live: bool | None = None
    geometry: object = None
    format: str | None = None


class _Stop:
    """Ctrl-C and SIGTERM set a flag (in the main thread; elsewhere nothing is installed)."""

    def __init__(self, wake):
        self.flag = threading.Event()
        self.wake = wake
        self._old = {}

    def __enter__(self):
        if threading.current_thread() is threading.main_thread():
            for number in (signal.SIGINT, signal.SIGTERM):
                self._old[number] = signal.signal(number, self._handle)
        return self

    def _handle(self, signum, frame):
        self.flag.set()
        self.wake.set()

    def __exit__(self, *exc):
        for number, handler in self._old.items():
            signal.signal(number, handler)


def run(options, settings):
    """Watch until the end (``until_end``) or Ctrl-C; returns the exit code (0).

    Raises
    ------
    granflow.GranflowError
        A path that does not exist (for a replay), an address that cannot be served, a
        log that cannot be written; each names the culprit.
    """
    from granflow.watch.engine import Watch
    from granflow.watch.outputs import AlarmCommand, Log
    from granflow.watch.panel import Panel
    from granflow.watch.sources import FollowedPath, Replay, wake_on_changes

    path = Path(options.path)
    if options.replay:
        if not path.is_file():
            raise InvalidParameterError(f"--replay needs a finished export; {path} is not a file")
        source = Replay(path, options.speed, options.geometry, options.format)
    else:
        if not path.exists() and not path.parent.is_dir():
            raise InvalidParameterError(f"{path}: neither the file nor its folder exists")
        source = FollowedPath(path, options.stall, options.geometry, options.format)
    log = Log(options.log)
    panel = Panel(options.live)
    server = None
    wake = threading.Event()
    observer = None if options.replay else wake_on_changes(path, wake)
    command = None

    def emit(record):
        log.write(record)
        panel.event(record)

    watch = Watch(settings, emit)
    if options.on_alarm:
        command = AlarmCommand(
            options.on_alarm,
            lambda event, message: watch.notice(str(path), event, message),
        )
        watch.on_alarm = command
    try:
        if options.serve is not None:
            from granflow.watch.server import Server, parse_address

            server = Server(*parse_address(options.serve))
            watch.notice(str(path), "serving", f"the live page is at {server.url}")
        watch.notice(
            str(path),
            "start",
            f"watching {path}: horizon {settings.horizon:g} s, alarm at "
            f"P >= {settings.alarm:g}, test {settings.test or 'from the file'}",
        )
        warm_up()
        with panel, _Stop(wake) as stop:
            reason = _loop(source, watch, panel, server, command, options, wake, stop)
        watch.notice(str(path), reason[0], reason[1])
    finally:
        if observer is not None:
            observer.stop()
        if server is not None:
            server.close()
        log.close()
    return 0


def warm_up():
    """One small forecast, so that the compiled kernels are loaded before the first real
    one (a replay's clock starts after it)."""
    from granflow.forecast.failure import forecast_failure
    from granflow.forecast.synthetic import ramp_record
    from granflow.model.params import Params

    params = Params(a=3.3e-3, alpha=5e4, Fd=11e-3, x0=0.3e-6)
    t, slip, force, _ = ramp_record(params, rate=0.065e-3, noise=2e-9, seed=0, dt=4.0)
    forecast_failure(t, slip, force)


def _loop(source, watch, panel, server, command, options, wake, stop):
    """Poll, forecast, show, until the end or a stop; returns (event, message)."""
    shown = None
    while True:
        watch.take(source.poll())
        if stop.flag.is_set():
            return "stopped", "stopped by a signal (Ctrl-C): the log is complete"
        watch.forecast()
        if command is not None:
            command.reap()
        if watch.changes != shown:  # the view only when something happened
            shown = watch.changes
            view = watch.view()
            panel.show(view)
            if server is not None:
                server.publish(view)
        if options.until_end and source.finished:
            return "end", "the end of the record: the watch stops (--until-end)"
        if stop.flag.is_set():
            return "stopped", "stopped by a signal (Ctrl-C): the log is complete"
        timeout = POLL
        if options.replay and not source.finished:
            timeout = min(max(source.wait(), 0.02), POLL)
        wake.wait(timeout)
        wake.clear()
