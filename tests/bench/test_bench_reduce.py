"""Benchmark of the whole reduction chain (prints figures, writes JSON; not a timed test):
mesh, assembly, tying, the eigen solve, invariants, stress modes and, where asked, the
geometric stiffness of the unit load cases, for the aluminium bar at about 55 k, 500 k and
1 M P2 DOF with 20 modes (issue 11, "large links fast").

Each case runs in a fresh subprocess so its peak resident memory is its own; they run one
after the other (the 1 M case alone takes most of this machine's 24 GB's worth of care).
Figures on this 2-core machine are in output/bench/reduce_chain.json and the issue notes.
Reference (issue 2): NGsolve/Netgen meshes the bar at 55 k in ~1.9 s and assembles K, M in
~0.9 s; scikit-fem's plain ``asm`` ~9 s.
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
    spec = spec.model_copy(update={
        "geometry": spec.geometry.model_copy(update={"mesh_size": float(sys.argv[1])}),
        "modes": spec.modes.model_copy(update={"count": int(sys.argv[2]),
                                               "geometric_stiffening": sys.argv[3] == "1"})})
    request, _ = link_request(spec, Path("meshes"))
    times = StageTimes()
    t0 = time.perf_counter()
    link = reduce_link(request, times)
    total = time.perf_counter() - t0
    cases = 12 + 3 * len(link.frames) if sys.argv[3] == "1" else 0  # inertia + frame forces
    print(json.dumps({"dof": link.meta["n_dof"], "modes": link.n_modes,
                      "f1_hz": float(link.frequencies_hz[0]), "total_s": total,
                      "stages_s": times.as_dict(), "stiffening_cases": cases,
                      "peak_rss_mib": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}))
""")

#: mesh sizes (m) of the bar for about 55 k, 500 k and 1 M P2 DOF
SIZES = {"55k": 0.00205, "500k": 0.00086, "1M": 0.00065}


def _run(mesh_size: float, modes: int = 20, stiffening: bool = False) -> dict:
    out = subprocess.run([sys.executable, "-c", CASE, str(mesh_size), str(modes),
                          "1" if stiffening else "0"], capture_output=True, text=True,
                         check=True, timeout=5400)
    return json.loads(out.stdout.strip().splitlines()[-1])


def _print(name: str, r: dict) -> None:
    print(f"\n{name}: {r['dof']} DOF, {r['modes']} modes, total {r['total_s']:.1f} s, "
          f"peak {r['peak_rss_mib'] / 1024:.1f} GiB")
    for stage, s in r["stages_s"].items():
        print(f"   {stage:55s} {s:8.2f} s")
    if r["stiffening_cases"]:
        g = next(s for k, s in r["stages_s"].items() if k.startswith("geometric stiffness"))
        print(f"   geometric stiffening: {r['stiffening_cases']} unit load cases, "
              f"{g / r['stiffening_cases']:.2f} s per right-hand side")


def test_bench_reduce_chain():
    results = {"machine": f"{platform.machine()}, Python {platform.python_version()}, "
                          "2 cores, 24 GB"}
    for name, size in SIZES.items():
        results[f"bar_{name}"] = _run(size)
        _print(f"bar_{name}", results[f"bar_{name}"])
    results["bar_55k_stiffening"] = _run(SIZES["55k"], stiffening=True)
    results["bar_500k_stiffening"] = _run(SIZES["500k"], stiffening=True)
    for name in ("bar_55k_stiffening", "bar_500k_stiffening"):
        _print(name, results[name])
    with atomic_open("output/bench/reduce_chain.json") as fh:
        json.dump(results, fh, indent=2)
