"""Andrews' squeezing mechanism (Schiehlen's seven-body planar benchmark, as posed in Hairer &
Wanner's "Solving ODE II", VII.7): seven rigid bodies, three closed loops meeting at one joint
(E), a drive torque on the crank and a stiff spring, 0.03 s of motion in which the crank turns
about 2.5 times at up to ~1400 rad/s.

Two independent models of the same machine:

* :func:`pipeline_model` builds it from links, 4x4 joints and force elements (ten joint angles,
  three cut joints at E, six out-of-plane closure rows per loop that are redundant);
* :func:`reference` writes the equations by hand in the seven absolute/relative angles
  q = (beta, Theta, gamma, Phi, delta, Omega, epsilon) with six constraints g(q) = 0 and
  Lagrange multipliers, M q'' = f - G^T lambda, G q'' = -g_qq(q', q'), every position a sum of
  planar "arm" terms L (cos(a.q + c), sin(a.q + c)) whose derivatives are written out
  exactly, integrated by scipy's DOP853 at rtol 1e-12 (index-1 form; the constraint drift
  over 0.03 s stays below 1e-10 and is checked).

Geometry and mass data are those of the benchmark's problem statement; the reference solution
is computed here.
"""

from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp

from pipeline.dynamics import BodyMass, System
from pipeline.dynamics.forces import JointForce, SpringDamper
from pipeline.kinematics import Joint, build_mechanism, rigid_link
from pipeline.kinematics.rotations import translation

# problem data (SI)
MASS = (.04325, .00365, .02373, .00706, .07050, .00706, .05498)
INERTIA = (2.194e-6, 4.410e-7, 5.255e-6, 5.667e-7, 1.169e-5, 5.667e-7, 1.912e-5)
XA, YA, XB, YB, XC, YC = -.06934, -.00227, -.03635, .03273, .014, .072
C0, L0, MOM = 4530.0, .07785, .033
D, DA, E, EA, RR, RA = 28e-3, 115e-4, 2e-2, 1421e-5, 7e-3, 92e-5
SS, SA, SB, SC, SD = 35e-3, 1874e-5, 1043e-5, 18e-3, 2e-2
TA, TB, U, UA, UB, ZF, ZT, FA = 2308e-5, 916e-5, 4e-2, 1228e-5, 449e-5, 2e-2, 4e-2, 1421e-5
#: approximate initial angles (beta, Theta, gamma, Phi, delta, Omega, epsilon), rad, at rest
Q0 = (-0.0617138900142764, 0.0, 0.455279819163070, 0.222668390165886, 0.487364979543843,
      -0.222668390165886, 1.23054744454982)
T_END = 0.03
#: pipeline coordinate of each reference angle
ANGLES = ("O.theta", "F.theta", "B.theta", "G.theta", "A5.theta", "H.theta", "A7.theta")

_BE, _TH, _GA, _PH, _DE, _OM, _EP = np.eye(7)
HALF_PI = 0.5 * np.pi
# each point: a constant point plus arms (length, phase, angle coefficients)
_COM = [
    ((0.0, 0.0), [(RA, 0.0, _BE)]),
    ((0.0, 0.0), [(RR, 0.0, _BE), (DA, np.pi, _BE + _TH)]),
    ((XB, YB), [(SB, 0.0, _GA), (SA, -HALF_PI, _GA)]),
    ((XA, YA), [(ZT, 0.0, _DE), (E - EA, -HALF_PI, _PH + _DE)]),
    ((XA, YA), [(TA, 0.0, _DE), (TB, HALF_PI, _DE)]),
    ((XA, YA), [(U, -HALF_PI, _EP), (ZF - FA, 0.0, _OM + _EP)]),
    ((XA, YA), [(UA, -HALF_PI, _EP), (UB, 0.0, _EP)]),
]
_OMEGA = np.array([_BE, _BE + _TH, _GA, _PH + _DE, _DE, _OM + _EP, _EP])  # body rotations
_SPRING_D = ((XB, YB), [(SD, 0.0, _GA), (SC, -HALF_PI, _GA)])
_E_CRANK = ((0.0, 0.0), [(RR, 0.0, _BE), (D, np.pi, _BE + _TH)])
_E_SIDES = [((XB, YB), [(SS, -HALF_PI, _GA)]),
            ((XA, YA), [(ZT, 0.0, _DE), (E, -HALF_PI, _PH + _DE)]),
            ((XA, YA), [(U, -HALF_PI, _EP), (ZF, 0.0, _OM + _EP)])]


def _point(p, q, qd):
    """Position (2,), Jacobian (2, 7) and q''-free acceleration (2,) of a point."""
    x = np.array(p[0], dtype=float)
    J = np.zeros((2, 7))
    acc = np.zeros(2)
    for L, c, a in p[1]:
        phi = a @ q + c
        cs, sn = np.cos(phi), np.sin(phi)
        x += L * np.array([cs, sn])
        J += L * np.outer([-sn, cs], a)
        acc -= L * np.array([cs, sn]) * (a @ qd) ** 2
    return x, J, acc


def reference_terms(q, qd):
    """M (7, 7), f (7,) = Q - h, g (6,), G (6, 7), gq (6,) = g_qq(q', q') of the hand model."""
    M = _OMEGA.T @ np.diag(INERTIA) @ _OMEGA
    f = np.zeros(7)
    for m, p in zip(MASS, _COM):
        _, J, acc = _point(p, q, qd)
        M += m * J.T @ J
        f -= m * J.T @ acc
    xd, Jd, _ = _point(_SPRING_D, q, qd)
    d = xd - np.array([XC, YC])
    length = np.linalg.norm(d)
    f -= C0 * (length - L0) * (Jd.T @ d) / length
    f[0] += MOM
    e0, J0, a0 = _point(_E_CRANK, q, qd)
    g, G, gq = np.zeros(6), np.zeros((6, 7)), np.zeros(6)
    for k, side in enumerate(_E_SIDES):
        ek, Jk, ak = _point(side, q, qd)
        g[2 * k:2 * k + 2], G[2 * k:2 * k + 2], gq[2 * k:2 * k + 2] = e0 - ek, J0 - Jk, a0 - ak
    return M, f, g, G, gq


def reference_energy(q, qd):
    """Kinetic + spring - motor work potential (J) of the hand model."""
    M = reference_terms(q, qd)[0]
    xd = _point(_SPRING_D, q, qd)[0]
    length = np.linalg.norm(xd - np.array([XC, YC]))
    return 0.5 * qd @ M @ qd + 0.5 * C0 * (length - L0) ** 2 - MOM * q[0]


def reference_initial():
    """Consistent initial angles (7,) at rest: beta held, the constraints closed by Newton."""
    q = np.array(Q0, dtype=float)
    for _ in range(50):
        _, _, g, G, _ = reference_terms(q, np.zeros(7))
        dq = np.linalg.solve(G[:, 1:], -g)
        q[1:] += dq
        if np.abs(dq).max() < 1e-15:
            break
    return q


def reference(t_eval, rtol=1e-12, atol=1e-14):
    """(q (k, 7), qd (k, 7), max constraint residual) of the hand model at t_eval (s)."""
    q0 = reference_initial()

    def rhs(t, y):
        q, qd = y[:7], y[7:]
        M, f, _, G, gq = reference_terms(q, qd)
        K = np.block([[M, G.T], [G, np.zeros((6, 6))]])
        sol = np.linalg.solve(K, np.concatenate([f, -gq]))
        return np.concatenate([qd, sol[:7]])

    r = solve_ivp(rhs, (0.0, float(t_eval[-1])), np.concatenate([q0, np.zeros(7)]),
                  method="DOP853", t_eval=t_eval, rtol=rtol, atol=atol)
    assert r.success, r.message
    q, qd = r.y[:7].T, r.y[7:].T
    drift = max(np.abs(reference_terms(qi, qdi)[2]).max() for qi, qdi in zip(q, qd))
    return q, qd, drift


# ----------------------------------------------------------------- pipeline model
def _rigid(name, mass, com, izz, frames):
    body = BodyMass.rigid(mass, [com[0], com[1], 0.0], np.diag([0.5 * izz, 0.5 * izz, izz]))
    return rigid_link(name, {k: translation([x, y, 0.0]) for k, (x, y) in frames.items()}), body


def pipeline_model() -> System:
    """The mechanism from links and joints (ten revolutes about z, three loops closing at E)."""
    T = translation
    ground = rigid_link("ground", {"A": T([XA, YA, 0]), "B": T([XB, YB, 0]),
                                   "C": T([XC, YC, 0])})
    parts = [_rigid("crank", MASS[0], (RA, 0.0), INERTIA[0], {"F": (RR, 0.0)}),
             _rigid("rod", MASS[1], (-DA, 0.0), INERTIA[1], {"E": (-D, 0.0)}),
             _rigid("b3", MASS[2], (SB, -SA), INERTIA[2], {"E": (0.0, -SS), "D": (SD, -SC)}),
             _rigid("b4", MASS[3], (0.0, EA - E), INERTIA[3], {"E": (0.0, -E)}),
             _rigid("b5", MASS[4], (TA, TB), INERTIA[4], {"G": (ZT, 0.0)}),
             _rigid("b6", MASS[5], (ZF - FA, 0.0), INERTIA[5], {"E": (ZF, 0.0)}),
             _rigid("b7", MASS[6], (UB, -UA), INERTIA[6], {"H": (0.0, -U)})]
    be, th, ga, ph, de, om, ep = Q0
    joints = [Joint("O", "revolute", "ground", "body", "crank", "body", (be,)),
              Joint("F", "revolute", "crank", "F", "rod", "body", (th,)),
              Joint("B", "revolute", "ground", "B", "b3", "body", (ga,)),
              Joint("A5", "revolute", "ground", "A", "b5", "body", (de,)),
              Joint("G", "revolute", "b5", "G", "b4", "body", (ph,)),
              Joint("A7", "revolute", "ground", "A", "b7", "body", (ep,)),
              Joint("H", "revolute", "b7", "H", "b6", "body", (om,)),
              Joint("E3", "revolute", "rod", "E", "b3", "E", (ga - be - th,)),
              Joint("E4", "revolute", "rod", "E", "b4", "E", (ph + de - be - th,)),
              Joint("E6", "revolute", "rod", "E", "b6", "E", (om + ep - be - th,))]
    mech = build_mechanism([ground] + [p[0] for p in parts], joints)
    forces = (SpringDamper("spring", ("ground", "C"), ("b3", "D"), stiffness=C0, free_length=L0),
              JointForce("motor", "O.theta", force=MOM))
    bodies = {p[0].name: p[1] for p in parts}
    return System(mech, bodies, gravity=[0.0, 0.0, 0.0], forces=forces)


def pipeline_initial(system):
    """(q0, qd0) of the pipeline model: beta held at the reference start, loops closed."""
    from pipeline.kinematics import assemble

    mech = system.mechanism
    q = mech.q_initial.copy()
    q[mech.index("O.theta")] = reference_initial()[0]
    a = assemble(mech, q, driven=["O.theta"])
    return a.q, np.zeros(mech.n)
