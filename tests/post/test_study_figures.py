"""A study's charts as Figures for a notebook (issue 29, item 5): ``convergence_figure``
and ``outputs_figure`` return the matplotlib Figure that ``plot_convergence`` and
``plot_outputs`` write, with no pyplot and no backend set."""

from __future__ import annotations

import numpy as np
from PIL import Image

from pipeline import api
from pipeline.post.plots import save_figure
from pipeline.post.study_plot import (
    convergence_figure,
    outputs_figure,
    plot_convergence,
    plot_outputs,
)


def test_the_convergence_figure_is_the_chart_written(tmp_path):
    labels = ["2 modes", "4 modes", "8 modes"]
    relative = {"q:J1.theta": [3.8e-3, 2.2e-4, 0.0], "tip:y": [2.2e-2, np.nan, 0.0]}
    fig = convergence_figure(labels, relative, reference="8 modes")
    ax = fig.axes[0]
    heights = sorted(p.get_height() for p in ax.patches)
    assert np.allclose(heights, [2.2e-4, 3.8e-3, 2.2e-2])  # reference left out, NaN no bar
    assert ax.get_yscale() == "log" and ax.get_ylim()[0] == 1e-5
    assert [t.get_text() for t in ax.get_xticklabels()] == ["2 modes", "4 modes"]
    assert hasattr(fig, "_repr_png_")  # shows itself in a notebook
    a, b = tmp_path / "a.png", tmp_path / "b.png"
    plot_convergence(a, labels, relative, reference="8 modes")
    save_figure(fig, b)
    assert np.array_equal(np.asarray(Image.open(a)), np.asarray(Image.open(b)))


def test_the_outputs_figure_draws_each_case_at_its_parameter(tmp_path):
    rows = [{"set:boom.E": "2.1e11", "out:tip": 0.02}, {"set:boom.E": "7e10", "out:tip": 0.06},
            {"set:boom.E": "1e11", "out:tip": float("nan")}, {"out:tip": 1.0}]
    fig = outputs_figure(rows, "tip", "boom.E")
    x, y = fig.axes[0].lines[0].get_data()
    assert list(x) == [7e10, 2.1e11] and list(y) == [0.06, 0.02]  # sorted; NaN, unset out
    path = plot_outputs(tmp_path / "o.png", rows, "tip", "boom.E")
    assert Image.open(path).size == Image.open(save_figure(fig, tmp_path / "p.png")).size
    assert api.convergence_figure is convergence_figure and api.outputs_figure is outputs_figure
