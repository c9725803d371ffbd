"""Front-end loader (DESIGN §5, geometry from loader_geometry.py): topology,
DOF, and a full lift stroke with both cylinders driven, checked against the
geometry module's own (scipy fsolve) planar solution."""

from __future__ import annotations

import loader_geometry as geo
import numpy as np
import pytest
from loader_model import build_loader

from pipeline.kinematics import closure_residual, dof_report, sweep
from pipeline.kinematics.drivers import SmoothStep

T_END = 4.0
TILT_END = geo.CYLINDERS["tilt"].min_length  # m: the bucket rolls back while the arm rises


@pytest.fixture(scope="module")
def loader():
    return build_loader()


@pytest.fixture(scope="module")
def stroke(loader):
    mech, q0 = loader
    lift = geo.CYLINDERS["lift"]
    drivers = {"LCYL.d": SmoothStep(0.0, T_END, lift.min_length, lift.max_length),
               "TCYL.d": SmoothStep(0.0, T_END, geo.REFERENCE_TILT_LENGTH, TILT_END)}
    t = np.linspace(0.0, T_END, 201)
    res = sweep(mech, drivers, t, q0, markers=[("lift_arm", "BKPT"), ("bucket", "LOAD")])
    return mech, drivers, res


def test_loader_topology_has_the_three_seed_loops(loader):
    mech, _ = loader
    loops = {frozenset(mech.joints[j].name for j in lp.joints) for lp in mech.topology.loops}
    assert loops == {frozenset(lp.joints) for lp in geo.LOOPS}


def test_loader_dof(loader):
    mech, q0 = loader
    assert np.abs(closure_residual(mech, q0)).max() < 1e-14  # the reference is assembled
    rep = dof_report(mech, q0)
    assert (rep.rank, rep.dof) == (9, 3)  # chassis slide + two cylinders
    # planar machine in the x-z plane: per loop, y position and x, z rotations redundant
    assert len(rep.redundant) == 9
    assert all(r.endswith(("position y", "rotation x", "rotation z")) for r in rep.redundant)
    driven = dof_report(mech, q0, ["LCYL.d", "TCYL.d"])
    assert driven.free == ("CHASSIS_X.d",) and driven.passive == ()


def test_full_lift_stroke_sweeps_without_failure(stroke):
    mech, _, res = stroke
    assert res.success, res.message
    assert res.free == ("CHASSIS_X.d",)
    assert np.all(res["CHASSIS_X.d"] == 0.0)
    L = mech.length_scale
    assert max(np.abs(closure_residual(mech, q)).max() for q in res.q) <= 1e-12 * L
    assert res.newton_iterations.max() <= 3


def test_lift_stroke_matches_the_geometry_module(stroke):
    mech, drivers, res = stroke
    prev = None
    for k in range(0, res.t.size, 10):
        lift, tilt = (drivers[n].value(res.t[k]) for n in ("LCYL.d", "TCYL.d"))
        ref = geo.pose(lift, tilt, prev)
        prev = ref
        q = res.q[k]
        arm = q[mech.index("LCPT.theta")] + q[mech.index("LLAPT.theta")]
        assert abs(arm - ref.arm_angle) < 1e-9
        assert abs(q[mech.index("BKPT.theta")] - ref.bucket_angle) < 1e-9
        pin = res.markers["lift_arm.BKPT"][k][:3, 3]
        assert np.abs(pin[[0, 2]] - ref.pin).max() < 1e-9 and abs(pin[1]) < 1e-14
        load = res.markers["bucket.LOAD"][k][:3, 3]
        assert np.abs(load[[0, 2]] - ref.point("LOAD")).max() < 1e-9
    # the arm really rose: about 1.08 rad over the stroke
    assert res.q[-1, mech.index("LCPT.theta")] + res.q[-1, mech.index("LLAPT.theta")] > 1.0


def test_marker_velocity_matches_geometry_module_differences(stroke):
    _, drivers, res = stroke
    h = 1e-4
    for k in (40, 100, 160):
        tk = res.t[k]

        def load_at(t):
            return geo.pose(drivers["LCYL.d"].value(t), drivers["TCYL.d"].value(t)).point("LOAD")

        v_fd = (load_at(tk + h) - load_at(tk - h)) / (2 * h)
        a_fd = (load_at(tk + h) - 2 * load_at(tk) + load_at(tk - h)) / h**2
        v = res.marker_velocity["bucket.LOAD"][k][[0, 2]]
        a = res.marker_acceleration["bucket.LOAD"][k][[0, 2]]
        assert np.abs(v - v_fd).max() < 1e-6 * max(1.0, np.abs(v).max())
        assert np.abs(a - a_fd).max() < 1e-3 * max(1.0, np.abs(a).max())
