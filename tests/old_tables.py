"""Campaign tables as granflow wrote them before the tidy format (written here by hand, so
that the tests of :func:`granflow.io.tidy.read_tidy` do not depend on the code they test).

The CSV's first line was ``# granflow campaign {json}``, then a table with columns run
(0-based), t, slip, velocity, force [SI], control and each scalar metadata entry; the Parquet
table had the same columns and the JSON under its schema metadata key ``granflow``.
"""

import json

import numpy as np
import pandas as pd


def _plain(value):
    """A metadata value as the old writer's JSON held it (NumPy scalars as Python numbers)."""
    return value.item() if isinstance(value, np.generic) else value


def write_old_campaign(path, runs, problems=()):
    """Write ``runs`` (granflow.Run) as an old campaign table (.csv or .parquet)."""
    header = {
        "runs": [
            {
                "control": run.control,
                "meta": {key: _plain(value) for key, value in run.meta.items()},
                "problems": list(run.problems),
            }
            for run in runs
        ],
        "problems": list(problems),
    }
    frames = []
    for index, run in enumerate(runs):
        columns = {"run": index, "t": run.t, "slip": run.slip, "velocity": run.velocity}
        columns.update(force=run.force, control=run.control)
        scalars = {k: v for k, v in run.meta.items() if isinstance(v, str | int | float)}
        frames.append(pd.DataFrame({**columns, **scalars}, index=range(len(run))))
    frame = pd.concat(frames, ignore_index=True)
    text = json.dumps(header, ensure_ascii=False)
    if str(path).endswith(".parquet"):
        import pyarrow as pa
        import pyarrow.parquet as pq

        table = pa.Table.from_pandas(frame, preserve_index=False)
        metadata = {**(table.schema.metadata or {}), b"granflow": text.encode("utf-8")}
        pq.write_table(table.replace_schema_metadata(metadata), path)
        return path
    with open(path, "w", encoding="utf-8", newline="") as stream:
        stream.write("# granflow campaign " + text + "\n")
        frame.to_csv(stream, index=False, float_format="%.17g")
    return path
