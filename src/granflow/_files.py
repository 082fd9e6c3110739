"""Files written atomically: a temporary file beside the target, then a rename."""

import contextlib
import os
import uuid
from pathlib import Path


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
