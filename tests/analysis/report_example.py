"""The input of the report tests: the results of analysing a small campaign.

The campaign of :func:`conftest.write_small_campaign` (start-ups at three loads and three
velocities, a stress ramp, a creep test and a switch, all simulated) plus one corrupt file,
analysed by :func:`granflow.analyze` into ``directory``: the figures lie under
``directory/figures`` and the results are read back from ``results.json``, exactly as the
report renders them after an analysis.
"""

import json

import yaml
from conftest import write_small_campaign

from granflow.analysis import analyze

#: The corrupt file added to the campaign.
CORRUPT = "corrupt-07.txt"


def example_results(directory):
    """Write and analyse the campaign under ``directory``; return its results.json content."""
    folder = directory / "campaign"
    manifest = write_small_campaign(folder)
    (folder / CORRUPT).write_bytes(b"\x00\xffnot an export\n\x13\x37" * 20)
    document = yaml.safe_load(manifest.read_text(encoding="utf-8"))
    document["runs"].append({"file": CORRUPT, "normal_load": "60 mN"})
    manifest.write_text(yaml.safe_dump(document, sort_keys=False), encoding="utf-8")
    analyze(manifest, directory, jobs=1, quiet=True, figure_formats=("png", "svg"))
    return json.loads((directory / "results.json").read_text(encoding="utf-8"))
