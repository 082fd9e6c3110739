"""Every figure of the report: drawn once, in the formats asked for, with mathtext labels
and units, and no text outside its frame (matplotlib's tight bounding box)."""

import pickle
import re

import pytest
from conftest import write_small_campaign

import granflow.plotting
from granflow.analysis import analyze, figures
from granflow.errors import InvalidParameterError
from granflow.plotting.files import check_formats

#: A symbol written with an underscore outside mathtext ("F_d", "μ_a").
_LITERAL_SUBSCRIPT = re.compile(r"[A-Za-zμτ]_[A-Za-z0-9]")


def _outside_mathtext(text):
    return re.sub(r"\$[^$]*\$", "", text)


def _labels(figure):
    for ax in figure.axes:
        for text in (ax.get_xlabel(), ax.get_ylabel()):
            if text:
                yield ax, text


def _legend_boxes(figure):
    """(axes box, legend box) in display pixels of each legend that overlaps its axes."""
    renderer = figure.canvas.get_renderer()
    for ax in figure.axes:
        legend = ax.get_legend()
        if legend is None:
            continue
        box, frame = legend.get_window_extent(renderer), ax.get_window_extent(renderer)
        if box.y0 < frame.y1 - 1:  # inside the axes, not a legend above them
            yield (frame.x0, frame.y0, frame.x1, frame.y1), (box.x0, box.y0, box.x1, box.y1)


def _overlap(a, b, margin=1.0):
    """Whether two boxes (x0, y0, x1, y1) share more than ``margin`` pixels each way."""
    return min(a[2], b[2]) - max(a[0], b[0]) > margin and min(a[3], b[3]) - max(a[1], b[1]) > margin


def _legend_covers(figure):
    """What each legend covers that it must not: another axes (an inset, a neighbouring
    panel) or a text drawn in the axes (a label such as "runaway")."""
    renderer = figure.canvas.get_renderer()
    found = []
    for ax in figure.axes:
        legend = ax.get_legend()
        if legend is None:
            continue
        box = legend.get_window_extent(renderer).extents
        own = ax.get_window_extent(renderer).extents
        insets = [child for parent in figure.axes for child in parent.child_axes]
        for other in [*figure.axes, *insets]:
            extent = other.get_window_extent(renderer).extents
            if other is ax or tuple(extent) == tuple(own):  # itself or its twin
                continue
            if other.get_visible() and other.axison and _overlap(box, extent):
                found.append(f"axes {other.get_label() or other.get_title()!r}")
        twins = [
            a for a in figure.axes if tuple(a.get_window_extent(renderer).extents) == tuple(own)
        ]
        for text in (text for twin in twins for text in twin.texts):
            shown = text.get_text().strip() and text.get_visible()
            if shown and _overlap(box, text.get_window_extent(renderer).extents):
                found.append(f"text {text.get_text()!r}")
    return found


@pytest.fixture(scope="module")
def drawn(tmp_path_factory):
    """Analyse the small campaign, checking each figure as it is saved."""
    directory = tmp_path_factory.mktemp("figures")
    return _analyse_checking(write_small_campaign(directory / "campaign"), directory / "out")


def _analyse_checking(manifest, out):
    seen = {}
    original = granflow.plotting.save_figure

    def checking(figure, folder, stem, formats=("png", "svg")):
        figure.canvas.draw()
        box = figure.get_tightbbox(figure.canvas.get_renderer())
        width, height = figure.get_size_inches()
        seen.setdefault(stem, []).append(
            {
                "box": (box.x0, box.y0, box.x1, box.y1),
                "size": (width, height),
                "labels": list(_labels(figure)),
                "legends": list(_legend_boxes(figure)),
                "covered": _legend_covers(figure),
                "formats": tuple(formats),
            }
        )
        return original(figure, folder, stem, formats)

    draw = figures.draw_figure

    def picklable(job):  # each figure can be drawn in another process
        copy = pickle.loads(pickle.dumps(job))
        assert copy.draw is job.draw and copy.name == job.name
        return draw(job)

    patch = pytest.MonkeyPatch()
    patch.setattr(granflow.plotting, "save_figure", checking)
    patch.setattr(figures, "draw_figure", picklable)
    try:
        result = analyze(manifest, out, jobs=1, quiet=True)
    finally:
        patch.undo()
    return result, seen


def test_every_figure_is_drawn_once_as_png(drawn):
    result, seen = drawn
    names = [figure["name"] for figure in result.results["figures"]]
    assert {"startup", "collapse", "amontons", "fits", "stress_ramp", "creep", "switch"} <= set(
        names
    )
    assert {"stability_map", "fig2", "fig3"} <= set(names)
    assert sorted(seen) == sorted(names)
    assert all(len(calls) == 1 and calls[0]["formats"] == ("png",) for calls in seen.values())
    files = sorted(p.suffix for p in (result.output / "figures").iterdir())
    assert set(files) == {".png"} and len(files) == len(names)


def test_no_text_outside_any_frame(drawn):
    _, seen = drawn
    for name, (call,) in seen.items():
        x0, y0, x1, y1 = call["box"]
        width, height = call["size"]
        tolerance = 0.02  # inch
        assert x0 >= -tolerance and y0 >= -tolerance, (name, call["box"], call["size"])
        assert x1 <= width + tolerance and y1 <= height + tolerance, (name, call["box"])


def test_legends_inside_the_axes_stay_inside_their_frame(drawn):
    _, seen = drawn
    checked = 0
    for name, (call,) in seen.items():
        for frame, box in call["legends"]:
            checked += 1
            assert box[0] >= frame[0] - 1 and box[2] <= frame[2] + 1, (name, frame, box)
            assert box[1] >= frame[1] - 1 and box[3] <= frame[3] + 1, (name, frame, box)
    assert checked >= 3  # the Amontons panels at least


def test_no_legend_covers_an_inset_a_panel_or_a_label(drawn):
    """A legend placed in a busy panel once hid Fig. 3b's creep inset (and, on the demo, Fig.
    3a's "runaway" label): the publication Fig. 3 gathers its panels' legends in one key."""
    _, seen = drawn
    assert "fig3" in seen
    covered = {name: call["covered"] for name, (call,) in seen.items() if call["covered"]}
    assert covered == {}


def test_axis_labels_carry_units_in_mathtext(drawn):
    _, seen = drawn
    for name, (call,) in seen.items():
        assert call["labels"], name
        for _, text in call["labels"]:
            assert "[" in text and "]" in text, (name, text)  # a unit
            assert not _LITERAL_SUBSCRIPT.search(_outside_mathtext(text)), (name, text)


def test_figure_formats_are_checked(tmp_path):
    assert check_formats("png, SVG,pdf") == ("png", "svg", "pdf")
    assert check_formats(["pdf", "pdf"]) == ("pdf",)
    for bad in ("gif", [], "png,jpeg"):
        with pytest.raises(InvalidParameterError, match="png, svg, pdf"):
            check_formats(bad)
    import matplotlib.pyplot as plt

    figure, ax = plt.subplots()
    ax.plot([0, 1], [0, 1])
    paths = granflow.plotting.save_figure(figure, tmp_path, "line", ("pdf",))
    plt.close(figure)
    assert list(paths) == ["pdf"] and paths["pdf"].read_bytes().startswith(b"%PDF")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["line.pdf"]
    with pytest.raises(InvalidParameterError, match="figure_formats"):
        analyze(tmp_path / "nothing.yaml", tmp_path / "out", figure_formats=("tiff",))


def test_every_fit_is_on_a_page_of_at_most_48_panels_and_none_is_lost():
    from types import SimpleNamespace

    startups = [SimpleNamespace(fit=f"fit {i}", name=f"run{i}") for i in range(100)]
    jobs = figures._fit_pages(startups)
    assert [job.name for job in jobs] == ["fits", "fits_2", "fits_3"]
    assert [len(job.inputs["fits"]) for job in jobs] == [48, 48, 4]
    assert [n for job in jobs for n in job.inputs["names"]] == [s.name for s in startups]
    assert "runs 97–100 of 100" in jobs[2].caption and "page 3 of 3" in jobs[2].title
    (single,) = figures._fit_pages(startups[:48])
    assert single.name == "fits" and single.title == "Every start-up fit"
