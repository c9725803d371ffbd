"""A case study's charts: relative RMS difference of each case from the reference (bars),
and a derived output against a varied parameter. Each is a matplotlib Figure
(``*_figure``, for a notebook) and a PNG writer of that Figure (``plot_*``)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from pipeline.post.plots import new_figure, save_figure

#: the smallest difference a bar is drawn to (an exact zero has no logarithm)
FLOOR = 1e-16


def log_bar_limits(values) -> tuple[float, float]:
    """(bottom, top) of a log axis for bars of ``values``: a decade below the smallest
    (floored at :data:`FLOOR`), so that every bar has a visible height (autoscaling put the
    bottom just under the smallest, and a 4e-3 bar beside a 2e-2 one looked like nothing),
    and a third of a decade above the largest, for its label.

    >>> log_bar_limits([3.8e-3, 2.2e-2, 9.5e-3])
    (0.0001, 0.047...)
    """
    v = np.maximum(np.asarray(values, dtype=float), FLOOR)
    bottom = 10.0 ** (np.floor(np.log10(v.min())) - 1.0)
    return float(bottom), float(v.max() * 10 ** (1 / 3))


def plot_convergence(path: str | Path, labels, relative: dict, *, reference: str,
                     title: str | None = None) -> Path:
    """PNG of :func:`convergence_figure`; returns the path."""
    return save_figure(convergence_figure(labels, relative, reference=reference, title=title),
                       path)


def convergence_figure(labels, relative: dict, *, reference: str, title: str | None = None):
    """Figure: one group of bars per case, one bar per series, log scale from a decade
    below the smallest bar (:func:`log_bar_limits`), each bar labelled with its value
    (reference omitted; a value that is not finite draws no bar, and a chart with none
    says so).

    Parameters
    ----------
    labels : (k,) case labels.  relative : series -> (k,) relative RMS difference (-).
    """
    keep = [i for i, lab in enumerate(labels) if lab != reference]
    fig = new_figure((7.5, 4.5))
    ax = fig.subplots()
    width = 0.8 / max(len(relative), 1)
    x = np.arange(len(keep))
    drawn = []
    for j, (name, values) in enumerate(relative.items()):
        v = np.asarray(values, dtype=float)[keep]
        ok = np.isfinite(v)  # no comparison (a case without data, a zero reference): no bar
        drawn += v[ok].tolist()
        bars = ax.bar((x + (j - (len(relative) - 1) / 2) * width)[ok],
                      np.maximum(v[ok], FLOOR), width, label=name)
        ax.bar_label(bars, labels=[f"{b:.2g}" for b in v[ok]], fontsize=7)
    ax.set_xticks(x, [labels[i] for i in keep])
    if drawn:
        ax.set_yscale("log")
        ax.set_ylim(*log_bar_limits(drawn))
    else:
        ax.text(0.5, 0.5, "no difference could be computed\n(see the CSV and the run's notes)",
                ha="center", va="center", transform=ax.transAxes)
    ax.set_ylabel(f"RMS difference from '{reference}' / RMS of '{reference}', -")
    ax.set_xlabel("case")
    ax.set_title(title or f"Convergence towards '{reference}'")
    ax.grid(True, axis="y", which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    return fig


def plot_outputs(path: str | Path, rows: list[dict], output: str, parameter: str,
                 title: str | None = None) -> Path:
    """PNG of :func:`outputs_figure`; returns the path."""
    return save_figure(outputs_figure(rows, output, parameter, title), path)


def outputs_figure(rows: list[dict], output: str, parameter: str, title: str | None = None):
    """Figure: a study's derived output (``out:<name>`` of the table rows) against one
    varied parameter (``set:<path>``, numeric), one point per case."""
    import json

    pts = []
    for r in rows:
        try:
            x = float(json.loads(r[f"set:{parameter}"]))
        except (KeyError, TypeError, ValueError):
            continue
        y = r.get(f"out:{output}")
        if isinstance(y, float) and np.isfinite(y):
            pts.append((x, y))
    pts.sort()
    fig = new_figure((6.5, 4.0))
    ax = fig.subplots()
    if pts:
        ax.plot(*zip(*pts, strict=True), "o-")
    ax.set_xlabel(parameter)
    ax.set_ylabel(output)
    ax.set_title(title or f"{output} against {parameter}")
    ax.grid(True, alpha=0.3)
    fig.tight_layout()
    return fig
