"""Progress reporting for long work (meshing, assembly, eigen solves, runs).

Library code reports through :func:`stage` (timed, logged) and
:func:`progress_bar` (a rich progress bar on an interactive stderr, silent
otherwise); only the CLI decides the logging level.
"""

from __future__ import annotations

import contextlib
import logging
import sys
import time
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field

logger = logging.getLogger(__name__)


@dataclass
class StageTimes:
    """Wall-clock seconds per named stage, in the order they ran."""

    seconds: dict[str, float] = field(default_factory=dict)

    def as_dict(self) -> dict[str, float]:
        return dict(self.seconds)


@contextlib.contextmanager
def stage(name: str, times: StageTimes | None = None) -> Iterator[None]:
    """Time a stage, show a spinner on a terminal and log its duration.

    Parameters
    ----------
    name : str
        What is being done, e.g. ``"meshing link 'arm'"``.
    times : StageTimes, optional
        Collector that receives the elapsed seconds under ``name``.
    """
    t0 = time.perf_counter()
    status = _spinner(name)
    try:
        with status:
            yield
    finally:
        dt = time.perf_counter() - t0
        if times is not None:
            times.seconds[name] = times.seconds.get(name, 0.0) + dt
        logger.info("%s: %.3f s", name, dt)


def progress_bar(iterable: Iterable, total: int | None = None, description: str = "") -> Iterator:
    """Iterate with a progress bar on an interactive terminal; plain iteration otherwise."""
    if not sys.stderr.isatty():
        yield from iterable
        return
    from rich.progress import track

    yield from track(iterable, total=total, description=description, transient=True)


@contextlib.contextmanager
def progress_counter(total: int, description: str = "", enabled: bool = True):
    """Context giving ``advance(k)``: the bar shows k of ``total`` done (a rich progress
    bar on an interactive stderr; nothing otherwise)."""
    if not (enabled and sys.stderr.isatty()):
        yield lambda k: None
        return
    from rich.progress import Progress

    with Progress(transient=True) as bar:
        task = bar.add_task(description, total=total)
        yield lambda k: bar.update(task, completed=k)


def _spinner(name: str):
    if not sys.stderr.isatty():
        return contextlib.nullcontext()
    from rich.console import Console

    return Console(stderr=True).status(name)
