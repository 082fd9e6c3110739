"""A campaign manifest, read strictly and within bounds.

A manifest (YAML or CSV) lists the export files of a campaign with their metadata. It is
input a person types, so it is checked at the door:

* a manifest larger than :data:`MAX_MANIFEST_BYTES` is refused before it is read;
* YAML anchors and aliases are refused where they appear, before anything is expanded (an
  alias "bomb" costs nothing), so a manifest is never larger in memory than on disk;
* a key that is not a manifest field is an error, at the top level (only ``defaults`` and
  ``runs``), in ``defaults`` and in an entry;
* a physical quantity needs its unit (``normal_load: 20`` is refused: "20 mN" or "0.02 N"),
  must be finite, and positive (``normal_load``, ``velocity``) or not negative
  (``rest_time``, ``switch_time``); ``interval`` is a positive integer; ``geometry`` is
  what :meth:`granflow.Annulus.from_spec` reads.

What is wrong with the manifest as a whole (its size, its YAML, a top-level key, ``defaults``)
raises a :class:`granflow.FileFormatError`; what is wrong with one entry is that entry's
error (a :class:`BadEntry` with ``errors="collect"``), and the other entries stand. Every
message is one line naming the manifest and the entry.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from granflow.errors import FileFormatError, GranflowError, InvalidParameterError
from granflow.families import record_families

if TYPE_CHECKING:
    from granflow._typing import PathLike

__all__ = [
    "MANIFEST_FIELDS",
    "MAX_MANIFEST_BYTES",
    "RECORD_KINDS",
    "RSF_LAWS",
    "RUN_KINDS",
    "TEST_KINDS",
    "BadEntry",
    "read_manifest",
]

#: Manifest fields: file (required), interval (default: all), normal_load ("50 mN"), velocity
#: ("0.86 um/s"), rest_time ("5 min"), preparation (the run's own preparation, a label),
#: preparation_state (the protocol it was prepared by: runs at one load and velocity with the
#: same preparation_state are repeats of one preparation state, whose spread of x0 the
#: analysis reports; without it, runs with the same preparation label are the repeats),
#: sample, notes, test (one of :data:`TEST_KINDS`; inferred from the data when absent),
#: switch_time ("60 s"; for a switch test: when the force was imposed), geometry (the tube,
#: see :meth:`granflow.Annulus.from_spec`; default the paper's), law (for a ``velocity_steps``
#: record: the rate-and-state law of its fit shown, one of :data:`RSF_LAWS`; default aging),
#: periodic (for a ``velocity_steps`` record: fit an apparatus ripple periodic in load-point
#: displacement, ``true`` to find its wavelength or the wavelength itself, "87 um"; default
#: none; see :func:`granflow.rsf.fit`).
MANIFEST_FIELDS = (
    "file",
    "interval",
    "normal_load",
    "velocity",
    "rest_time",
    "preparation",
    "preparation_state",
    "sample",
    "notes",
    "test",
    "switch_time",
    "geometry",
    "law",
    "periodic",
)
#: What a run is: a rate-controlled start-up (Fig. 2), a stress ramp (Fig. 3a), creep under a
#: constant stress (Fig. 3b), or a switch from rate to stress control (Fig. 3c).
RUN_KINDS = ("startup", "ramp", "creep", "switch")
#: The records of the model families (:func:`granflow.families.record_families`), analysed
#: by their family apart from the runs: ``velocity_steps`` is a rate-and-state velocity-step
#: record (time, displacement, friction; :func:`granflow.io.read_velocity_steps`).
RECORD_KINDS = tuple(str(family.test_kind) for family in record_families())
#: Every ``test`` a manifest entry may name.
TEST_KINDS = RUN_KINDS + RECORD_KINDS
#: The rate-and-state laws a ``velocity_steps`` entry may name.
RSF_LAWS = ("aging", "slip")
#: The largest manifest read [bytes] (1 MiB: tens of thousands of entries).
MAX_MANIFEST_BYTES = 1 << 20
#: The deepest nesting of YAML collections a manifest may have (it needs four: the
#: document, its runs, an entry, an entry's geometry); deeper is refused before it is built.
MAX_DEPTH = 16
#: Physical quantities: True where the value must be positive, False where it may be zero.
_QUANTITIES = {"normal_load": True, "velocity": True, "rest_time": False, "switch_time": False}
#: The largest value of each quantity a laboratory record may have [SI]: a press of 10 MN,
#: a sliding velocity of 1 km/s, times of 30 years. Beyond is a wrong unit, and the joint
#: analyses would divide forces by it into numbers float64 cannot hold.
LARGEST = {"normal_load": 1e7, "velocity": 1e3, "rest_time": 1e9, "switch_time": 1e9}
_TOP_LEVEL = ("defaults", "runs")


@dataclass(frozen=True)
class BadEntry:
    """A manifest entry that cannot be used, kept in its place with its own label.

    Attributes
    ----------
    where : str
        ``"entry 3"`` (YAML) or ``"line 4"`` (CSV).
    file : str or None
        The entry's file, where it names one.
    interval : int or None
        The entry's interval, where it gives a valid one.
    reason : str
        One line naming the manifest, the entry and what is wrong.
    """

    where: str
    file: str | None
    interval: int | None
    reason: str

    @property
    def label(self):
        """``file#interval``, ``file`` or the entry's place in the manifest."""
        if self.file is None:
            return f"manifest {self.where}"
        return self.file if self.interval is None else f"{self.file}#{self.interval}"


@dataclass(frozen=True)
class _Refused:
    """What the loader puts where a YAML anchor or alias was: ``&name`` or ``*name``."""

    text: str


class _Located(dict):
    """A YAML mapping that knows its line in the manifest (``line``, 1-based) and the line
    of each of its keys (``key_lines``)."""

    line = 0
    key_lines: dict = {}  # noqa: RUF012 - replaced per instance

    def line_of(self, key):
        """The line of ``key``, else of the mapping."""
        return self.key_lines.get(key, self.line)


class _RefusedError(Exception):
    """A manifest the loader refuses as a whole: ``lines`` and the reason."""

    def __init__(self, lines, reason):
        super().__init__(reason)
        self.lines = lines
        self.reason = reason


def _strict_loader():
    """A ``yaml.SafeLoader`` that replaces every anchored node and every alias by a
    :class:`_Refused` marker while composing, so nothing is ever expanded."""
    import yaml

    class StrictLoader(yaml.SafeLoader):
        depth = 0

        def compose_node(self, parent, index):
            event = self.peek_event()
            self.depth += 1
            try:
                if self.depth > MAX_DEPTH:
                    raise _RefusedError(
                        (event.start_mark.line + 1,),
                        f"collections nested more than {MAX_DEPTH} deep (a manifest needs four "
                        "levels: runs, an entry, its values)",
                    )
                if isinstance(event, yaml.AliasEvent):
                    self.get_event()
                    return self._refused(f"*{event.anchor}", event)
                if getattr(event, "anchor", None) is not None:
                    anchor = event.anchor
                    event.anchor = None
                    super().compose_node(parent, index)
                    return self._refused(f"&{anchor}", event)
                return super().compose_node(parent, index)
            finally:
                self.depth -= 1

        def construct_mapping(self, node, deep=False):
            # a key given twice: YAML keeps the last one silently, a manifest refuses it
            if isinstance(node, yaml.MappingNode):
                self.flatten_mapping(node)
                seen = {}
                for key, _ in node.value:
                    if not isinstance(key, yaml.ScalarNode):
                        continue
                    line = key.start_mark.line + 1
                    if key.value in seen:
                        raise _RefusedError(
                            (seen[key.value], line),
                            f"the key {key.value[:40]!r} is given twice in one mapping "
                            "(YAML would keep the last silently)",
                        )
                    seen[key.value] = line
            return super().construct_mapping(node, deep=deep)

        def construct_located_mapping(self, node):
            data = _Located()
            data.line = node.start_mark.line + 1
            yield data
            data.update(self.construct_mapping(node))
            data.key_lines = {
                key.value: key.start_mark.line + 1
                for key, _ in node.value
                if isinstance(key, yaml.ScalarNode)
            }

        @staticmethod
        def _refused(text, event):
            return yaml.ScalarNode("!granflow-refused", text, event.start_mark, event.end_mark)

        def flatten_mapping(self, node):
            # a merge key ("<<: *defaults") on a refused alias stays an ordinary key, so that
            # the entry reports the alias rather than YAML a bad merge
            for key, value in node.value:
                if key.tag == "tag:yaml.org,2002:merge" and value.tag == "!granflow-refused":
                    key.tag = "tag:yaml.org,2002:str"
            super().flatten_mapping(node)

    StrictLoader.add_constructor(
        "!granflow-refused", lambda loader, node: _Refused(loader.construct_scalar(node))
    )
    StrictLoader.add_constructor("tag:yaml.org,2002:map", StrictLoader.construct_located_mapping)
    return StrictLoader


def _read_text(path):
    """The manifest's text, refused unread above :data:`MAX_MANIFEST_BYTES`."""
    try:
        size = path.stat().st_size
        if size > MAX_MANIFEST_BYTES:
            raise FileFormatError(
                f"{path}: the manifest is {size} bytes, more than the limit of "
                f"{MAX_MANIFEST_BYTES} bytes (granflow.io.manifest.MAX_MANIFEST_BYTES)"
            )
        with path.open("rb") as stream:
            data = stream.read(MAX_MANIFEST_BYTES + 1)
        if len(data) > MAX_MANIFEST_BYTES:
            raise FileFormatError(
                f"{path}: the manifest is larger than the limit of {MAX_MANIFEST_BYTES} bytes"
            )
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        line = data.count(b"\n", 0, exc.start) + 1
        raise FileFormatError(
            f"{path}, line {line}: the manifest is not UTF-8 text (save it as UTF-8)"
        ) from None
    except OSError as exc:
        raise FileFormatError(f"{path}: cannot read the manifest ({exc.strerror})") from None


def _load_yaml(text, path):
    import yaml

    try:
        return yaml.load(text, Loader=_strict_loader())
    except _RefusedError as exc:
        lines = " and ".join(str(line) for line in exc.lines)
        where = f"line{'s' if len(exc.lines) > 1 else ''} {lines}"
        raise FileFormatError(f"{path}, {where}: {exc.reason}") from None
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f", line {mark.line + 1}" if mark is not None else ""
        problem = getattr(exc, "problem", None) or str(exc).splitlines()[0]
        raise FileFormatError(f"{path}{where}: not valid YAML ({problem})") from None


def _refused_in(value):
    """The first anchor or alias inside ``value`` (None when there is none)."""
    if isinstance(value, _Refused):
        return value
    if isinstance(value, dict):
        for key, item in value.items():
            found = _refused_in(key) or _refused_in(item)
            if found:
                return found
    if isinstance(value, list):
        for item in value:
            found = _refused_in(item)
            if found:
                return found
    return None


def _absent(value):
    return value is None or (isinstance(value, str) and not value.strip())


def _quantity(key, value):
    """A physical quantity [SI] from a string with its unit."""
    from granflow.model.units import display_unit, parse_quantity, si_unit

    if isinstance(value, bool) or not isinstance(value, str | int | float):
        raise InvalidParameterError(f"{key} must be a quantity with a unit, got {value!r}")
    if isinstance(value, float) and not math.isfinite(value):
        raise InvalidParameterError(f"{key} must be finite, got {value!r}")
    try:
        float(str(value).strip())
    except ValueError:
        pass
    else:
        raise InvalidParameterError(
            f"{key} {value!r} has no unit; write it with one, e.g. '{value} {display_unit(key)}'"
        )
    number = parse_quantity(value, si_unit(key), key)
    if number < 0 or (number == 0 and _QUANTITIES[key]):
        sign = "positive" if _QUANTITIES[key] else "zero or positive"
        raise InvalidParameterError(f"{key} must be {sign}, got {value!r}")
    if number > LARGEST[key]:
        raise InvalidParameterError(
            f"{key} {str(value)[:40]!r} is beyond any laboratory record (at most "
            f"{LARGEST[key]:g} {si_unit(key)}): is the unit right?"
        )
    return number


def _interval(value):
    if isinstance(value, str) and value.strip().isdigit():
        value = int(value.strip())
    if isinstance(value, bool) or not isinstance(value, int) or value < 1:
        raise InvalidParameterError(f"interval must be a positive integer, got {value!r}")
    return value


def _periodic(value):
    """The ``periodic`` field: True, False (also for none, the default), or a wavelength [m]
    from text with its unit."""
    if value is None:
        return False
    if isinstance(value, bool):
        return value
    text = str(value).strip().lower()
    if text in ("true", "yes", "on"):
        return True
    if text in ("false", "no", "off", "none", "null", "~"):
        return False
    from granflow.model.units import parse_quantity

    try:
        float(text)
    except ValueError:
        pass
    else:
        raise InvalidParameterError(
            f"periodic {value!r} has no unit; write true, false or a wavelength, e.g. '87 um'"
        )
    number = parse_quantity(str(value), "m", "periodic")
    if not number > 0:
        raise InvalidParameterError(f"periodic must be a positive wavelength, got {value!r}")
    return number


def _field(key, value):
    """One manifest value, checked and converted (quantities to SI)."""
    if key == "periodic":
        return _periodic(value)
    if key in _QUANTITIES:
        return _quantity(key, value)
    if key == "interval":
        return _interval(value)
    if key == "geometry":
        from granflow.model.geometry import Annulus

        Annulus.from_spec(value)  # checked now; kept as written (the reader converts)
        return value if isinstance(value, str) else {str(k): v for k, v in value.items()}
    if not isinstance(value, str | int | float) or isinstance(value, bool):
        raise InvalidParameterError(f"{key} must be a single value, got {value!r}")
    if key == "test":
        value = str(value).strip().lower()
        if value not in TEST_KINDS:
            raise InvalidParameterError(
                f"test must be one of {', '.join(TEST_KINDS)}, got {value!r}"
            )
    if key == "law":
        value = str(value).strip().lower()
        if value not in RSF_LAWS:
            raise InvalidParameterError(f"law must be one of {', '.join(RSF_LAWS)}, got {value!r}")
    return str(value)


def _short(value):
    """``repr(value)``, cut to 60 characters: a message quotes the manifest, not pages of it."""
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def _fields(raw, where, manifest):
    """The checked fields of a mapping (an entry or the defaults); raises on the first error."""
    refused = _refused_in(raw)
    if refused is not None:
        raise FileFormatError(
            f"{manifest}, {where}: YAML anchors and aliases are not allowed (found {refused.text})"
        )
    if not isinstance(raw, dict):
        raise FileFormatError(f"{manifest}, {where}: expected a mapping, got {_short(raw)}")
    entry = {}
    for key, value in raw.items():
        key = str(key).strip()
        if key not in MANIFEST_FIELDS:
            raise FileFormatError(
                f"{manifest}, {where}: unknown field {key!r}; known: {', '.join(MANIFEST_FIELDS)}"
            )
        if _absent(value):
            continue
        try:
            entry[key] = _field(key, value)
        except GranflowError as exc:
            raise FileFormatError(f"{manifest}, {where}: {exc}") from None
    return entry


def _entry(raw, defaults, where, manifest):
    """A checked entry (defaults first), or a :class:`BadEntry`."""
    try:
        entry = {**defaults, **_fields(raw, where, manifest)}
        if "file" not in entry:
            raise FileFormatError(f"{manifest}, {where}: the entry has no 'file'")
        return entry
    except FileFormatError as exc:
        return _bad(raw, defaults, where, str(exc))


def _bad(raw, defaults, where, reason):
    """The :class:`BadEntry` of ``raw``, labelled with whatever of it can be read."""
    raw = raw if isinstance(raw, dict) else {}
    file = raw.get("file", defaults.get("file"))
    file = file.strip() if isinstance(file, str) and file.strip() else None
    try:
        interval = _interval(raw["interval"]) if "interval" in raw else defaults.get("interval")
    except InvalidParameterError:
        interval = None
    return BadEntry(where=where, file=file, interval=interval, reason=reason)


def _yaml_entries(text, path):
    document = _load_yaml(text, path)
    defaults = {}
    where = f"{path}, line 1"
    if isinstance(document, dict):
        for key in document:
            if isinstance(key, _Refused) or key not in _TOP_LEVEL:
                shown = str(getattr(key, "text", key))[:40]
                line = document.line_of(str(getattr(key, "text", key)))
                raise FileFormatError(
                    f"{path}, line {line}: unknown top-level key {shown!r}; a manifest "
                    "has 'runs' (a list of entries) and optional 'defaults'"
                )
        if not _absent(document.get("defaults")):
            place = f"defaults (line {document.line_of('defaults')})"
            defaults = _fields(document["defaults"], place, path)
        where = f"{path}, line {document.line_of('runs')}"
        document = document.get("runs")
    if isinstance(document, _Refused):
        raise FileFormatError(
            f"{where}: YAML anchors and aliases are not allowed (found {document.text})"
        )
    if not isinstance(document, list):
        raise FileFormatError(f"{where}: expected a list of runs (or 'runs:' with a list)")
    located = []
    for i, raw in enumerate(document, start=1):
        line = getattr(raw, "line", None)
        located.append((_entry(raw, defaults, _where(f"entry {i}", line), path), line))
    return located


def _csv_entries(text, path):
    import csv

    reader = csv.DictReader(text.splitlines())
    unknown = [name for name in reader.fieldnames or () if name.strip() not in MANIFEST_FIELDS]
    if unknown:
        raise FileFormatError(
            f"{path}, line 1: unknown column {unknown[0]!r}; known: {', '.join(MANIFEST_FIELDS)}"
        )
    entries = []
    for line, row in enumerate(reader, start=2):
        if None in row:
            bad = _bad(row, {}, f"line {line}", f"{path}, line {line}: more cells than columns")
            entries.append((bad, line))
        else:
            entries.append((_entry(row, {}, f"line {line}", path), line))
    return entries


def _where(where, line):
    """ "entry 3 (line 9)" (YAML) or "line 9" (CSV)."""
    return where if line is None or where.startswith("line") else f"{where} (line {line})"


def _checked_files(located, path, allow_outside):
    """The entries with each file checked: inside the manifest's folder (unless
    ``allow_outside``) and named by one entry only. An entry that breaks either rule is a
    :class:`BadEntry` naming its file, its line and, for a repeat, the line it repeats."""
    root = os.path.realpath(path.parent)
    claimed = {}  # real path -> (where the whole file was named, {interval: where})
    checked = []
    for position, (entry, line) in enumerate(located, start=1):
        if isinstance(entry, BadEntry):
            checked.append(entry)
            continue
        yaml_entry = path.suffix.lower() in (".yaml", ".yml")
        where = _where(f"entry {position}", line) if yaml_entry else f"line {line}"
        target = os.path.realpath(path.parent / str(entry["file"]))
        if not allow_outside and os.path.commonpath([root, target]) != root:
            checked.append(
                _bad(
                    entry,
                    {},
                    where,
                    f"{path}, {where}: the file {str(entry['file'])[:200]!r} is outside the "
                    f"campaign folder {path.parent} (granflow reads the files inside it only; "
                    "--allow-outside, or allow_outside=True, reads it anyway)",
                )
            )
            continue
        interval = entry.get("interval")
        whole, intervals = claimed.setdefault(target, (None, {}))
        if interval is None:
            earlier = whole or next(iter(intervals.values()), None)
        else:
            earlier = whole or intervals.get(interval)
        if earlier is not None:
            what = "the file" if interval is None else f"interval {interval} of the file"
            checked.append(
                _bad(
                    entry,
                    {},
                    where,
                    f"{path}, {where}: {what} {str(entry['file'])[:200]!r} is already named by "
                    f"{earlier}; a run is analysed once (remove one of the two)",
                )
            )
            continue
        if interval is None:
            claimed[target] = (where, intervals)
        else:
            intervals[interval] = where
        checked.append(entry)
    return checked


def read_manifest(path: PathLike, errors: str = "raise", *, allow_outside: bool = False) -> Any:
    """Read a manifest into a list of checked entries (see the module's rules).

    Parameters
    ----------
    path : str or pathlib.Path
        YAML (a list of entries, or ``runs:`` with optional ``defaults:``) or CSV (a header
        row of :data:`MANIFEST_FIELDS`).
    errors : {"raise", "collect"}
        "raise" (default): the first bad entry raises; "collect": a bad entry is a
        :class:`BadEntry` in its place.
    allow_outside : bool
        Read files outside the manifest's folder too (a path with ``..``, an absolute path,
        a symbolic link that leads out). Default False: such an entry is a bad entry, so
        that a manifest someone else wrote reads nothing but the campaign's files.

    Returns
    -------
    list of dict (and BadEntry with ``errors="collect"``)
        Each entry's fields, quantities in SI units, in manifest order.

    Raises
    ------
    granflow.FileFormatError
        A manifest too large, not readable, not valid YAML, with an unknown top-level key or
        column or a bad ``defaults``; with ``errors="raise"``, a bad entry.
    """
    if errors not in ("raise", "collect"):
        raise InvalidParameterError(f"errors must be 'raise' or 'collect', got {errors!r}")
    path = Path(path)
    text = _read_text(path)
    if path.suffix.lower() in (".yaml", ".yml"):
        located = _yaml_entries(text, path)
    else:
        located = _csv_entries(text, path)
    if not located:
        raise FileFormatError(f"{path}, line 1: the manifest lists no runs")
    entries = _checked_files(located, path, allow_outside)
    if errors == "raise":
        bad = next((entry for entry in entries if isinstance(entry, BadEntry)), None)
        if bad is not None:
            raise FileFormatError(bad.reason)
    return entries
