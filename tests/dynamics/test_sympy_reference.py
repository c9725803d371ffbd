"""Rigid double pendulum and slider-crank with flywheel vs sympy.physics.mechanics.

The references are derived independently (KanesMethod for the pendulum, a
one-coordinate LagrangesMethod with the closed-form slider-crank geometry),
lambdified and integrated with scipy's DOP853 at the same tolerance.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest
import sympy as sp
from scipy.integrate import solve_ivp
from sympy.physics import mechanics as me

from pipeline.dynamics import BodyMass, System
from pipeline.kinematics import Joint, assemble, build_mechanism, rigid_link, solve_velocity
from pipeline.kinematics.initial import initial_positions
from pipeline.kinematics.rotations import translation
from pipeline.solver import simulate

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "kinematics"))
from kin_models import slider_crank

TOL = 1e-12
T_END = 2.0
G = 9.81


def _integrate_reference(M_f, F_f, y0, te, n):
    def f(t, y):
        M = np.asarray(M_f(*y), dtype=float).reshape(n, n)
        F = np.asarray(F_f(*y), dtype=float).reshape(n)
        return np.concatenate([y[n:], np.linalg.solve(M, F)])

    sol = solve_ivp(f, (0.0, T_END), y0, method="DOP853", t_eval=te, rtol=TOL, atol=TOL)
    assert sol.success
    return sol.y[:n].T


# ------------------------------------------------------------------ double pendulum
P1 = {"L1": 1.0, "m1": 2.0, "c1": (0.45, 0.03), "I1": 0.21, "m2": 1.3, "c2": (0.38, -0.02),
      "I2": 0.09}


def _sympy_double_pendulum():
    q1, q2, u1, u2 = me.dynamicsymbols("q1 q2 u1 u2")
    N = me.ReferenceFrame("N")
    A = N.orientnew("A", "Axis", (q1, N.z))
    B = A.orientnew("B", "Axis", (q2, A.z))
    A.set_ang_vel(N, u1 * N.z)
    B.set_ang_vel(A, u2 * A.z)
    O = me.Point("O")
    O.set_vel(N, 0)
    P = O.locatenew("P", P1["L1"] * A.x)
    G1 = O.locatenew("G1", P1["c1"][0] * A.x + P1["c1"][1] * A.y)
    G2 = P.locatenew("G2", P1["c2"][0] * B.x + P1["c2"][1] * B.y)
    for pt in (P, G1, G2):
        pt.v2pt_theory(O if pt is not G2 else P, N, A if pt is not G2 else B)
    b1 = me.RigidBody("b1", G1, A, P1["m1"], (me.inertia(A, 0.1, 0.2, P1["I1"]), G1))
    b2 = me.RigidBody("b2", G2, B, P1["m2"], (me.inertia(B, 0.05, 0.07, P1["I2"]), G2))
    loads = [(G1, -P1["m1"] * G * N.y), (G2, -P1["m2"] * G * N.y)]
    km = me.KanesMethod(N, q_ind=[q1, q2], u_ind=[u1, u2], kd_eqs=[q1.diff() - u1,
                                                                   q2.diff() - u2])
    km.kanes_equations([b1, b2], loads)
    args = [q1, q2, u1, u2]
    return sp.lambdify(args, km.mass_matrix), sp.lambdify(args, km.forcing)


def _pipeline_double_pendulum():
    mech = build_mechanism(
        [rigid_link("ground"), rigid_link("a", {"P": translation([P1["L1"], 0, 0])}),
         rigid_link("b")],
        [Joint("j1", "revolute", "ground", "body", "a", "body"),
         Joint("j2", "revolute", "a", "P", "b", "body")])
    bodies = {"a": BodyMass.rigid(P1["m1"], [*P1["c1"], 0.0], np.diag([0.1, 0.2, P1["I1"]])),
              "b": BodyMass.rigid(P1["m2"], [*P1["c2"], 0.0], np.diag([0.05, 0.07, P1["I2"]]))}
    return System(mech, bodies, gravity=[0.0, -G, 0.0])


def test_rigid_double_pendulum_matches_sympy_kane():
    te = np.linspace(0.0, T_END, 41)
    y0 = np.array([0.5, -0.3, 0.0, 1.0])
    ref = _integrate_reference(*_sympy_double_pendulum(), y0, te, 2)
    r = simulate(_pipeline_double_pendulum(), y0[:2], y0[2:], (0.0, T_END), te, rtol=TOL,
                 atol=TOL, progress=False)
    assert r.success, r.message
    err = np.abs(r.q - ref).max()
    assert err < 1e-8, err
    assert np.ptp(ref[:, 1]) > 1.0  # a real swing, not a trivial run


# ------------------------------------------------------------------ slider-crank
SC = {"r": 0.3, "l": 1.0, "e": 0.1, "m1": 4.0, "c1": 0.02, "I1": 0.8, "m2": 1.5, "c2": 0.4,
      "I2": 0.12, "m3": 2.5}


def _sympy_slider_crank():
    th = me.dynamicsymbols("theta")
    t = me.dynamicsymbols._t
    r, l, e = SC["r"], SC["l"], SC["e"]
    phi = sp.asin((e - r * sp.sin(th)) / l)  # rod angle, cos(phi) > 0 branch
    A = sp.Matrix([r * sp.cos(th), r * sp.sin(th)])
    g1 = SC["c1"] * sp.Matrix([sp.cos(th), sp.sin(th)])
    g2 = A + SC["c2"] * sp.Matrix([sp.cos(phi), sp.sin(phi)])
    x3 = sp.Matrix([r * sp.cos(th) + l * sp.cos(phi), e])
    v = lambda p: p.diff(t)
    T = (SC["m1"] * v(g1).dot(v(g1)) + SC["I1"] * th.diff(t) ** 2
         + SC["m2"] * v(g2).dot(v(g2)) + SC["I2"] * phi.diff(t) ** 2
         + SC["m3"] * v(x3).dot(v(x3))) / 2
    V = G * (SC["m1"] * g1[1] + SC["m2"] * g2[1] + SC["m3"] * x3[1])
    lm = me.LagrangesMethod(T - V, [th])
    lm.form_lagranges_equations()
    w = sp.Symbol("w")
    sub = {th.diff(t): w}
    M = lm.mass_matrix.subs(sub)
    F = lm.forcing.subs(sub)
    x = sp.Symbol("x")
    return (sp.lambdify([x, w], M.subs(th, x)), sp.lambdify([x, w], F.subs(th, x)))


def _pipeline_slider_crank(theta0):
    mech = slider_crank(SC["r"], SC["l"], SC["e"], theta0)
    bodies = {"crank": BodyMass.rigid(SC["m1"], [SC["c1"], 0, 0], np.diag([0.3, 0.3, SC["I1"]])),
              "rod": BodyMass.rigid(SC["m2"], [SC["c2"], 0, 0], np.diag([0.01, 0.1, SC["I2"]])),
              "slider": BodyMass.rigid(SC["m3"], [0, 0, 0], np.diag([0.01, 0.01, 0.01]))}
    return System(mech, bodies, gravity=[0.0, -G, 0.0])


@pytest.mark.parametrize("formulation", ["dae", "partitioned"])
def test_slider_crank_with_flywheel_matches_sympy_lagrange(formulation):
    theta0, w0 = 0.3, 6.0
    te = np.linspace(0.0, T_END, 41)
    ref = _integrate_reference(*_sympy_slider_crank(), np.array([theta0, w0]), te, 1)
    s = _pipeline_slider_crank(theta0)
    mech = s.mechanism
    a = assemble(mech, driven=["crank.theta"])  # crank prescribed: consistent q0, qd0
    qd = np.zeros(mech.n)
    qd[mech.index("crank.theta")] = w0
    qd0 = solve_velocity(a.closure.J, a.partition, qd)
    r = simulate(s, a.q, qd0, (0.0, T_END), te, rtol=TOL, atol=TOL, progress=False,
                 formulation=formulation)
    assert r.success and r.formulation == formulation, r.message
    err = np.abs(r.coordinate("crank.theta") - ref[:, 0]).max()
    assert err < 1e-8, err
    assert r.closure_residual.max() < 1e-10
    assert np.ptp(ref[:, 0]) > 3.0  # the flywheel turns through several radians


@pytest.mark.parametrize("formulation", ["dae", "partitioned"])
def test_crank_rate_given_at_top_dead_centre_is_honoured(formulation):
    """Only the crank's rate is given, at top dead centre (crank and rod aligned: the
    slider's rate is zero whatever the crank does). It used to be read through a slider
    chosen as the independent coordinate and lost: the crank sat there."""
    theta0, w0 = float(np.arcsin(SC["e"] / (SC["r"] + SC["l"]))), 6.0
    te = np.linspace(0.0, T_END, 41)
    ref = _integrate_reference(*_sympy_slider_crank(), np.array([theta0, w0]), te, 1)
    s = _pipeline_slider_crank(theta0)
    mech = s.mechanism
    q0 = initial_positions(mech, mech.q_initial, given={"crank.theta": theta0})
    qd0 = np.zeros(mech.n)
    qd0[mech.index("crank.theta")] = w0
    r = simulate(s, q0, qd0, (0.0, T_END), te, rtol=TOL, atol=TOL, progress=False,
                 formulation=formulation)
    assert r.verdict == "ok", r.report
    assert abs(r.qd[0, mech.index("slide.d")]) < 1e-9  # top dead centre
    assert abs(r.qd[0, mech.index("crank.theta")] - w0) < 1e-12
    assert np.abs(r.coordinate("crank.theta") - ref[:, 0]).max() < 1e-7
