"""Watching an experiment: the forecast, live, while the rheometer writes its export.

``engine`` (:class:`Watch`: samples in; forecasts, alarms and log records out), ``sources``
(a file or folder followed while written, or a finished record replayed), ``outputs`` (the
JSON-lines log, the ``--on-alarm`` command), ``panel`` (the terminal), ``server`` (the live
page), ``session`` (the loop of ``granflow watch``).
"""

from granflow._lazy import attach

__getattr__, __dir__, __all__ = attach(
    __name__,
    {
        "engine": ["LOG_FIELDS", "TESTS", "Settings", "Stream", "Watch"],
        "sources": ["FollowedPath", "Replay"],
        "outputs": ["AlarmCommand", "Log"],
        "server": ["Server"],
        "session": ["Options", "run"],
    },
)
