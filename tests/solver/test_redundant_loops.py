"""Redundant closure rows handled, not refused: a planar four-bar whose flexible coupler keeps
its out-of-plane modes (the pins lock them: the out-of-plane closure rows, redundant for a
rigid coupler, now constrain modal coordinates), against the planar-projected model; an
excavator-type slewing base under a planar boom loop, driven, free, and on a brake spring."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "dynamics"))
sys.path.insert(0, str(Path(__file__).resolve().parent))
import excavator
from dyn2_models import EB_ROOTS

from pipeline.dynamics import BodyMass, System
from pipeline.kinematics import Joint, build_mechanism, flexible_link, rigid_link
from pipeline.kinematics.initial import initial_positions
from pipeline.kinematics.rotations import translation
from pipeline.solver import simulate

A_, B_, C_, D_ = 1.0, 2.2, 2.0, 2.5  # crank, coupler, rocker, ground (m)


def _eb_modes(length, n, n_quad=400):
    """Closed-form clamped-free Euler-Bernoulli shapes w_a(x) (unit max), their tip values
    and slopes, at Gauss points: (x, weights, (n, G) shapes, (n,) tip, (n,) tip slope)."""
    xg, wg = np.polynomial.legendre.leggauss(n_quad)
    x = 0.5 * length * (xg + 1.0)
    w = 0.5 * length * wg
    shapes, tip, slope = [], [], []
    for b in EB_ROOTS[:n] / length:
        s = (np.cosh(b * length) + np.cos(b * length)) / (np.sinh(b * length)
                                                           + np.sin(b * length))
        f = (lambda xx, b=b, s=s: np.cosh(b * xx) - np.cos(b * xx)
             - s * (np.sinh(b * xx) - np.sin(b * xx)))
        df = (lambda xx, b=b, s=s: b * (np.sinh(b * xx) + np.sin(b * xx)
                                        - s * (np.cosh(b * xx) - np.cos(b * xx))))
        shapes.append(f(x))
        tip.append(f(length))
        slope.append(df(length))
    return x, w, np.array(shapes), np.array(tip), np.array(slope)


def coupler(n_in=2, n_out=3, rho_a=3.0, ei_in=2.0e4, ei_out=1.0e4):
    """(BodyMass, tip phi, tip psi) of the coupler bar along body x with n_in bending modes in
    the loop's plane (body y) and n_out out of it (body z), mass-normalised, EB frequencies."""
    x, w, W, tip, slope = _eb_modes(B_, max(n_in, n_out))
    m = w * rho_a
    rows, phi, psi, om2 = [], [], [], []
    for axis, count, ei in ((1, n_in, ei_in), (2, n_out, ei_out)):
        for a in range(count):
            norm = np.sqrt(np.sum(m * W[a] ** 2))
            field = np.zeros((4, x.size))
            field[axis] = W[a] / norm
            rows.append(field)
            p, r = np.zeros(3), np.zeros(3)
            p[axis] = tip[a] / norm
            r[2 if axis == 1 else 1] = (1.0 if axis == 1 else -1.0) * slope[a] / norm
            phi.append(p)
            psi.append(r)
            om2.append((EB_ROOTS[a] / B_) ** 4 * ei / rho_a)
    rbar = np.stack([x, 0 * x, 0 * x, 1 + 0 * x])
    C = (rbar * m) @ rbar.T
    Cp = np.array([(rbar * m) @ f.T for f in rows])
    Cpp = np.array([[(fa * m) @ fb.T for fb in rows] for fa in rows])
    k = len(rows)
    return (BodyMass(C=C, Cp=Cp, Cpp=Cpp, stiffness=np.diag(om2), damping=np.zeros((k, k))),
            np.array(phi), np.array(psi))


def four_bar(n_out: int) -> System:
    """Four-bar (pins about z, gravity -y) with the flexible coupler keeping n_out modes out
    of the loop's plane (0: the planar-projected model)."""
    body, phi, psi = coupler(n_out=n_out)
    keep = slice(0, 2 + n_out)
    T = translation
    links = [rigid_link("ground", {"D": T([D_, 0, 0])}), rigid_link("crank", {"B": T([A_, 0, 0])}),
             flexible_link("coupler", {"C": (T([B_, 0, 0]), phi[keep], psi[keep])}),
             rigid_link("rocker", {"C": T([C_, 0, 0])})]
    joints = [Joint("JA", "revolute", "ground", "body", "crank", "body", (1.2,)),
              Joint("JB", "revolute", "crank", "B", "coupler", "body", (-0.85,)),
              Joint("JC", "revolute", "coupler", "C", "rocker", "C", (1.15,)),
              Joint("JD", "revolute", "ground", "D", "rocker", "body", (1.5,))]
    mech = build_mechanism(links, joints)
    bodies = {"crank": BodyMass.rigid(2.0, [0.5, 0, 0], np.diag([0.01, 0.2, 0.2])),
              "coupler": body,
              "rocker": BodyMass.rigid(3.0, [1.0, 0, 0], np.diag([0.01, 1.0, 1.0]))}
    return System(mech, bodies, gravity=[0.0, -9.81, 0.0])


def _run(n_out, formulation, t_end=0.5):
    s = four_bar(n_out)
    q0 = initial_positions(s.mechanism, s.mechanism.q_initial, given={"JA.theta": 1.2})
    te = np.linspace(0.0, t_end, 51)
    return s, simulate(s, q0, np.zeros_like(q0), (0.0, t_end), te, rtol=1e-9, atol=1e-11,
                       progress=False, formulation=formulation)


@pytest.fixture(scope="module")
def planar():
    return _run(0, "dae")


@pytest.mark.parametrize("formulation", ["dae", "partitioned"])
@pytest.mark.parametrize("n_out", [2, 3])
def test_out_of_plane_modes_in_a_planar_loop_agree_with_the_planar_model(planar, n_out,
                                                                         formulation):
    s0, ref = planar
    assert ref.verdict == "ok", ref.report
    s, r = _run(n_out, formulation)
    assert r.verdict == "ok", r.report
    names = list(s0.mechanism.coordinates)  # joints and the two in-plane modes
    idx = s.mechanism.indices(names)
    assert np.abs(r.q[:, idx] - ref.q).max() < 1e-7
    out = s.mechanism.indices([f"coupler.eta{k}" for k in range(3, 3 + n_out)])
    assert np.abs(r.q[:, out]).max() < 1e-9  # locked by the pins, not excited in plane
    assert np.ptp(np.abs(ref.q[:, s0.mechanism.index("coupler.eta1")])) > 1e-3  # it bends


def _excavator(drivers=None, brake=False):
    from pipeline.dynamics.forces import JointSpringDamper

    s, q0 = excavator.build()
    forces = s.forces
    if brake:
        forces += (JointSpringDamper("brake", "slew.theta", stiffness=5e4, free_value=0.7,
                                     damping=1e3),)
    system = System(s.mechanism, s.bodies, s.gravity, forces=forces, drivers=drivers or {})
    fixed = {k: d.value(0.0) for k, d in (drivers or {}).items()}
    return system, initial_positions(s.mechanism, q0, fixed)


def _angular_momentum_z(system, q, qd) -> np.ndarray:
    """H_z (N m s) about the slew axis of every body, from poses and the mass matrices C alone:
    H = vee of the skew part of sum_b A_b C_b A_b'^T (no equations of motion involved)."""
    from pipeline.kinematics import evaluate_tree

    mech = system.mechanism
    out = []
    for qk, vk in zip(q, qd):
        tree = evaluate_tree(mech, qk, vk, derivatives=False)
        H = 0.0
        for name, body in system.bodies.items():
            li = mech.link_index(name)
            M = (tree.A[li] @ body.C @ tree.Ad[li].T)[:3, :3]
            H += M[0, 1] - M[1, 0]
        out.append(H)
    return np.array(out)


@pytest.mark.parametrize("formulation", ["dae", "partitioned"])
def test_slewing_base_held_still_equals_the_planar_boom(formulation):
    """Driven slew (the redundant out-of-plane rows and the slew's zero column used to be
    refused) at a constant angle: the boom loop moves exactly as the same loop on the ground."""
    from pipeline.kinematics.drivers import Constant

    s, q0 = _excavator({"slew.theta": Constant(0.7)})
    sp, qp = excavator.build(planar=True)
    qp = initial_positions(sp.mechanism, qp)
    te = np.linspace(0.0, 1.0, 51)
    r = simulate(s, q0, np.zeros_like(q0), (0.0, 1.0), te, progress=False,
                 formulation=formulation)
    ref = simulate(sp, qp, np.zeros_like(qp), (0.0, 1.0), te, progress=False,
                   formulation=formulation)
    assert r.verdict == "ok" and ref.verdict == "ok", (r.report, ref.report)
    idx = s.mechanism.indices(sp.mechanism.coordinates)
    assert np.abs(r.q[:, idx] - ref.q).max() < 1e-9
    assert np.ptp(ref.q[:, 0]) > 1e-3  # the boom settles on its cylinder


@pytest.mark.parametrize("formulation", ["dae", "partitioned"])
def test_slewing_torque_is_the_rate_of_angular_momentum(formulation):
    """Slewing at 0.5 rad/s: gravity has no moment about the vertical axis, so the slew
    torque the driver applies equals dH_z/dt of all the bodies (central differences of the
    angular momentum computed from the poses)."""
    from pipeline.kinematics.drivers import Ramp

    s, q0 = _excavator({"slew.theta": Ramp(0.0, 0.5, 0.7)})
    te = np.linspace(0.0, 1.0, 401)
    r = simulate(s, q0, np.zeros_like(q0), (0.0, 1.0), te, rtol=1e-10, atol=1e-12,
                 progress=False, formulation=formulation)
    assert r.verdict == "ok", r.report
    H = _angular_momentum_z(s, r.q, r.qd)
    dH = (H[2:] - H[:-2]) / (te[2:] - te[:-2])
    torque = r.driver_forces[1:-1, r.driven.index("slew.theta")]
    assert np.abs(torque).max() > 10.0  # the boom's swing is resisted
    assert np.abs(dH - torque).max() < 1e-3 * np.abs(torque).max()


@pytest.mark.parametrize("formulation", ["dae", "partitioned"])
def test_free_slew_on_a_brake_spring(formulation):
    """Left free on a brake spring (statics used to fail with 'Singular matrix'): statics
    find the same equilibrium as with the slew driven, and the free run keeps H_z constant
    up to the brake's torque (none here: nothing turns the base)."""
    from pipeline.dynamics import static_equilibrium
    from pipeline.kinematics.drivers import Constant

    s, q0 = _excavator(brake=True)
    st = static_equilibrium(s, q0)
    sd, qd0 = _excavator({"slew.theta": Constant(0.7)})
    ref = static_equilibrium(sd, qd0)
    assert st.success and ref.success, (st.message, ref.message)
    assert np.abs(st.q - ref.q).max() < 1e-9
    r = simulate(s, q0, np.zeros_like(q0), (0.0, 1.0), progress=False,
                 formulation=formulation)
    assert r.verdict == "ok", r.report
    assert np.abs(r.q[:, 0] - 0.7).max() < 1e-9
