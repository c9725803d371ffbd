"""DOF and redundant constraints (planar four-bar in 3D), the spatial RSSR with
its passive coupler spin, and a spherical joint driven across 60 deg."""

from __future__ import annotations

import numpy as np
from kin_models import four_bar, rssr, rssr_rocker, wrist_loop

from pipeline.kinematics import assemble, closure_residual, dof_report, sweep
from pipeline.kinematics.drivers import Ramp
from pipeline.kinematics.poses import evaluate_tree, step_pose
from pipeline.kinematics.rotations import log_so3, rot_x, rot_y, rot_z

PIVOT, A_CRANK = (2.5, 0.5, 1.0), 0.5


def Linear(v0, w):
    """Coordinate v0 + w t (t >= 0)."""
    return Ramp(t0=0.0, slope=w, v0=v0)


def test_planar_four_bar_in_3d_dof_and_redundant_rows():
    m = four_bar(0.04, 0.12, 0.09, 0.10)
    a = assemble(m, driven=["J2.theta"])
    rep = dof_report(m, a.q)
    assert (rep.n_coordinates, rep.rank, rep.dof, rep.effective_dof) == (4, 3, 1, 1)
    # the loop moves in the x-y plane: out-of-plane position and in-plane rotations
    assert rep.redundant == ("L1 (cut 'J4'): position z", "L1 (cut 'J4'): rotation x",
                             "L1 (cut 'J4'): rotation y")
    assert rep.passive == ()
    driven = dof_report(m, a.q, ["J2.theta"])
    assert driven.free == () and len(driven.dependent) == 3
    assert "redundant constraints" in rep.summary()


def test_rssr_dof_with_passive_coupler_spin():
    m, b = rssr(a=A_CRANK, pivot=PIVOT)
    a = assemble(m, driven=["crank.theta"])
    rep = dof_report(m, a.q)
    assert (rep.rank, rep.dof, rep.effective_dof) == (6, 2, 1)
    assert rep.redundant == ()
    (p,) = rep.passive
    assert p.link == "coupler"
    A_pin = step_pose(m.marker("crank", "A"), evaluate_tree(m, a.q, derivatives=False).A, a.q)
    B_pin = step_pose(m.marker("rocker", "B"), evaluate_tree(m, a.q, derivatives=False).A, a.q)
    axis = B_pin[:3, 3] - A_pin[:3, 3]
    assert np.isclose(np.linalg.norm(axis), b)
    # spin axis = line through both sphere centres (independent geometry)
    assert np.linalg.norm(np.cross(p.direction, axis / b)) < 1e-9
    assert np.linalg.norm(np.cross(p.point - A_pin[:3, 3], axis / b)) < 1e-9
    assert not any(c.startswith(("crank.", "rocker.")) for c in p.coordinates)
    driven = dof_report(m, a.q, ["crank.theta"])
    assert len(driven.free) == 1 and driven.free[0].startswith("S")  # the spin is what is left
    assert len(driven.passive) == 1


def test_rssr_rocker_follows_closed_form_over_a_crank_revolution():
    m, b = rssr(a=A_CRANK, pivot=PIVOT)
    t = np.linspace(0.0, 2 * np.pi, 181)
    res = sweep(m, {"crank.theta": Linear(0.5, 1.0)}, t)
    assert res.success, res.message
    ref = np.array([rssr_rocker(0.5 + x, b, 0.3, a=A_CRANK, pivot=PIVOT) for x in t])
    err = np.angle(np.exp(1j * (res["rocker.theta"] - np.pi / 2 - ref)))
    assert np.abs(err).max() < 1e-10
    assert max(np.abs(closure_residual(m, q)).max() for q in res.q) < 1e-11
    # rocker rate: finite difference of the closed form (central, h = 1e-6)
    h = 1e-6
    rate = [(rssr_rocker(0.5 + x + h, b, 0.3, a=A_CRANK, pivot=PIVOT)
             - rssr_rocker(0.5 + x - h, b, 0.3, a=A_CRANK, pivot=PIVOT)) / (2 * h) for x in t]
    assert np.abs(res.qd[:, m.index("rocker.theta")] - rate).max() < 1e-8


def test_spherical_joint_driven_across_60_degrees():
    """The spherical's ZYX angles are solved (dependent) while three revolutes
    rotate the link by more than 60 deg about a skew axis; they equal the ZYX
    decomposition of rot_z(a) rot_x(b) rot_y(c) and the block stays regular."""
    m = wrist_loop()
    drv = {"R1.theta": Linear(0.0, 0.8), "R2.theta": Linear(0.0, -0.75),
           "R3.theta": Linear(0.0, 0.6)}
    t = np.linspace(0.0, 1.0, 61)
    res = sweep(m, drv, t)
    assert res.success, res.message
    assert res.reselections == ()
    i = m.index("S.rz")
    angles = []
    for k, tk in enumerate(t):
        R = rot_z(0.8 * tk) @ rot_x(-0.75 * tk) @ rot_y(0.6 * tk)
        ref = [np.arctan2(R[1, 0], R[0, 0]), -np.arcsin(R[2, 0]), np.arctan2(R[2, 1], R[2, 2])]
        assert np.abs(res.q[k, i:i + 3] - ref).max() < 1e-12
        angles.append(np.degrees(np.linalg.norm(log_so3(R))))
    assert max(angles) > 60.0
    assert np.degrees(np.abs(res.q[:, i + 1]).max()) < 60.0  # pitch well away from 90 deg
    # all three position rows are redundant (every axis passes through the centre)
    rep = dof_report(m, res.q[-1], list(drv))
    assert rep.rank == 3 and len(rep.redundant) == 3 and rep.free == ()
