"""Figures rendered through the executor (granflow.analysis.render) and the parallel pipeline:
the same files and the same results whatever the number of processes."""

import json
import os
from types import MappingProxyType

import numpy as np
import pytest
from conftest import analyze_in_fresh_process, write_small_campaign

from granflow._json import json_safe
from granflow._parallel import Executor
from granflow.analysis import analyze
from granflow.analysis.render import render_figures
from granflow.io.campaign import manifest_runs


def _line(slope):
    import matplotlib.pyplot as plt

    figure, axes = plt.subplots(figsize=(3, 2))
    axes.plot(np.arange(50.0), slope * np.arange(50.0), "o-")
    return figure, f"slope {slope}"


def _broken():
    raise ValueError("no data to draw")


def _specs(slopes, broken_at):
    """Module-level builder: one figure per slope, the one at ``broken_at`` failing."""
    specs = []
    for position, slope in enumerate(slopes):
        draw = _broken if position == broken_at else (lambda slope=slope: _line(slope))
        specs.append((f"line_{position}", f"Line {position}", draw))
    return specs


@pytest.mark.parametrize("jobs", [1, 2])
def test_figures_through_the_executor_match_in_process_ones(tmp_path, jobs):
    args = ((1.0, 2.0, 3.0, 4.0), 2)
    serial = render_figures(_specs, args, tmp_path / "serial")
    with Executor(jobs) as executor:
        parallel = render_figures(_specs, args, tmp_path / "parallel", executor)
    assert parallel == serial
    assert [outcome[0] for outcome in serial if not isinstance(outcome, str)] == [
        "slope 1.0",
        "slope 2.0",
        "slope 4.0",
    ]
    assert serial[2] == "ValueError: no data to draw"  # the failure costs only its figure
    written = sorted(path.name for path in (tmp_path / "parallel").iterdir())
    assert written == sorted(f"line_{i}.{s}" for i in (0, 1, 3) for s in ("png", "svg"))
    for name in written:
        assert (tmp_path / "parallel" / name).read_bytes() == (
            tmp_path / "serial" / name
        ).read_bytes()
    assert not list(tmp_path.rglob("*.tmp"))


def test_read_only_mappings_travel_to_the_workers():
    proxy = MappingProxyType({"hold": 1.0, "ramp": (2.0, 3.0)})
    with Executor(2) as executor:
        back = executor.map(dict, [proxy, proxy])
    assert back == [{"hold": 1.0, "ramp": (2.0, 3.0)}] * 2


def test_manifest_read_in_parallel_is_the_same(tmp_path):
    manifest = write_small_campaign(tmp_path / "campaign")
    serial = manifest_runs(manifest)
    with Executor(2) as executor:
        parallel = manifest_runs(manifest, executor=executor)
    assert [e.label for e in parallel] == [e.label for e in serial]
    assert [e.reason for e in parallel] == [e.reason for e in serial]
    for one, other in zip(serial, parallel, strict=True):
        assert len(one.runs) == len(other.runs)
        for a, b in zip(one.runs, other.runs, strict=True):
            assert dict(a.meta) == dict(b.meta)
            for column in ("t", "slip", "velocity", "force"):
                np.testing.assert_array_equal(getattr(a, column), getattr(b, column))


def test_analysis_files_are_identical_across_jobs(tmp_path):
    manifest = write_small_campaign(tmp_path / "campaign")
    outputs = {jobs: tmp_path / f"out{jobs}" for jobs in (1, 2)}
    for jobs, output in outputs.items():
        result = analyze(manifest, output, jobs=jobs, quiet=True)
        stored = json.loads((output / "results.json").read_text(encoding="utf-8"))
        assert stored == {**result.to_dict(), "timing": stored["timing"]}
    names = sorted(p.relative_to(outputs[1]) for p in outputs[1].rglob("*") if p.is_file())
    assert names == sorted(p.relative_to(outputs[2]) for p in outputs[2].rglob("*") if p.is_file())
    figures = [name for name in names if name.parts[0] == "figures"]
    assert figures, "the campaign draws figures"
    for name in names:
        if name.parts[0] in ("figures", "runs", "tables"):
            assert (outputs[1] / name).read_bytes() == (outputs[2] / name).read_bytes(), name


def _reference_json_safe(value):
    """The rule of json_safe written plainly (one isinstance chain, no fast paths)."""
    from collections.abc import Mapping

    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, bool | int | str) or value is None:
        return value
    if isinstance(value, float):
        return value if np.isfinite(value) else None
    if isinstance(value, Mapping):
        return {str(key): _reference_json_safe(item) for key, item in value.items()}
    if isinstance(value, list | tuple | np.ndarray):
        return [_reference_json_safe(item) for item in value]
    return str(value)


def test_json_safe_fast_paths_follow_the_rule():
    value = {
        1: 2.0,
        "nan": float("nan"),
        "inf": [float("-inf"), np.float32("inf"), np.float64(3.5)],
        "arrays": (np.array([1.0, np.nan]), np.array([[1, 2], [3, 4]]), np.array([True])),
        "empty": np.array([], dtype=float),
        "proxy": MappingProxyType({"x": np.arange(3.0)}),
        "other": [None, True, np.bool_(False), np.int64(7), 1 + 2j, object],
        2.5: "key",
    }
    out = json_safe(value)
    assert repr(out) == repr(_reference_json_safe(value))
    assert json.dumps(out, allow_nan=False)


_MARKED = []  # in a worker: whether an earlier task ran there


def _pid(_):
    return os.getpid()


def _mark(_):
    seen = bool(_MARKED)
    _MARKED.append(True)
    return seen


def _marked(_):
    return bool(_MARKED)


def _fail(_):
    raise ValueError("no such table")


def test_an_isolating_executor_sends_even_one_task_to_a_worker():
    here = os.getpid()
    with Executor(2) as executor:
        assert executor.map(_pid, [0]) == [here]
        assert list(executor.run(_pid, [0])) == [(0, here)]
    with Executor(2, isolate=True) as executor:
        assert executor.map(_pid, [0]) != [here]
        assert dict(executor.run(_pid, [0]))[0] != here
        assert executor.call(_pid, 0) != here
        with pytest.raises(ValueError, match="no such table"):
            executor.call(_fail, 0)
    with Executor(1, isolate=True) as executor:
        assert executor.call(_pid, 0) == here
        assert executor.map(_pid, [0, 1]) == [here, here]


def _sigterm_is_default(_):
    import signal

    return signal.getsignal(signal.SIGTERM) == signal.SIG_DFL


def test_workers_end_on_sigterm_whatever_handler_they_were_forked_with():
    import signal

    def interrupt(signum, frame):  # the command line's: SIGTERM stops like Ctrl-C
        raise KeyboardInterrupt

    previous = signal.signal(signal.SIGTERM, interrupt)
    try:
        with Executor(2, isolate=True) as executor:
            assert executor.call(_sigterm_is_default, 0)
    finally:
        signal.signal(signal.SIGTERM, previous)


def _die_on_a_worker(home):
    if os.getpid() != home:
        os._exit(1)  # a worker killed under its task (for memory, say)
    return "here"


def test_a_task_whose_worker_dies_is_done_here_and_the_next_get_new_workers():
    with Executor(2, isolate=True) as executor:
        assert executor.call(_die_on_a_worker, os.getpid()) == "here"
        assert executor.call(_pid, 0) != os.getpid()


def test_recycled_workers_begin_without_what_earlier_tasks_left():
    with Executor(2) as executor:
        # one worker runs the four tasks in one chunk: it remembers the earlier ones
        assert executor.map(_mark, range(4), chunksize=4) == [False, True, True, True]
        executor.recycle()
        assert executor.map(_marked, range(4)) == [False] * 4
    assert not _MARKED  # and none of it ran here


def test_a_parallel_analysis_leaves_pandas_and_matplotlib_to_the_workers(tmp_path):
    manifest = write_small_campaign(tmp_path / "campaign")
    output = tmp_path / "out"
    assert analyze_in_fresh_process(manifest, output) == (False, False)
    result = json.loads((output / "results.json").read_text(encoding="utf-8"))
    assert result["figures"] and result["tables"]
