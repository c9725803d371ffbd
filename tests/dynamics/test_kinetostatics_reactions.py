"""Joint reactions: a slider-crank's two-force rod vs the closed form, and Newton-Euler
consistency of the loader's actuator forces (from Lagrange's equations) with the
inertia and weight of every body (from the invariants)."""

from __future__ import annotations

import numpy as np
import pytest
from test_kinetostatics import DRIVEN, R, _loader, _slider_system

from pipeline.dynamics.kinetostatics import joint_reactions, kinetostatics


def test_slider_crank_rod_is_a_two_force_member():
    system = _slider_system(tau=35.0)
    mech = system.mechanism
    t = np.linspace(0.0, 2.0, 5)
    res = kinetostatics(system, t, mech.q_initial, reactions=True)
    assert res.success and len(res.reactions) == t.size
    j = {n: k for k, n in enumerate(res.reactions[0].joints)}
    for k, r in enumerate(res.reactions):
        th = res.q[k, mech.index("crank.theta")]
        a = R * np.array([np.cos(th), np.sin(th)])
        b = np.array([res.q[k, mech.index("slide.d")], 0.1])
        u = (b - a) / np.linalg.norm(b - a)
        C = -res.force("slide.d")[k] / u[0]  # slider x balance: lambda + C u_x = 0
        scale = abs(C)
        for name in ("crank", "pin", "wrist"):  # every joint carries C u in the plane
            assert np.allclose(r.force[j[name], :2], C * u, atol=1e-9 * scale), name
            assert abs(r.force[j[name], 2]) <= 1e-9 * scale
        # free revolutes transmit no torque about their axes
        for name in ("crank", "pin", "wrist"):
            assert abs(r.moment[j[name], 2]) <= 1e-9 * scale * R
        # slider: the rail pushes back with -C u (axial part = the actuator force)
        assert np.allclose(r.force[j["slide"], :2], -C * u, atol=1e-9 * scale)
        assert r.residual <= 1e-9 * scale


@pytest.fixture(scope="module")
def loader_dyn():
    system, q0 = _loader(True)
    t = np.array([0.7, 2.0, 3.1])
    return system, kinetostatics(system, t, q0, inertia=True, reactions=True)


def test_loader_actuator_forces_balance_newton_euler_of_every_body(loader_dyn):
    """The planar machine's in-plane equations are overdetermined by its 3 DOF: the
    residual vanishes only if the Lagrange actuator forces match the bodies'
    Newton-Euler loads (weights, bucket load, inertia)."""
    _, res = loader_dyn
    assert res.success
    scale = np.abs(res.forces).max()
    for r in res.reactions:
        assert r.residual <= 1e-8 * scale
    # pin loads of the order of the cylinder forces
    assert 0.2 * scale < np.abs(res.reactions[1].force).max() < 20 * scale


def test_wrong_actuator_force_breaks_newton_euler(loader_dyn):
    system, res = loader_dyn
    k = 1
    forces = dict(zip(res.names, res.forces[k]))
    forces[DRIVEN[0]] *= 1.01
    r = joint_reactions(system, res.q[k], res.qd[k], res.qdd[k], res.t[k], forces)
    assert r.residual > 1e-4 * abs(forces[DRIVEN[0]])
    # and ignoring inertia is visibly wrong during the motion
    r0 = joint_reactions(system, res.q[k], res.qd[k], np.zeros_like(res.qdd[k]), res.t[k],
                         dict(zip(res.names, res.forces[k])))
    assert r0.residual > 1e3 * res.reactions[k].residual


@pytest.mark.parametrize("second_order", [False, True])
def test_free_flexible_pendulum_reactions_balance_every_body(second_order):
    """A free flexible double pendulum at random states, accelerations from Lagrange's
    equations: the joint wrenches balance the inertia and weight of both bodies from their
    invariants (residual ~ 0), also with links whose mass moves towards their reference as
    they bend (the second-order first moment's inertia, A s''|0, in the body's momentum)."""
    from eom_models import flexible_double_pendulum

    from pipeline.dynamics.equations import equation_terms

    s = flexible_double_pendulum(n_modes=3, second_order=second_order).system
    rng = np.random.default_rng(2)
    for _ in range(3):
        q, qd = rng.uniform(-1, 1, s.mechanism.n), rng.normal(size=s.mechanism.n)
        # small deflections: the joints' frames are first-order rotations (I + [psi eta]x),
        # orthonormal to O(eta^2); fast modal rates keep A s''|0 = A eta'^T H eta' large
        q[s.mechanism.modal_coordinates] *= 1e-4
        terms = equation_terms(s, q, qd, 0.0)
        qdd = np.linalg.solve(terms.M, terms.rhs)
        r = joint_reactions(s, q, qd, qdd, 0.0, {})
        scale = np.abs(r.force).max()
        assert r.residual <= 1e-9 * scale, r.residual / scale
