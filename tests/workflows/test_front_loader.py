"""workflows/front_loader.yaml in --quick mode against independent references.

The references are the planar loader model of tests/kinematics/loader_geometry.py (its own
closed-loop solution in the side plane) and the free-body statics / virtual work of
tests/kinematics/test_loader_geometry.py, which share nothing with the 4x4 machinery.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "kinematics"))
import loader_geometry as lg
from test_loader_geometry import statics_forces, vw_forces

from pipeline.kinematics import evaluate_tree
from pipeline.workflow import build_machine, load_workflow, run_analysis
from pipeline.workflow.series import series

pytestmark = pytest.mark.gmsh
WF = Path(__file__).resolve().parents[2] / "workflows" / "front_loader.yaml"
RIGID_NO_WEIGHT = ("gravity=[0, 0, 0]", "links.lift_arm.modes=0", "links.lower_link.modes=0",
                   "links.upper_link.modes=0", "analyses.lift.t_end=0.002",
                   "analyses.lift.outputs=2")


@pytest.fixture(scope="module")
def run(quick_run):
    return quick_run("front_loader")


def _planar_poses(r, mech):
    L = series(r, mech, "q:LCYL.d").values
    T = series(r, mech, "q:TCYL.d").values
    poses, prev = [], None
    for a, b in zip(L, T):
        prev = lg.pose(a, b, prev)
        poses.append(prev)
    return poses


@pytest.mark.slow  # budget of the default run: .ci/run's slow run has it
def test_bucket_path_matches_planar_model(run):
    r = run.result("lift_path")
    mech = run.machine.mechanism
    assert r.success, r.message
    xy = np.column_stack([series(r, mech, f"marker:bucket.LOAD:{c}").values for c in "xy"])
    ref = np.array([p.point("LOAD") for p in _planar_poses(r, mech)])
    assert np.abs(xy - ref).max() < 1e-9
    assert xy[-1, 1] - xy[0, 1] > 2.5  # lifts the load more than 2.5 m


def test_load_only_cylinder_forces_equal_free_body_statics(quick_run):
    res = quick_run("front_loader", RIGID_NO_WEIGHT)
    r = res.result("cylinder_forces")
    mech = res.machine.mechanism
    assert r.success, r.message
    for k, p in enumerate(_planar_poses(r, mech)):
        f_lift, f_tilt = statics_forces(p)
        assert r.forces["LCYL.d"][k] == pytest.approx(f_lift, rel=1e-6)
        assert r.forces["TCYL.d"][k] == pytest.approx(f_tilt, rel=1e-6, abs=1e-6 * abs(f_lift))
        vl, _ = vw_forces(p)  # the power balance: F_cyl dL = W dz_load
        assert r.forces["LCYL.d"][k] == pytest.approx(vl, rel=1e-5)


@pytest.mark.slow  # budget of the default run: .ci/run's slow run has it
def test_with_weights_lift_force_is_larger_and_positive(run):
    r = run.result("cylinder_forces")
    f = r.forces["LCYL.d"]
    assert r.success and np.all(f > 0)
    # link weights add to the load: more than the load-only force at the bottom
    p0 = lg.pose(lg.REFERENCE_LIFT_LENGTH, lg.REFERENCE_TILT_LENGTH)
    assert f[0] > statics_forces(p0)[0]


def _deflection(load_n: float):
    wf = load_workflow(WF, quick=True, sets=[f"forces.rated_load.force=[0, {-load_n}, 0]",
                                             "analyses.deflection.t=5.0"])
    m = build_machine(wf, Path(__file__).resolve().parents[2] / "output" / "links")
    r = run_analysis(m, "deflection")
    assert r.success, r.message
    return np.concatenate([series(r, m.mechanism, s).values for s in (
        "deflection:lift_arm.bucket:x", "deflection:lift_arm.bucket:y", "marker:bucket.LOAD:y")])


def test_static_deflection_is_linear_in_the_load():
    d0, d1, d2 = (_deflection(w) for w in (0.0, lg.RATED_LOAD_N, 2 * lg.RATED_LOAD_N))
    step1, step2 = d1 - d0, d2 - d1
    assert np.linalg.norm(step1[:2]) > 1e-5  # the load visibly bends the arm
    # linear up to the small geometric nonlinearity of the deflected loops
    np.testing.assert_allclose(step2, step1, rtol=1e-2, atol=1e-2 * np.abs(step1).max())
    # with the cylinders held only elasticity lets the load point move: down, sub-mm to mm
    assert -5e-3 < step1[2] < 0


@pytest.mark.slow  # budget of the default run: .ci/run's slow run has it
def test_static_cases_and_transient(run):
    for r in run.results["deflection"]:
        assert r.success, (r.case, r.message)
    r = run.result("lift")
    assert r.success, r.message
    assert r.extra["closure_residual"].max() < 1e-10
    e = series(r, run.machines[r.case].mechanism, "energy:total").values
    scale = np.abs(series(r, run.machines[r.case].mechanism, "energy:gravity").values).max()
    # generalised-alpha: second order, trapezoidal energy integrals, numerical damping of
    # the stiff closed-loop modes (rho_inf 0.8): the balance closes to O(h^2), not to 1e-12
    assert np.abs(e - e[0]).max() < 1e-4 * scale


def _leg_stress_by_beam_theory(r, mech, k: int) -> dict[str, float]:
    """Axial stress (Pa) at the front leg's two edge hot spots from beam theory: the cut
    halfway between the lift-cylinder eye and the bucket pin carries the bucket-pin force
    (the joint reaction, rotated into the arm's axes) and the weight of the plate below
    it; sigma = N / A + M s / I across the 160 x 25 mm section."""
    li = mech.link_index("lift_arm")
    link = mech.links[li]
    B = link.frame("bucket").pose[:3, 3]
    spots = {s: link.frame(s).pose[:3, 3] for s in ("leg_front", "leg_back")}
    d = np.array([0.30, -1.10, 0.0]) / np.hypot(0.30, 1.10)  # bend -> bucket pin
    n = np.array([-d[1], d[0], 0.0])
    c = (spots["leg_front"] + spots["leg_back"]) / 2
    c[2] = 0.0
    w, t, rho = 0.16, 0.025, 7850.0
    # plate below the cut: strip to the pin, half disc around it, less the bore
    parts = [(w * np.linalg.norm(B - c), (c + B) / 2),
             (np.pi * w ** 2 / 8, B + d * 2 * w / (3 * np.pi)), (-np.pi * 0.022 ** 2, B)]
    area = sum(a for a, _ in parts)
    g_c = sum(a * p for a, p in parts) / area
    R = evaluate_tree(mech, r.q[k], derivatives=False).A[li][:3, :3]
    j = list(r.extra["reactions"][k].joints).index("BKPT")
    F = -R.T @ r.extra["reactions"][k].force[j]  # the bucket on the arm (body axes)
    W = R.T @ np.array([0.0, -9.81, 0.0]) * area * t * rho
    N = F @ d + W @ d  # tension positive
    M = (np.cross(B - c, F) + np.cross(g_c - c, W))[2]
    return {s: N / (w * t) - M * ((p - c) @ n) / (t * w ** 3 / 12) for s, p in spots.items()}


@pytest.mark.slow  # budget of the default run: .ci/run's slow run has it
def test_lift_arm_stress_along_the_lift_is_the_beam_theory_stress(run):
    """The front leg's edge stress under the rated load (quasi-static, weights included)
    from the Craig-Bampton stress modes equals beam theory with the bucket-pin reaction
    (docs/front_loader.md) within 2 % at every position of the lift."""
    r = run.result("cylinder_forces")
    m = run.machines[r.case]
    mech = m.mechanism
    d = np.array([0.30, -1.10]) / np.hypot(0.30, 1.10)
    fe = {}
    for s in ("leg_front", "leg_back"):
        xx, yy, xy = (series(r, mech, f"stress:lift_arm.{s}:{c}", m.parts).values
                      for c in ("xx", "yy", "xy"))
        fe[s] = d[0] ** 2 * xx + d[1] ** 2 * yy + 2 * d[0] * d[1] * xy
        vm = series(r, mech, f"stress:lift_arm.{s}:von_mises", m.parts).values
        np.testing.assert_allclose(vm, np.abs(fe[s]), rtol=1e-2)  # a free edge: uniaxial
    for k in range(len(r.t)):
        hand = _leg_stress_by_beam_theory(r, mech, k)
        assert hand["leg_front"] > 10e6 and hand["leg_back"] < -10e6  # bending dominates
        for s in hand:
            assert fe[s][k] == pytest.approx(hand[s], rel=2e-2), (s, r.t[k])


def test_the_valve_driven_lift_needs_the_pressures_the_kinetostatics_give(quick_run):
    """workflows/front_loader_hydraulic.yaml (the lift cylinder a hydraulic cylinder, its
    valve opening at 0.2 s, the tilt held) against the prescribed-stroke model's
    kinetostatic cylinder force at the same stroke, tilt held alike (the thesis' way to the
    pressure requirement). The cylinder's force from its pressures, p_a A_a - p_b A_b - c s',
    equals it at rest (the hold pressure found at the start) and during the steady lift
    (within the few per mille the lift's own dynamics add)."""
    held = "drivers.TCYL.d={type: constant, value: 1.0514870}"
    hyd, ref = quick_run("front_loader_hydraulic"), quick_run("front_loader", (held,))
    r, k = hyd.result("lift", ""), ref.result("cylinder_forces", "")
    assert r.verdict == "ok", r.warnings
    mh, mr = hyd.machine.mechanism, ref.machine.mechanism
    s, sd = series(r, mh, "q:LCYL.d").values, r.qd[:, mh.index("LCYL.d")]
    aa = np.pi / 4 * 0.063 ** 2
    ab = aa - np.pi / 4 * 0.035 ** 2
    force = r.states["lift_cyl.p_a"][1] * aa - r.states["lift_cyl.p_b"][1] * ab - 2e3 * sd
    kinetostatic = np.interp(s, series(k, mr, "q:LCYL.d").values, k.forces["LCYL.d"])
    ratio = force / kinetostatic - 1.0
    assert np.abs(ratio[r.t <= 0.2]).max() < 1e-4  # 2.4e-5
    assert np.abs(ratio[r.t >= 0.9]).max() < 1e-2  # 2-5e-3
    assert s[-1] - s[0] > 0.15  # it lifted
