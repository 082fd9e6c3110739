"""A file's text as one byte buffer (LF or CRLF line ends), read in bounded memory.

The readers never hold a file's bytes and its decoded text at once: :func:`load` reads the
file in chunks into one buffer of UTF-8 or cp1252 bytes (UTF-16/32 files are transcoded to
UTF-8 chunk by chunk; a file with ``\\r`` line ends gets ``\\n``), so a file of N bytes
costs about N bytes while it is read (N/2 for UTF-16 text). Header lines are decoded one
at a time by a :class:`Cursor`; data blocks are located with compiled regular expressions
and handed as byte ranges to pandas' C parser (:func:`granflow.io._text.read_block`).

Files above a size limit are refused before they are read: ``max_bytes=`` on the readers,
else the ``GRANFLOW_MAX_BYTES`` environment variable, else :data:`MAX_BYTES` (2 GiB).
"""

import codecs
import os
import re
from dataclasses import dataclass
from pathlib import Path

from granflow.errors import FileFormatError

__all__ = ["MAX_BYTES", "Buffer", "Cursor", "encoding_of", "from_text", "load", "size_limit"]

#: Default largest file the readers accept [bytes]: 2 GiB. Override per call with
#: ``max_bytes=`` or for a session with the ``GRANFLOW_MAX_BYTES`` environment variable.
MAX_BYTES = 2 * 2**30
#: Longest header line a reader decodes [bytes]; a longer one is not a text export.
MAX_LINE = 1 << 20
#: Most lines in a row outside data blocks (metadata, blank lines) a reader walks through.
MAX_HEADER_LINES = 10_000
_CHUNK = 1 << 24
_BOMS = (
    (codecs.BOM_UTF32_LE, "utf-32"),
    (codecs.BOM_UTF32_BE, "utf-32"),
    (codecs.BOM_UTF8, "utf-8-sig"),
    (codecs.BOM_UTF16_LE, "utf-16"),
    (codecs.BOM_UTF16_BE, "utf-16"),
)
#: Bytes that cp1252 leaves undefined (a spreadsheet-mangled file may hold them).
_CP1252_UNDEFINED = re.compile(rb"[\x81\x8d\x8f\x90\x9d]")
_CONTENT = re.compile(rb"\S")
_CONTROL = re.compile(r"[\x00-\x08\x0b\x0c\x0e-\x1f\x7f]")


def fail(source, line, message):
    """A FileFormatError that names the file and the line (1-based)."""
    return FileFormatError(f"{source}, line {line}: {message}")


@dataclass(frozen=True, eq=False)
class Buffer:
    """A file's content: ``data`` in ``codec`` ("utf-8" or "cp1252") with LF or CRLF line ends,
    the file's ``encoding`` (what it was written in) and problems found while decoding."""

    data: bytes
    codec: str
    encoding: str
    problems: tuple = ()

    def is_blank(self):
        """True when the buffer holds nothing but white space."""
        return _CONTENT.search(self.data) is None

    def line_number(self, offset):
        """The 1-based line number of byte ``offset``."""
        return self.data.count(b"\n", 0, offset) + 1

    def text(self, start, stop):
        """Bytes ``start:stop`` decoded (undefined cp1252 bytes become U+FFFD)."""
        return self.data[start:stop].decode(self.codec, errors="replace")


def size_limit(max_bytes=None):
    """The size limit in force [bytes]: ``max_bytes``, else ``GRANFLOW_MAX_BYTES``, else
    :data:`MAX_BYTES`."""
    if max_bytes is None:
        max_bytes = os.environ.get("GRANFLOW_MAX_BYTES", MAX_BYTES)
    try:
        limit = int(max_bytes)
    except (TypeError, ValueError):
        raise FileFormatError(
            f"max_bytes must be a whole number of bytes, got {max_bytes!r}"
        ) from None
    if limit <= 0:
        raise FileFormatError(f"max_bytes must be positive, got {limit}")
    return limit


def _mib(size):
    return f"{size / 2**20:.1f} MiB"


def load(path, max_bytes=None):
    """Read a file into a :class:`Buffer`, refusing it first if it is over the size limit.

    Parameters
    ----------
    path : str or pathlib.Path
        The file; never modified.
    max_bytes : int, optional
        Largest accepted file size [bytes]; see :func:`size_limit`.

    Raises
    ------
    granflow.FileFormatError
        The file cannot be read, is too large, is not text, or is not valid in its encoding.
    """
    path = Path(path)
    source = str(path)
    limit = size_limit(max_bytes)
    try:
        size = path.stat().st_size
        if size > limit:
            raise FileFormatError(
                f"{source}: the file is {size} bytes ({_mib(size)}), over the limit of {limit} "
                f"bytes ({_mib(limit)}); pass max_bytes= or set GRANFLOW_MAX_BYTES to read it"
            )
        with path.open("rb") as stream:
            return read_stream(stream, source, size)
    except OSError as exc:
        raise FileFormatError(f"{source}: cannot read the file ({exc.strerror})") from None


def encoding_of(head):
    for bom, name in _BOMS:
        if head.startswith(bom):
            return name
    sample = head[:4096]
    if sample.count(0) > len(sample) // 4:
        return "utf-16-be" if sample[0::2].count(0) > sample[1::2].count(0) else "utf-16-le"
    return None


def read_stream(stream, source, size=None):
    """A :class:`Buffer` from a binary stream (``size``: its length in bytes, if known)."""
    head = stream.read(_CHUNK)
    encoding = encoding_of(head)
    if encoding in (None, "utf-8-sig"):
        data, encoding = _read_bytes(stream, head, encoding, source)
        codec = "cp1252" if encoding == "cp1252" else "utf-8"
    else:
        data = _transcode(stream, head, encoding, source, size)
        codec = "utf-8"
    problems = []
    if codec == "cp1252":
        _refuse_mixed_encodings(data, source)
        undefined = _CP1252_UNDEFINED.search(data)
        if undefined:
            line = data.count(b"\n", 0, undefined.start()) + 1
            problems.append(
                f"line {line}: bytes that are not cp1252 text were replaced by '\ufffd'"
            )
    return Buffer(data, codec, encoding, tuple(problems))


#: A character of two to four bytes in UTF-8: text that was written as UTF-8.
_UTF8_SEQUENCE = re.compile(
    rb"[\xc2-\xdf][\x80-\xbf]|[\xe0-\xef][\x80-\xbf]{2}|[\xf0-\xf4][\x80-\xbf]{3}"
)


def _refuse_mixed_encodings(data, source):
    """A file that is not UTF-8 but holds UTF-8 characters mixes two encodings (a line
    pasted from another file): read as cp1252 its UTF-8 characters would be wrong ('µm'
    becomes 'Âµm'), so it is an error naming the first line that is not UTF-8."""
    utf8 = _UTF8_SEQUENCE.search(data)
    if utf8 is None:
        return
    try:
        bytes(data).decode("utf-8")
    except UnicodeDecodeError as exc:
        bad = exc.start
    else:  # pragma: no cover - only called on data that is not UTF-8
        return
    written = data.count(b"\n", 0, utf8.start()) + 1
    raise fail(
        source,
        data.count(b"\n", 0, bad) + 1,
        f"this line is not UTF-8 text while line {written} is: the file mixes two "
        "encodings; save it in one (UTF-8) and read it again",
    )


def _newlines(chunk, carry, mac):
    """``carry + chunk`` with CRs made LF in a file with CR line ends (``mac``); LF and CRLF
    files are kept as they are (pandas and the patterns read both). A trailing CR is held
    back as the next carry."""
    if not mac:
        return chunk, carry
    if carry:
        chunk = carry + chunk
    carry = chunk[-1:] if chunk[-1:] in (b"\r", "\r") else chunk[:0]
    if carry:
        chunk = chunk[:-1]
    cr, lf = ("\r", "\n") if isinstance(chunk, str) else (b"\r", b"\n")
    return chunk.replace(cr + lf, lf).replace(cr, lf), carry


def _cr_line_ends(head):
    """True when a file's first chunk ends its lines with CR alone (classic Mac OS)."""
    cr, lf = ("\r", "\n") if isinstance(head, str) else (b"\r", b"\n")
    return cr in head and lf not in head


def _refuse_nul(piece, data, used, source, encoding):
    """A NUL in a chunk ends the reading at once (binary data, or the wrong encoding)."""
    nul = piece.find(b"\x00")
    if nul >= 0:
        raise fail(
            source,
            data.count(b"\n", 0, used) + piece.count(b"\n", 0, nul) + 1,
            f"NUL character in {encoding or 'utf-8'} text: the file is binary or has the "
            "wrong encoding",
        )


def _read_bytes(stream, head, encoding, source):
    """UTF-8 (validated chunk by chunk) or, at the first invalid byte, cp1252: kept as bytes."""
    if encoding == "utf-8-sig":
        head = head[len(codecs.BOM_UTF8) :]
    validate = codecs.getincrementaldecoder("utf-8")()
    data, carry = bytearray(), b""
    chunk = head
    mac = _cr_line_ends(head)
    while True:
        final = len(chunk) < _CHUNK
        if encoding != "cp1252":
            try:
                validate.decode(chunk, final)
            except UnicodeDecodeError:
                encoding = "cp1252"
        piece, carry = _newlines(chunk, carry, mac)
        _refuse_nul(piece, data, len(data), source, encoding)
        data += piece
        if final:
            break
        chunk = stream.read(_CHUNK)
    data += b"\n" if carry else b""
    return data, encoding or "utf-8"


def _transcode(stream, head, encoding, source, size):
    """UTF-16/32 bytes to UTF-8, chunk by chunk; an invalid sequence names its line.

    The output is written into one buffer sized for ASCII text (half a UTF-16 file), grown
    only where the text needs more, so no chunk is copied twice."""
    decoder = codecs.getincrementaldecoder(encoding)()
    data = bytearray((size or 0) // (4 if encoding == "utf-32" else 2) + 16)
    used, carry, mac = 0, "", None
    chunk = head
    while True:
        final = len(chunk) < _CHUNK
        try:
            text = decoder.decode(chunk, final)
        except UnicodeDecodeError as exc:
            prefix = exc.object[: exc.start].decode(encoding, errors="replace")
            line = data.count(b"\n", 0, used) + prefix.count("\n") + 1
            raise fail(
                source,
                line,
                f"the file is not valid {encoding} text (byte {exc.start}: {exc.reason})",
            ) from None
        mac = _cr_line_ends(text) if mac is None else mac
        piece, carry = _newlines(text, carry, mac)
        encoded = piece.encode("utf-8", errors="surrogatepass") + (
            b"\n" if final and carry else b""
        )
        _refuse_nul(encoded, data, used, source, encoding)
        if used + len(encoded) > len(data):
            data.extend(bytes(used + len(encoded) - len(data)))
        data[used : used + len(encoded)] = encoded
        used += len(encoded)
        if final:
            break
        chunk = stream.read(_CHUNK)
    del data[used:]
    return data


def from_text(text, encoding="str"):
    """A :class:`Buffer` from decoded text (the ``parse_<format>(text)`` entry points)."""
    if isinstance(text, Buffer):
        return text
    if not isinstance(text, str):
        raise FileFormatError(f"expected the decoded text of a file (str), got {type(text)}")
    data = text.replace("\r\n", "\n").replace("\r", "\n").encode("utf-8", errors="replace")
    return Buffer(data, "utf-8", encoding)


class Cursor:
    """Walks a buffer line by line; :meth:`block` jumps over a data block in one search.

    ``number`` is the 1-based line number of the line at ``pos``. More than
    :data:`MAX_HEADER_LINES` lines in a row outside data blocks is an error that says what
    was expected (``expect``): a header followed by junk is refused, not collected.
    """

    def __init__(self, buffer, source, expect):
        self.buffer = buffer
        self.data = buffer.data
        self.source = source
        self.expect = expect
        self.pos = 0
        self.number = 1
        self._since_block = 0

    def done(self):
        """True at the end of the buffer."""
        return self.pos >= len(self.data)

    def _end(self):
        end = self.data.find(b"\n", self.pos, self.pos + MAX_LINE + 1)
        if end < 0:
            end = len(self.data)
            if end - self.pos > MAX_LINE:
                raise fail(
                    self.source,
                    self.number,
                    f"a line longer than {MAX_LINE} bytes where a header line was expected: "
                    "this is not a text export",
                )
        return end

    def peek(self):
        """The current line, decoded, without its line end ("" at the end)."""
        if self.done():
            return ""
        line = self.buffer.text(self.pos, self._end())
        line = line[:-1] if line.endswith("\r") else line
        control = _CONTROL.search(line)
        if control:
            raise fail(
                self.source,
                self.number,
                f"control character {control.group()!r} where a header line was expected: "
                "binary data or the wrong encoding",
            )
        return line

    def lookahead(self, count):
        """The next ``count`` lines from here (decoded, fewer at the end); the cursor stays."""
        pos, number, since = self.pos, self.number, self._since_block
        try:
            return [self.next() for _ in range(count) if not self.done()]
        finally:
            self.pos, self.number, self._since_block = pos, number, since

    def advance(self):
        """Move to the next line."""
        if not self.done():
            self.pos = self._end() + 1
            self.number += 1
            self._since_block += 1
            if self._since_block > MAX_HEADER_LINES:
                raise fail(
                    self.source,
                    self.number,
                    f"{MAX_HEADER_LINES} lines without a data block; expected {self.expect}",
                )

    def next(self):
        """The current line (see :meth:`peek`), then move past it."""
        line = self.peek()
        self.advance()
        return line

    def block(self, end):
        """Jump over the data rows from here: ``end`` is a compiled bytes pattern that
        matches the ``\\n`` before the first line that is not a data row.

        Returns
        -------
        tuple
            ``(start, stop, first_line, rows)``: byte range of the rows, the file line
            number of the first row, and the number of rows.
        """
        start, first_line = self.pos, self.number
        if self.done() or start == 0:  # a data block always follows its header line
            return start, start, first_line, 0
        match = end.search(self.data, start - 1)
        stop = len(self.data) if match is None else match.start() + 1
        rows = self.data.count(b"\n", start, stop)
        if stop == len(self.data) and stop > start and self.data[-1:] != b"\n":
            rows += 1
        self.pos, self.number, self._since_block = stop, first_line + rows, 0
        return start, stop, first_line, rows
