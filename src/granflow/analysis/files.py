"""The names of the files :func:`granflow.analyze` reads and writes, and its JSON helpers.

The lowest module of :mod:`granflow.analysis`: the engine, the outputs and the demo all name
their files through it, so that none of them imports another for a file name.
"""

import json
from pathlib import Path

from granflow._files import write_atomic

__all__ = [
    "FIGURES_DIR",
    "MANIFEST_NAMES",
    "REPORT_FILE",
    "RESULTS_FILE",
    "RUNS_DIR",
    "RUN_RECORD_MARKER",
    "TABLES_DIR",
    "TRUTH_FILE",
    "dump_json",
    "read_json",
    "write_json",
]

#: The campaign's results (the ``to_dict()`` of :class:`granflow.analysis.AnalysisResult`
#: plus the ``timing`` entry).
RESULTS_FILE = "results.json"
#: The HTML report.
REPORT_FILE = "report.html"
#: One saved result per run, ``<key>.json``, for ``resume=True``.
RUNS_DIR = "runs"
#: CSV (and Parquet) tables.
TABLES_DIR = "tables"
#: PNG and SVG figures.
FIGURES_DIR = "figures"
#: The generator's truth of a synthetic campaign (beside the manifest or one folder up).
TRUTH_FILE = "synthetic_truth.json"
#: Manifest names looked for in a campaign folder, in this order.
MANIFEST_NAMES = ("manifest.yaml", "manifest.yml", "manifest.csv")
#: The key that marks a JSON file in ``runs/`` as granflow's own saved run result.
RUN_RECORD_MARKER = "granflow_run_record"


def dump_json(value):
    """``value`` as indented JSON text (UTF-8, no NaN), ending in a newline."""
    return json.dumps(value, indent=2, ensure_ascii=False, allow_nan=False) + "\n"


def write_json(path, value):
    """Write ``value`` as JSON to ``path`` atomically (a reader never sees half a file)."""
    text = dump_json(value)
    return write_atomic(path, lambda temporary: temporary.write_text(text, encoding="utf-8"))


def read_json(path):
    """The JSON content of ``path``, or None when it is missing or not JSON."""
    try:
        return json.loads(Path(path).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
