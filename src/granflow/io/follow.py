"""An export followed while the instrument software writes it: new rows as they arrive, read
with the readers' own parsing (format, column mapping, units, data quality), without reading
the whole file again at each step.

A :class:`Follower` keeps the byte offset it has read to and decodes what was added
(UTF-16 with or without its BOM, UTF-8, cp1252, chunk by chunk: a character split across two
reads waits for its second half). Only complete lines are read; a half-written last line
waits for its end. Two ways to read what arrived:

* **rows appended to the block being written** (the usual case): each new line with the
  block's number of cells is a data row; they are parsed as one small block with the
  readers' row parser (:func:`granflow.io._file.make_interval`: the file's delimiter,
  decimal mark, columns and units; missing, invalid and non-finite cells flagged) and
  turned into SI as :func:`granflow.read_runs` does (torque to force, angle to slip from the
  interval's first angle). The cost is that of the new rows.
* **anything else** (a header, a row the fast path cannot read) after the blank lines that
  close a block: the complete lines so far are parsed as a whole
  (:func:`granflow.io.reader.parse`), and what was not yet given is given. This is how a
  new interval or test is found, and it costs the file's size in time and memory (about
  three times the size of a UTF-16 file's text), once per such change; blank lines alone
  cost nothing.

:meth:`Follower.poll` returns what happened since the last poll, in order: :class:`Rows`
(new samples of one interval, with their data-quality sentences as in ``Run.problems``) and
:class:`Notice` (``"opened"``, ``"interval"``: a new interval or test began, ``"truncated"``,
``"replaced"``: the file shrank or is another file, ``"waiting"``: what is there cannot be
read yet, ``"damaged"``: rows with missing or invalid cells or no time).
"""

from __future__ import annotations

import codecs
import io
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from granflow.errors import FileFormatError
from granflow.io import _buffer, _columns
from granflow.io._file import BlockSpec, make_interval
from granflow.io._runs import interval_to_run, runs_from_file
from granflow.io._text import NumberFormat, split

if TYPE_CHECKING:
    from granflow._typing import PathLike

__all__ = ["Follower", "Notice", "Rows"]

#: Bytes read and parsed at a time: a file that grew by more (a watch started late) is read
#: in such steps, each parsed before the next is read, so memory stays bounded.
READ_CHUNK = 1 << 20
#: Bytes compared at the file's start to tell an appended file from a rewritten one.
_HEAD = 256
_BOMS = (
    (codecs.BOM_UTF8, "utf-8-sig", "utf-8"),
    (codecs.BOM_UTF16_LE, "utf-16", "utf-16-le"),
    (codecs.BOM_UTF16_BE, "utf-16", "utf-16-be"),
)


@dataclass(frozen=True)
class Rows:
    """New samples of one interval, in SI units.

    Attributes
    ----------
    source : str
        The file.
    interval : int
        The interval's ordinal in the file (1-based).
    test : str
        The test it belongs to.
    control : str or None
        "rate" or "stress" where the file's metadata says so, else None.
    t, slip, velocity, force : numpy.ndarray
        Time [s], slip [m] (from the interval's first angle), velocity [m/s] and force [N]
        of the rows (NaN where a cell is missing or damaged; rows without a time dropped).
    problems : tuple of str
        Data-quality sentences about these rows, as in ``Run.problems``.
    metadata : dict
        The interval's metadata (normal load, nominal velocity, ...).
    """

    source: str
    interval: int
    test: str
    control: str | None
    t: np.ndarray
    slip: np.ndarray
    velocity: np.ndarray
    force: np.ndarray
    problems: tuple = ()
    metadata: dict = field(default_factory=dict)


@dataclass(frozen=True)
class Notice:
    """Something about the file itself: ``kind`` ("opened", "interval", "truncated",
    "replaced", "waiting", "damaged"), a sentence, and the interval it is about (0: the
    file)."""

    source: str
    kind: str
    message: str
    interval: int = 0


@dataclass
class _Block:
    """What the fast path needs of the block being written."""

    ordinal: int
    test: str
    number: int
    header_line: int
    columns: tuple
    metadata: dict
    skip_first: bool
    origin: float  # the interval's first finite angle [rad] (nan: none yet)
    control: str | None


def _metadata_control(metadata):
    """The control mode the metadata names, else None."""
    for key in ("control", "profile"):
        value = metadata.get(key)
        if isinstance(value, str):
            mode = _columns.control_from_text(value)
            if mode is not None:
                return mode
    return None


class Follower:
    """Follow one export while it grows.

    Parameters
    ----------
    path : str or pathlib.Path
        The export; never modified. It need not exist yet.
    geometry : granflow.Annulus, optional
        Torque to force, angle to slip; default ``Annulus.paper()``.
    format : {"rheocompass", "rheoplus", "trios", "csv"}, optional
        Skip detection.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "run.csv"
    >>> _ = path.write_text("Time [s],Torque [mN m],Deflection Angle [mrad]\\n0,0.1,1\\n1,0.2")
    >>> follower = Follower(path)
    >>> [event.kind if isinstance(event, Notice) else len(event.t) for event in follower.poll()]
    ['opened', 'interval', 1]
    >>> with path.open("a") as stream:
    ...     _ = stream.write(",2\\n2,0.3,3\\n")
    >>> [len(event.t) for event in follower.poll()]
    [2]
    """

    def __init__(self, path: PathLike, geometry: Any = None, format: str | None = None) -> None:
        from granflow.model.geometry import Annulus

        self.path = Path(path)
        self.source = str(self.path)
        self.geometry = geometry or Annulus.paper()
        self.format = format
        self._reset()

    def _reset(self):
        self._identity = None  # (device, inode) of the file read
        self._head = b""
        self._offset = 0  # bytes read
        self._decoder = None
        self._encoding = None  # (name for the readers, codec of the partial line)
        self._partial = ""  # text after the last line end
        self._undecoded = b""  # the first bytes, before the encoding is told
        self._lines = 0  # complete lines read
        self._pending = []  # complete lines not yet given (the block's rows, or a change)
        self._given = {}  # interval ordinal -> rows given
        self._block = None  # the block being written, when the file ends in its rows
        self._parsed = None  # the last full parse (delimiter, numbers)
        self._said = set()  # sentences already given, so that a full parse repeats none
        self._waiting = None

    @property
    def encoding(self):
        """The file's encoding, once known."""
        return None if self._encoding is None else self._encoding[0]

    def poll(self) -> list:
        """What arrived since the last poll: a list of :class:`Rows` and :class:`Notice`."""
        events = []
        try:
            with self.path.open("rb") as stream:
                status = os.fstat(stream.fileno())
                identity = (status.st_dev, status.st_ino)
                head = stream.read(_HEAD)
                changed = self._identity is not None and identity != self._identity
                rewritten = self._head and not head.startswith(self._head[: len(head)])
                if status.st_size < self._offset:
                    events.append(
                        self._restart(
                            "truncated",
                            f"the file was truncated ({self._offset} -> {status.st_size} bytes)",
                        )
                    )
                elif changed or rewritten:
                    events.append(self._restart("replaced", "the file was replaced"))
                if self._identity is None:
                    self._identity = identity
                    events.append(Notice(self.source, "opened", f"following {self.source}"))
                stream.seek(self._offset)
                while data := stream.read(READ_CHUNK):
                    if len(self._head) < _HEAD:
                        self._head = (self._head + data)[:_HEAD]
                    self._offset += len(data)
                    self._take(data)
                    events += self._read_lines()
        except FileNotFoundError:
            return events
        except OSError as exc:
            raise FileFormatError(f"{self.source}: cannot read the file ({exc.strerror})") from None
        return events

    def _restart(self, kind, message):
        self._reset()
        return Notice(self.source, kind, f"{message}: read again from its start")

    def _take(self, data):
        """Decode new bytes; complete lines go to the pending list. The encoding is told
        from the first line end or the first 64 bytes, whichever comes first (a BOM or
        UTF-16's NULs need a few bytes to be seen)."""
        if self._decoder is None:
            data = self._undecoded + data
            if len(data) < 64 and b"\n" not in data:
                self._undecoded = data
                return
            self._undecoded = b""
            self._start_decoding(data)
        try:
            text = self._decoder.decode(data)
        except UnicodeDecodeError:
            if self._encoding[0] != "utf-8":
                raise FileFormatError(
                    f"{self.source}: not valid {self._encoding[0]} text near byte "
                    f"{self._offset - len(data)}"
                ) from None
            self._encoding = ("cp1252", "cp1252")  # as the readers fall back
            self._decoder = codecs.getincrementaldecoder("cp1252")()
            self._partial, self._pending, self._lines, self._block = "", [], 0, None
            text = self._decoder.decode(self._read_prefix(self._offset))
        text = self._partial + text
        lines = text.split("\n")
        self._partial = lines.pop()
        self._pending += [line[:-1] if line.endswith("\r") else line for line in lines]

    def _start_decoding(self, data):
        for bom, name, codec in _BOMS:
            if data.startswith(bom):
                self._encoding = (name if name != "utf-16" else codec, codec)
                self._decoder = codecs.getincrementaldecoder(name)()
                return
        sample = data[:4096]
        if sample and sample.count(0) > len(sample) // 4:
            codec = "utf-16-be" if sample[0::2].count(0) > sample[1::2].count(0) else "utf-16-le"
        else:
            codec = "utf-8"
        self._encoding = (codec, codec)
        self._decoder = codecs.getincrementaldecoder(codec)()

    def _read_prefix(self, size):
        with self.path.open("rb") as stream:
            return stream.read(size)

    def _complete_bytes(self):
        """Bytes of the file up to the end of its last complete line."""
        if self._decoder is None:
            return 0
        held = len(self._decoder.getstate()[0])
        partial = len(self._partial.encode(self._encoding[1])) if self._partial else 0
        return self._offset - held - partial

    def _read_lines(self):
        """The pending lines as rows of the block being written, or a full parse."""
        events = []
        if not self._pending or self._decoder is None:
            return events
        if self._block is not None:
            count = self._data_rows()
            if count:
                lines, self._pending = self._pending[:count], self._pending[count:]
                first = self._lines + 1
                try:
                    events += self._rows_of(lines, first)
                    self._lines += count
                except FileFormatError:
                    self._pending = lines + self._pending  # the full parse will read them
            if not self._pending:
                return events
        if not any(line.strip() for line in self._pending):
            # blank lines close the block; what follows them (a new interval) is parsed
            # with the whole file, but the blank lines alone are no reason to
            self._lines += len(self._pending)
            self._pending = []
            self._block = None
            return events
        events += self._parse_all()
        return events

    def _data_rows(self):
        """How many of the pending lines lead with the block's data rows."""
        block, parsed = self._block, self._parsed
        cells = len(block.columns) + (1 if block.skip_first else 0)
        count = 0
        for line in self._pending:
            row = split(line, parsed.delimiter)
            if len(row) != cells or (block.skip_first and row[0].strip()) or not line.strip():
                break
            count += 1
        return count

    def _rows_of(self, lines, first):
        """:class:`Rows` of data lines of the block being written (file lines from
        ``first``)."""
        block, parsed = self._block, self._parsed
        buffer = _buffer.from_text("\n".join(lines) + "\n")
        spec = BlockSpec(
            test=block.test,
            number=block.number,
            header_line=block.header_line,
            names=[column.name for column in block.columns],
            units=[],
            meanings=[],
            region=(0, len(buffer.data), first, len(lines)),
            metadata={},
            skip_first=block.skip_first,
        )
        numbers = NumberFormat(parsed.decimal, parsed.thousands)
        interval = make_interval(
            spec, block.columns, buffer, parsed.delimiter, numbers, self.source, block.metadata
        )
        run = interval_to_run(interval, self.geometry, self.source, block.ordinal)
        angle = interval.si("angle")
        slip = run.slip
        if angle is not None and interval.find("slip") is None:
            finite = angle[np.isfinite(angle)]
            if finite.size:
                if not np.isfinite(block.origin):
                    block.origin = float(finite[0])
                slip = slip + (finite[0] - block.origin) * self.geometry.mean_radius
        self._given[block.ordinal] = self._given.get(block.ordinal, 0) + len(run.t)
        return self._emit(block, run.t, slip, run.velocity, run.force, run.problems)

    def _emit(self, block, t, slip, velocity, force, problems):
        events = []
        new = tuple(problem for problem in problems if problem not in self._said)
        self._said.update(new)
        if new:
            events.append(Notice(self.source, "damaged", "; ".join(new), block.ordinal))
        if len(t):
            events.append(
                Rows(
                    self.source,
                    block.ordinal,
                    block.test,
                    block.control,
                    np.asarray(t),
                    np.asarray(slip),
                    np.asarray(velocity),
                    np.asarray(force),
                    new,
                    dict(block.metadata),
                )
            )
        return events

    def _parse_all(self):
        """Parse the complete lines so far as a whole; give what was not given."""
        from granflow.io.reader import parse

        self._lines += len(self._pending)
        self._pending = []
        size = self._complete_bytes()
        try:
            buffer = _buffer.read_stream(io.BytesIO(self._read_prefix(size)), self.source, size)
            if buffer.is_blank():
                return []
            parsed = parse(buffer, self.source, format=self.format, encoding=buffer.encoding)
            runs = runs_from_file(parsed, self.geometry)
        except FileFormatError as exc:
            self._block = None
            if str(exc) == self._waiting:
                return []
            self._waiting = str(exc)
            return [Notice(self.source, "waiting", f"cannot read the file yet: {exc}")]
        self._waiting = None
        self._parsed = parsed
        events = []
        for ordinal, (interval, run) in enumerate(
            zip(parsed.intervals, runs, strict=True), start=1
        ):
            angle = interval.si("angle")
            finite = angle[np.isfinite(angle)] if angle is not None else np.empty(0)
            block = _Block(
                ordinal=ordinal,
                test=interval.test,
                number=interval.number,
                header_line=interval.line,
                columns=interval.columns,
                metadata={k: v for k, v in interval.metadata.items() if k != "declared_points"},
                skip_first=False,
                origin=float(finite[0]) if finite.size else np.nan,
                control=_metadata_control(interval.metadata),
            )
            if ordinal not in self._given:
                self._given[ordinal] = 0
                events.append(
                    Notice(
                        self.source,
                        "interval",
                        f"interval {ordinal} (test {interval.test!r}) begins, "
                        f"{block.control or 'control from the data'}",
                        ordinal,
                    )
                )
            given = self._given[ordinal]
            self._given[ordinal] = len(run.t)
            # a growing file's last block is incomplete: not a problem of the data
            growing = ordinal == len(parsed.intervals)
            problems = [
                p
                for p in run.problems
                if not (growing and ("declares" in p or "no data rows after the header" in p))
            ]
            events += self._emit(
                block,
                run.t[given:],
                run.slip[given:],
                run.velocity[given:],
                run.force[given:],
                problems,
            )
            self._block = block
        self._block = self._writing(self._block)
        return events

    def _writing(self, block):
        """The last block, where the file ends in its data rows (the fast path's block)."""
        if block is None or not self._given.get(block.ordinal):
            return None
        last = self._last_line()
        if last is None:
            return None
        cells = split(last, self._parsed.delimiter)
        width = len(block.columns)
        if len(cells) == width + 1 and not cells[0].strip():
            block.skip_first = True
        elif len(cells) != width:
            return None
        return block

    def _last_line(self):
        """The last complete line of the file (None if it is blank)."""
        size = self._complete_bytes()
        step = 4096 * (4 if self._encoding[1].startswith("utf-16") else 1)
        with self.path.open("rb") as stream:
            stream.seek(max(size - step, 0))
            tail = stream.read(size - max(size - step, 0))
        codec = self._encoding[1]
        if codec.startswith("utf-16") and len(tail) % 2:
            tail = tail[1:]
        text = tail.decode(codec, errors="replace").rstrip("\n").rstrip("\r")
        line = text.rsplit("\n", 1)[-1].rstrip("\r")
        return line if line.strip() else None
