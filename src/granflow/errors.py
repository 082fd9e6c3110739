"""The exceptions granflow raises.

Every error derives from :class:`GranflowError` and also from the built-in exception a
user would expect, so ``except ValueError`` and ``except granflow.GranflowError`` both work.
"""

__all__ = [
    "ConvergenceWarning",
    "FileFormatError",
    "FitError",
    "GranflowError",
    "InvalidDataError",
    "InvalidParameterError",
    "InvalidProtocolError",
    "OutputError",
]


class GranflowError(Exception):
    """Root of every error raised by granflow."""


class InvalidParameterError(GranflowError, ValueError):
    """A parameter or argument is out of its domain (negative, NaN, wrong shape, ...)."""


class InvalidProtocolError(GranflowError, ValueError):
    """A protocol or one of its segments is malformed."""


class InvalidDataError(GranflowError, ValueError):
    """Measured or user-supplied data cannot be used (too short, NaN, not increasing, ...)."""


class FileFormatError(GranflowError, ValueError):
    """A file cannot be parsed; the message names the file and, where known, the line."""


class OutputError(GranflowError, OSError):
    """A file or folder granflow was asked to write cannot be written; the message names it
    and the reason."""


class FitError(GranflowError, RuntimeError):
    """A fit cannot be carried out at all (as opposed to a fit that ends unsuccessfully)."""


class ConvergenceWarning(UserWarning):
    """A computation finished but its result may be unreliable (short chains, bounds hit)."""
