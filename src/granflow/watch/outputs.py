"""What a watch writes and runs: the log (one JSON object a line, flushed line by line, so
that a watch stopped at any moment leaves it whole) and the ``--on-alarm`` command."""

from __future__ import annotations

import datetime
import json
import os
import shlex
import subprocess
from pathlib import Path

from granflow.errors import InvalidParameterError

__all__ = ["AlarmCommand", "Log"]


class Log:
    """A JSON-lines log, appended to (an earlier watch's lines are kept).

    Each record gets ``clock``, the wall time it was written (ISO 8601, UTC). Values are
    written as JSON numbers, ``null`` for unknown or unbounded ones (never NaN).

    Parameters
    ----------
    path : str or pathlib.Path
        The log file (created with its folder if missing).
    """

    def __init__(self, path):
        self.path = Path(path)
        if self.path.is_dir():
            raise InvalidParameterError(f"--log {self.path} is a folder; give a file")
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._stream = self.path.open("a", encoding="utf-8")
        self.lines = 0

    def write(self, record):
        """Write one record as one line, and flush it."""
        entry = dict(record)
        entry["clock"] = datetime.datetime.now(datetime.UTC).isoformat(timespec="milliseconds")
        line = json.dumps(entry, allow_nan=False, separators=(",", ":"))
        self._stream.write(line + "\n")
        self._stream.flush()
        self.lines += 1

    def close(self):
        """Close the file."""
        self._stream.close()


def alarm_environment(record):
    """The environment variables that give the alarm's forecast to ``--on-alarm``: the whole
    record as JSON (``GRANFLOW_FORECAST``) and its main values one by one (SI units; an
    unknown or unbounded value is empty)."""

    def text(value):
        return "" if value is None else repr(value) if isinstance(value, float) else str(value)

    interval = record.get("time_interval") or [None, None]
    force = record.get("force_interval") or [None, None]
    return {
        "GRANFLOW_FORECAST": json.dumps(record, allow_nan=False),
        "GRANFLOW_EVENT": str(record.get("event", "")),
        "GRANFLOW_SOURCE": str(record.get("source", "")),
        "GRANFLOW_INTERVAL": text(record.get("interval")),
        "GRANFLOW_T": text(record.get("t")),
        "GRANFLOW_PROBABILITY": text(record.get("probability_within_horizon")),
        "GRANFLOW_HORIZON": text(record.get("horizon")),
        "GRANFLOW_TIME": text(record.get("time")),
        "GRANFLOW_TIME_LOW": text(interval[0]),
        "GRANFLOW_TIME_HIGH": text(interval[1]),
        "GRANFLOW_FORCE_LOW": text(force[0]),
        "GRANFLOW_FORCE_HIGH": text(force[1]),
    }


class AlarmCommand:
    """A shell command run (not waited for) each time an alarm is raised, with the forecast
    in its environment (:func:`alarm_environment`).

    Parameters
    ----------
    command : str
        The command line, run by the shell.
    say : callable
        ``say(event, message)`` logs what happened (started, or could not start).
    """

    def __init__(self, command, say):
        if not command.strip():
            raise InvalidParameterError("--on-alarm needs a command")
        self.command = command
        self.say = say
        self.children = []

    def __call__(self, record):
        environment = {**os.environ, **alarm_environment(record)}
        try:
            child = subprocess.Popen(self.command, shell=True, env=environment)
        except OSError as exc:
            self.say("on-alarm", f"could not run {shlex.quote(self.command)}: {exc.strerror}")
            return
        self.children.append(child)
        self.say("on-alarm", f"ran {self.command!r} (pid {child.pid})")

    def reap(self):
        """Collect the commands that ended; say which failed."""
        for child in [child for child in self.children if child.poll() is not None]:
            self.children.remove(child)
            if child.returncode:
                self.say("on-alarm", f"the command {self.command!r} exited {child.returncode}")
