"""Damaged and crossed files, tried as a user would (issue 31): each is a correct read or a
FileFormatError naming the file and the line, never a silent wrong answer nor another
exception. The expected values are written into the files by hand here."""

import numpy as np
import pytest

import granflow
from granflow.io import parse_csv


def write(tmp_path, name, text, encoding="utf-8"):
    path = tmp_path / name
    path.write_bytes(text.encode(encoding))
    return path


# --------------------------------------------------------------------------- point 2


def test_a_row_wider_than_the_header_is_an_error_naming_its_line(tmp_path):
    path = write(tmp_path, "wide.csv", "time [s],slip [m],force [N]\n0,0,0.01\n1,1e-6,0.011,99\n")
    with pytest.raises(granflow.FileFormatError) as caught:
        granflow.read_runs(path)
    message = str(caught.value)
    assert str(path) in message and "line 3" in message and "4 cells" in message


def test_empty_cells_after_the_last_column_are_no_wider_row(tmp_path):
    path = write(tmp_path, "trailing.csv", "time [s],force [N]\n0,0.01,\n1,0.011,,\n")
    (run,) = granflow.read_runs(path)
    assert run.t.tolist() == [0.0, 1.0] and run.force.tolist() == [0.01, 0.011]


def test_decimal_commas_with_comma_separators_are_an_error_not_integer_parts(tmp_path):
    text = "Time [s],Deflection Angle [mrad],Torque [mN m]\n0,5,0,43,2,74502\n1,5,0,53,2,84502\n"
    path = write(tmp_path, "comma.csv", text)
    with pytest.raises(granflow.FileFormatError) as caught:
        granflow.read_runs(path)
    message = str(caught.value)
    assert str(path) in message and "line 2" in message and "decimal comma" in message


def test_a_cell_that_starts_like_a_number_but_is_not_one_is_an_error_naming_its_line():
    text = "Time [s]\tTorque [mN m]\n0\t1.5\n1\t1.5.3\n2\t1.7\n"
    with pytest.raises(granflow.FileFormatError, match=r"x\.csv, line 3: column 2"):
        parse_csv(text, source="x.csv")


# --------------------------------------------------------------------------- point 6


def test_a_last_line_cut_in_the_middle_of_its_number_is_left_out_and_said(tmp_path):
    # the file was "...\n3,3e-6,0.0123\n" before it was cut after "0.01"
    text = "time [s],slip [m],force [N]\n0,0,0.01\n1,1e-6,0.011\n3,3e-6,0.01"
    path = write(tmp_path, "cut.csv", text)
    (run,) = granflow.read_runs(path)
    assert run.t.tolist() == [0.0, 1.0]
    assert run.force.tolist() == [0.01, 0.011]
    assert any("line 4" in problem and "cut short" in problem for problem in run.problems)


def test_a_whole_file_keeps_its_last_row(tmp_path):
    path = write(tmp_path, "whole.csv", "time [s],force [N]\r\n0,0.01\r\n1,0.011\r\n")
    (run,) = granflow.read_runs(path)
    assert run.force.tolist() == [0.01, 0.011] and run.problems == ()


# --------------------------------------------------------------------------- point 6b


def test_granflows_own_column_words_are_read_by_name_and_unit(tmp_path):
    path = write(tmp_path, "own.csv", "time [s],slip [m],force [N]\n0,0,0.01\n1,1e-6,0.011\n")
    (run,) = granflow.read_runs(path)
    assert run.slip.tolist() == [0.0, 1e-6]
    assert run.force.tolist() == [0.01, 0.011]
    assert run.problems == ()


def test_the_names_granflow_writes_are_read_back(tmp_path):
    text = "t_s,slip_m,velocity_m_s,force_N\n0,0,1e-6,0.01\n1,1e-6,1e-6,0.011\n"
    (run,) = granflow.read_runs(write(tmp_path, "t.csv", text))
    assert run.t.tolist() == [0.0, 1.0]
    assert run.slip.tolist() == [0.0, 1e-6]
    assert run.velocity.tolist() == [1e-6, 1e-6]
    assert run.force.tolist() == [0.01, 0.011]


def test_a_granflow_column_without_a_unit_is_an_error_naming_it(tmp_path):
    path = write(tmp_path, "bare.csv", "time [s],force\n0,0.01\n1,0.011\n")
    with pytest.raises(granflow.FileFormatError, match=r"bare\.csv, line 1: column 2 \('force'\)"):
        granflow.read_runs(path)


def test_velocity_in_a_length_per_time_is_the_sliding_velocity_in_rad_s_the_speed():
    sliding = parse_csv("Time [s],Velocity [um/s]\n0,0.86\n").intervals[0]
    assert sliding.si("velocity").tolist() == [0.86e-6] and sliding.si("speed") is None
    rotating = parse_csv("Time [s],Velocity [rad/s]\n0,2\n").intervals[0]
    assert rotating.si("speed") == pytest.approx([1 / np.pi], rel=1e-15)


# --------------------------------------------------------------------------- point 7


@pytest.mark.parametrize("cell", ["inf", "-inf", "1e400", "-1E+400"])
def test_a_non_finite_cell_in_a_numeric_column_is_nan_with_its_line(tmp_path, cell):
    text = f"time [s],slip [m],force [N]\n0,0,0.01\n1,1e-6,{cell}\n2,2e-6,0.012\n"
    (run,) = granflow.read_runs(write(tmp_path, "inf.csv", text))
    assert np.isnan(run.force[1]) and run.force[[0, 2]].tolist() == [0.01, 0.012]
    (problem,) = run.problems
    assert "non-finite" in problem and "line 3" in problem


def test_a_non_finite_cell_in_an_instrument_export_is_nan_with_its_line():
    text = "Time [s]\tTorque [mN m]\n0\t1\n1\tinf\n2\t3\n"
    interval = parse_csv(text).intervals[0]
    assert interval.si("torque")[[0, 2]].tolist() == [1e-3, 3e-3]
    assert np.isnan(interval.si("torque")[1])


# --------------------------------------------------------------------------- point 12


def test_a_utf8_file_with_one_latin1_line_names_the_line_that_is_not_utf8(tmp_path):
    path = tmp_path / "mixed.csv"
    header = "Time [s]\tDeflection Angle [µm]\tTorque [mN m]\n".encode()
    rows = b"0\t1\t2\n1\t2\t3\n"
    path.write_bytes(header + rows + "# note: café\n".encode("latin-1") + rows)
    with pytest.raises(granflow.FileFormatError) as caught:
        granflow.read_runs(path)
    message = str(caught.value)
    assert message.startswith(f"{path}, line 4: ") and "not UTF-8" in message
    assert "Âµm" not in message


def test_a_cp1252_file_is_still_read_as_cp1252(tmp_path):
    path = tmp_path / "cp1252.csv"
    path.write_bytes("Time [s]\tTorque [µN·m]\n0\t1\n1\t2\n".encode("cp1252"))
    parsed = granflow.read(path)
    assert parsed.encoding == "cp1252"
    assert parsed.intervals[0].si("torque").tolist() == [1e-6, 2e-6]


def test_a_header_of_delimiters_only_is_an_error_naming_its_line(tmp_path):
    # found by the long fuzzing run: an export cut to nothing, one comma written into it
    path = write(tmp_path, "comma.txt", ",")
    with pytest.raises(granflow.FileFormatError, match=r"comma\.txt, line 1: the header line"):
        granflow.read_runs(path)


# --------------------------------------------------------------------------- the long fuzz run


def test_a_stray_carriage_return_before_a_quoted_cell_is_no_crash(tmp_path):
    """The long fuzz run found it: a lone carriage return inserted before the first line of
    a RheoCompass export, whose first line quotes a cell, raised the csv module's own
    error. It is a space now."""
    head = '\rProject:\t"Viscosity Curve | DESKTOP, 8/1/2019 | 1"\t\t\n'
    body = "Time [s]\tTorque [mN m]\tDeflection Angle [mrad]\n0.5\t1.25\t0.5\n1.5\t2.25\t1.5\n"
    path = write(tmp_path, "cr.txt", head + body)
    try:
        runs = granflow.read_runs(path)
    except granflow.FileFormatError as exc:
        assert str(path) in str(exc) and "line " in str(exc)
    else:
        (run,) = runs
        assert run.t.tolist() == [0.5, 1.5]


def test_a_cell_of_a_megabyte_is_quoted_cut_short(tmp_path):
    """A cell far past the csv module's field limit (128 KiB) is read as the text it is, kept
    as NaN with its line; the message quotes its first 40 characters only."""
    cell = "x" * 1_000_000
    path = write(tmp_path, "huge.csv", f't_s,slip_m,force_N\n0,"{cell}",1\n1,2,3\n')
    (run,) = granflow.read_runs(path)
    assert np.isnan(run.slip[0]) and run.slip[1] == 2.0
    (problem,) = run.problems
    assert "line 2" in problem and len(problem) < 200
