"""Bad input through the command line, tried as a user would (issue 31): a clear one-line
error naming the culprit, or a result that says what it did; never a raw exception."""

import contextlib
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from conftest import shared_data

import granflow
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


# --------------------------------------------------------------------------- point 10

_MEASURED = """
import sys
from granflow.cli import main
code = main(sys.argv[1:])
status = open("/proc/self/status").read()
print("exit", code, "VmHWM", status.split("VmHWM:")[1].split()[0])
"""

_BLOCKED_JOINT = """
import sys
import granflow.analysis.engine as engine
joint_stage = engine.joint_stage
def blocked(*args, **kwargs):
    with open({barrier!r}, encoding="utf-8") as barrier:
        barrier.read()
    return joint_stage(*args, **kwargs)
engine.joint_stage = blocked
from granflow.cli import main
sys.exit(main(sys.argv[1:]))
"""


@pytest.fixture(scope="module")
def twelve_thousand(tmp_path_factory):
    """A campaign folder whose manifest has 12 000 short entries naming three runs."""
    from conftest import write_small_campaign

    folder = tmp_path_factory.mktemp("large")
    write_small_campaign(folder)
    lines = ["runs:"]
    lines += [
        f"  - {{file: startup_30mN.txt, interval: {1 + i % 3}, normal_load: 30 mN}}"
        for i in range(12_000)
    ]
    (folder / "manifest.yaml").write_text("\n".join(lines) + "\n", encoding="utf-8")
    return folder


def _granflow_env():
    return {**os.environ, "PYTHONPATH": str(Path(granflow.__file__).resolve().parents[1])}


@pytest.mark.slow
@pytest.mark.skipif(
    not Path("/proc/self/status").is_file(), reason="reads the peak memory from /proc (Linux)"
)
def test_analyze_on_twelve_thousand_entries_stays_under_one_gigabyte(twelve_thousand, tmp_path):
    done = subprocess.run(
        [sys.executable, "-c", _MEASURED, "analyze", str(twelve_thousand), "-o",
         str(tmp_path / "out"), "--jobs", "1", "--quiet"],
        capture_output=True, text=True, timeout=1200, env=_granflow_env(), check=False,
    )  # fmt: skip
    last = done.stdout.strip().splitlines()[-1].split()
    assert last[:2] == ["exit", "1"], done.stderr  # the repeats failed, named
    assert "campaign: 12000 runs, 3 analysed, 11997 failed" in done.stdout
    assert int(last[3]) < 1024 * 1024, last  # peak resident memory [KiB] under 1 GB


@pytest.mark.slow
@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="needs named pipes (POSIX)")
def test_sigterm_stops_the_analysis_of_twelve_thousand_entries(twelve_thousand, tmp_path):
    barrier = tmp_path / "barrier"
    os.mkfifo(barrier)
    output = tmp_path / "out"
    process = subprocess.Popen(
        [sys.executable, "-c", _BLOCKED_JOINT.format(barrier=str(barrier)), "analyze",
         str(twelve_thousand), "-o", str(output), "--jobs", "1", "--quiet"],
        env=_granflow_env(), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    try:
        # a guard against a hang, not a timing assumption: the process blocks at the joint
        # stage, after its three runs are saved, until the pipe is opened
        deadline = time.monotonic() + 900
        while len(list((output / "runs").glob("*.json"))) < 3:
            assert process.poll() is None, process.communicate()
            assert time.monotonic() < deadline
            time.sleep(0.05)
        process.send_signal(signal.SIGTERM)
    finally:
        # the signal may already have taken the reader out of open(): nothing to release
        with contextlib.suppress(OSError):
            os.close(os.open(barrier, os.O_WRONLY | os.O_NONBLOCK))
    _, err = process.communicate(timeout=600)
    assert process.returncode == 130, err
    assert "interrupted" in err and "Traceback" not in err


# --------------------------------------------------------------------------- point 9


@pytest.fixture(scope="module")
def small_campaign(tmp_path_factory):
    from conftest import write_small_campaign

    return write_small_campaign(tmp_path_factory.mktemp("small")).parent


@pytest.mark.parametrize(
    "command",
    [
        ["analyze", "{campaign}", "-o", "{blocked}/out", "--jobs", "1", "--quiet"],
        ["demo", "-o", "{blocked}/demo", "--quiet"],
        [
            "curve",
            "--a",
            "3mN",
            "--Fd",
            "10mN",
            "--alpha",
            "4e4/m",
            "--x0",
            "0.2um",
            "-o",
            "{blocked}/curve.csv",
        ],
        ["convert", "{campaign}/ramp.txt", "-o", "{blocked}/tidy.csv"],
    ],
    ids=["analyze", "demo", "curve", "convert"],
)
def test_an_output_that_cannot_be_written_is_a_sentence_before_any_work(
    small_campaign, tmp_path, capsys, command
):
    blocked = tmp_path / "a-file"
    blocked.write_text("not a folder", encoding="utf-8")
    argv = [word.format(campaign=small_campaign, blocked=blocked) for word in command]
    assert main(argv) == 2
    err = one_line(capsys.readouterr().err, command[0])
    assert str(blocked) in err and "cannot write" in err and "not a folder" in err
    assert blocked.read_text(encoding="utf-8") == "not a folder"  # nothing touched


def test_a_folder_the_system_refuses_is_named_with_the_reason(
    small_campaign, tmp_path, capsys, monkeypatch
):
    import errno

    import granflow._files

    def refuse(folder):
        raise PermissionError(errno.EPERM, "Operation not permitted", str(folder))

    monkeypatch.setattr(granflow._files, "_probe", refuse)
    out = tmp_path / "out"
    assert main(["analyze", str(small_campaign), "-o", str(out), "--jobs", "1", "--quiet"]) == 2
    err = one_line(capsys.readouterr().err, "analyze")
    assert f"{out}: cannot write the output folder (operation not permitted)" in err
    with pytest.raises(granflow.OutputError, match="operation not permitted"):
        granflow.analyze(small_campaign, out, jobs=1, quiet=True)


# --------------------------------------------------------------------------- point 12


@pytest.mark.slow
def test_a_joint_fit_that_fails_makes_the_exit_code_1_and_leaks_no_numpy_warning(
    small_campaign, tmp_path, capsys
):
    # every run declared at one huge load (9 MN): the single-load joint fit over runs of
    # three real loads cannot hold one Fd, and is no fit
    manifest = small_campaign / "manifest.yaml"
    text = manifest.read_text(encoding="utf-8")
    for load in ("30 mN", "60 mN", "90 mN"):
        text = text.replace(load, "9e6 N")
    (tmp_path / "campaign").mkdir()
    for path in small_campaign.glob("*.txt"):
        (tmp_path / "campaign" / path.name).write_bytes(path.read_bytes())
    (tmp_path / "campaign" / "manifest.yaml").write_text(text, encoding="utf-8")
    out = tmp_path / "out"
    code = main(["analyze", str(tmp_path / "campaign"), "-o", str(out), "--jobs", "1", "--quiet"])
    captured = capsys.readouterr()
    assert code == 1
    assert "joint analysis failed" in captured.out
    assert "RuntimeWarning" not in captured.err and "overflow" not in captured.err
