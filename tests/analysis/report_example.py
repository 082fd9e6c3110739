"""The input of the report tests: the result of analysing a small campaign.

The campaign of :func:`conftest.write_small_campaign` (start-ups at three loads and three
velocities, a stress ramp, a creep test and a switch, all simulated) plus one corrupt file,
analysed by :func:`granflow.analyze` into ``directory``: the figures lie under
``directory/figures``; the typed :class:`~granflow.analysis.AnalysisResult` is what the report
renders.
"""

import yaml
from conftest import write_small_campaign

from granflow.analysis import analyze

#: The corrupt file added to the campaign.
CORRUPT = "corrupt-07.txt"


def example_result(directory):
    """Write and analyse the campaign under ``directory``; return its AnalysisResult."""
    folder = directory / "campaign"
    manifest = write_small_campaign(folder)
    (folder / CORRUPT).write_bytes(b"\x00\xffnot an export\n\x13\x37" * 20)
    document = yaml.safe_load(manifest.read_text(encoding="utf-8"))
    document["runs"].append({"file": CORRUPT, "normal_load": "60 mN"})
    manifest.write_text(yaml.safe_dump(document, sort_keys=False), encoding="utf-8")
    return analyze(manifest, directory, jobs=1, quiet=True, figure_formats=("png", "svg"))
