"""granflow.io.follow: an export read while it grows gives the rows read_runs gives, and says
when the file is truncated or replaced, when a new interval begins and when rows are
damaged; a half-written line waits for its end."""

import numpy as np
import pytest

import granflow as gf
from granflow.io import write_rheocompass, write_trios
from granflow.io.follow import Follower, Notice, Rows


def _run(points=80, control="stress", seed=0):
    rng = np.random.default_rng(seed)
    t = np.arange(points) * 0.5
    slip = 1e-8 * t**1.5 + 1e-10 * rng.standard_normal(points)
    force = 1e-4 * t + 1e-6
    return gf.Run(
        t=t,
        slip=slip,
        velocity=np.gradient(slip, t),
        force=force,
        control=control,
        meta={"normal_load": 0.05},
    )


def _collect(events):
    rows = [event for event in events if isinstance(event, Rows)]
    notices = [event for event in events if isinstance(event, Notice)]
    return rows, notices


def _joined(rows, interval, name):
    return np.concatenate([getattr(r, name) for r in rows if r.interval == interval])


def _grow(path, data, sizes):
    """Append ``data`` to ``path`` in pieces of the given sizes, polling after each; all
    events in order."""
    follower = Follower(path)
    events, position = [], 0
    path.write_bytes(b"")
    for size in sizes:
        with path.open("ab") as stream:
            stream.write(data[position : position + size])
        position += size
        events += follower.poll()
    with path.open("ab") as stream:
        stream.write(data[position:])
    events += follower.poll()
    return follower, events


@pytest.mark.parametrize("encoding", ["utf-16", "utf-8-sig", "cp1252"])
def test_a_growing_export_gives_the_rows_read_runs_gives(tmp_path, encoding):
    full = tmp_path / "full.txt"
    write_rheocompass(full, [_run(), _run(30, seed=1)], encoding=encoding, test="ramp")
    expected = gf.read_runs(full)
    data = full.read_bytes()
    sizes = np.random.default_rng(1).integers(1, 700, size=len(data) // 350)  # odd cuts too
    follower, events = _grow(tmp_path / "grow.txt", data, sizes)
    rows, notices = _collect(events)
    assert follower.encoding == {"utf-16": "utf-16-le"}.get(encoding, encoding)
    # before its first data row the file cannot be read yet: "waiting" says why
    said = [n.kind for n in notices if n.kind != "waiting"]
    assert said == ["opened", "interval", "interval"]
    for ordinal, run in enumerate(expected, start=1):
        np.testing.assert_array_equal(_joined(rows, ordinal, "t"), run.t)
        np.testing.assert_array_equal(_joined(rows, ordinal, "force"), run.force)
        np.testing.assert_allclose(_joined(rows, ordinal, "slip"), run.slip, rtol=0, atol=1e-18)
    assert all(r.control == "stress" for r in rows)
    assert len(rows) > 4  # read piece by piece, not at the end


def test_a_half_written_line_waits_for_its_end(tmp_path):
    path = tmp_path / "run.csv"
    path.write_text("Time [s],Torque [mN m],Deflection Angle [mrad]\n0,0.1,1\n1,0.2,2\n2,0.3")
    follower = Follower(path)
    rows, _ = _collect(follower.poll())
    assert _joined(rows, 1, "t").tolist() == [0.0, 1.0]  # "2,0.3" is not a row yet
    with path.open("a") as stream:
        stream.write("5")  # still no line end: 0.35 may go on
    assert _collect(follower.poll())[0] == []
    with path.open("a") as stream:
        stream.write(",3\n")
    rows, _ = _collect(follower.poll())
    assert _joined(rows, 1, "t").tolist() == [2.0]
    radius = gf.Annulus.paper().effective_radius
    assert _joined(rows, 1, "force") == pytest.approx([0.35e-3 / radius])


def test_a_utf16_character_split_across_two_reads(tmp_path):
    full = tmp_path / "full.txt"
    write_rheocompass(full, _run(20), encoding="utf-16")
    data = full.read_bytes()
    _follower, events = _grow(tmp_path / "grow.txt", data, [1, 2, 3, 5, 7, 11, 13] * 40)
    rows, _ = _collect(events)
    np.testing.assert_array_equal(_joined(rows, 1, "t"), gf.read_runs(full)[0].t)


def test_truncation_and_replacement_are_said_and_read_again(tmp_path):
    path = tmp_path / "run.txt"
    write_rheocompass(path, _run(40), encoding="utf-8")
    follower = Follower(path)
    rows, _ = _collect(follower.poll())
    assert _joined(rows, 1, "t").size == 40
    write_rheocompass(path, _run(10), encoding="utf-8")  # rewritten, shorter
    rows, notices = _collect(follower.poll())
    assert notices[0].kind == "truncated"
    assert "read again from its start" in notices[0].message
    assert _joined(rows, 1, "t").size == 10
    other = tmp_path / "other.txt"
    write_trios(other, _run(25))
    other.replace(path)  # another file in its place
    rows, notices = _collect(follower.poll())
    assert notices[0].kind == "replaced"
    assert _joined(rows, 1, "t").size == 25


def test_a_new_interval_in_the_same_file_is_said(tmp_path):
    path = tmp_path / "run.txt"
    full = tmp_path / "full.txt"
    write_rheocompass(full, [_run(30), _run(20, control="rate")], encoding="utf-8")
    text = full.read_text(encoding="utf-8")
    second = text.index("Interval and data points:\t2")
    path.write_text(text[:second], encoding="utf-8")
    follower = Follower(path)
    _first_rows, first_notices = _collect(follower.poll())
    assert [n.kind for n in first_notices] == ["opened", "interval"]
    with path.open("a", encoding="utf-8") as stream:
        stream.write(text[second:])
    rows, notices = _collect(follower.poll())
    assert [(n.kind, n.interval) for n in notices] == [("interval", 2)]
    assert {r.interval for r in rows} == {2}
    assert rows[0].control == "rate"
    assert _joined(rows, 2, "t").size == 20


def test_damaged_rows_are_flagged_and_kept_as_missing_values(tmp_path):
    path = tmp_path / "run.csv"
    path.write_text("Time [s],Torque [mN m],Deflection Angle [mrad]\n0,0.1,1\n1,0.2,2\n")
    follower = Follower(path)
    follower.poll()
    with path.open("a") as stream:
        stream.write("2,abc,3\n3,0.4,4\n")
    rows, notices = _collect(follower.poll())
    damaged = [n for n in notices if n.kind == "damaged"]
    assert damaged and "invalid" in damaged[0].message and "line 4" in damaged[0].message
    force = _joined(rows, 1, "force")
    assert np.isnan(force[0]) and np.isfinite(force[1])
    assert rows[0].problems  # the sentences travel with the rows, as in Run.problems


def test_a_file_that_does_not_exist_yet_gives_nothing(tmp_path):
    follower = Follower(tmp_path / "later.csv")
    assert follower.poll() == []
    (tmp_path / "later.csv").write_text("Time [s],Torque [mN m]\n0,1\n")
    rows, notices = _collect(follower.poll())
    assert notices[0].kind == "opened" and _joined(rows, 1, "t").tolist() == [0.0]
