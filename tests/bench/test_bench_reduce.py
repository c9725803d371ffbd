"""Benchmark of the whole reduction chain (prints figures, writes JSON; not a timed test).

Each case runs in a fresh subprocess so its peak resident memory is its own.
Reference on this 2-core machine (issue 2): NGsolve/Netgen meshes the Al bar
in ~1.9 s and assembles K, M in ~0.9 s; scikit-fem's plain ``asm`` ~9 s.
"""

import json
import platform
import subprocess
import sys
import textwrap

import pytest

from pipeline.core.atomic import atomic_open

pytestmark = [pytest.mark.bench, pytest.mark.gmsh]

CASE = textwrap.dedent("""
    import json, resource, sys, time
    from pathlib import Path
    from pipeline.core.progress import StageTimes
    from pipeline.invariants.reduce import reduce_link
    from pipeline.workflow.link_build import link_request
    from pipeline.workflow.link_spec import load_link_spec
    spec = load_link_spec(Path("meshes/al_bar.yaml"))
    spec = spec.model_copy(update={"geometry": spec.geometry.model_copy(
        update={"mesh_size": float(sys.argv[1])})})
    request, _ = link_request(spec, Path("meshes"))
    times = StageTimes()
    t0 = time.perf_counter()
    link = reduce_link(request, times)
    total = time.perf_counter() - t0
    print(json.dumps({"dof": link.meta["n_dof"], "modes": link.n_modes,
                      "f1_hz": float(link.frequencies_hz[0]), "total_s": total,
                      "stages_s": times.as_dict(),
                      "peak_rss_mib": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}))
""")


def _run(mesh_size: float) -> dict:
    out = subprocess.run([sys.executable, "-c", CASE, str(mesh_size)], capture_output=True,
                         text=True, check=True, timeout=3000)
    return json.loads(out.stdout.strip().splitlines()[-1])


def test_bench_reduce_chain():
    results = {"machine": f"{platform.machine()}, {platform.python_version()}, 2 cores",
               "bar_55k": _run(0.00205), "bar_500k": _run(0.00086)}
    for name in ("bar_55k", "bar_500k"):
        r = results[name]
        print(f"\n{name}: {r['dof']} DOF, {r['modes']} modes, total {r['total_s']:.2f} s, "
              f"peak {r['peak_rss_mib']:.0f} MiB")
        for stage, s in r["stages_s"].items():
            print(f"   {stage:45s} {s:8.3f} s")
    with atomic_open("output/bench/reduce_chain.json") as fh:
        json.dump(results, fh, indent=2)
