"""The run's results store (issue 29 item 4): ``results.parquet`` holds every series of every
analysis and case with its unit, and the manifest; read back equal to the run's NPZ and CSV
exports."""

from __future__ import annotations

import csv
import json
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
from test_workflow_run import FOURBAR

pytest.importorskip("pyarrow")


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    from pipeline.workflow import run_workflow

    tmp = tmp_path_factory.mktemp("store")
    p = tmp / "fourbar.yaml"
    p.write_text(FOURBAR)
    return run_workflow(p, out_root=tmp / "out").out_dir


def _series(table, case, series):
    import pyarrow.compute as pc

    rows = table.filter(pc.and_(pc.equal(table["case"], case),
                                pc.equal(table["series"], series)))
    units = set(rows["unit"].to_pylist())
    assert len(units) == 1, (series, units)
    return rows["t"].to_numpy(), rows["value"].to_numpy(), units.pop(), rows["k"].to_numpy()


def test_the_store_holds_every_series_with_units_and_the_manifest(run):
    from pipeline.workflow.store import STORE, read_store

    table, manifest = read_store(run / STORE)
    assert manifest == json.loads((run / "manifest.json").read_text())
    assert STORE in manifest["files"]
    assert set(table["analysis"].to_pylist()) == {"turn"}
    assert set(table["case"].to_pylist()) == {"slow", "fast"}
    for case in ("slow", "fast"):
        npz = np.load(run / f"turn_{case}.npz")
        coords = list(npz["coordinates"])
        for key, unit in (("q", "rad"), ("qd", "rad/s"), ("qdd", "rad/s²")):
            for i, c in enumerate(coords):
                t, v, u, k = _series(table, case, f"{key}:{c}")
                assert u == unit
                assert np.array_equal(t, npz["t"]) and np.array_equal(v, npz[key][:, i])
                assert np.array_equal(k, np.arange(len(t)))
        with open(run / f"turn_{case}.csv") as fh:
            cols = list(zip(*csv.reader(fh), strict=True))
        csv_cols = {c[0]: np.array(c[1:], dtype=float) for c in cols}
        for ax in "xyz":
            _, v, u, _ = _series(table, case, f"marker:coupler.C:{ax}")
            assert u == "m"
            np.testing.assert_allclose(v, csv_cols[f"coupler.C.{ax}_m"], rtol=1e-11,
                                       atol=1e-12)
    # the fast case turns the crank twice as fast: its store says so
    _, slow, _, _ = _series(table, "slow", "qd:JA.theta")
    _, fast, _, _ = _series(table, "fast", "qd:JA.theta")
    assert fast == pytest.approx(2 * slow)


def test_a_parquet_file_that_is_not_a_store_is_refused(tmp_path):
    import pyarrow as pa
    import pyarrow.parquet as pq

    from pipeline.workflow.store import read_store

    pq.write_table(pa.table({"x": [1.0]}), tmp_path / "other.parquet")
    with pytest.raises(ValueError, match="not a run's results store"):
        read_store(tmp_path / "other.parquet")
