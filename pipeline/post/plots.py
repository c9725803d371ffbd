"""Time-history and sweep plots (matplotlib, Agg backend, PNG written atomically)."""

from __future__ import annotations

import functools
import io
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from pipeline.core.atomic import atomic_path


@dataclass(frozen=True)
class Curve:
    """One line: label, x (k,) and y (k,) values."""

    label: str
    x: np.ndarray
    y: np.ndarray
    style: str | None = None


@dataclass(frozen=True)
class Panel:
    """One axes: title, axis labels with units, curves."""

    title: str
    xlabel: str
    ylabel: str
    curves: list = field(default_factory=list)
    xlim: tuple | None = None
    equal: bool = False


def plot_panels(path: str | Path, panels, *, suptitle: str | None = None,
                ncols: int = 1) -> Path:
    """PNG with one axes per panel (legend when a panel has more than one curve): the
    figure of :func:`panels_figure`, written atomically; returns the path."""
    return save_figure(panels_figure(panels, suptitle=suptitle, ncols=ncols), path)


def panels_figure(panels, *, suptitle: str | None = None, ncols: int = 1):
    """A matplotlib Figure with one axes per panel (legend when a panel has more than one
    curve), made outside pyplot (:func:`new_figure`): a notebook shows it inline as the
    cell's value, ``fig.savefig`` writes it; no process-wide state changes."""
    n = len(panels)
    nrows = int(np.ceil(n / ncols))
    fig = new_figure((7.5 * ncols, 3.4 * nrows + 0.6))
    axes = fig.subplots(nrows, ncols, squeeze=False)
    for ax, p in zip(axes.ravel(), panels):
        if p.curves and all(len(c.y) == 1 for c in p.curves):
            _bars(ax, p)  # one value per case (statics): a bar chart, not dots over "time"
            continue
        lines = [ax.plot(c.x, c.y, c.style, label=c.label)[0] if c.style else
                 ax.plot(c.x, c.y, label=c.label, marker="o" if len(c.x) < 15 else None)[0]
                 for c in p.curves]
        if not p.equal:  # histories (a path's x is no time: it has no extreme)
            labelled = len(p.curves) <= MAX_LABELLED_EXTREMES
            for i, (c, line) in enumerate(zip(p.curves, lines, strict=True)):
                _mark_extreme(ax, c, line.get_color(), p.xlabel, i if labelled else None)
        if p.equal:  # a path: one metre is as long across as up
            ax.set_aspect("equal", adjustable="datalim")
        ax.set_title(p.title, fontsize=10)
        ax.set_xlabel(p.xlabel)
        ax.set_ylabel(p.ylabel)
        if p.xlim:
            ax.set_xlim(*p.xlim)
        ax.grid(True, alpha=0.3)
        if len(p.curves) > 1:
            ax.legend(fontsize=8)
    for ax in axes.ravel()[n:]:
        ax.set_visible(False)
    if suptitle:
        fig.suptitle(suptitle, fontsize=11)
    return fig


#: a panel with more curves marks their extremes without writing each value (the labels
#: would hide the lines)
MAX_LABELLED_EXTREMES = 3


def _mark_extreme(ax, c: Curve, color, xlabel: str, row: int | None) -> None:
    """Ring the point of largest |y| of curve c (the first, on a tie) and, given its
    label ``row`` (the curve's place in the panel), write its value and where: what a
    reader of a history looks for first. A curve that stays at 0 has none."""
    y, x = np.asarray(c.y, dtype=float), np.asarray(c.x, dtype=float)
    if y.size < 2 or not np.isfinite(y).any() or np.nanmax(np.abs(y)) == 0.0:
        return
    k = int(np.nanargmax(np.abs(y)))
    ax.plot([x[k]], [y[k]], "o", mfc="none", ms=8, mew=1.5, color=color, label="_extreme")
    if row is not None:
        unit = " s" if xlabel.startswith("time") else ""
        # late in the span the label reads leftwards (inside the axes); the curves'
        # labels are stacked so that coinciding extremes stay legible
        late = x[k] > np.nanmin(x) + 0.7 * np.ptp(x[np.isfinite(x)])
        ax.annotate(f"{_short(y[k])} at {_short(x[k])}{unit}", (x[k], y[k]),
                    xytext=(-6 if late else 6, 4 - 10 * row), textcoords="offset points",
                    ha="right" if late else "left", fontsize=7, color=color)


def _short(v: float) -> str:
    """v in 3 significant digits, as a reader writes it: whole from 1000 to 10^6 (1227, not
    1.23e+03), with an exponent only beyond.

    >>> _short(1227.4), _short(-29240.0), _short(0.00166), _short(3.0), _short(2.5e7)
    ('1227', '-29240', '0.00166', '3', '2.5e+07')
    """
    text = f"{v:.3g}"
    return f"{v:.0f}" if "e+" in text and abs(v) < 1e6 else text


def _bars(ax, p: Panel) -> None:
    """One bar per curve (case), its value written on it."""
    names = [c.label for c in p.curves]
    values = [float(c.y[0]) for c in p.curves]
    bars = ax.bar(names, values, color="tab:blue")
    ax.bar_label(bars, labels=[f"{v:.4g}" for v in values], fontsize=8)
    ax.axhline(0.0, color="black", lw=0.8)
    ax.set_title(p.title, fontsize=10)
    ax.set_ylabel(p.ylabel)
    ax.grid(True, axis="y", alpha=0.3)


def new_figure(size: tuple[float, float], dpi: int = 110):
    """A matplotlib Figure of ``size`` (inches) outside pyplot: drawing it changes no
    process-wide state (no backend switch, no figure left open in pyplot's list, so a
    notebook's inline figures and a GUI session are left as they were). A notebook shows
    it as a cell's value (its ``_repr_png_``), with no backend set up for it."""
    return _shown_figure()(figsize=size, dpi=dpi)


@functools.cache
def _shown_figure():
    """The Figure class of :func:`new_figure` (matplotlib imported when first needed)."""
    from matplotlib.figure import Figure

    class ShownFigure(Figure):
        """A matplotlib Figure that shows itself in a notebook (IPython's rich display)."""

        def _repr_png_(self) -> bytes:
            buf = io.BytesIO()
            self.savefig(buf, format="png", bbox_inches="tight")
            return buf.getvalue()

    return ShownFigure


def save_figure(fig, path: str | Path) -> Path:
    """Lay out and write a matplotlib figure as PNG atomically; returns the path."""
    fig.tight_layout()
    path = Path(path)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format="png")
    return path


def plot_histories(path: str | Path, t, series: dict, *, ylabel: str, title: str) -> Path:
    """One panel of several histories over time t (s)."""
    curves = [Curve(k, np.asarray(t), np.asarray(v)) for k, v in series.items()]
    return plot_panels(path, [Panel(title, "time, s", ylabel, curves)])
