"""Files written atomically: a temporary file beside the target, then a rename; and the
check, before any work, that an output can be written at all."""

import contextlib
import errno
import os
import uuid
from pathlib import Path

from granflow.errors import OutputError

_REASONS = {
    errno.EACCES: "permission denied",
    errno.EPERM: "operation not permitted",
    errno.EROFS: "the file system is read-only",
    errno.ENOSPC: "no space left on the device",
    errno.ENOENT: "a folder on the way does not exist",
    errno.ENOTDIR: "a part of the path is a file, not a folder",
    errno.EEXIST: "a file of that name is in the way",
}


def reason(error):
    """The reason an OSError gives, in words ("permission denied")."""
    return _REASONS.get(error.errno) or (error.strerror or str(error)).lower()


def _probe(folder):
    """Make a temporary file in ``folder`` and remove it (OSError when it cannot)."""
    probe = Path(folder) / f".granflow-write-check.{os.getpid()}.{uuid.uuid4().hex}.tmp"
    os.close(os.open(probe, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o666))
    os.unlink(probe)


def writable_folder(folder, what="output folder"):
    """Make ``folder`` (and its parents) and check that a file can be written in it, before
    any work is done: a temporary file is made and removed. Returns the folder.

    Raises
    ------
    granflow.OutputError
        The folder cannot be made or written; the message names it and the reason.
    """
    folder = Path(folder)
    try:
        folder.mkdir(parents=True, exist_ok=True)
        _probe(folder)
    except OSError as exc:
        raise OutputError(f"{folder}: cannot write the {what} ({reason(exc)})") from None
    return folder


def writable_file(path, what="output file"):
    """Check that ``path`` can be written (its folder exists and takes a new file; it is not
    a folder), before any work is done. Returns the path.

    Raises
    ------
    granflow.OutputError
        It cannot; the message names the path and the reason.
    """
    path = Path(path)
    if path.is_dir():
        raise OutputError(f"{path}: cannot write the {what} (it is a folder)")
    try:
        _probe(path.parent)
    except OSError as exc:
        raise OutputError(f"{path}: cannot write the {what} ({reason(exc)})") from None
    return path


def write_atomic(path, write):
    """Call ``write(temporary_path)``, then move the file into place (same folder).

    A reader never sees a half-written file, and an interrupted write leaves the previous
    file (if any) untouched. The temporary file is made with the usual permissions (umask),
    not mkstemp's 0600. Returns ``path`` as a :class:`pathlib.Path`.
    """
    path = Path(path)
    temporary = path.with_name(f".{path.name}.{os.getpid()}.{uuid.uuid4().hex}.tmp")
    os.close(os.open(temporary, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o666))
    try:
        write(temporary)
        os.replace(temporary, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(temporary)
        raise
    return path


def write_text_atomic(path, text):
    """Write ``text`` (UTF-8, ``\\n`` line ends) to ``path`` atomically."""

    def write(temporary):
        with open(temporary, "w", encoding="utf-8", newline="\n") as stream:
            stream.write(text)

    return write_atomic(path, write)
