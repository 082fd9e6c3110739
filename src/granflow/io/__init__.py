"""Instrument files to data: readers for rheometer exports, and a writer for simulated runs.

Each format has ``parse_<format>(text)`` (decoded text in, :class:`ParsedFile` out) and
``read_<format>(path)``; :func:`read` detects the format, and :func:`read_runs` turns every
interval into a :class:`granflow.Run` with an :class:`granflow.Annulus`.

Formats: Anton Paar RheoCompass and Rheoplus text exports, TA Instruments TRIOS text exports,
and generic CSV/TSV with a column map. Encodings UTF-16 (LE/BE), UTF-8 (with or without BOM)
and cp1252; tab, semicolon or comma delimiters; decimal comma or dot and thousands separators
decided per file from the numbers; labels in English, French, German, Spanish or Italian
(:mod:`granflow.io._columns`), and, where the labels are unknown, the interval header found by
its structure (names above a row of [units]) and the columns' roles from their units.

Data quality travels with the data: missing values (empty, a single space, ``******``),
invalid and infinite cells become NaN (rows kept), rows without a time are dropped, and every
such thing, a truncated block (fewer points than declared), time that does not increase and
gaps in time are sentences on ``Interval.problems`` and, naming the file and the interval,
on ``Run.problems``. Files over a size limit (``max_bytes=``, ``GRANFLOW_MAX_BYTES``, default
2 GiB) are refused before they are read; reading costs about the file's size in memory.
An unknown layout or unit is a :class:`granflow.FileFormatError` that says what was expected.

granflow's own table of runs (``tidy``): one row per point with the columns run, source,
interval, control, t_s, slip_m, velocity_m_s, force_N (SI), which ``pandas.read_csv`` reads as
it is; the metadata (column descriptions, geometry, each run's metadata and problems, what
failed) in a sidecar ``<table>.json`` beside a CSV or under the Parquet metadata key
``granflow``. :func:`write_tidy` writes it (``granflow convert``, :meth:`Campaign.save`) and
:func:`read_tidy` reads it back bit for bit, as well as the tables of earlier versions (a
``# granflow campaign`` first line).

Modules: ``reader`` (detection, :func:`read`, :func:`read_runs`), one module per format,
``writer`` (exports for tests and the demo), ``tidy`` (granflow's table of runs),
``campaign`` (a manifest of runs; save and load through ``tidy``).
"""

from granflow._lazy import attach

__getattr__, __dir__, __all__ = attach(
    __name__,
    {
        "reader": ["FORMATS", "detect_file_format", "detect_format", "parse", "read", "read_runs"],
        "_file": ["Column", "Interval", "ParsedFile"],
        "_runs": ["control_mode"],
        "generic": ["parse_csv", "read_csv"],
        "rheocompass": ["parse_rheocompass", "read_rheocompass"],
        "rheoplus": ["parse_rheoplus", "read_rheoplus"],
        "trios": ["parse_trios", "read_trios"],
        "writer": ["write_rheocompass", "write_trios"],
        "tidy": ["TidyTable", "read_tidy", "write_tidy"],
        "campaign": ["Campaign", "read_manifest"],
        "velocity_steps": ["VelocityStepRecord", "parse_velocity_steps", "read_velocity_steps"],
    },
)
