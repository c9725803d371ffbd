"""Kinetostatics: actuator forces vs closed forms, power balances and the loader's
planar virtual-work figures (tests/kinematics/loader_geometry.py).

Power balance (independent of the velocity transform): the loads' velocities
are central differences in time of marker / centre-of-mass positions at
configurations assembled for the drivers at t +- h; quasi-static,
sum F_act s' + sum F . v + sum m g . v_com = 0; with inertia the right side
is dT/dt, T from link velocities (m v_c^2 + w . I w) / 2.
"""

from __future__ import annotations

import dyn2_models  # noqa: F401  (puts tests/kinematics on sys.path)
import loader_geometry as lg
import numpy as np
import pytest
from kin_models import slider_crank
from loader_model import build_loader
from test_loader_geometry import vw_forces

from pipeline.core.errors import ConfigError
from pipeline.dynamics import BodyMass, System
from pipeline.dynamics.forces import PointForce, Torque
from pipeline.dynamics.kinetostatics import kinetostatics
from pipeline.kinematics import assemble, evaluate_tree
from pipeline.kinematics.drivers import Harmonic, SmoothStep
from pipeline.kinematics.poses import step_pose

H_T = 1e-4  # s: central-difference step of the inertia check's dT/dt
H_V = 2e-3  # s: step of the five-point velocity stencil (error O(h^4) ~ 1e-12)


def _positions(system, q_guess, t, held, points):
    """Global positions (k, 3) of (link, frame, offset) points with the drivers at t."""
    mech = system.mechanism
    q = np.array(q_guess, dtype=float)
    for name, drv in system.drivers.items():
        q[mech.index(name)] = drv.value(t)
    q = assemble(mech, q, driven=held).q
    A = evaluate_tree(mech, q, derivatives=False).A
    return np.array([(step_pose(mech.marker(lk, fr), A, q) @ np.append(off, 1.0))[:3]
                     for lk, fr, off in points])


def _load_power(system, q, t, held, loads):
    """sum F . v over (link, frame, offset, F) loads, v by central differences in time."""
    pts = [(lk, fr, off) for lk, fr, off, _ in loads]
    x = {j: _positions(system, q, t + j * H_V, held, pts) for j in (-2, -1, 1, 2)}
    v = (x[-2] - 8 * x[-1] + 8 * x[1] - x[2]) / (12 * H_V)
    return float(sum(F @ vi for (_, _, _, F), vi in zip(loads, v)))


# ------------------------------------------------------------------ slider-crank
R, L, E = 0.3, 1.0, 0.1


def _slider_system(tau, m_crank=0.0, p_slider=0.0):
    mech = slider_crank(R, L, E, theta0=0.8)
    bodies = {"crank": BodyMass.rigid(m_crank, [R / 2, 0, 0], np.eye(3) * 1e-3)} if m_crank \
        else {}
    forces = [Torque("tau", ("crank", "body"), (0.0, 0.0, tau))]
    if p_slider:
        forces.append(PointForce("p", ("slider", "body"), (-p_slider, 0.0, 0.0)))
    drivers = {"slide.d": Harmonic(0.15, 0.5, 0.0, 1.05)}
    return System(mech, bodies, [0.0, -9.81, 0.0], forces=forces, drivers=drivers)


def test_slider_crank_cylinder_force_balances_crank_torque_closed_form():
    system = _slider_system(tau=35.0)
    t = np.linspace(0.0, 2.0, 9)
    res = kinetostatics(system, t, system.mechanism.q_initial)
    assert res.success, res.message
    th = res.q[:, system.mechanism.index("crank.theta")]
    s = np.sqrt(L**2 - (E - R * np.sin(th)) ** 2)
    dx_dth = -R * np.sin(th) + (E - R * np.sin(th)) * R * np.cos(th) / s
    # virtual work: F dx + tau dtheta = 0
    np.testing.assert_allclose(res.force("slide.d"), -35.0 / dx_dth, rtol=1e-10)


def test_slider_crank_power_balance_with_weight_and_load():
    system = _slider_system(tau=-20.0, m_crank=4.0, p_slider=150.0)
    mech = system.mechanism
    t = np.linspace(0.1, 1.9, 7)
    res = kinetostatics(system, t, mech.q_initial)
    assert res.success
    held = ["slide.d"]
    for k, tk in enumerate(t):
        q = res.q[k]
        p_load = _load_power(system, q, tk, held, [("slider", "body", np.zeros(3),
                                                    np.array([-150.0, 0.0, 0.0])),
                                                   ("crank", "body", np.array([R / 2, 0, 0]),
                                                    np.array([0.0, -9.81 * 4.0, 0.0]))])
        ang = {j: np.arctan2(*_positions(system, q, tk + j * H_V, held,
                                           [("crank", "A", np.zeros(3))])[0][1::-1])
               for j in (-2, -1, 1, 2)}
        dth = (ang[-2] - 8 * ang[-1] + 8 * ang[1] - ang[2]) / (12 * H_V)
        p_tau = -20.0 * dth
        p_act = res.force("slide.d")[k] * system.drivers["slide.d"].rate(tk)
        scale = abs(p_act) + abs(p_load) + abs(p_tau)
        assert abs(p_act + p_load + p_tau) <= 1e-8 * scale


# ------------------------------------------------------------------ front-end loader
T_END = 4.0
DRIVEN = ("LCYL.d", "TCYL.d")


def _loader(weights: bool):
    mech, q0 = build_loader()
    lift = lg.CYLINDERS["lift"]
    drivers = {"LCYL.d": SmoothStep(0.0, T_END, lift.min_length, lift.max_length),
               "TCYL.d": SmoothStep(0.0, T_END, lg.REFERENCE_TILT_LENGTH,
                                    lg.CYLINDERS["tilt"].min_length)}
    load = PointForce("load", ("bucket", "LOAD"), (0.0, 0.0, -lg.RATED_LOAD_N))
    bodies = {}
    if weights:
        A0 = evaluate_tree(mech, q0, derivatives=False).A
        for name, mp in lg.mass_properties().items():
            A = A0[mech.link_index(name)]
            Rb = A[:3, :3]
            bodies[name] = BodyMass.rigid(mp.mass, Rb.T @ (mp.com - A[:3, 3]),
                                          Rb.T @ mp.inertia @ Rb)
    return System(mech, bodies, [0.0, 0.0, -lg.G], forces=[load], drivers=drivers), q0


@pytest.fixture(scope="module")
def loader_load_only():
    system, q0 = _loader(False)
    t = np.linspace(0.0, T_END, 9)
    return system, q0, t, kinetostatics(system, t, q0)


def test_loader_cylinder_forces_equal_planar_virtual_work(loader_load_only):
    system, _, t, res = loader_load_only
    assert res.success, res.message
    assert res.names == (*DRIVEN, "CHASSIS_X.d")
    prev = None
    for k, tk in enumerate(t):
        Lk, Tk = (system.drivers[d].value(tk) for d in DRIVEN)
        prev = lg.pose(Lk, Tk, prev)
        f_lift, f_tilt = vw_forces(prev)
        assert res.force("LCYL.d")[k] == pytest.approx(f_lift, rel=1e-6)
        assert res.force("TCYL.d")[k] == pytest.approx(f_tilt, rel=1e-6, abs=1e-6 * abs(f_lift))
    print("\nloader lift force (kN) along the stroke:",
          np.round(res.force("LCYL.d") / 1e3, 3).tolist())


def test_loader_power_balance_load_only(loader_load_only):
    system, _, t, res = loader_load_only
    held = [*DRIVEN, "CHASSIS_X.d"]
    worst = 0.0
    for k, tk in enumerate(t[1:-1], start=1):  # interior: the stroke rates vanish at the ends
        p_load = _load_power(system, res.q[k], tk, held,
                             [("bucket", "LOAD", np.zeros(3),
                               np.array([0.0, 0.0, -lg.RATED_LOAD_N]))])
        p_act = sum(res.force(d)[k] * system.drivers[d].rate(tk) for d in DRIVEN)
        worst = max(worst, abs(p_act + p_load) / abs(p_load))
    print(f"\nloader power balance, worst relative error {worst:.2e}")
    assert worst <= 1e-9


def _com_points(system):
    out = []
    for name, body in system.bodies.items():
        C = body.C
        out.append((name, "body", C[:3, 3] / C[3, 3], C[3, 3]))
    return out


def test_loader_with_weights_quasi_static_and_with_inertia():
    system, q0 = _loader(True)
    held = [*DRIVEN, "CHASSIS_X.d"]
    t_mid = np.array([1.3, 2.0, 2.9])
    ts = np.sort(np.concatenate([t_mid - H_T, t_mid, t_mid + H_T]))
    qs = kinetostatics(system, ts, q0)
    dyn = kinetostatics(system, ts, q0, inertia=True)
    assert qs.success and dyn.success
    g = np.array([0.0, 0.0, -lg.G])
    loads = [(lk, fr, c, m * g) for lk, fr, c, m in _com_points(system)]
    loads.append(("bucket", "LOAD", np.zeros(3), np.array([0.0, 0.0, -lg.RATED_LOAD_N])))

    def kinetic(k):
        tree = evaluate_tree(system.mechanism, dyn.q[k], dyn.qd[k], derivatives=False)
        T = 0.0
        for name, body in system.bodies.items():
            li = system.mechanism.link_index(name)
            A, Ad = tree.A[li], tree.Ad[li]
            m, c = body.C[3, 3], body.C[:3, 3] / body.C[3, 3]
            S = body.C[:3, :3] - m * np.outer(c, c)
            Ic = np.trace(S) * np.eye(3) - S
            W = Ad[:3, :3] @ A[:3, :3].T
            w = np.array([W[2, 1], W[0, 2], W[1, 0]])
            v = Ad[:3, :3] @ c + Ad[:3, 3]
            T += 0.5 * m * v @ v + 0.5 * w @ (A[:3, :3] @ Ic @ A[:3, :3].T) @ w
        return T

    for j in range(t_mid.size):
        k = 3 * j + 1
        tk = ts[k]
        p_load = _load_power(system, qs.q[k], tk, held, loads)
        rates = [system.drivers[d].rate(tk) for d in DRIVEN]
        p_qs = sum(qs.force(d)[k] * r for d, r in zip(DRIVEN, rates))
        assert abs(p_qs + p_load) <= 1e-8 * abs(p_load)
        dT = (kinetic(k + 1) - kinetic(k - 1)) / (2 * H_T)
        p_dyn = sum(dyn.force(d)[k] * r for d, r in zip(DRIVEN, rates))
        assert abs(p_dyn + p_load - dT) <= 1e-6 * abs(p_load)
        assert abs(dT) > 1e-3  # the inertia check is not vacuous


def test_loader_weights_match_planar_potential_gradient():
    """Lift/tilt forces with link weights vs central differences of the planar potential
    V(L, T) = W z_load + sum m g z_com of loader_geometry (its own fsolve poses)."""
    system, q0 = _loader(True)
    mp = lg.mass_properties()
    t = np.array([1.0, 2.5])
    res = kinetostatics(system, t, q0)
    prev, h = None, 1e-6

    def V(Lc, Tc, guess):
        p = lg.pose(Lc, Tc, guess)
        return lg.RATED_LOAD_N * p.point("LOAD")[1] + sum(
            lg.G * m.mass * lg.com_xz(p, k, mp)[1] for k, m in mp.items())

    for k, tk in enumerate(t):
        Lk, Tk = (system.drivers[d].value(tk) for d in DRIVEN)
        prev = lg.pose(Lk, Tk, prev)
        f_lift = (V(Lk + h, Tk, prev) - V(Lk - h, Tk, prev)) / (2 * h)
        f_tilt = (V(Lk, Tk + h, prev) - V(Lk, Tk - h, prev)) / (2 * h)
        assert res.force("LCYL.d")[k] == pytest.approx(f_lift, rel=1e-6)
        assert res.force("TCYL.d")[k] == pytest.approx(f_tilt, rel=1e-6)


def test_kinetostatics_needs_drivers():
    system = System(slider_crank(R, L, E), {})
    with pytest.raises(ConfigError, match="system.drivers: expected at least one"):
        kinetostatics(system, [0.0], system.mechanism.q_initial)


def test_flexible_beam_on_driven_hinge_holding_torque_includes_its_sag():
    """EB beam (6 modes) on a driven hinge at angle theta, gravity -y: quasi-static modal
    deflection w(x) = -q cos(theta) x^2 (6L^2 - 4Lx + x^2) / 24EI (linear theory), so
    the holding torque is rho A g (L^2/2 cos(theta) + sin(theta) q cos(theta) L^5 / 20EI)."""
    from dyn2_models import eb_cantilever

    from pipeline.kinematics import Joint, build_mechanism, flexible_link, rigid_link
    from pipeline.kinematics.drivers import Ramp
    from pipeline.kinematics.rotations import translation

    Lb, EI, rho_A, g = 2.0, 3.0e3, 12.0, 9.81
    body, phi, psi, _ = eb_cantilever(Lb, EI, rho_A, 6)
    beam = flexible_link("beam", {"tip": (translation([Lb, 0, 0]), phi, psi)})
    mech = build_mechanism([rigid_link("ground"), beam],
                           [Joint("hinge", "revolute", "ground", "body", "beam", "body")])
    system = System(mech, {"beam": body}, [0.0, -g, 0.0],
                    drivers={"hinge.theta": Ramp(0.0, 0.5, -0.3)})
    t = np.array([0.0, 1.0, 2.0])
    res = kinetostatics(system, t, np.zeros(mech.n))
    assert res.success and res.names == ("hinge.theta",)
    th = -0.3 + 0.5 * t
    q = rho_A * g
    ref = q * (Lb**2 / 2 * np.cos(th) + np.sin(th) * q * np.cos(th) * Lb**5 / (20 * EI))
    sag = ref - q * Lb**2 / 2 * np.cos(th)
    np.testing.assert_allclose(res.force("hinge.theta"), ref, rtol=1e-6)
    assert np.all(np.abs(sag[[0, 2]]) > 1e-3 * np.abs(ref[[0, 2]]))  # the sag matters
