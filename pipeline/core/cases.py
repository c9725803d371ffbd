"""The one case runner: independent cases (a workflow's analysis cases, a study's design
and truncation cases) as tasks on ``dask.distributed``, on a local cluster of processes
or an existing scheduler.

What it owns, once for every caller:

* starting a local cluster (tried again when a worker dies as it comes up), its workers
  quiet (their stderr is this terminal, which shows the table of cases);
* progress: a live table of the cases under the running stage on a terminal, one log
  line per finished case otherwise;
* results as they arrive, each handed to the caller's ``record`` at once (a run killed
  later keeps what finished);
* a dead worker: distributed runs its case again elsewhere, and a case whose workers
  keep dying comes back as :class:`CaseLost` for that case alone;
* a cluster left without any worker for ``worker_timeout`` s (an external one whose
  workers died): the cases left end as :class:`CaseLost` instead of waiting for ever;
* distributed's own log at this process's level, one line a record without ``--debug``.

What a case means is the caller's: ``record(k, value, error)`` turns a result or an
error into the case's state and seconds (or raises, which stops the run: the cluster is
closed and nothing is left running).

Examples
--------
>>> def record(k, value, error):  # doctest: +SKIP
...     return ("ok", value["seconds"]) if error is None else ("lost", float("nan"))
>>> run_cases([Task("a", f, (1,), "case-a")], title="demo", record=record)  # doctest: +SKIP
"""

from __future__ import annotations

import contextlib
import logging
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

from pipeline.core.errors import ConfigError, PipelineError
from pipeline.core.progress import QUIET_ENV, TaskBoard, stage

logger = logging.getLogger(__name__)

__all__ = [
    "CLUSTER_STARTS",
    "WORKER_TIMEOUT",
    "CaseLost",
    "Task",
    "local_cluster",
    "quiet_distributed",
    "run_cases",
]

#: seconds a run waits while its cluster has no worker before the cases left are lost
WORKER_TIMEOUT = 120.0

#: seconds to fetch a finished case's result before looking at the cluster again (its
#: worker may have died holding it; at 10 s, futures in that state one after another
#: livelocked a study whose workers were killed every 1-2.5 s)
GATHER_SECONDS = 1.0

#: seconds between looks at the cases' futures while none has finished
POLL_SECONDS = 0.2

#: attempts at starting the local cluster (a worker killed while it starts fails the start)
CLUSTER_STARTS = 3

#: the local workers' housekeeping, slowed: each periodic callback of a worker's event loop
#: takes the GIL from the case computing beside it, and at distributed's defaults (a stack
#: sample every 10 ms for a profile nobody reads, the memory every 100 ms, the system every
#: 500 ms, the loop's tick every 20 ms) the main job's flexible swing took 7.1 s on a
#: worker against 4.9 s in the client (5.2 s with these; benchmark test_bench_study.py)
WORKER_CONFIG = {
    "distributed.worker.profile.enabled": False,
    "distributed.admin.tick.interval": "1s",
    "distributed.admin.system-monitor.interval": "2s",
    "distributed.worker.memory.monitor-interval": "2s",
}


@dataclass(frozen=True)
class Task:
    """One case: ``label`` its name in the progress table and the log; a worker calls
    ``fn(*args)`` (a module-level function of picklable values); ``key`` names it on the
    cluster (unique within the run)."""

    label: str
    fn: Callable
    args: tuple
    key: str


class CaseLost(PipelineError):
    """A case that did not finish for a reason outside it (no worker left to run it)."""


class _OneLine(logging.Filter):
    """distributed's records as one line: its tracebacks (a scheduler dying, a cluster
    shutting down under load) are shown only with ``--debug``."""

    def filter(self, record: logging.LogRecord) -> bool:
        if logging.getLogger().getEffectiveLevel() > logging.DEBUG:
            record.exc_info = record.exc_text = record.stack_info = None
        return True


@contextlib.contextmanager
def quiet_distributed():
    """For a run's span: distributed's loggers at this process's level (its cluster's
    life is logged at INFO) and one line per record; restored after."""
    log = logging.getLogger("distributed")
    level, one_line = log.level, _OneLine()
    log.setLevel(max(logging.WARNING, logging.getLogger().getEffectiveLevel()))
    handlers = [*logging.getLogger().handlers, *log.handlers]
    for h in handlers:
        h.addFilter(one_line)
    try:
        yield
    finally:
        log.setLevel(level)
        for h in handlers:
            h.removeFilter(one_line)


def local_cluster(LocalCluster, workers: int):
    """A local cluster of ``workers`` quiet processes (one thread each, their housekeeping
    slowed to :data:`WORKER_CONFIG`); a start that fails (a worker process killed or out of
    memory as it comes up) is tried again, then named."""
    import dask

    for attempt in range(CLUSTER_STARTS):
        try:  # the nannies hand this process's configuration to their workers
            with dask.config.set(WORKER_CONFIG):
                return LocalCluster(n_workers=workers, threads_per_worker=1,
                                    processes=True, dashboard_address=None,
                                    env={QUIET_ENV: "1"})
        except (RuntimeError, OSError, TimeoutError) as exc:
            logger.warning("the local Dask cluster did not start (%s: %s)%s",
                           type(exc).__name__, exc,
                           "; trying again" if attempt + 1 < CLUSTER_STARTS else "")
            last = exc
    raise PipelineError(f"the local Dask cluster of {workers} processes did not start in "
                        f"{CLUSTER_STARTS} attempts ({type(last).__name__}: {last}); "
                        "check memory and the temporary folder") from None


def run_cases(tasks: Sequence[Task], *, title: str,
              record: Callable[[int, Any, BaseException | None], tuple[str, float]],
              workers: int = 2, scheduler: str | None = None, plugin=None,
              worker_timeout: float = WORKER_TIMEOUT) -> None:
    """Run ``tasks`` on a local cluster of ``workers`` processes (or on the cluster at
    ``scheduler``, ``tcp://host:8786``), handing each finished one to
    ``record(k, value, error)`` as it arrives: ``value`` what ``tasks[k].fn`` returned,
    or ``error`` what it raised, or :class:`CaseLost` for a case whose workers kept dying
    (distributed runs a case again when its worker dies, up to its ``allowed-failures``)
    or that no worker was left to run. ``record`` returns the case's state and seconds
    for the progress table; an exception it raises ends the run (the cluster is closed).
    ``plugin`` is a ``distributed`` worker plugin registered for the run (every worker,
    including those that join later, gets it) and unregistered after.

    Raises
    ------
    ConfigError
        ``distributed`` is not installed.
    PipelineError
        The local cluster did not start.
    """
    try:
        from distributed import Client, LocalCluster
    except ImportError:
        raise ConfigError("running cases in parallel needs dask.distributed: "
                          "pip install 'dask[distributed]'") from None
    if not tasks:
        return
    where = scheduler or f"a local cluster of {workers} processes"
    cluster = client = None
    with quiet_distributed(), stage(f"{title}: {len(tasks)} cases on {where}"):
        try:
            if scheduler is None:
                cluster = local_cluster(LocalCluster, workers)
            client = Client(scheduler or cluster)
            if plugin is not None:
                client.register_plugin(plugin, name=plugin.name)
            futures = {client.submit(t.fn, *t.args, pure=False, key=t.key): k
                       for k, t in enumerate(tasks)}
            _collect(client, tasks, futures, title, record, worker_timeout)
        finally:
            if client is not None:
                if plugin is not None:
                    with contextlib.suppress(Exception):  # a scheduler that is gone
                        client.unregister_worker_plugin(plugin.name)
                client.close()
            if cluster is not None:
                cluster.close()


def _collect(client, tasks, futures, title, record, worker_timeout) -> None:
    from distributed import KilledWorker

    board = TaskBoard(t.label for t in tasks)
    submitted = time.perf_counter()
    for k in range(len(tasks)):  # the scheduler does not say which has started
        board.running(k, submitted)
    pending, alone_since, looked = set(futures), None, time.monotonic()

    def finished(k: int, value, error) -> None:
        state, seconds = record(k, value, error)
        board.finished(k, state, seconds)
        logger.info("%s: %s: %s in %.1f s (%d of %d cases done)", title, tasks[k].label,
                    state, seconds, board.n_done, len(tasks))
        board.show(time.perf_counter())

    while pending:
        # the futures' own states, polled: distributed.wait(timeout=2) was seen to hang for
        # good once workers had been killed in a row (the soak: its timeout never fired
        # while the event loop sat idle)
        done = {f for f in pending if f.done()}
        if not done:
            time.sleep(POLL_SECONDS)
        gathered = False
        for fut in done:
            value = error = None
            try:
                value = fut.result(timeout=GATHER_SECONDS)
            except TimeoutError:  # its worker died before the result came: the scheduler
                continue          # computes it again; keep waiting
            except KilledWorker as exc:
                error = CaseLost("its worker process died (killed, or out of memory) before "
                                 f"the case finished ({type(exc).__name__}: {exc})")
            except Exception as exc:  # noqa: BLE001 - the case's own error: the caller's to judge
                error = exc
            pending.discard(fut)
            # forget the future: a result the cluster still held would be computed again
            # when its worker dies (a finished case run twice)
            k = futures.pop(fut)
            fut.release()
            finished(k, value, error)
            gathered = True
        if gathered or not pending or time.monotonic() - looked < 2.0:
            continue
        looked = time.monotonic()  # the scheduler asked every 2 s, not every poll
        if client.scheduler_info().get("workers"):
            alone_since = None
            continue
        alone_since = alone_since or time.monotonic()
        if time.monotonic() - alone_since > worker_timeout:
            for fut in sorted(pending, key=futures.get):
                fut.cancel()
                finished(futures[fut], None,
                         CaseLost(f"the cluster had no worker for {worker_timeout:g} s"))
            pending.clear()
