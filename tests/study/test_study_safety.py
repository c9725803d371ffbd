"""Studies lose nothing (issue 26, seen 3): a study and a workflow run of one name cannot
overwrite each other; the table grows case by case, so a killed client loses at most the
cases it was running; a damaged table or case file is set aside and its cases run again."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from luff_study import write_luff_study

from pipeline.core.errors import ConfigError
from pipeline.study.engine import run_study
from pipeline.workflow import run_workflow

pytestmark = pytest.mark.gmsh

ROOT = Path(__file__).resolve().parents[2]
ANGLES = [-0.7, -0.8, -0.9, -1.0, -1.1, -1.2]


@pytest.fixture(scope="module")
def links(tmp_path_factory):
    return tmp_path_factory.mktemp("safety_links")


def _study(folder: Path, angles=ANGLES, name="luff") -> Path:
    p = write_luff_study(folder / f"{name}.yaml",
                         f"grid: {{drivers.LUFF.theta.value: {list(angles)}}}")
    if name != "luff":
        p.write_text(p.read_text().replace("name: luff", f"name: {name}"))
    return p


def test_a_study_and_a_run_of_one_name_do_not_overwrite_each_other(tmp_path, links):
    """A study named like a workflow wrote into that workflow's run folder, and the next run
    replaced it with the study's table inside; a study named 'links' wrote into the link
    cache. Each is refused before anything is written."""
    out = tmp_path / "out"
    run = run_workflow(ROOT / "workflows" / "mobile_crane.yaml", quick=True, outputs=False,
                       out_root=out, cache_dir=links)
    study = _study(tmp_path, [-0.8], name="mobile_crane")
    before = sorted(p.name for p in run.out_dir.iterdir())
    with pytest.raises(ConfigError, match=r"holds a workflow run's results \(manifest.json\); "
                                          r"a study of the same name would mix into it"):
        run_study(study, out_root=out, workers=1, cache_dir=links)
    assert sorted(p.name for p in run.out_dir.iterdir()) == before
    # the other way round: a study's folder is not replaced by a run of that name
    res = run_study(_study(tmp_path, [-0.8]), out_root=out, workers=1, cache_dir=links)
    crane = (ROOT / "workflows" / "mobile_crane.yaml").read_text().replace(
        "name: mobile_crane", "name: luff")
    (tmp_path / "luff_wf.yaml").write_text(crane.replace("../meshes/", f"{ROOT}/meshes/"))
    with pytest.raises(ConfigError, match=r"holds a study's table and cases \(study.json\); "
                                          r"a run of the same name would replace it"):
        run_workflow(tmp_path / "luff_wf.yaml", quick=True, out_root=out, cache_dir=links)
    assert (res.folder / "study.json").is_file() and (res.folder / "cases.parquet").is_file()
    with pytest.raises(ConfigError, match="'links' is a folder the pipeline keeps"):
        run_study(_study(tmp_path, [-0.8], name="links"), out_root=out, cache_dir=links)


@pytest.mark.slow  # a study's client killed once its first case is in (7 s)
def test_a_killed_client_loses_at_most_the_cases_it_was_running(tmp_path, links):
    """kill -9 of the study's own process once the first case is in the table: the table
    was written only at the end, so the rerun repeated every finished case. Now each
    finished case is in the table, and the rerun runs only the others."""
    study = _study(tmp_path)
    out = tmp_path / "out"
    code = ("import sys; from pipeline.study.engine import run_study\n"
            "if __name__ == '__main__':\n"
            f"    run_study({str(study)!r}, out_root={str(out)!r}, workers=1, "
            f"cache_dir={str(links)!r})\n")
    proc = subprocess.Popen([sys.executable, "-c", code], cwd=tmp_path,
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                            start_new_session=True)
    table = out / "luff" / "cases.parquet"
    t0 = time.time()
    try:
        while time.time() - t0 < 300 and not table.is_file() and proc.poll() is None:
            time.sleep(0.05)
    finally:
        os.killpg(proc.pid, signal.SIGKILL)  # the client and its local cluster, at once
        proc.wait()
    assert table.is_file(), "no case finished in time"
    import pyarrow.parquet as pq

    kept = pq.read_table(table).to_pylist()
    assert 1 <= len(kept) < len(ANGLES) and all(r["status"] == "ok" for r in kept)
    again = run_study(study, out_root=out, workers=1, cache_dir=links)
    assert again.ran == len(ANGLES) - len(kept)
    assert [r["status"] for r in again.rows] == ["ok"] * len(ANGLES)


@pytest.mark.slow  # three studies on a local cluster (12 s)
def test_a_damaged_table_or_case_file_is_set_aside_and_rerun(tmp_path, links, caplog):
    study = _study(tmp_path, ANGLES[:3])
    out = tmp_path / "out"
    first = run_study(study, out_root=out, workers=1, cache_dir=links)
    folder = first.folder
    # a case file damaged (a zip cut short): only that case runs again
    case = sorted((folder / "cases").glob("*.npz"))[0]
    case.write_bytes(b"PK\x03\x04" + case.read_bytes()[4:][:len(case.read_bytes()) // 2])
    with caplog.at_level("WARNING", logger="pipeline.core.cases"):
        again = run_study(study, out_root=out, workers=1, cache_dir=links)
    assert again.ran == 1 and [r["status"] for r in again.rows] == ["ok"] * 3
    assert any("is damaged" in m and case.name in m for m in caplog.messages)
    assert list((folder / "cases").glob(f"{case.name}.damaged-*"))
    # a table that is not parquet, and one without input_hash: every case runs again
    for damage in (b"not a parquet file", None):
        table = folder / "cases.parquet"
        if damage is None:
            import pyarrow as pa
            import pyarrow.parquet as pq

            pq.write_table(pa.Table.from_pylist([{"case": "x", "status": "ok"}]), table)
        else:
            table.write_bytes(damage)
        res = run_study(study, out_root=out, workers=1, cache_dir=links)
        assert res.ran == 3 and [r["status"] for r in res.rows] == ["ok"] * 3
    assert len(list(folder.glob("cases.parquet.damaged-*"))) >= 1
    np.testing.assert_array_equal([r["out:peak_heave"] for r in res.rows],
                                  [r["out:peak_heave"] for r in first.rows])


@pytest.mark.slow  # waits out its worker timeout (12 s)
def test_an_external_cluster_without_workers_ends_its_cases_lost(tmp_path, links):
    """The only worker of an external cluster dies: the study waited for ever, silently.
    Now the cases left come back 'lost' once the cluster has had no worker for the
    timeout, and the rerun on a live cluster runs exactly those."""
    import threading

    from test_study import _cluster, _stop

    study = _study(tmp_path, ANGLES[:3])
    address, sched, workers = _cluster(tmp_path, n_workers=1)
    _stop(workers)  # the only worker gone before the cases are submitted
    out: dict = {}
    th = threading.Thread(target=lambda: out.setdefault("res", run_study(
        study, out_root=tmp_path / "out", scheduler=address, cache_dir=links,
        worker_timeout=3.0)))
    t0 = time.time()
    th.start()
    th.join(timeout=120)
    try:
        assert not th.is_alive(), "the study still waits"
    finally:
        _stop([sched])
    res = out["res"]
    assert time.time() - t0 < 120
    assert [r["status"] for r in res.rows] == ["lost"] * 3
    assert all(r["message"] == "the cluster had no worker for 3 s" for r in res.rows)
    again = run_study(study, out_root=tmp_path / "out", workers=1, cache_dir=links)
    assert again.ran == 3 and [r["status"] for r in again.rows] == ["ok"] * 3


def test_distributed_tracebacks_are_one_line_without_debug(caplog):
    import logging

    from pipeline.core.cases import quiet_distributed as _quiet_distributed

    log = logging.getLogger("distributed.scheduler")
    handler = logging.StreamHandler()
    logging.getLogger().addHandler(handler)
    try:
        with _quiet_distributed(), caplog.at_level(logging.WARNING):
            try:
                raise RuntimeError("scheduler gone")
            except RuntimeError:
                log.error("the scheduler closed", exc_info=True)
    finally:
        logging.getLogger().removeHandler(handler)
    rec = [r for r in caplog.records if r.getMessage() == "the scheduler closed"]
    assert rec and rec[0].exc_info is None
    assert not handler.filters  # restored


@pytest.mark.parametrize("override, expect", [
    ("links.boom.modes: -3", "set.links.boom.modes: Input should be greater than or equal to 0"),
    ("links.boom.mdoes: 2", "set.links.boom.mdoes: unknown key (misspelt?)")])
def test_an_error_in_a_studys_set_is_at_the_studys_line(tmp_path, override, expect):
    """It pointed at the base workflow's line."""
    p = _study(tmp_path, [-0.8])
    text = p.read_text().replace("analyses: [release]\n", f"analyses: [release]\nset:\n"
                                 f"  {override}\n")
    p.write_text(text)
    line = text.splitlines().index(f"  {override}") + 1
    with pytest.raises(ConfigError) as exc:
        run_study(p, out_root=tmp_path / "out")
    assert str(exc.value) == f"{p}:{line}: {expect}"


def test_a_cluster_that_fails_to_start_is_started_again_then_named(caplog):
    """A worker killed while the local cluster comes up failed the study with distributed's
    traceback ("Nanny failed to start"); the start is tried again, and after the last
    attempt the study stops with one line."""
    from pipeline.core.errors import PipelineError
    from pipeline.core.cases import CLUSTER_STARTS
    from pipeline.core.cases import local_cluster as _local_cluster

    calls = []

    def flaky(fail):
        def make(**kw):
            calls.append(kw)
            if len(calls) <= fail:
                raise RuntimeError("Nanny failed to start.")
            return "cluster"
        return make

    with caplog.at_level("WARNING", logger="pipeline.core.cases"):
        assert _local_cluster(flaky(1), 2) == "cluster"
    assert len(calls) == 2 and "trying again" in caplog.text
    calls.clear()
    with pytest.raises(PipelineError, match=rf"did not start in {CLUSTER_STARTS} attempts "
                                            r"\(RuntimeError: Nanny failed to start.\)"):
        _local_cluster(flaky(99), 2)
    assert len(calls) == CLUSTER_STARTS
