"""One self-describing results file per run: ``results.parquet``.

Every series of every analysis and case in one tidy table, a row per value:

=========  =======  ============================================================
column     type     meaning
=========  =======  ============================================================
analysis   string   the analysis' name
case       string   the case's label ("" without cases)
series     string   ``q:<coordinate>``, ``qd:``, ``qdd:``, ``force:<coordinate>``,
                    ``marker:<link>.<frame>:x|y|z``, ``reaction:<joint>:fx..mz``,
                    ``energy:<name>``, ``state:<element>.<state>``,
                    ``closure_residual``, ``mode:frequency`` / ``mode:damping``
unit       string   SI: rad, m, rad/s, N, N m, J, Pa, Hz, ... (``-``: none)
k          int64    the output's index (a mode's number for ``mode:`` series)
t          float64  time, s
value      float64  the value, in ``unit``
=========  =======  ============================================================

and the run's manifest (model summary, verdicts, provenance, versions) as JSON in the
file's metadata under ``flexmech``: ``{"format": "flexmech.RunResults", "version": 1,
"manifest": {...}}``. Parquet because the readers engineers use take it as it is: pandas
(``pd.read_parquet``), polars, DuckDB, R's arrow, MATLAB's ``parquetread``; one table so
that a filter on analysis, case and series is all it takes (:func:`read_store`).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from pipeline.core.atomic import atomic_path
from pipeline.workflow.series import coordinate_unit, marker_positions

__all__ = ["STORE", "STORE_FORMAT", "read_store", "result_series", "run_rows",
           "write_store"]

STORE = "results.parquet"
STORE_FORMAT = {"format": "flexmech.RunResults", "version": 1}


def _force_unit(coordinate: str) -> str:
    return {"rad": "N m", "m": "N", "-": "J"}[coordinate_unit(coordinate)]


def result_series(r, mech, markers) -> list[tuple[str, str, np.ndarray, np.ndarray]]:
    """[(series, unit, t (T,), values (T,))] of one analysis result (an
    :class:`pipeline.workflow.analyses.AnalysisResult` on mechanism ``mech``; ``markers``
    the (link, frame) it records)."""
    t = np.asarray(r.t, dtype=float)
    T = t.size
    out = []
    for key, order in (("q", 0), ("qd", 1), ("qdd", 2)):
        X = np.asarray(getattr(r, key))
        if X.shape[:1] != (T,):
            continue
        for i, c in enumerate(r.coordinates):
            out.append((f"{key}:{c}", coordinate_unit(c, order), t, X[:, i]))
    for link, frame in markers:
        P = marker_positions(mech, r.q, link, frame)
        for k, ax in enumerate("xyz"):
            out.append((f"marker:{link}.{frame}:{ax}", "m", t, P[:, k]))
    for name, f in r.forces.items():
        out.append((f"force:{name}", _force_unit(name), t, np.asarray(f)))
    reactions = r.extra.get("reactions") or ()
    if len(reactions) == T:
        for j, joint in enumerate(reactions[0].joints):
            for what, unit, k in (("f", "N", 0), ("m", "N m", 1)):
                V = np.array([(x.force, x.moment)[k][j] for x in reactions])
                for c, ax in enumerate("xyz"):
                    out.append((f"reaction:{joint}:{what}{ax}", unit, t, V[:, c]))
    for name, e in r.energies.items():
        out.append((f"energy:{name}", "J", t, np.asarray(e)))
    for name, (unit, x) in r.states.items():
        out.append((f"state:{name}", unit, t, np.asarray(x)))
    res = r.extra.get("closure_residual")
    if res is not None and np.shape(res) == (T,):
        out.append(("closure_residual", "-", t, np.asarray(res)))
    if "frequencies_hz" in r.extra and T:
        f = np.asarray(r.extra["frequencies_hz"], dtype=float)
        at = np.full(f.size, t[0])
        out.append(("mode:frequency", "Hz", at, f))
        if "damping_ratios" in r.extra:
            out.append(("mode:damping", "-", at, np.asarray(r.extra["damping_ratios"])))
    return out


def run_rows(wf, machines, results) -> list[tuple[str, str, list]]:
    """[(analysis, case, :func:`result_series`)] of a run's results with data."""
    rows = []
    for name, rs in results.items():
        markers = [tuple(s.split(".", 1)) for s in wf.spec.analysis(name).markers]
        for r in rs:
            if r.has_data:
                rows.append((name, r.case or "",
                             result_series(r, machines[r.case].mechanism, markers)))
    return rows


def write_store(path: Path, rows: list[tuple[str, str, list]], manifest: dict) -> Path:
    """Write the store of ``rows`` = [(analysis, case, :func:`result_series` of it)] and
    the run's ``manifest`` to ``path`` (Parquet, zstd)."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    text = ("analysis", "case", "series", "unit")
    words: dict[str, dict[str, int]] = {key: {} for key in text}  # the columns' dictionaries
    codes: dict[str, list] = {key: [] for key in text}
    numbers: dict[str, list] = {"k": [], "t": [], "value": []}
    for analysis, case, series in rows:
        for name, unit, t, v in series:
            n = len(v)
            for key, word in zip(text, (analysis, case, name, unit), strict=True):
                code = words[key].setdefault(word, len(words[key]))
                codes[key].append(np.full(n, code, dtype=np.int32))
            numbers["k"].append(np.arange(n, dtype=np.int64))
            numbers["t"].append(np.asarray(t, dtype=float))
            numbers["value"].append(np.asarray(v, dtype=float))

    def joined(parts, dtype):
        return np.concatenate(parts) if parts else np.zeros(0, dtype=dtype)

    arrays = {key: pa.DictionaryArray.from_arrays(joined(codes[key], np.int32),
                                                  pa.array(list(words[key]), pa.string()))
              for key in text}
    arrays["k"] = pa.array(joined(numbers["k"], np.int64))
    arrays["t"] = pa.array(joined(numbers["t"], float))
    arrays["value"] = pa.array(joined(numbers["value"], float))
    meta = {"flexmech": json.dumps({**STORE_FORMAT, "manifest": manifest}, default=str)}
    table = pa.table(arrays).replace_schema_metadata(meta)
    with atomic_path(path) as tmp:
        pq.write_table(table, tmp, compression="zstd")
    return path


def read_store(path: str | Path):
    """(pyarrow Table, manifest dict) of a run's ``results.parquet`` (``table.to_pandas()``
    gives a DataFrame where pandas is installed).

    Raises ValueError for a Parquet file that is not a run's store."""
    import pyarrow.parquet as pq

    table = pq.read_table(path)
    raw = (table.schema.metadata or {}).get(b"flexmech")
    info = json.loads(raw) if raw else {}
    if info.get("format") != STORE_FORMAT["format"]:
        raise ValueError(f"{path}: not a run's results store (no flexmech metadata)")
    return table, info["manifest"]
