"""Time-history and sweep plots (matplotlib, Agg backend, PNG written atomically)."""

from __future__ import annotations

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


def plot_panels(path: str | Path, panels, *, suptitle: str | None = None,
                ncols: int = 1) -> Path:
    """PNG with one axes per panel (legend when a panel has more than one curve)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    n = len(panels)
    nrows = int(np.ceil(n / ncols))
    fig, axes = plt.subplots(nrows, ncols, figsize=(7.5 * ncols, 3.4 * nrows + 0.6),
                             dpi=110, squeeze=False)
    for ax, p in zip(axes.ravel(), panels):
        for c in p.curves:
            if c.style:
                ax.plot(c.x, c.y, c.style, label=c.label)
            else:
                ax.plot(c.x, c.y, label=c.label, marker="o" if len(c.x) < 15 else None)
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
    return save_figure(fig, path)


def save_figure(fig, path: str | Path) -> Path:
    """Lay out, write as PNG atomically and close a matplotlib figure; returns the path."""
    import matplotlib.pyplot as plt

    fig.tight_layout()
    path = Path(path)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format="png")
    plt.close(fig)
    return path


def plot_histories(path: str | Path, t, series: dict, *, ylabel: str, title: str) -> Path:
    """One panel of several histories over time t (s)."""
    curves = [Curve(k, np.asarray(t), np.asarray(v)) for k, v in series.items()]
    return plot_panels(path, [Panel(title, "time, s", ylabel, curves)])
