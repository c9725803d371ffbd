"""Benchmark: what importing the package costs (issue 25's goal: ``import pipeline.api``
within 0.3 s). Each figure is a fresh interpreter, interleaved, 7 repeats, CPU seconds of
the child (user + system) and its peak RSS:

* ``python -c pass`` (the interpreter alone, the floor);
* ``import pipeline.api`` (the lazy facade: no numpy, scipy or numba yet);
* ``from pipeline.api import simulate, System`` (the dynamics stack: numpy, scipy, numba's
  kernels declared, not yet loaded from its cache).

-> ``output/bench/import.json``. Not a timed test."""

from __future__ import annotations

import json
import resource
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from pipeline.core.atomic import atomic_open

OUT = Path(__file__).resolve().parents[2] / "output" / "bench" / "import.json"
REPEATS = 7
CASES = {"interpreter": "pass", "facade": "import pipeline.api",
         "dynamics": "from pipeline.api import System, simulate"}


#: the child's own peak RSS (VmHWM: ru_maxrss would carry the forking parent's across exec)
PEAK = ("\nfor line in open('/proc/self/status'):\n"
        "    if line.startswith('VmHWM:'):\n        print(line.split()[1])")


def _child(code: str) -> tuple[float, float]:
    """(CPU s, peak RSS MiB) of a fresh interpreter running ``code``."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    out = subprocess.run([sys.executable, "-c", code + PEAK], capture_output=True, text=True,
                         check=True)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return cpu, int(out.stdout.split()[-1]) / 1024.0


@pytest.mark.bench
def test_bench_import():
    rows = {k: [] for k in CASES}
    for _ in range(REPEATS):
        for k, code in CASES.items():
            rows[k].append(_child(code))
    out = {"machine": "2-core shared machine, CPU seconds of a fresh interpreter",
           "repeats": REPEATS}
    for k, runs in rows.items():
        cpu, rss = np.array(runs).T
        out[k] = {"cpu_s_median": float(np.median(cpu)), "cpu_s_range": [cpu.min(), cpu.max()],
                  "peak_rss_mib_median": float(np.median(rss))}
    out["facade_over_interpreter_s"] = out["facade"]["cpu_s_median"] - \
        out["interpreter"]["cpu_s_median"]
    print(json.dumps(out, indent=1))
    OUT.parent.mkdir(parents=True, exist_ok=True)
    with atomic_open(OUT) as fh:
        json.dump(out, fh, indent=2)
    assert out["facade"]["cpu_s_median"] < out["dynamics"]["cpu_s_median"]
