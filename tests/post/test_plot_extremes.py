"""Every time history marks its extreme (the largest |value|) with its value: what a reader
looks for first (issue 29: "extremes marked")."""

import numpy as np

from pipeline.post.plots import Curve, Panel, panels_figure


def _marks(ax):
    return [line for line in ax.lines if line.get_label() == "_extreme"]


def test_each_history_marks_its_largest_magnitude_with_its_value():
    t = np.linspace(0.0, 2.0, 201)
    down = Curve("sag", t, -3.0 * np.sin(np.pi * t / 2.0) ** 2)  # -3.0 at t = 1
    up = Curve("lift", t, 1.5 * t)  # 3.0 at t = 2 (its end)
    fig = panels_figure([Panel("two", "time, s", "m", [down, up])])
    ax = fig.axes[0]
    marks = _marks(ax)
    assert [(m.get_xdata()[0], m.get_ydata()[0]) for m in marks] == [(1.0, -3.0), (2.0, 3.0)]
    assert [m.get_color() for m in marks] == [line.get_color() for line in ax.lines[:2]]
    texts = [a.get_text() for a in ax.texts]
    assert texts == ["-3 at 1 s", "3 at 2 s"]
    # the legend lists the curves, not the marks
    assert [x.get_text() for x in ax.get_legend().get_texts()] == ["sag", "lift"]


def test_many_curves_keep_their_marks_but_not_their_labels():
    t = np.linspace(0.0, 1.0, 50)
    curves = [Curve(f"c{k}", t, (k + 1) * t) for k in range(5)]
    ax = panels_figure([Panel("many", "time, s", "N", curves)]).axes[0]
    assert len(_marks(ax)) == 5 and not ax.texts  # five labels would hide the lines


def test_a_curve_that_stays_at_zero_has_no_extreme():
    t = np.linspace(0.0, 1.0, 50)
    ax = panels_figure([Panel("rigid", "time, s", "J", [Curve("elastic", t, 0 * t)])]).axes[0]
    assert not _marks(ax) and not ax.texts


def test_bars_and_paths_are_left_as_they_are():
    one = [Curve("a", np.array([0.0]), np.array([2.0])), Curve("b", np.array([0.0]),
                                                                  np.array([1.0]))]
    ax = panels_figure([Panel("cases", "", "m", one)]).axes[0]
    assert not _marks(ax)
    s = np.linspace(0, 2 * np.pi, 40)
    path = Curve("tip", np.cos(s), np.sin(s))
    ax = panels_figure([Panel("path", "x, m", "y, m", [path], equal=True)]).axes[0]
    assert not _marks(ax)  # a path's x is not time: no extreme of a history


def test_a_large_value_is_written_whole_not_with_an_exponent():
    """A stroke of 1227 mm read "1.23e+03 at 1.5 s" on the excavator's plot."""
    t = np.linspace(0.0, 1.5, 31)
    ax = panels_figure([Panel("BCYL.d", "time, s", "mm", [Curve("d", t, 1195 + 21.5 * t ** 2),
                                                         ])]).axes[0]
    assert [a.get_text() for a in ax.texts] == ["1243 at 1.5 s"]
    ax = panels_figure([Panel("p", "time, s", "Pa", [Curve("p", t, 2.5e7 * t)])]).axes[0]
    assert [a.get_text() for a in ax.texts] == ["3.75e+07 at 1.5 s"]
