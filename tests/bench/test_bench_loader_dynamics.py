"""Benchmark (b): front-end loader with two flexible links (reduced lift arm from
meshes/lift_arm.yaml, reduced lower lift link), 10 s lift.

Wall time, steps, right-hand-side evaluations, time per evaluation, real-time
factor, closure residual and energy balance, and a cProfile breakdown of the
right-hand side -> ``output/bench/loader_dynamics.json``. If the full 10 s would
take longer than ~5 min the run covers the first SIM_END seconds of the 10 s lift
and the wall time is extrapolated linearly (flagged in the JSON). Not a timed test.
"""

from __future__ import annotations

import cProfile
import io
import json
import pstats
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "dynamics"))
from loader_flex_model import build_flexible_loader, reduce_links

from pipeline.core.atomic import atomic_open
from pipeline.dynamics import static_equilibrium
from pipeline.dynamics.linearize import vibration_modes
from pipeline.solver import simulate

OUT = Path(__file__).resolve().parents[2] / "output" / "bench" / "loader_dynamics.json"
T_LIFT = 10.0
SIM_END = 1.0  # s simulated (a 10 s run at ~0.06x real time would exceed 5 min)
METHOD, RTOL, ATOL = "DOP853", 1e-6, 1e-8
FUNCS = ("reduced_state", "inertia_terms", "equation_terms", "evaluate_tree",
         "elastic_forces", "generalized_force",
         "complete_position", "velocity_transform", "closure", "closure_jacobian",
         "closure_gamma", "solve", "lstsq", "svd", "qr", "driver_forces")


def _profile(system, q0, t1=0.02):
    pr = cProfile.Profile()
    pr.enable()
    r = simulate(system, q0, np.zeros_like(q0), (0.0, t1), np.linspace(0, t1, 3), method=METHOD,
                 rtol=RTOL, atol=ATOL, progress=False)
    pr.disable()
    st = pstats.Stats(pr)
    rhs = [v for k, v in st.stats.items() if k[2] == "__call__" and "integrate" in k[0]]
    total = rhs[0][3] if rhs else 1.0
    shares = {}
    for (file, _, func), v in st.stats.items():
        if func in FUNCS:
            key = f"{Path(file).stem}.{func}"
            shares[key] = round(shares.get(key, 0.0) + v[3] / total, 3)
    buf = io.StringIO()
    pstats.Stats(pr, stream=buf).sort_stats("tottime").print_stats(15)
    return dict(sorted(shares.items(), key=lambda kv: -kv[1])), buf.getvalue(), r.n_rhs


@pytest.mark.bench
@pytest.mark.gmsh
def test_bench_loader_two_flexible_links(tmp_path):
    reduced = reduce_links(tmp_path, arm_size=0.02, link_size=0.015, arm_modes=2, link_modes=1)
    system, q0 = build_flexible_loader(reduced, t_lift=T_LIFT)
    t = np.linspace(0.0, SIM_END, round(SIM_END * 100) + 1)
    r = simulate(system, q0, np.zeros_like(q0), (0.0, SIM_END), t, method=METHOD, rtol=RTOL,
                 atol=ATOL, progress=False)
    assert r.success, r.message
    e = r.energies
    scale = sum(np.ptp(e[k]) for k in ("kinetic", "gravity", "elastic", "forces",
                                       "dissipated", "driver_work"))
    wall = r.timings["total"]
    shares, table, n_prof = _profile(system, q0)
    vib = vibration_modes(system, q0)
    print(table)
    links = {name: {"mass_kg": red.mass, "kept_modes": [int(m) for m in modes],
                    "clamped_frequencies_hz": red.frequencies_hz[modes].tolist()}
             for name, (red, modes) in reduced.items()}
    report = {
        "case": "front-end loader, flexible lift arm (meshes/lift_arm.yaml, in-plane modes) and "
                "flexible lower link (plate_with_bores), lift 0->stroke by quintic smooth step "
                f"over {T_LIFT} s, tilt retracted over the same time, chassis held, rated load "
                "4448.2 N at LOAD, gravity, 2 % modal damping, released undeformed",
        "method": METHOD, "rtol": RTOL, "atol": ATOL, "links": links,
        "n_coordinates": system.mechanism.n,
        "simulated_s": SIM_END, "extrapolated_to_s": T_LIFT,
        "extrapolated": SIM_END < T_LIFT,
        "wall_s": wall, "integrate_s": r.timings["integrate"], "output_s": r.timings["output"],
        "steps": r.n_steps, "rhs_evaluations": r.n_rhs,
        "ms_per_rhs": 1e3 * r.timings["integrate"] / r.n_rhs,
        "mean_step_s": SIM_END / r.n_steps,
        "real_time_factor": SIM_END / wall,  # simulated seconds per wall second
        "wall_s_for_10s_extrapolated": wall * T_LIFT / SIM_END,
        "goal_10x_real_time_met": SIM_END / wall >= 10.0,
        "closure_residual_max": float(r.closure_residual.max()),
        "energy_balance_residual_J": float(np.abs(e["total"] - e["total"][0]).max()),
        "energy_balance_residual_rel": float(np.abs(e["total"] - e["total"][0]).max() / scale),
        "max_abs_eta": float(np.abs(r.q[:, -3:]).max()),
        # linearised closed-loop modes at the start: the stiffest one bounds the explicit step
        "closed_loop_frequencies_hz": vib.frequencies_hz.tolist(),
        "mean_step_times_omega_max": float(np.nanmax(vib.omega) * SIM_END / r.n_steps),
        "profile_rhs_evaluations": n_prof,
        "profile_share_of_rhs": shares,
    }
    print(json.dumps({k: v for k, v in report.items() if k != "profile_share_of_rhs"}, indent=1))
    print("share of rhs time:", shares)
    OUT.parent.mkdir(parents=True, exist_ok=True)
    with atomic_open(OUT) as fh:
        json.dump(report, fh, indent=2)
    assert r.closure_residual.max() < 1e-9


OUT_GA = OUT.with_name("loader_dynamics_generalized_alpha.json")
GA_RHO, GA_RTOL, GA_ATOL = 0.8, 1e-6, 1e-8
#: (step s, output spacing s): 10 ms resolves the lowest closed-loop mode (16 Hz) with 6
#: steps; 8 ms with outputs every 10 ms (between step ends, interpolated and projected) is
#: the largest step within the issue's 1e-4 (the error at 10 ms is the 141 Hz ring the
#: reference keeps and the step filters)
GA_STEPS = ((0.005, 0.01), (0.008, 0.01), (0.01, 0.01), (0.02, 0.02))
HEADLINE_STEP = 0.01
REPEATS = 3  # wall time: best of REPEATS (the machine's speed varies by up to ~40 %)
REF_END = 2.0  # s of the reference run
GA_FUNCS = ("closed_state", "_closed_state", "_compiled_state", "equation_terms",
            "_force_elements", "_solve_reduced", "predict", "_try", "_jacobian", "_record",
            "_reselect", "energies")


def _ga_profile(system, q0, step, t1=2.0):
    """Share of the wall time of a generalised-alpha run per function (cumulative)."""
    pr = cProfile.Profile()
    t = np.linspace(0.0, t1, round(t1 / step) + 1)
    pr.enable()
    simulate(system, q0, np.zeros_like(q0), (0.0, t1), t, method="generalized_alpha",
             error_estimate=False,
             step=step, rho_inf=GA_RHO, rtol=GA_RTOL, atol=GA_ATOL, progress=False)
    pr.disable()
    st = pstats.Stats(pr)
    total = max(v[3] for v in st.stats.values())
    shares = {}
    for (file, _, func), v in st.stats.items():
        if func in GA_FUNCS:
            key = f"{Path(file).stem}.{func}"
            shares[key] = round(shares.get(key, 0.0) + v[3] / total, 3)
    return dict(sorted(shares.items(), key=lambda kv: -kv[1]))


@pytest.mark.bench
@pytest.mark.gmsh
def test_bench_loader_generalized_alpha_full_lift(tmp_path):
    """The full 10 s lift with the implicit generalised-alpha at 5, 10 and 20 ms (rho_inf
    0.8, Newton rtol 1e-6), each against DOP853 at rtol 1e-9 over the first 2 s."""
    reduced = reduce_links(tmp_path, arm_size=0.02, link_size=0.015, arm_modes=2, link_modes=1)
    system, q_ref = build_flexible_loader(reduced, t_lift=T_LIFT)
    # from the static equilibrium (as the workflow's transient starts): released undeformed,
    # the links ring at up to ~1 kHz, which these steps filter out by design
    st = static_equilibrium(system, q_ref)
    assert st.success, st.message
    q0 = st.q
    # warm the compiled kernels (numba compiles on first use, then loads from its cache)
    simulate(system, q0, np.zeros_like(q0), (0.0, 0.02), [0.0, 0.02],
             method="generalized_alpha", error_estimate=False, step=0.01, progress=False)
    t_ref = np.linspace(0.0, REF_END, round(REF_END * 100) + 1)
    # max_step: DOP853's own first step on this stiff system is long enough for its trial
    # stages to close the loops on another assembly branch (README, limits)
    ref = simulate(system, q0, np.zeros_like(q0), (0.0, REF_END), t_ref, method="DOP853",
                   rtol=1e-9, atol=1e-11, max_step=1e-3, progress=False)
    assert ref.success, ref.message
    modal = list(system.mechanism.modal_coordinates)
    peak_modal = float(np.abs(ref.q[:, modal]).max())
    peak_force = float(np.abs(ref.driver_forces).max())
    runs = []
    for step, spacing in GA_STEPS:
        t = np.linspace(0.0, T_LIFT, round(T_LIFT / spacing) + 1)
        walls, r = [], None
        for _ in range(REPEATS):
            r = simulate(system, q0, np.zeros_like(q0), (0.0, T_LIFT), t,
                         method="generalized_alpha",
                         error_estimate=False, step=step, rho_inf=GA_RHO, rtol=GA_RTOL,
                         atol=GA_ATOL, progress=False)
            assert r.success, r.message
            walls.append(r.timings["total"])
        k = np.flatnonzero(t <= REF_END + 1e-12)
        kr = np.searchsorted(t_ref, t[k] - 1e-9)  # the reference at the same instants
        assert np.allclose(t_ref[kr], t[k])
        e = r.energies
        wall = min(walls)
        runs.append({
            "step_s": step, "output_spacing_s": spacing, "outputs": int(t.size),
            "wall_s_best": wall, "wall_s_all": walls, "steps": r.n_steps,
            "rhs_evaluations": r.n_rhs, "rhs_per_step": r.n_rhs / r.n_steps,
            "ms_per_rhs_incl_step_overhead": 1e3 * (wall - r.timings["output"]) / r.n_rhs,
            "output_s": r.timings["output"],
            "real_time_factor": T_LIFT / wall, "goal_10x_real_time_met": T_LIFT / wall >= 10.0,
            "modal_coordinate_error_rel": float(np.abs(r.q[k][:, modal]
                                                       - ref.q[kr][:, modal]).max()
                                                / peak_modal),
            "driver_force_error_rel": float(np.abs(r.driver_forces[k] - ref.driver_forces[kr])
                                            .max() / peak_force),
            "closure_residual_max": float(r.closure_residual.max()),
            "energy_balance_residual_J": float(np.abs(e["total"] - e["total"][0]).max()),
        })
        print(json.dumps(runs[-1], indent=1))
    head = next(x for x in runs if x["step_s"] == HEADLINE_STEP)
    report = {
        "case": "as loader_dynamics.json, the full 10 s lift, from the static equilibrium",
        "method": "generalized_alpha", "rho_inf": GA_RHO, "rtol": GA_RTOL, "atol": GA_ATOL,
        "n_coordinates": system.mechanism.n, "simulated_s": T_LIFT,
        "closed_loop_frequencies_hz": vibration_modes(system, q0).frequencies_hz.tolist(),
        "reference": f"DOP853 rtol 1e-9, max_step 1 ms, over the first {REF_END} s "
                     f"({ref.timings['total']:.1f} s wall, {ref.n_rhs} evaluations)",
        "headline_step_s": HEADLINE_STEP,
        "real_time_factor": head["real_time_factor"],
        "goal_10x_real_time_met": head["goal_10x_real_time_met"],
        "runs": runs,
        "profile_share_of_wall_10ms": _ga_profile(system, q0, HEADLINE_STEP),
    }
    print(json.dumps({k: v for k, v in report.items() if k != "runs"}, indent=1))
    OUT_GA.parent.mkdir(parents=True, exist_ok=True)
    with atomic_open(OUT_GA) as fh:
        json.dump(report, fh, indent=2)
    for x in runs:
        assert x["closure_residual_max"] < 1e-9
