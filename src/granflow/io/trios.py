"""TA Instruments TRIOS text exports ("Export to LIMS" / text).

Layout: ``Key<TAB>value`` lines for the file (Filename, Instrument name, Sample name, ...),
then one block per step::

    [step]
    Flow Peak Hold - 1            the step name
    Key<TAB>value                 optional step metadata (granflow's writer adds some)
    Step time<TAB>Torque<TAB>...  column names
    s<TAB>µN.m<TAB>...            units (no brackets)
    0.5<TAB>12.3<TAB>...          data rows up to a blank line or the next [step]
"""

from granflow.io import _columns
from granflow.io._file import BlockSpec, parse_blocks, read_with
from granflow.io._text import split

__all__ = ["looks_like_trios", "parse_trios", "read_trios"]


def looks_like_trios(lines):
    """True when the file has TRIOS's "[step]" section lines."""
    return any(line.strip().lower() == "[step]" for line in lines[:5000])


def _is_header(cells):
    known = [_columns.match_quantity(cell)[0] for cell in cells]
    return sum(quantity is not None for quantity in known) >= 2


def _scan(lines, delimiter, source, problems):
    specs, file_metadata = [], {}
    index, count = 0, len(lines)
    step, metadata, steps = None, {}, 0
    while index < count:
        line = lines[index]
        if not line.strip():
            index += 1
            continue
        if line.strip().lower() == "[step]":
            steps += 1
            index += 1
            while index < count and not lines[index].strip():
                index += 1
            step = lines[index].strip() if index < count else f"step {steps}"
            metadata = {}
            index += 1
            continue
        cells = split(line, delimiter)
        if step is not None and _is_header(cells):
            units = lines[index + 1].split(delimiter) if index + 1 < count else []
            start = index + 2
            stop = start
            while stop < count and lines[stop].strip() and lines[stop].strip().lower() != "[step]":
                stop += 1
            specs.append(BlockSpec(step, steps, index + 1, cells, units, [], start, stop, metadata))
            index = stop
            step = None
            continue
        target = metadata if step is not None else file_metadata
        if cells:
            target[cells[0].strip()] = cells[1:]
        index += 1
    return file_metadata, specs


def parse_trios(text, source="<text>", encoding="str"):
    """Parse the text of a TRIOS export into a :class:`granflow.io.ParsedFile`.

    Examples
    --------
    >>> from granflow.io import parse_trios
    >>> text = ("Filename\\tdemo\\n[step]\\nPeak hold - 1\\nStep time\\tTorque\\n"
    ...         "s\\tµN.m\\n1\\t2.5\\n2\\t3.5\\n")
    >>> parse_trios(text).intervals[0].si("torque")
    array([2.5e-06, 3.5e-06])
    """
    return parse_blocks(_scan, "trios", text, source, encoding)


def read_trios(path):
    """Read a TRIOS text export; see :func:`parse_trios`."""
    return read_with(parse_trios, path)
