"""Where a watch's samples come from: a file or a folder being written
(:class:`FollowedPath`, over :class:`~granflow.io.follow.Follower`, woken by watchdog's file
events), or a finished record played back as if it were being written (:class:`Replay`).

Each source's ``poll()`` returns :class:`~granflow.io.follow.Rows` and
:class:`~granflow.io.follow.Notice` in order, and ``finished`` says when there is nothing
more to come: a followed file whose end was reached and that has not changed for the stall
time, or a replay played to its end. Data that stop coming are a ``"stalled"`` notice
(``"resumed"`` when they come again).
"""

from __future__ import annotations

import os
import time as clock
from pathlib import Path

import numpy as np

from granflow.errors import FileFormatError
from granflow.io.follow import Follower, Notice, Rows

__all__ = ["EXPORT_SUFFIXES", "FollowedPath", "Replay", "wake_on_changes"]

#: Files of a folder that are followed: instrument exports (not logs, JSON or images).
EXPORT_SUFFIXES = (".txt", ".csv", ".tsv", ".dat")


def wake_on_changes(path, wake):
    """Set the event ``wake`` whenever something under ``path`` changes (watchdog's native
    observer, or its polling observer where the system gives no file events). Returns the
    started observer (``stop()`` and ``join()`` it), or None without watchdog."""
    try:
        from watchdog.events import FileSystemEventHandler
        from watchdog.observers import Observer
        from watchdog.observers.polling import PollingObserver
    except ImportError:  # the loop polls on its own, only less promptly
        return None

    class Wake(FileSystemEventHandler):
        def on_any_event(self, event):
            wake.set()

    folder = Path(path) if Path(path).is_dir() else Path(path).parent
    for kind in (Observer, PollingObserver):
        observer = kind()
        try:
            observer.schedule(Wake(), str(folder), recursive=False)
            observer.daemon = True
            observer.start()
            return observer
        except OSError:  # e.g. the inotify watch limit reached
            continue
    return None


class FollowedPath:
    """A file, or every export that appears in a folder, followed while written.

    Parameters
    ----------
    path : str or pathlib.Path
        The file or the folder.
    stall : float
        Seconds without new data after which the data have stopped [s].
    geometry, format
        As :class:`~granflow.io.follow.Follower` takes them.
    """

    def __init__(self, path, stall=30.0, geometry=None, format=None, now=clock.time):
        self.path = Path(path)
        self.folder = self.path.is_dir()
        self.stall = float(stall)
        self.geometry = geometry
        self.format = format
        self.now = now
        self.followers = {}
        self._stalled = {}

    def _paths(self):
        if not self.folder:
            return [self.path]
        try:
            entries = sorted(os.scandir(self.path), key=lambda entry: entry.name)
        except OSError as exc:
            raise FileFormatError(f"{self.path}: cannot list the folder ({exc.strerror})") from None
        return [
            Path(entry.path)
            for entry in entries
            if entry.is_file()
            and not entry.name.startswith(".")
            and Path(entry.name).suffix.lower() in EXPORT_SUFFIXES
        ]

    def poll(self):
        """New rows and notices of every file followed."""
        events = []
        for path in self._paths():
            source = str(path)
            if source not in self.followers:
                self.followers[source] = Follower(path, self.geometry, self.format)
            new = self.followers[source].poll()
            events += new
            if any(isinstance(event, Rows) for event in new):
                if self._stalled.pop(source, False):
                    events.insert(0, Notice(source, "resumed", "data come again"))
            elif not self._stalled.get(source) and self._idle(source) >= self.stall:
                self._stalled[source] = True
                events.append(
                    Notice(source, "stalled", f"no new data for {self._idle(source):.0f} s")
                )
        return events

    def _idle(self, source):
        """Seconds since the file last changed."""
        try:
            return self.now() - os.stat(source).st_mtime
        except OSError:
            return np.inf

    @property
    def finished(self):
        """Whether every file followed has stopped growing (stalled)."""
        return bool(self.followers) and all(self._stalled.get(s) for s in self.followers)


class Replay:
    """A finished record played as if it were being written: ``speed`` seconds of record
    per second of wall time, interval after interval (each a new forecast).

    Parameters
    ----------
    path : str or pathlib.Path
        The export.
    speed : float
        Record seconds per wall second (> 0).
    geometry, format
        As :func:`granflow.read_runs` takes them.
    """

    def __init__(self, path, speed=1.0, geometry=None, format=None, now=clock.monotonic):
        from granflow.io.reader import read_runs

        if not speed > 0:
            raise FileFormatError(f"--speed must be positive, got {speed:g}")
        self.source = str(path)
        self.runs = read_runs(path, geometry, format)
        self.speed = float(speed)
        self.now = now
        self._start = None
        self._index = 0  # the run being played
        self._given = 0  # rows of it given
        self._offset = 0.0  # wall seconds taken by the runs before it
        self._announced = False

    def poll(self):
        """The rows whose record time has come."""
        if self._start is None:
            self._start = self.now()
            events = [Notice(self.source, "opened", f"replaying {self.source} at {self.speed:g}x")]
        else:
            events = []
        elapsed = self.now() - self._start
        while self._index < len(self.runs):
            run = self.runs[self._index]
            ordinal = int(run.meta.get("interval", self._index + 1))
            if not self._announced:
                self._announced = True
                events.append(
                    Notice(
                        self.source,
                        "interval",
                        f"interval {ordinal} (test {run.meta.get('test', '')!r}) begins",
                        ordinal,
                    )
                )
                if run.problems:
                    events.append(Notice(self.source, "damaged", "; ".join(run.problems), ordinal))
            start = float(run.t[0]) if len(run.t) else 0.0
            record_now = start + (elapsed - self._offset) * self.speed
            stop = int(np.searchsorted(run.t, record_now, side="right"))
            if stop > self._given:
                part = slice(self._given, stop)
                events.append(
                    Rows(
                        self.source,
                        ordinal,
                        str(run.meta.get("test", "")),
                        run.control,
                        run.t[part],
                        run.slip[part],
                        run.velocity[part],
                        run.force[part],
                        (),
                        dict(run.meta),
                    )
                )
                self._given = stop
            if self._given < len(run.t):
                break
            self._offset += (float(run.t[-1]) - start) / self.speed if len(run.t) else 0.0
            self._index += 1
            self._given = 0
            self._announced = False
        return events

    @property
    def finished(self):
        """Whether the whole record has been played."""
        return self._index >= len(self.runs)

    def wait(self):
        """Wall seconds until the next row is due (for the loop's sleep)."""
        if self.finished or self._start is None:
            return 0.0
        run = self.runs[self._index]
        if self._given >= len(run.t):
            return 0.0
        due = (float(run.t[self._given]) - float(run.t[0])) / self.speed + self._offset
        return max(due - (self.now() - self._start), 0.0)
