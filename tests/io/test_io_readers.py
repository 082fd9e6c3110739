"""The readers on the real exports in shared/data/instrument-exports and on small texts.

Expected values are copied from the files by hand (spot checks), not from the reader.
"""

import numpy as np
import pytest
from conftest import shared_data

import granflow
from granflow.io import parse_csv, parse_rheocompass, parse_rheoplus, parse_trios
from granflow.io._text import NumberFormat, decode, sniff_numbers


def export(name):
    return shared_data("instrument-exports", name)


def test_utf16_shear_file_columns_units_and_values():
    parsed = granflow.read(export("rheocompass-en-utf16-shear.txt"))
    assert (parsed.format, parsed.encoding, parsed.delimiter) == ("rheocompass", "utf-16", "\t")
    assert parsed.tests == ("Test",)
    (interval,) = parsed.intervals
    assert interval.rows == 20
    names = [column.name for column in interval.columns]
    units = [column.unit for column in interval.columns]
    assert names == [
        "Point No.",
        "Time",
        "Shear Rate",
        "Shear Stress",
        "Viscosity",
        "Torque",
        "Status",
    ]
    assert units == ["", "s", "1/s", "Pa", "mPa·s", "mN·m", ""]
    # line 9 of the file: 1  6.0  50  3608.4  72195  3.5868
    assert interval.si("torque")[0] == pytest.approx(3.5868e-3, rel=1e-15)
    assert interval.si("time")[-1] == 120.0
    assert interval.values[3][17] == 3448.0
    assert parsed.metadata["project"] == "Shear Test | DESKTOP-4HEH0CM, 2/24/2020 | 2"


def test_multiple_tests_split_into_intervals_with_point_numbers_restarting():
    parsed = granflow.read(export("rheocompass-en-utf16-multiple-tests.csv"))
    assert parsed.tests == ("Stress Relaxation 1", "Stress Relaxation")
    assert [interval.rows for interval in parsed.intervals] == [451, 155]
    second = parsed.intervals[1]
    assert second.values[0][0] == 1.0  # point numbers restart
    assert second.si("torque")[0] == pytest.approx(-0.040448e-3, rel=1e-14)
    assert second.si("time")[-1] == pytest.approx(42.458)
    status = second.columns.index(next(c for c in second.columns if c.quantity == "status"))
    assert set(second.text[status]) == {"Dy_auto"}
    assert second.metadata["result"] == "Step strain 1"
    runs = granflow.read_runs(export("rheocompass-en-utf16-multiple-tests.csv"))
    assert [run.meta["interval"] for run in runs] == [1, 2]
    assert runs[1].meta["test"] == "Stress Relaxation"


def test_viscosity_curve_micro_newton_metre_and_meaning_row():
    parsed = granflow.read(export("rheocompass-en-utf16-viscosity-curve.csv"))
    assert len(parsed.intervals) == 11
    assert all(interval.rows == 25 for interval in parsed.intervals)
    first = parsed.intervals[0]
    torque = next(column for column in first.columns if column.quantity == "torque")
    assert torque.unit == "µN·m"
    assert first.si("torque")[2] == pytest.approx(-0.002733e-6, rel=1e-14)
    assert first.values[3][2] == pytest.approx(-8.3392e-05, rel=1e-15)
    assert (first.columns[1].name, first.columns[1].meaning) == ("Time", "Constant component")
    assert parsed.intervals[-1].si("torque")[-1] == pytest.approx(120.21e-6, rel=1e-14)


def test_spreadsheet_resaved_cp1252_file_is_read():
    parsed = granflow.read(export("rheocompass-en-cp1252-excel-resaved.txt"))
    assert parsed.encoding == "cp1252"
    assert len(parsed.intervals) == 12
    assert [interval.rows for interval in parsed.intervals] == [25] * 12
    torque = next(c for c in parsed.intervals[0].columns if c.quantity == "torque")
    assert torque.unit == "µN·m"
    assert parsed.intervals[-1].si("torque")[-1] == pytest.approx(143.88e-6, rel=1e-14)
    assert parsed.metadata["project"] == "Viscosity Curve | DESKTOP-4HEH0CM, 8/1/2019 | 1"


def test_rheoplus_series_missing_markers_and_units():
    parsed = granflow.read(export("rheoplus-en-utf8-stress-relaxation.txt"))
    assert parsed.format == "rheoplus"
    assert [interval.rows for interval in parsed.intervals] == [100, 100, 100, 99, 100, 100]
    first = parsed.intervals[0]
    assert first.test == "5perc 8arm 10kDa PEGMAL + 2kDa PEGSH sample 1 day 0 sr 1"
    assert np.isnan(first.values[1]).all()  # Angular Frequency: ******
    assert any(
        "Angular Frequency" in problem and "100 missing" in problem for problem in first.problems
    )
    assert first.si("torque")[0] == pytest.approx(-1.51e-3, rel=1e-14)  # -1.51E+3 µNm
    assert first.si("angle")[0] == pytest.approx(1.14e-3, rel=1e-14)  # 1.14E0 mrad
    assert first.metadata["Norm. Css [Pa/mNm]"] == 9945.692  # thousands comma in the header
    assert first.metadata["profile"] == "Strain gamma = 1 %"
    assert parsed.intervals[3].metadata["declared_points"] == 99
    runs = granflow.read_runs(export("rheoplus-en-utf8-stress-relaxation.txt"))
    tube = granflow.Annulus.paper()
    assert runs[0].slip[0] == 0.0
    assert runs[0].slip[1] == pytest.approx((1.77e-3 - 1.14e-3) * tube.mean_radius, rel=1e-12)
    assert runs[0].force[0] == pytest.approx(-1.51e-3 / tube.effective_radius, rel=1e-12)
    assert np.isnan(runs[0].velocity).all()  # no speed column
    assert runs[0].control == "rate"  # the profile imposes a strain


def test_every_export_gives_runs_with_source_and_interval():
    for path in sorted(shared_data("instrument-exports").glob("*.*")):
        if path.suffix == ".md":
            continue
        runs = granflow.read_runs(path)
        assert runs, path
        for ordinal, run in enumerate(runs, start=1):
            assert run.meta["source"] == str(path)
            assert run.meta["interval"] == ordinal
            assert run.control in ("rate", "stress")


def test_decimal_comma_semicolon_csv_and_quoted_fields():
    text = 'Time [s];Torque [mN·m];Note\n0,5;1,25;"a;b"\n1,5;1 ;c\n'
    parsed = parse_csv(text)
    assert (parsed.delimiter, parsed.decimal) == (";", ",")
    torque = parsed.intervals[0].si("torque")
    assert torque[0] == pytest.approx(1.25e-3)
    assert torque[1] == pytest.approx(1e-3)
    assert parsed.intervals[0].text[2].tolist() == ["a;b", "c"]


def test_missing_markers_become_nan_and_are_reported():
    text = "Time [s]\tTorque [mN m]\n1\t******\n2\t \n3\t\n4\t1.5\n"
    interval = parse_csv(text).intervals[0]
    torque = interval.si("torque")
    assert np.isnan(torque[:3]).all() and torque[3] == pytest.approx(1.5e-3)
    assert any(
        "3 missing values" in problem and "line 2" in problem for problem in interval.problems
    )


def test_invalid_cells_become_nan_with_their_line():
    text = "Time [s]\tTorque [mN m]\n1\t1.0\n2\tabc\n3\t2.0\n4\t3.0\n"
    interval = parse_csv(text).intervals[0]
    assert np.isnan(interval.si("torque")[1])
    assert any("'abc' at line 3" in problem for problem in interval.problems)


@pytest.mark.parametrize(
    ("cells", "expected"),
    [
        (["0,0073", "12"], NumberFormat(",", None)),
        (["1,5E+3"], NumberFormat(",", None)),
        (["12.5", "3"], NumberFormat(".", None)),
        (["9,945.692", "1.5"], NumberFormat(".", ",")),
        (["1.234,5"], NumberFormat(",", ".")),
        (["1,234", "17"], NumberFormat(".", None)),  # ambiguous alone: dot, no thousands
    ],
)
def test_number_format_is_decided_from_the_data(cells, expected):
    assert sniff_numbers([(1, cells)], "\t", "f.txt") == expected


def test_mixed_decimal_marks_are_an_error_naming_both_lines():
    with pytest.raises(granflow.FileFormatError, match=r"line 3.*line 7"):
        sniff_numbers([(3, ["0,5"]), (7, ["0.25"])], "\t", "f.txt")


def test_unknown_unit_is_an_error_that_names_it():
    text = "Time [s]\tTorque [furlongs]\n1\t2\n"
    with pytest.raises(granflow.FileFormatError, match=r"line 1.*'furlongs'"):
        parse_csv(text, source="x.csv")


@pytest.mark.parametrize(
    ("unit", "factor"),
    [("µN·m", 1e-6), ("mN·m", 1e-3), ("µNm", 1e-6), ("N m", 1.0), ("µN.m", 1e-6)],
)
def test_torque_units(unit, factor):
    interval = parse_csv(f"Time [s]\tTorque [{unit}]\n1\t2.5\n").intervals[0]
    assert interval.si("torque")[0] == pytest.approx(2.5 * factor, rel=1e-15)


@pytest.mark.parametrize(
    ("quantity", "label", "unit", "si"),
    [
        ("speed", "Rotational Speed", "1/min", 2.5 / 60),
        ("speed", "Drehzahl", "1/s", 2.5),
        ("speed", "Vitesse de Rotation", "rad/s", 2.5 / (2 * np.pi)),
        ("angle", "Auslenkwinkel", "mrad", 2.5e-3),
        ("angle", "Angle de Déflexion", "°", 2.5 * np.pi / 180),
        ("time", "Zeit", "min", 150.0),
        ("normal_force", "Force Normale", "mN", 2.5e-3),
        ("normal_force", "Normalkraft", "N", 2.5),
    ],
)
def test_localized_labels_and_units(quantity, label, unit, si):
    interval = parse_csv(f"n\t{label} [{unit}]\n1\t2.5\n").intervals[0]
    assert interval.si(quantity)[0] == pytest.approx(si, rel=1e-14)


def test_rheocompass_french_labels_parse():
    text = (
        "Projet:\tP\nTest:\tessai\nIntervalle et points de données:\t1\t2\n"
        "Données d'intervalle:\tN° de point\tTemps\tCouple\tAngle de Déflexion\n"
        "\t\t\t\t\n\t\t[s]\t[µN·m]\t[mrad]\n\t1\t0,5\t12,5\t0,25\n\t2\t1,5\t13,5\t0,75\n"
    )
    interval = parse_rheocompass(text).intervals[0]
    assert interval.si("torque").tolist() == pytest.approx([12.5e-6, 13.5e-6], rel=1e-14)
    assert interval.si("angle").tolist() == pytest.approx([0.25e-3, 0.75e-3], rel=1e-14)


def test_trios_and_rheoplus_parsers_from_text():
    trios = parse_trios("Filename\tx\n[step]\nhold\nStep time\tTorque\ns\tmN.m\n1\t2\n\n")
    assert trios.intervals[0].si("torque")[0] == pytest.approx(2e-3)
    plus = parse_rheoplus(
        "Data Series Information\nName:\t\t\td\n\nMeas. Pts.\tTime\n\t[min]\n1\t2E0\n"
    )
    assert plus.intervals[0].si("time")[0] == 120.0


def test_encodings_are_detected_from_bytes():
    text = "Time [s]\tTorque [µN·m]\n1\t2\n"
    for encoding, raw in [
        ("utf-16", b"\xff\xfe" + text.encode("utf-16-le")),
        ("utf-16", b"\xfe\xff" + text.encode("utf-16-be")),
        ("utf-8-sig", text.encode("utf-8-sig")),
        ("utf-8", text.encode("utf-8")),
        ("cp1252", text.encode("cp1252")),
    ]:
        decoded, found, problems = decode(raw, "f.txt")
        assert (decoded, found, problems) == (text, encoding, [])


def test_stress_control_told_from_constant_torque():
    rows = "\n".join(f"{t}\t{0.1 + 0.05 * t}\t2.0" for t in range(1, 11))
    text = f"Time [s]\tRotational Speed [1/min]\tTorque [mN m]\n{rows}\n"
    parsed = parse_csv(text)
    assert granflow.io.control_mode(parsed.intervals[0]) == "stress"


def test_read_missing_file_is_a_file_format_error(tmp_path):
    with pytest.raises(granflow.FileFormatError, match="cannot read"):
        granflow.read(tmp_path / "nothing.txt")


def test_report_and_to_dict(tmp_path):
    parsed = granflow.read(export("rheocompass-en-utf16-shear.txt"))
    report = parsed.report()
    assert "utf-16" in report and "Torque [mN·m] -> torque" in report and "20 rows" in report
    import json

    summary = json.loads(json.dumps(parsed.to_dict()))
    assert summary["intervals"][0]["rows"] == 20


def test_a_tidy_table_maps_slip_and_force_and_leaves_the_other_columns_alone():
    # "Velocity" is a vendor label of the rotational speed; in um/s it is the sliding
    # velocity. With only_mapped the column is read as it is, not interpreted
    text = "time_s,slip [um],force [mN],velocity [um/s]\n1,2.5,3.5,1\n2,5.0,4.0,1\n"
    parsed = parse_csv(
        text,
        column_map={"time": "time_s", "slip": "slip", "force": "force"},
        units={"time_s": "s"},
        only_mapped=True,
    )
    interval = parsed.intervals[0]
    assert interval.si("slip").tolist() == [2.5e-6, 5e-6]  # um -> m by hand
    assert interval.si("force").tolist() == [3.5e-3, 4e-3]
    assert interval.si("time").tolist() == [1.0, 2.0]
    assert [column.quantity for column in interval.columns] == ["time", "slip", "force", None]
    recognised = parse_csv(text).intervals[0]  # by their labels and units (issue 31, 6b)
    assert recognised.si("velocity").tolist() == [1e-6, 1e-6]
    assert recognised.si("slip").tolist() == [2.5e-6, 5e-6]


def test_runs_take_mapped_slip_and_force_columns_as_they_are(tmp_path):
    # a plain table with slip and force (no torque, no angle): the mapped columns are the
    # run's slip and force, converted by hand from um and mN, whatever the geometry
    path = tmp_path / "plain.csv"
    path.write_text("time [s],force [mN],slip [um]\n0,0,0\n1,5,0.86\n2,8,1.72\n")
    for geometry in (granflow.Annulus.paper(), granflow.Annulus.from_spec("paper")):
        (run,) = granflow.read_runs(
            path, geometry=geometry, column_map={"force": "force", "slip": "slip"}
        )
        assert run.force.tolist() == [0.0, 5e-3, 8e-3]
        assert run.slip.tolist() == pytest.approx([0.0, 0.86e-6, 1.72e-6], rel=1e-15)
        assert run.t.tolist() == [0.0, 1.0, 2.0]


def test_slip_and_force_are_recognised_by_name_and_unit_never_by_name_alone():
    interval = parse_csv("slip [um],force [mN]\n1,2\n").intervals[0]
    assert interval.si("slip").tolist() == [1e-6] and interval.si("force").tolist() == [2e-3]
    with pytest.raises(granflow.FileFormatError, match=r"line 1: column 1 \('slip'\).*no unit"):
        parse_csv("slip,force [mN]\n1,2\n")


def test_strict_tables_refuse_a_non_numeric_cell_naming_its_line():
    text = "time [s],force [mN]\n1,2\n2,abc\n3,4\n4,5\n"
    with pytest.raises(granflow.FileFormatError, match=r"line 3: column 2 \('force'\)") as caught:
        parse_csv(text, source="x.csv", column_map={"force": "force"}, strict=True)
    assert "abc" not in str(caught.value)  # a cell is named by its line, never copied
    assert np.isnan(parse_csv(text, column_map={"force": "force"}).intervals[0].si("force")[1])


def test_column_map_errors_name_the_column_and_the_quantity():
    with pytest.raises(granflow.FileFormatError, match="'M' of the column map"):
        parse_csv("t,F\n1,2\n", column_map={"torque": "M"})
    with pytest.raises(granflow.FileFormatError, match="unknown quantity 'mass'"):
        parse_csv("t,F\n1,2\n", column_map={"mass": "F"})


def test_every_reader_reads_a_file_like_its_parser(tmp_path):
    from granflow.io import read_csv, read_rheocompass, read_rheoplus, read_trios

    parsed = read_rheocompass(export("rheocompass-en-utf16-shear.txt"))
    assert parsed.encoding.startswith("utf-16") and parsed.intervals[0].rows == 20
    table = tmp_path / "t.csv"
    table.write_bytes("t;M\n1;2,5\n".encode("utf-16"))
    parsed = read_csv(table, column_map={"torque": "M"}, units={"M": "mN m"})
    assert parsed.source == str(table) and parsed.intervals[0].si("torque")[0] == 2.5e-3
    trios = tmp_path / "t.txt"
    trios.write_text("Filename\tdemo\n[step]\nhold\nStep time\tTorque\ns\tµN.m\n1\t2.5\n")
    assert read_trios(trios).intervals[0].si("torque")[0] == pytest.approx(2.5e-6)
    plus = tmp_path / "p.txt"
    plus.write_bytes(
        "Data Series Information\nMeas. Pts.\tTime\tTorque\n\t[s]\t[µNm]\n1\t1\t5\n".encode(
            "cp1252"
        )
    )
    parsed = read_rheoplus(plus)
    assert parsed.encoding == "cp1252" and parsed.intervals[0].si("torque")[0] == 5e-6


def test_the_column_units_come_from_the_one_unit_table():
    from granflow.io import _columns
    from granflow.model.units import si_unit

    for quantity, unit in _columns.SI_UNITS.items():
        assert unit is None or unit == si_unit(quantity)
    assert _columns.SI_UNITS["torque"] == "N m" and _columns.SI_UNITS["status"] is None
