"""Bad input through the command line, tried as a user would (issue 31): a clear one-line
error naming the culprit, or a result that says what it did; never a raw exception."""

import json

import numpy as np
import pytest
from conftest import shared_data

from granflow import rsf
from granflow.cli import main


def velocity_steps(name="velstep4_BRAVA_expb819_basalt.txt"):
    return shared_data("rate-state-velocity-steps", name)


def one_line(err, command):
    assert err.startswith(f"granflow {command}: error: ") and err.count("\n") == 1, err
    assert "Traceback" not in err and "Errno" not in err, err
    return err


# --------------------------------------------------------------------------- point 4


def test_fit_rsf_on_a_real_record_scales_for_correlated_residuals_and_says_so(capsys):
    path = velocity_steps()
    assert main(["fit", str(path), "--model", "rsf", "--json"]) == 0
    payload = json.loads(capsys.readouterr().out)
    assert payload["correlated_noise"] is True
    assert payload["correlation_time"] > 10  # about 52 points on this record
    # the same interval as the API's fit with correlated_noise=True, independently run
    reference = rsf.fit(rsf.read_velocity_steps(path), correlated_noise=True)
    names = ("a", "b", "Dc")
    assert [payload["stderr"][n] for n in names] == pytest.approx(
        [reference.stderr[n] for n in names], rel=1e-9
    )
    assert main(["fit", str(path), "--model", "rsf"]) == 0
    out = capsys.readouterr().out
    assert "noise: correlated (the residuals are correlated" in out


def test_fit_rsf_white_noise_only_when_asked_and_then_warned(capsys):
    path = velocity_steps()
    assert main(["fit", str(path), "--model", "rsf", "--white-noise"]) == 0
    out = capsys.readouterr().out
    assert "noise: white (--white-noise), although the residuals are correlated" in out


def test_the_api_default_is_white_noise_and_its_message_says_the_intervals_are_narrow():
    result = rsf.fit(rsf.read_velocity_steps(velocity_steps()))
    assert result.correlated_noise is False
    assert "the intervals are too narrow" in result.message


# --------------------------------------------------------------------------- point 12


def test_fit_of_a_velocity_step_record_without_model_rsf_suggests_it(capsys):
    assert main(["fit", str(velocity_steps())]) == 2
    err = one_line(capsys.readouterr().err, "fit")
    assert "--model rsf" in err and "unit" not in err


def test_fit_rsf_reads_a_utf16_record(tmp_path, capsys):
    text = velocity_steps().read_bytes().decode("ascii").replace("\n", "\r\n")
    path = tmp_path / "utf16.txt"
    path.write_bytes(text.encode("utf-16"))
    assert main(["fit", str(path), "--model", "rsf", "--json"]) == 0
    payload = json.loads(capsys.readouterr().out)
    assert payload["record"]["step_times"] == pytest.approx([68.59], abs=0.01)
    assert np.isfinite(payload["params"]["a"])


# --------------------------------------------------------------------------- point 5


def test_fit_of_data_that_are_not_a_friction_record_exits_1_and_says_why(capsys):
    export = shared_data("instrument-exports", "rheocompass-en-utf16-shear.txt")
    assert main(["fit", str(export)]) == 1
    captured = capsys.readouterr()
    assert "success            = False" in captured.out
    assert "not a fit of these data: " in captured.out
    assert "Traceback" not in captured.err


# --------------------------------------------------------------------------- point 8


def test_fit_of_a_rheocompass_export_cut_at_three_quarters_is_no_crash(tmp_path, capsys):
    export = shared_data("instrument-exports", "rheocompass-en-utf16-shear.txt")
    raw = export.read_bytes()
    cut = tmp_path / "cut.txt"
    cut.write_bytes(raw[: 3 * len(raw) // 4])
    code = main(["fit", str(cut)])
    captured = capsys.readouterr()
    assert code in (1, 2)
    assert "OverflowError" not in captured.err and "Traceback" not in captured.err
    assert "cut short" in captured.out + captured.err


# --------------------------------------------------------------------------- point 12


def test_fit_of_a_creep_record_suggests_the_time_domain(capsys):
    export = shared_data("instrument-exports", "trios", "creep_experiment.txt")
    assert main(["fit", str(export)]) == 2
    err = one_line(capsys.readouterr().err, "fit")
    assert "--domain time" in err and "must increase strictly" not in err


def test_fit_without_an_overshoot_speaks_the_command_lines_words(tmp_path, capsys):
    flat = tmp_path / "flat.csv"
    slip = np.linspace(0.1e-6, 500e-6, 200)
    text = "slip [m],force [N]\n" + "".join(f"{x:.17g},0.01\n" for x in slip)
    flat.write_text(text, encoding="utf-8")
    assert main(["fit", str(flat)]) == 2
    err = one_line(capsys.readouterr().err, "fit")
    assert "--fix a=VALUE" in err
