"""The campaign's stage of the record families (:mod:`granflow.families`): each family with
a manifest ``test`` kind and entries in the manifest is analysed by its ``analyse``, on a
worker of the campaign's executor (a family's fits and figures load what the main process
should not), after the joint stage.
"""

import time
from typing import Any

from granflow.analysis.files import FIGURES_DIR
from granflow.families import record_families, resolve

__all__ = ["analyse_records"]


def analyse_records(manifest, output, allow_outside, executor, reporter, stages):
    """The analyses of the record families with entries in ``manifest``, by ``test`` kind
    (what each family's ``analyse`` returned), and under ``"files"`` the files each read.

    Parameters
    ----------
    manifest : path-like or None
        The campaign's manifest (None: a Campaign, which has no records of a family).
    output : path-like
        The analysis's output folder (figures go to its ``figures`` folder).
    allow_outside : bool
        Read records outside the manifest's folder too.
    executor : granflow._parallel.Executor
        Where each family's analysis runs (one task per family, workers recycled after).
    reporter : granflow._progress.RunProgress
        Announces the stage of each family the manifest has records of (its ``test`` kind
        in words).
    stages : dict
        Gets each family's duration [s] as ``<test>_s``.
    """
    analysed: dict[str, Any] = {"files": []}
    for family in record_families():
        if family.entries is None or family.analyse is None:
            continue
        kind = str(family.test_kind)
        clock = time.perf_counter()
        listed = resolve(family.entries)(manifest, allow_outside)
        if listed:  # a family the campaign has no records of is no stage of it
            reporter.stage(kind.replace("_", " "))
            task = (family.name, manifest, output, allow_outside)
            analysed[kind] = executor.call(_record_analysis, task)
            executor.recycle()
        analysed["files"].append([entry["file"] for entry in listed])
        stages[f"{kind}_s"] = time.perf_counter() - clock
    return analysed


def _record_analysis(task):
    """The ``analyse`` of the family named in ``(family, manifest, output, allow_outside)``,
    as one executor task."""
    name, manifest, output, allow_outside = task
    family = next(f for f in record_families() if f.name == name)
    return resolve(str(family.analyse))(manifest, output, FIGURES_DIR, allow_outside)
