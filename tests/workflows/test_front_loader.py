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
import loader_geometry as lg  # noqa: E402
from test_loader_geometry import statics_forces, vw_forces  # noqa: E402

from pipeline.workflow import build_machine, load_workflow, run_analysis  # noqa: E402
from pipeline.workflow.series import series  # noqa: E402

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
        vl, vt = vw_forces(p)  # the power balance: F_cyl dL = W dz_load
        assert r.forces["LCYL.d"][k] == pytest.approx(vl, rel=1e-5)


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
