"""Data quality travels with the data; inputs are bounded; every language and layout reads.

Damaged exports are made by editing files the writer produced; the expected line numbers
and counts are found in the edited text itself (by searching its lines), not by the reader.
"""

import numpy as np
import pytest
from conftest import shared_data

import granflow
from granflow.io import _buffer, write_rheocompass

LANGUAGES = ("en", "fr", "de", "es", "it")


def startup(points=40):
    time = np.arange(points, dtype=float)
    return granflow.Run(
        t=time,
        slip=1e-6 * time,
        velocity=np.full(points, 1e-6),
        force=0.01 + 1e-4 * time,
        meta={"normal_load": 0.05},
    )


def written_lines(tmp_path, points=40, runs=1):
    path = write_rheocompass(tmp_path / "run.txt", [startup(points)] * runs, encoding="utf-8")
    return path, path.read_bytes().decode("utf-8").split("\r\n")


def data_line(lines, point, interval=1):
    """1-based file line of data point ``point`` (1-based) of an interval, found by search."""
    seen = 0
    for index, line in enumerate(lines):
        if line.startswith(f"\t{point}\t"):
            seen += 1
            if seen == interval:
                return index + 1
    raise AssertionError(point)


def set_cell(lines, line, column, value):
    cells = lines[line - 1].split("\t")
    cells[column] = value
    lines[line - 1] = "\t".join(cells)


TIME, TORQUE = 2, 4  # cell positions in a written row: "", point, time, speed, torque, angle


def test_a_clean_export_has_no_problems(tmp_path):
    path, _ = written_lines(tmp_path)
    (run,) = granflow.read_runs(path)
    assert run.problems == ()


def test_a_truncated_block_is_named_with_its_file_interval_and_lines(tmp_path):
    path, lines = written_lines(tmp_path, points=401)
    last = data_line(lines, 79)
    path.write_text("\r\n".join(lines[:last]) + "\r\n", encoding="utf-8")
    (run,) = granflow.read_runs(path)
    assert len(run) == 79
    first = data_line(lines, 1)
    assert run.problems == (
        f"run.txt, interval 1: the header declares 401 points, found 79 "
        f"(truncated, lines {first}-{last})",
    )


def test_missing_invalid_and_infinite_cells_are_kept_as_nan_with_their_lines(tmp_path):
    path, lines = written_lines(tmp_path)
    marked = {5: "******", 6: "", 9: "abc", 12: "inf", 13: "-inf", 20: "nan"}
    for point, value in marked.items():
        set_cell(lines, data_line(lines, point), TORQUE, value)
    path.write_text("\r\n".join(lines), encoding="utf-8")
    (run,) = granflow.read_runs(path)
    assert len(run) == 40  # rows kept
    assert np.isnan(run.force[[p - 1 for p in marked]]).all()
    assert np.isfinite(np.delete(run.force, [p - 1 for p in marked])).all()
    line = {point: data_line(lines, point) for point in marked}
    assert run.problems == (
        f"run.txt, interval 1: column 'Torque': 2 missing values kept as NaN, first at line "
        f"{line[5]} (lines {line[5]}-{line[6]})",
        f"run.txt, interval 1: column 'Torque': 1 invalid value kept as NaN 'abc' at line "
        f"{line[9]}",
        f"run.txt, interval 1: column 'Torque': 3 non-finite values kept as NaN, first 'inf' "
        f"at line {line[12]} (lines {line[12]}-{line[13]}, {line[20]})",
    )


def test_rows_without_a_time_are_dropped_and_said_so(tmp_path):
    path, lines = written_lines(tmp_path)
    for point in (3, 4):
        set_cell(lines, data_line(lines, point), TIME, "")
    path.write_text("\r\n".join(lines), encoding="utf-8")
    (run,) = granflow.read_runs(path)
    assert len(run) == 38 and 2.0 not in run.t and 3.0 not in run.t
    first, second = data_line(lines, 3), data_line(lines, 4)
    assert (
        f"run.txt, interval 1: 2 rows without a time dropped from the run (lines {first}-{second})"
        in run.problems
    )


def test_time_running_backwards_and_gaps_are_reported_and_rows_kept(tmp_path):
    path, lines = written_lines(tmp_path)
    set_cell(lines, data_line(lines, 10), TIME, "7.5")  # 8 -> 7.5 after 8: backwards at 10
    for point in range(30, 41):
        set_cell(lines, data_line(lines, point), TIME, str(point - 1 + 60))  # a 61 s gap
    path.write_text("\r\n".join(lines), encoding="utf-8")
    (run,) = granflow.read_runs(path)
    assert len(run) == 40
    backwards, gap = run.problems
    assert backwards == (
        f"run.txt, interval 1: time does not increase at 1 row (line {data_line(lines, 10)}); "
        "rows kept"
    )
    assert gap == (
        "run.txt, interval 1: 1 gap in time over 10x the median step 1 s, largest 61 s "
        f"(before line {data_line(lines, 30)}); rows kept"
    )


def test_problems_of_columns_a_run_does_not_use_stay_on_the_parsed_file():
    path = shared_data("instrument-exports", "rheoplus-en-utf8-stress-relaxation.txt")
    parsed = granflow.read(path)
    assert any("Angular Frequency" in problem for problem in parsed.intervals[0].problems)
    runs = granflow.read_runs(path)
    assert not any("Angular Frequency" in problem for problem in runs[0].problems)
    assert not any("declares" in problem for problem in runs[3].problems)  # 99 of 99


def test_files_over_the_size_limit_are_refused_before_they_are_read(tmp_path, monkeypatch):
    path, _ = written_lines(tmp_path)
    size = path.stat().st_size

    def never(*args):
        raise AssertionError("read although over the limit")

    monkeypatch.setattr(_buffer, "read_stream", never)
    with pytest.raises(granflow.FileFormatError) as error:
        granflow.read_runs(path, max_bytes=size - 1)
    assert str(error.value).startswith(f"{path}: the file is {size} bytes")
    assert f"over the limit of {size - 1} bytes" in str(error.value)
    monkeypatch.setenv("GRANFLOW_MAX_BYTES", str(size // 2))
    with pytest.raises(granflow.FileFormatError, match=f"limit of {size // 2} bytes"):
        granflow.read(path)
    assert _buffer.MAX_BYTES == 2 * 2**30


def test_a_header_followed_by_junk_is_refused(tmp_path):
    _, lines = written_lines(tmp_path)
    header = "\r\n".join(lines[: data_line(lines, 1) - 1]) + "\r\n"
    rng = np.random.default_rng(7)
    junk = tmp_path / "junk.txt"
    junk.write_bytes(header.encode() + rng.integers(0, 256, 100_000, dtype=np.uint8).tobytes())
    with pytest.raises(granflow.FileFormatError, match=r"junk.txt, line \d+: "):
        granflow.read_runs(junk)
    prose = tmp_path / "prose.txt"
    prose.write_text(header + "no data here\n" * 20_000, encoding="utf-8")
    # prose where the data rows should be: the first such line is named, and why
    with pytest.raises(
        granflow.FileFormatError, match=r"prose.txt, line \d+: this line interrupts the data rows"
    ):
        granflow.read_runs(prose)


def test_an_unknown_layout_says_what_was_expected(tmp_path):
    path = tmp_path / "notes.txt"
    path.write_text("Some notes about the sample\n\nnothing tabular here\n", encoding="utf-8")
    with pytest.raises(granflow.FileFormatError, match="expected a RheoCompass export"):
        granflow.read_runs(path)


@pytest.mark.parametrize("language", LANGUAGES)
@pytest.mark.parametrize(
    ("encoding", "decimal", "torque"), [("utf-16", ",", "µN·m"), ("utf-8", ".", "mN·m")]
)
def test_exports_in_every_language_round_trip(tmp_path, language, encoding, decimal, torque):
    runs = [startup(), startup(25)]
    path = write_rheocompass(
        tmp_path / "x.csv",
        runs,
        language=language,
        encoding=encoding,
        decimal=decimal,
        units={"torque": torque},
    )
    parsed = granflow.read(path)
    assert parsed.format == "rheocompass" and len(parsed.intervals) == 2
    quantities = {column.quantity for column in parsed.intervals[0].columns}
    assert {"point", "time", "speed", "torque", "angle", "status"} <= quantities
    for written, back in zip(runs, granflow.read_runs(path), strict=True):
        for name in ("t", "slip", "velocity", "force"):
            np.testing.assert_allclose(getattr(back, name), getattr(written, name), rtol=1e-9)
        assert back.meta["normal_load"] == 0.05 and back.control == "rate"
        assert back.problems == ()


def test_a_layout_in_an_unknown_language_is_read_by_its_structure(tmp_path):
    run = startup()
    path = write_rheocompass(tmp_path / "x.txt", [run], encoding="utf-8", language="it")
    text = path.read_bytes().decode("utf-8")
    esperanto = {
        "Intervallo e punti dati:": "Intervalo kaj datumpunktoj:",
        "Dati intervallo:": "Intervalaj datumoj:",
        "N. punto": "Punkto",
        "Tempo": "Daŭro",
        "Velocità di rotazione": "Rotacia rapido",
        "Coppia": "Tordmomanto",
        "Angolo di deflessione": "Deflekta angulo",
        "Stato": "Stato de mezuro",
    }
    for italian, other in esperanto.items():
        assert italian in text
        text = text.replace(italian, other)
    path.write_text(text, encoding="utf-8")
    parsed = granflow.read(path)
    assert parsed.format == "rheocompass"
    roles = {column.name: column.quantity for column in parsed.intervals[0].columns}
    assert roles == {
        "Punkto": None,
        "Daŭro": "time",
        "Rotacia rapido": "speed",
        "Tordmomanto": "torque",
        "Deflekta angulo": "angle",
        "Stato de mezuro": None,
    }
    (back,) = granflow.read_runs(path)
    np.testing.assert_allclose(back.force, run.force, rtol=1e-9)
    np.testing.assert_allclose(back.slip, run.slip, rtol=1e-9, atol=1e-22)


@pytest.mark.parametrize("newline", ["\r", "\n", "\r\n"])
def test_every_line_end_reads_the_same(tmp_path, newline):
    path, lines = written_lines(tmp_path)
    path.write_bytes(newline.join(lines).encode("utf-16"))
    (run,) = granflow.read_runs(path)
    np.testing.assert_allclose(run.force, startup().force, rtol=1e-9)
    assert run.problems == ()


def test_the_french_spellings_of_real_rheocompass_exports_are_known():
    from granflow.io import _columns

    assert _columns.match_keyword("Interval données:") == "interval_data"
    assert _columns.match_quantity("Intervalle Temps")[0] == "interval_time"
    assert _columns.match_quantity("Gradient de Cisaillement")[0] == "shear_rate"
    assert _columns.match_quantity("Etat")[0] == "status"


def test_an_odd_cell_deep_in_a_long_block_is_found_with_its_line():
    rows = [f"{index}\t{index * 0.5}" for index in range(300_000)]
    rows[290_000] = "290000\tabc"  # past pandas' first low-memory chunk
    parsed = granflow.io.parse_csv("Time [s]\tTorque [mN m]\n" + "\n".join(rows) + "\n")
    (interval,) = parsed.intervals
    torque = interval.si("torque")
    assert np.isnan(torque[290_000]) and np.isnan(torque).sum() == 1
    assert torque[289_999] == pytest.approx(289_999 * 0.5e-3, rel=1e-15)
    assert interval.problems == (
        "column 'Torque': 1 invalid value kept as NaN 'abc' at line 290002",
    )


def test_a_logarithmic_time_grid_has_no_gaps_and_a_jump_in_it_is_one():
    from granflow.io._file import time_problems

    grid = np.geomspace(0.01, 1e4, 200)  # each step 7 % longer than the one before
    assert time_problems(grid, 1) == []
    jumped = grid.copy()
    jumped[150:] += 1e4  # one step of 10^4 s where its neighbours are about 10^2 s
    (gap,) = time_problems(jumped, 1)
    assert "1 gap in time" in gap and "(before line 151)" in gap
