"""Progress reporting for long work (meshing, assembly, eigen solves, runs).

Library code reports through :func:`stage` (timed, logged; a spinner on an
interactive stderr), :func:`report` (what the innermost stage is doing now: a
count, or a table such as the worker cases'), and :func:`progress_bar` /
:func:`progress_counter` (rich progress bars). Off a terminal, and in worker
processes (``QUIET_ENV`` set: :func:`pipeline.core.cases.local_cluster` starts its
workers so), only the log remains; only the CLI decides the
logging level.
"""

from __future__ import annotations

import contextlib
import logging
import os
import sys
import time
from collections.abc import Iterable, Iterator
from contextvars import ContextVar
from dataclasses import dataclass, field
from typing import Any

logger = logging.getLogger(__name__)

#: set in worker processes: their stderr is the parent's terminal, which shows the table
QUIET_ENV = "PIPELINE_QUIET_PROGRESS"

#: (rich Status, stage name) of the innermost stage showing a spinner, if any
_current: ContextVar[tuple[Any, str] | None] = ContextVar("pipeline_stage", default=None)
#: name of the innermost running stage, drawn or not
_running: ContextVar[str | None] = ContextVar("pipeline_stage_name", default=None)


def interactive() -> bool:
    """True when progress is drawn: stderr is a terminal and this is not a worker."""
    return sys.stderr.isatty() and not os.environ.get(QUIET_ENV)


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
    if name == _running.get() and times is None:
        # the same stage, opened again inside itself (a library step that times itself,
        # called by a caller that times it too): shown and logged once, by the outer one
        yield
        return
    t0 = time.perf_counter()
    status = _spinner(name)
    token = _current.set((status, name)) if status is not None else None
    running = _running.set(name)
    try:
        with status if status is not None else contextlib.nullcontext():
            yield
    finally:
        _running.reset(running)
        if token is not None:
            _current.reset(token)
        dt = time.perf_counter() - t0
        if times is not None:
            times.seconds[name] = times.seconds.get(name, 0.0) + dt
        logger.info("%s: %.3f s", name, dt)


def report(what) -> None:
    """Show what the innermost running :func:`stage` is doing now, under its name: a
    short text (``"Lanczos: 40 solves"``) or a rich renderable (a table). Nothing when no
    stage draws (off a terminal); cheap enough to call in a loop."""
    line = _current.get()
    if line is None:
        return
    status, name = line
    if isinstance(what, str):
        status.update(f"{name}: {what}")
    else:
        from rich.console import Group

        status.update(Group(name, what))


def progress_bar(iterable: Iterable, total: int | None = None, description: str = "") -> Iterator:
    """Iterate with a progress bar on an interactive terminal; plain iteration otherwise."""
    if not interactive():
        yield from iterable
        return
    from rich.progress import track

    yield from track(iterable, total=total, description=description, transient=True)


@contextlib.contextmanager
def progress_counter(total: int, description: str = "", enabled: bool = True):
    """Context giving ``advance(k)``: the bar shows k of ``total`` done (a rich progress
    bar on an interactive stderr; nothing otherwise)."""
    if not (enabled and interactive()):
        yield lambda k: None
        return
    from rich.progress import Progress

    with Progress(transient=True) as bar:
        task = bar.add_task(description, total=total)
        yield lambda k: bar.update(task, completed=k)


def _spinner(name: str):
    if not interactive():
        return None
    from rich.console import Console

    return Console(stderr=True).status(name)


def task_table(rows: Iterable[tuple[str, str, float | None]], title: str = ""):
    """A rich table of tasks for :func:`report`: rows of (task, state, seconds so far or
    None), e.g. the analysis cases on worker processes. A state other than queued,
    running or ok is drawn in red."""
    from rich.table import Table

    table = Table(title=title or None, box=None, pad_edge=False)
    for col, justify in (("case", "left"), ("state", "left"), ("s", "right")):
        table.add_column(col, justify=justify)
    for name, state, seconds in rows:
        style = "" if state in ("queued", "running", "ok") else "red"
        table.add_row(name, state, "" if seconds is None else f"{seconds:.1f}", style=style)
    return table


class TaskBoard:
    """The state of a pool's tasks, drawn by :meth:`show` as a :func:`task_table` under the
    running stage: queued until :meth:`running`, then the state and seconds
    :meth:`finished` gives (a running task shows its seconds so far)."""

    def __init__(self, names: Iterable[str]):
        self.names = list(names)
        self.state = ["queued"] * len(self.names)
        self.began: list[float | None] = [None] * len(self.names)
        self.took: list[float | None] = [None] * len(self.names)

    def running(self, k: int, now: float) -> None:
        """Task k started at ``now`` (perf_counter seconds), unless it already had."""
        if self.began[k] is None:
            self.began[k], self.state[k] = now, "running"

    def finished(self, k: int, state: str, seconds: float) -> None:
        self.state[k], self.took[k] = state, seconds

    @property
    def n_done(self) -> int:
        return sum(t is not None for t in self.took)

    def show(self, now: float) -> None:
        report(task_table([(n, s, t if t is not None else None if b is None else now - b)
                           for n, s, b, t in zip(self.names, self.state, self.began,
                                                 self.took, strict=True)]))
