"""Static equilibrium vs closed forms: a rigid pendulum on a torsional spring,
an Euler-Bernoulli cantilever (hand-made modal data) under gravity and a tip
load, and a closed loop (slider-crank) vs a direct virtual-work root."""

from __future__ import annotations

import numpy as np
import pytest
from dyn2_models import eb_cantilever, rigid_bar
from kin_models import slider_crank
from scipy.optimize import brentq

from pipeline.core.errors import ConfigError
from pipeline.dynamics import BodyMass, System
from pipeline.dynamics.forces import JointSpringDamper, PointForce, SpringDamper
from pipeline.dynamics.statics import static_equilibrium
from pipeline.kinematics import Joint, build_mechanism, flexible_link, rigid_link
from pipeline.kinematics.rotations import translation

G = 9.81


def pendulum(k, theta0, m=3.0, length=1.2):
    mech = build_mechanism([rigid_link("ground"), rigid_link("arm")],
                           [Joint("pin", "revolute", "ground", "body", "arm", "body")])
    return System(mech, {"arm": rigid_bar(m, length)}, [0.0, -G, 0.0],
                  forces=[JointSpringDamper("k", "pin.theta", stiffness=k, free_value=theta0)])


@pytest.mark.parametrize("k, theta0", [(50.0, 0.3), (20.0, 1.0), (200.0, -0.4)])
def test_rigid_pendulum_on_torsional_spring_matches_closed_form(k, theta0):
    m, length = 3.0, 1.2
    # k (theta - theta0) + m g (L/2) cos(theta) = 0, root near theta0 (independent of the code)
    ref = brentq(lambda x: k * (x - theta0) + m * G * 0.5 * length * np.cos(x), -np.pi / 2,
                 np.pi / 2)
    res = static_equilibrium(pendulum(k, theta0), np.array([theta0]))
    assert res.success, res.message
    assert res.q[0] == pytest.approx(ref, abs=1e-11)
    # tangent stiffness k - m g (L/2) sin(theta)
    assert res.stiffness[0, 0] == pytest.approx(k - m * G * 0.5 * length * np.sin(ref),
                                                rel=1e-7)


def cantilever(n_modes, L=2.0, EI=3.0e4, rho_A=12.0, tip_load=0.0, gravity=G):
    body, phi, psi, _ = eb_cantilever(L, EI, rho_A, n_modes)
    beam = flexible_link("beam", {"tip": (translation([L, 0, 0]), phi, psi)})
    mech = build_mechanism([rigid_link("ground"), beam],
                           [Joint("clamp", "fixed", "ground", "body", "beam", "body")])
    forces = [PointForce("P", ("beam", "tip"), (0.0, -tip_load, 0.0))] if tip_load else []
    return System(mech, {"beam": body}, [0.0, -gravity, 0.0], forces=forces), phi


def _tip_deflection(n_modes, **kw):
    system, phi = cantilever(n_modes, **kw)
    res = static_equilibrium(system, np.zeros(system.mechanism.n))
    assert res.success, res.message
    return float(res.q @ phi[:, 1])


def test_cantilever_under_gravity_matches_qL4_over_8EI():
    L, EI, rho_A = 2.0, 3.0e4, 12.0
    ref = -rho_A * G * L**4 / (8 * EI)
    err = [abs(_tip_deflection(n, L=L, EI=EI, rho_A=rho_A) / ref - 1) for n in (1, 2, 4, 6)]
    print("\ncantilever gravity tip error vs modes 1,2,4,6:", [f"{e:.2e}" for e in err])
    assert err[-1] < 1e-2 and err[2] < 1e-2
    assert err[0] > err[-1]  # converges with modes


def test_cantilever_tip_load_matches_PL3_over_3EI():
    L, EI, P = 2.0, 3.0e4, 500.0
    ref = -P * L**3 / (3 * EI)
    err = [abs(_tip_deflection(n, L=L, EI=EI, tip_load=P, gravity=0.0) / ref - 1)
           for n in (1, 3, 6)]
    print("\ncantilever tip-load error vs modes 1,3,6:", [f"{e:.2e}" for e in err])
    assert err[-1] < 1e-2
    assert err[0] > err[-1]


def test_closed_loop_statics_slider_crank_spring_and_crank_weight():
    """Slider-crank, crank weight + slider spring: equilibrium where the virtual work
    of the crank weight and the spring vanishes (closed-form slider position)."""
    r, l, e = 0.3, 1.0, 0.1
    mech = slider_crank(r, l, e, theta0=0.8)
    k, x0, m = 400.0, 1.0, 5.0
    system = System(mech, {"crank": BodyMass.rigid(m, [r, 0, 0], np.eye(3) * 1e-3)},
                    [0.0, -G, 0.0],
                    forces=[SpringDamper("s", ("ground", "body"), ("slider", "body"),
                                         stiffness=k, free_length=x0)])

    def xs(th):  # slider x from the loop, closed form
        return r * np.cos(th) + np.sqrt(l**2 - (e - r * np.sin(th))**2)

    def work(th, h=1e-7):  # dV/dtheta with V = m g r sin + k/2 (|x, e| - x0)^2
        def V(t):
            return m * G * r * np.sin(t) + 0.5 * k * (np.hypot(xs(t), e) - x0)**2
        return (V(th + h) - V(th - h)) / (2 * h)

    ref = brentq(work, 0.2, 1.4)
    res = static_equilibrium(system, mech.q_initial)
    assert res.success, res.message
    assert res.coordinates == ("crank.theta",) or len(res.coordinates) == 1
    assert res.q[mech.index("crank.theta")] == pytest.approx(ref, abs=1e-8)
    assert res.q[mech.index("slide.d")] == pytest.approx(xs(ref), abs=1e-8)


def test_bad_guess_is_a_config_error():
    with pytest.raises(ConfigError, match="q_guess: expected 1 finite values"):
        static_equilibrium(pendulum(1.0, 0.0), np.array([np.nan]))


def test_flexible_closed_loop_equilibrium_is_a_stationary_minimum_of_the_potential():
    """Four-bar with a flexible coupler (3 EB modes), link weights and a crank spring:
    at the equilibrium the total potential (gravity + strain + spring), evaluated on
    closed configurations, is stationary in every independent coordinate and the
    tangent stiffness is its Hessian (positive definite)."""
    from kin_models import four_bar

    from pipeline.dynamics.energy import elastic_energy
    from pipeline.dynamics.gravity import gravity_potential
    from pipeline.kinematics import evaluate_tree, solve_position

    a, b, c, d = 0.4, 1.2, 0.9, 1.0
    body, phi, psi, _ = eb_cantilever(b, 400.0, 8.0, 3)
    mech = four_bar(a, b, c, d, flexible=(phi, psi))
    spring = JointSpringDamper("k", "J2.theta", stiffness=60.0, free_value=0.6)
    system = System(mech, {"crank": rigid_bar(2.0, a), "coupler": body,
                           "rocker": rigid_bar(4.0, c)}, [0.0, -G, 0.0], forces=[spring])
    res = static_equilibrium(system, mech.q_initial)
    assert res.success, res.message
    q_eq, red = res.q, res.reduced
    assert len(red.x) == 4  # one free joint angle + three modal coordinates

    def V(x):
        q = q_eq.copy()
        q[red.x] = x
        q = solve_position(mech, q, red.partition)[0]
        tree = evaluate_tree(mech, q, derivatives=False)
        return (gravity_potential(system, tree, q) + elastic_energy(system, q)
                + spring.potential_energy(system, tree, q))

    x0, h = q_eq[red.x], 1e-4
    E = np.eye(4) * h
    grad = np.array([(V(x0 + e) - V(x0 - e)) / (2 * h) for e in E])
    hess = np.array([[(V(x0 + ei + ej) - V(x0 + ei - ej) - V(x0 - ei + ej) + V(x0 - ei - ej))
                      / (4 * h * h) for ej in E] for ei in E])
    force_scale = 9.81 * (2.0 * a + 4.0 * c + 8.0 * b)
    assert np.abs(grad).max() <= 1e-7 * force_scale
    assert np.all(np.linalg.eigvalsh(0.5 * (hess + hess.T)) > 0)
    np.testing.assert_allclose(res.stiffness, hess, rtol=1e-4, atol=1e-4 * np.abs(hess).max())
    assert np.abs(res.q[mech.modal_coordinates]).max() > 1e-4  # the coupler does deflect


def test_loader_held_by_a_force_cylinder_is_in_equilibrium_where_kinetostatics_says():
    """Loader (weights + bucket load): replace the lift driver by a force-driven cylinder
    with the kinetostatic lift force at t; statics from a displaced start returns to the
    kinetostatic configuration (the chassis slide is neutral under vertical loads)."""
    from test_kinetostatics import _loader

    from pipeline.dynamics.forces import ForceCylinder
    from pipeline.dynamics.kinetostatics import kinetostatics
    from pipeline.kinematics.drivers import Constant

    system, q0 = _loader(True)
    ks = kinetostatics(system, np.array([2.0]), q0)
    q_star, f_lift = ks.q[0], ks.force("LCYL.d")[0]
    tilt = Constant(float(system.drivers["TCYL.d"].value(2.0)))
    held = System(system.mechanism, system.bodies, system.gravity,
                  forces=[*system.forces, ForceCylinder("lift", "LCYL.d", f_lift)],
                  drivers={"TCYL.d": tilt})
    mech = system.mechanism
    start = q_star.copy()
    start[mech.index("LCYL.d")] += 0.02
    res = static_equilibrium(held, start)
    assert res.success, res.message
    assert len(res.coordinates) == 2 and "CHASSIS_X.d" in res.coordinates
    assert res.q[mech.index("LCYL.d")] == pytest.approx(q_star[mech.index("LCYL.d")], abs=1e-9)
    assert np.abs(res.q - q_star).max() < 1e-8
