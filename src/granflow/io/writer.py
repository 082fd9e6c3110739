"""Simulated runs to instrument-style exports: RheoCompass-style and TRIOS-style text files.

For the demo (simulated campaigns written as the files a rheometer would give) and for
tests of the readers on formats the real example files lack: French, German, Spanish and
Italian labels, decimal commas, other encodings and units, TRIOS. The files carry the run's
metadata (sample, preparation, normal load, rest time, nominal velocity, control mode) in
header lines that the readers map back, so a written run reads back with the same values
and metadata.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from granflow.errors import InvalidParameterError
from granflow.io import _columns
from granflow.model.run import Run

if TYPE_CHECKING:
    from granflow._typing import PathLike
    from granflow.model.run import Run

__all__ = ["ENCODINGS", "write_rheocompass", "write_trios"]

#: Encodings the writer offers; UTF-16 ones start with a BOM, as RheoCompass writes them.
ENCODINGS = ("utf-16", "utf-16-le", "utf-16-be", "utf-8", "utf-8-sig", "cp1252")
_BOM16 = {"utf-16-le": b"\xff\xfe", "utf-16-be": b"\xfe\xff"}
_DEFAULT_UNITS = {
    "rheocompass": {"time": "s", "torque": "mN·m", "speed": "1/min", "angle": "mrad"},
    "trios": {"time": "s", "torque": "µN.m", "speed": "rad/s", "angle": "rad"},
}
_META_ORDER = ("sample", "preparation", "normal_load", "rest_time", "velocity")


def _check_choice(value, choices, name):
    if value not in choices:
        raise InvalidParameterError(f"{name} must be one of {', '.join(choices)}, got {value!r}")
    return value


def _units(units, form):
    chosen = dict(_DEFAULT_UNITS[form])
    for quantity, unit in dict(units or {}).items():
        _check_choice(quantity, tuple(chosen), "units key")
        _columns.si_factor(quantity, unit)  # raises on an unknown unit
        chosen[quantity] = unit
    return chosen


def _runs(runs: Run | Sequence[Run]) -> list[Run]:
    runs = [runs] if isinstance(runs, Run) else list(runs)
    if not runs:
        raise InvalidParameterError("runs must hold at least one Run")
    for index, run in enumerate(runs):
        if not isinstance(run, Run):
            raise InvalidParameterError(f"runs[{index}] must be a granflow.Run, got {run!r}")
    return runs


class _Numbers:
    """Formats floats with ``digits`` significant digits and the chosen decimal mark."""

    def __init__(self, decimal, digits, missing):
        self.decimal = _check_choice(decimal, (".", ","), "decimal")
        if not isinstance(digits, int) or not 3 <= digits <= 17:
            raise InvalidParameterError(f"digits must be an integer in 3..17, got {digits!r}")
        self.pattern = f"{{:.{digits}g}}"
        self.missing = _check_choice(missing, ("", " ", "******"), "missing")

    def one(self, value, pattern=None):
        if value is None or not math.isfinite(value):
            return self.missing
        text = repr(float(value)) if pattern == "repr" else self.pattern.format(float(value))
        return text.replace(".", ",") if self.decimal == "," else text

    def column(self, values):
        return [self.one(value) for value in np.asarray(values, dtype=float).tolist()]


def _columns_of(run, geometry, units):
    """The run's columns in the chosen units (time, speed, torque, angle)."""
    factor = {quantity: _columns.si_factor(quantity, unit) for quantity, unit in units.items()}
    two_pi_r = 2.0 * math.pi * geometry.mean_radius
    return {
        "time": run.t / factor["time"],
        "speed": run.velocity / two_pi_r / factor["speed"],
        "torque": run.force * geometry.effective_radius / factor["torque"],
        "angle": run.slip / geometry.mean_radius / factor["angle"],
    }


def _metadata_lines(run, language, numbers, delimiter):
    lines = []
    for key in _META_ORDER:
        value = run.meta.get(key)
        if value is None:
            continue
        labels, unit = _columns.METADATA[key]
        label = labels[language]
        if unit is None:
            lines.append(f"{label}:{delimiter}{value}")
        else:
            number = numbers.one(float(value), "repr")
            lines.append(f"{label} [{unit}]:{delimiter}{number}")
    control_label = _columns.METADATA["control"][0][language]
    control = _columns.CONTROL_LABELS[language][run.control]
    lines.append(f"{control_label}:{delimiter}{control}")
    return lines


def _save(path, lines, encoding):
    _check_choice(encoding, ENCODINGS, "encoding")
    text = "\r\n".join(lines) + "\r\n"
    path = Path(path)
    try:
        if encoding in _BOM16:
            data = _BOM16[encoding] + text.encode(encoding)
        else:
            data = text.encode(encoding)
    except UnicodeEncodeError as exc:
        raise InvalidParameterError(
            f"encoding {encoding} cannot write {exc.object[exc.start : exc.end]!r}: "
            "choose a UTF encoding"
        ) from None
    path.write_bytes(data)
    return path


def write_rheocompass(
    path: PathLike,
    runs: Run | Sequence[Run],
    *,
    geometry: Any = None,
    language: str = "en",
    encoding: str = "utf-16",
    decimal: str = ".",
    units: Mapping[str, str] | None = None,
    digits: int = 10,
    missing: str = "",
    project: str = "granflow simulation",
    test: str = "simulated start-up",
) -> Path:
    """Write runs as one RheoCompass-style export, one interval per run.

    Parameters
    ----------
    path : str or pathlib.Path
        The file to write (overwritten).
    runs : granflow.Run or sequence of Run
        The runs; each becomes an interval of one test.
    geometry : granflow.Annulus, optional
        Converts force -> torque, slip -> deflection angle and velocity -> rotational speed;
        default ``Annulus.paper()``. Read back with the same geometry.
    language : {"en", "fr", "de", "es", "it"}
        Labels of the columns and header lines (the first spelling of each language in
        :mod:`granflow.io._columns`).
    encoding : {"utf-16", "utf-16-le", "utf-16-be", "utf-8", "utf-8-sig", "cp1252"}
        UTF-16 files start with a BOM, as RheoCompass writes them.
    decimal : {".", ","}
        Decimal mark (the delimiter is a tab, so a comma is safe).
    units : mapping, optional
        Units per quantity: ``{"time": "s"|"min", "torque": "µN·m"|"mN·m"|"N m"|...,
        "speed": "1/min"|"1/s"|"rad/s", "angle": "mrad"|"rad"|"°"}``; defaults s, mN·m,
        1/min, mrad.
    digits : int
        Significant digits of the data (3..17); 10 by default.
    missing : {"", " ", "******"}
        What NaN values are written as.
    project, test : str
        Names in the Project: and Test: lines.

    Returns
    -------
    pathlib.Path
        The written file.

    Examples
    --------
    >>> import numpy as np, tempfile, pathlib, granflow
    >>> from granflow.io import write_rheocompass
    >>> t = np.linspace(1.0, 60.0, 60)
    >>> params = granflow.Params.from_time_domain(a=3.31e-3, k=0.036, t0=0.23, Fd=10e-3,
    ...                                           velocity=0.86e-6)
    >>> run = granflow.Run(t=t, slip=0.86e-6 * (t - 1.0), velocity=np.full(60, 0.86e-6),
    ...                    force=granflow.friction_time(t, params, 0.86e-6),
    ...                    meta={"normal_load": 0.05, "sample": "PMMA 40 um"})
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "startup.csv"
    >>> _ = write_rheocompass(path, [run], language="fr", decimal=",",
    ...                       units={"torque": "µN·m", "angle": "mrad"})
    >>> back = granflow.read_runs(path)[0]
    >>> bool(np.allclose(back.force, run.force, rtol=1e-9)), back.meta["normal_load"]
    (True, 0.05)
    """
    from granflow.model.geometry import Annulus

    runs = _runs(runs)
    geometry = geometry or Annulus.paper()
    _check_choice(language, _columns.LANGUAGES, "language")
    units = _units(units, "rheocompass")
    numbers = _Numbers(decimal, digits, missing)
    tab = "\t"
    word = {name: _columns.keyword(name, language) for name in _columns.KEYWORDS}
    quantities = ("point", "time", "speed", "torque", "angle", "status")
    names = [_columns.label(quantity, language) for quantity in quantities]
    unit_row = ["", "", *(f"[{units[q]}]" for q in ("time", "speed", "torque", "angle")), ""]
    lines = [f"{word['project']}{tab}{project}", "", f"{word['test']}{tab}{test}", ""]
    lines += [f"{word['result']}{tab}{test}", ""]
    for number, run in enumerate(runs, start=1):
        lines.append(f"{word['interval_points']}{tab}{number}{tab}{len(run)}")
        lines += _metadata_lines(run, language, numbers, tab)
        lines.append(tab.join([word["interval_data"], *names]))
        lines.append(tab * (len(names)))
        lines.append(tab.join(unit_row))
        values = _columns_of(run, geometry, units)
        cells = [numbers.column(values[q]) for q in ("time", "speed", "torque", "angle")]
        for index, row in enumerate(zip(*cells, strict=True), start=1):
            lines.append(f"{tab}{index}{tab}{tab.join(row)}{tab}Dy_auto")
        lines.append("")
    return _save(path, lines, encoding)


def write_trios(
    path: PathLike,
    runs: Run | Sequence[Run],
    *,
    geometry: Any = None,
    encoding: str = "utf-8",
    decimal: str = ".",
    units: Mapping[str, str] | None = None,
    digits: int = 10,
    missing: str = "",
    sample: str = "simulated sample",
) -> Path:
    """Write runs as a TRIOS-style text export, one ``[step]`` per run.

    Parameters are those of :func:`write_rheocompass` (English labels only, as TRIOS
    writes them); default units s, µN.m, rad/s (Velocity) and rad (Displacement).

    Examples
    --------
    >>> import numpy as np, tempfile, pathlib, granflow
    >>> from granflow.io import write_trios
    >>> run = granflow.Run(t=[1.0, 2.0], slip=[0.0, 1e-6], velocity=[1e-6, 1e-6],
    ...                    force=[0.01, 0.012])
    >>> path = write_trios(pathlib.Path(tempfile.mkdtemp()) / "run.txt", run)
    >>> granflow.read(path).format
    'trios'
    """
    from granflow.model.geometry import Annulus

    runs = _runs(runs)
    geometry = geometry or Annulus.paper()
    units = _units(units, "trios")
    numbers = _Numbers(decimal, digits, missing)
    tab = "\t"
    labels = {"time": "Step time", "torque": "Torque", "speed": "Velocity", "angle": "Displacement"}
    order = ("time", "torque", "speed", "angle")
    lines = [
        f"Filename{tab}{Path(path).name}",
        f"Instrument name{tab}granflow writer (simulated data)",
        f"Sample name{tab}{sample}",
        "",
    ]
    for number, run in enumerate(runs, start=1):
        lines += ["[step]", f"Peak hold - {number}"]
        lines += _metadata_lines(run, "en", numbers, tab)
        lines.append(tab.join(labels[q] for q in order))
        lines.append(tab.join(units[q] for q in order))
        values = _columns_of(run, geometry, units)
        cells = [numbers.column(values[q]) for q in order]
        lines += [tab.join(row) for row in zip(*cells, strict=True)]
        lines.append("")
    return _save(path, lines, encoding)
