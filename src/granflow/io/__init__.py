"""Instrument files to data: readers for rheometer exports, and a writer for simulated runs.

Each format has ``parse_<format>(text)`` (decoded text in, :class:`ParsedFile` out) and
``read_<format>(path)``; :func:`read` detects the format, and :func:`read_runs` turns every
interval into a :class:`granflow.Run` with an :class:`granflow.Annulus`.

Formats: Anton Paar RheoCompass and Rheoplus text exports, TA Instruments TRIOS text exports,
and generic CSV/TSV with a column map. Encodings UTF-16 (LE/BE), UTF-8 (with or without BOM)
and cp1252; tab, semicolon or comma delimiters; decimal comma or dot and thousands separators
decided per file from the numbers; column labels in English, French or German
(:mod:`granflow.io._columns`). Missing values (empty, a single space, ``******``) become NaN
and are listed in the problems; an unknown unit is a :class:`granflow.FileFormatError`.

Modules: ``reader`` (detection, :func:`read`, :func:`read_runs`), one module per format,
``writer`` (exports for tests and the demo), ``campaign`` (a manifest of runs).
"""

from granflow._lazy import attach

__getattr__, __dir__, __all__ = attach(
    __name__,
    {
        "reader": ["FORMATS", "detect_format", "parse", "read", "read_runs"],
        "_file": ["Column", "Interval", "ParsedFile"],
        "_runs": ["control_mode"],
        "generic": ["parse_csv", "read_csv"],
        "rheocompass": ["parse_rheocompass", "read_rheocompass"],
        "rheoplus": ["parse_rheoplus", "read_rheoplus"],
        "trios": ["parse_trios", "read_trios"],
        "writer": ["write_rheocompass", "write_trios"],
        "campaign": ["Campaign", "read_manifest"],
    },
)
