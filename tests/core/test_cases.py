"""The one case runner (pipeline.core.cases) on a real local Dask cluster: results handed
over as they arrive, a worker that dies costs its case alone, the caller's error stops the
run and leaves no process behind, and the workers draw no progress."""

from __future__ import annotations

import logging
import os
import signal

import pytest

pytest.importorskip("distributed")

from pipeline.core.cases import CaseLost, Task, run_cases  # noqa: E402
from pipeline.core.progress import QUIET_ENV  # noqa: E402


def square(x: float) -> dict:
    """A case: its value, whether its process draws progress and samples its stack."""
    import dask

    return {"value": x * x, "quiet": os.environ.get(QUIET_ENV), "pid": os.getpid(),
            "profile": dask.config.get("distributed.worker.profile.enabled")}


def die(_x: float) -> dict:
    """A case that kills the process it runs in (an out-of-memory kill, a segfault)."""
    os.kill(os.getpid(), signal.SIGKILL)
    return {}


def test_results_arrive_in_the_callers_record_with_quiet_workers(caplog):
    got: dict = {}

    def record(k, value, error):
        assert error is None
        got[k] = value
        return "ok", 0.25

    tasks = [Task(f"x={x}", square, (float(x),), f"sq-{x}") for x in range(5)]
    with caplog.at_level(logging.INFO, logger="pipeline.core.cases"):
        run_cases(tasks, title="squares", record=record, workers=2)
    assert sorted(got) == list(range(5))
    assert [got[k]["value"] for k in range(5)] == [0.0, 1.0, 4.0, 9.0, 16.0]
    assert all(v["quiet"] == "1" for v in got.values())  # workers: no spinner on our tty
    assert all(v["pid"] != os.getpid() for v in got.values())
    assert all(v["profile"] is False for v in got.values())  # no GIL taken every 10 ms
    lines = [r.getMessage() for r in caplog.records if "cases done" in r.getMessage()]
    assert len(lines) == 5 and lines[-1].endswith("(5 of 5 cases done)")
    assert all(m.startswith("squares: x=") and ": ok in 0.2 s" in m for m in lines)


def test_a_case_whose_worker_dies_is_lost_alone():
    """The dying case kills every worker it is given (distributed tries it again up to
    allowed-failures); it comes back as CaseLost naming the cause, the others as results."""
    import dask

    got: dict = {}

    def record(k, value, error):
        got[k] = (value, error)
        return ("lost" if error else "ok"), 0.0

    tasks = [Task("a", square, (2.0,), "a"), Task("dies", die, (0.0,), "dies"),
             Task("b", square, (3.0,), "b")]
    with dask.config.set({"distributed.scheduler.allowed-failures": 0}):
        run_cases(tasks, title="t", record=record, workers=2)
    assert got[0][0]["value"] == 4.0 and got[2][0]["value"] == 9.0
    value, error = got[1]
    assert value is None and isinstance(error, CaseLost)
    assert "worker process died" in str(error) and "KilledWorker" in str(error)


def test_an_error_in_record_stops_the_run_and_closes_the_cluster():
    import psutil

    before = {p.pid for p in psutil.Process().children(recursive=True)}

    def record(k, value, error):
        raise ValueError("the caller stops here")

    tasks = [Task(f"{x}", square, (float(x),), f"e-{x}") for x in range(4)]
    with pytest.raises(ValueError, match="the caller stops here"):
        run_cases(tasks, title="t", record=record, workers=2)
    left = [p for p in psutil.Process().children(recursive=True)
            if p.pid not in before and p.is_running() and p.status() != psutil.STATUS_ZOMBIE]
    assert not left, left


def test_a_cases_own_error_reaches_record_as_raised():
    got = {}

    def record(k, value, error):
        got[k] = error
        return "failed", 0.0

    run_cases([Task("bad", square, ("text",), "bad")], title="t", record=record, workers=1)
    assert isinstance(got[0], TypeError) and not isinstance(got[0], CaseLost)
