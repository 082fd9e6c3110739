"""Progress bars: one per long loop when asked (or when a person watches), none when not."""

import io
import sys
import types
import warnings

import numpy as np
import pytest

import granflow as gf
from granflow import _progress
from granflow.errors import ConvergenceWarning, InvalidParameterError

P = gf.Params(a=3e-3, alpha=4e4, Fd=10e-3, x0=2e-7)


def _curves(count):
    x = np.linspace(1e-6, 5e-4, 200)
    return [(x, gf.friction_slip(x, P.replace(Fd=Fd))) for Fd in np.linspace(8e-3, 12e-3, count)]


class _Terminal(io.StringIO):
    def isatty(self):
        return True


def test_jupyter_is_told_by_its_shell(monkeypatch):
    class ZMQInteractiveShell:  # the name of IPython's shell in a Jupyter kernel
        pass

    class TerminalInteractiveShell:
        pass

    for shell, expected in ((ZMQInteractiveShell(), True), (TerminalInteractiveShell(), False)):
        fake = types.SimpleNamespace(get_ipython=lambda shell=shell: shell)
        monkeypatch.setitem(sys.modules, "IPython", fake)
        assert _progress.in_jupyter() is expected
    monkeypatch.delitem(sys.modules, "IPython")
    assert not _progress.in_jupyter()


def test_automatic_mode_follows_the_session(monkeypatch):
    # under pytest stderr is captured (not a terminal) and no Jupyter kernel runs
    assert not _progress.interactive()
    assert not _progress.wanted(None)
    assert _progress.interactive(_Terminal())
    monkeypatch.setattr(_progress, "in_jupyter", lambda: True)
    assert _progress.wanted(None)
    with _progress.silenced():
        assert not _progress.wanted(None) and not _progress.wanted(True)
    assert _progress.wanted(True) and not _progress.wanted(False)


@pytest.mark.parametrize("bad", ["yes", 1, 0.5])
def test_progress_must_be_a_bool_or_none(bad):
    with pytest.raises(InvalidParameterError, match="progress must be True, False or None"):
        gf.fit_many(_curves(1), jobs=1, progress=bad)


def test_fit_many_bar_counts_every_curve_and_keeps_the_order(capsys):
    quiet = gf.fit_many(_curves(3), jobs=1)
    assert capsys.readouterr().err == ""
    shown = gf.fit_many(_curves(3), jobs=1, progress=True)
    err = capsys.readouterr().err
    assert "fitting" in err and "3/3" in err and "curve" in err
    assert [r.params["Fd"] for r in shown] == pytest.approx([r.params["Fd"] for r in quiet])


def test_stability_map_bar(capsys):
    p = gf.Params.from_time_domain(a=3.31e-3, k=0.036, t0=0.23, Fd=10e-3, velocity=0.86e-6)
    args = (p, [10.0, 80.0], [0.99, 1.01])
    quiet = gf.stability_map(*args, velocity=0.86e-6)
    assert capsys.readouterr().err == ""
    shown = gf.stability_map(*args, velocity=0.86e-6, progress=True)
    err = capsys.readouterr().err
    assert "stability map" in err and "2/2" in err
    assert (
        shown.outcome.tolist()
        == quiet.outcome.tolist()
        == [
            ["stop", "stop"],
            ["stop", "failure"],
        ]
    )


def test_mcmc_bar_leaves_the_chain_unchanged(capsys):
    pytest.importorskip("emcee")
    x = np.linspace(P.x0, 4e-4, 200)
    y = gf.friction_slip(x, P) + np.random.default_rng(2).normal(0, 5e-5, x.size)
    least_squares = gf.fit((x, y))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ConvergenceWarning)
        plain = gf.sample_posterior(least_squares, nwalkers=8, nsteps=30, seed=5)
        assert capsys.readouterr().err == ""
        shown = gf.sample_posterior(least_squares, nwalkers=8, nsteps=30, seed=5, progress=True)
    err = capsys.readouterr().err
    assert "sampling" in err and "30/30" in err
    np.testing.assert_array_equal(plain.chain, shown.chain)


def test_run_progress_one_bar_on_a_terminal_lines_in_a_log():
    seen = []
    terminal = _Terminal()
    progress = _progress.RunProgress(False, lambda *a: seen.append(a), stream=terminal)
    # tqdm writes to sys.stderr; the terminal only decides that a bar is wanted
    progress.stage("reading")
    assert progress._bar is not None
    progress.start(3)
    for name in ("a", "b", "c"):
        progress.step(name)
    progress.finish()
    assert progress._bar is None
    assert seen == [(1, 3, "a"), (2, 3, "b"), (3, 3, "c")]
    assert "fitted" not in terminal.getvalue()
    silent = io.StringIO()
    progress = _progress.RunProgress(True, None, stream=silent)
    progress.stage("reading")
    progress.start(1)
    progress.line("a note")
    progress.step("a")
    progress.finish("report.html")
    assert silent.getvalue() == ""


def test_the_progress_covers_every_stage_by_its_weight_and_ends_with_the_report():
    log = io.StringIO()
    progress = _progress.RunProgress(False, None, stream=log)
    shares = dict(_progress.STAGES)
    assert sum(shares.values()) == pytest.approx(100.0)
    progress.stage("reading")
    progress.start(2)
    progress.step("a")
    progress.step("b")
    after_runs = progress.percent
    assert after_runs == pytest.approx(shares["reading"] + shares["runs"])
    for name in ("joint analyses, predictions and forecasts", "tables", "figures", "report"):
        progress.stage(name)
    assert progress.percent < 100.0  # the report is still being written
    progress.finish("out/report.html")
    lines = log.getvalue().splitlines()
    # reading has no line of its own in a log: a bad manifest is then a one-line error
    assert lines[0] == f"[{shares['reading']:3.0f}%] runs"
    assert lines[1] == f"[{shares['reading'] + shares['runs'] / 2:3.0f}%] fitted 1/2: a"
    assert lines[-2].endswith("] report") and lines[-1] == "[100%] report: out/report.html"
    percents = [float(line[1:4]) for line in lines]
    assert percents == sorted(percents)  # it never goes back
