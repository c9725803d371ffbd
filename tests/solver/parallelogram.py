"""A parallelogram linkage with a redundant bar and singular positions.

Three equal cranks (length L, uniform rods of mass m) pinned to the ground at x = 0, L, 2L,
their tips pinned to one coupler bar (length 2L, mass m_c, uniform): two four-bars sharing the
coupler and the middle crank. Gruebler's count gives 0 DOF; the linkage moves with 1 (the third
crank is redundant), and whenever the cranks are horizontal every bar is aligned: the two
branches (parallel cranks, or a folded crossed linkage) meet there. Gravity -y; released with
the cranks vertical and spinning, it passes those singular positions twice per turn.

On the parallelogram branch every crank has the same angle theta and the coupler translates,
so (the independent one-DOF model, written by hand)

    T = 1/2 (m + m_c) L^2 theta'^2,    V = (3 m / 2 + m_c) g L sin(theta),
    (m + m_c) L^2 theta'' = -(3 m / 2 + m_c) g L cos(theta).
"""

from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp

from pipeline.dynamics import BodyMass, System
from pipeline.kinematics import Joint, build_mechanism, rigid_link
from pipeline.kinematics.rotations import translation

L, M_CRANK, M_COUPLER, G = 1.0, 1.0, 2.0, 9.81
THETA0, OMEGA0 = 0.5 * np.pi, 2.0
CRANKS = ("J1.theta", "J2.theta", "J3.theta")


def _bar(mass, length):
    i = mass * length ** 2 / 12.0
    return BodyMass.rigid(mass, [0.5 * length, 0.0, 0.0], np.diag([1e-6 * i, i, i]))


def pipeline_model(redundant: bool = True) -> System:
    """The linkage from links and revolute joints (tree: J1 -> c1 -> coupler; J2, J3 -> c2,
    c3; the coupler's pins on c2 and c3 close the two loops). ``redundant=False`` drops the
    third crank (a single parallelogram four-bar, no redundancy, same singular positions)."""
    T = translation
    n = 3 if redundant else 2
    links = [rigid_link("ground", {f"O{i}": T([i * L, 0, 0]) for i in range(n)})]
    links += [rigid_link(f"c{i + 1}", {"tip": T([L, 0, 0])}) for i in range(n)]
    links += [rigid_link("coupler", {f"P{i}": T([i * L, 0, 0]) for i in range(n)})]
    joints = [Joint(f"J{i + 1}", "revolute", "ground", f"O{i}", f"c{i + 1}", "body", (THETA0,))
              for i in range(n)]
    joints += [Joint(f"K{i + 1}", "revolute", f"c{i + 1}", "tip", "coupler", f"P{i}",
                     (-THETA0,)) for i in range(n)]
    mech = build_mechanism(links, joints)
    bodies = {f"c{i + 1}": _bar(M_CRANK, L) for i in range(n)}
    bodies["coupler"] = _bar(M_COUPLER * (n - 1) / 2.0, (n - 1) * L)
    return System(mech, bodies, gravity=[0.0, -G, 0.0])


def initial_state(system):
    """(q0, qd0): cranks vertical turning at OMEGA0, coupler horizontal and translating."""
    mech = system.mechanism
    q = mech.q_initial.copy()
    qd = np.zeros(mech.n)
    for name in mech.coordinates:
        qd[mech.index(name)] = OMEGA0 if name.startswith("J") else -OMEGA0
    return q, qd


def _constants(redundant: bool):
    n = 3 if redundant else 2
    mc = M_COUPLER * (n - 1) / 2.0
    inertia = (n * M_CRANK / 3.0 + mc) * L ** 2
    weight = (n * M_CRANK / 2.0 + mc) * G * L
    return inertia, weight


def reference(t_eval, redundant: bool = True):
    """(theta, theta') of the one-DOF model at t_eval (DOP853, rtol 1e-12)."""
    inertia, weight = _constants(redundant)
    r = solve_ivp(lambda t, y: [y[1], -weight * np.cos(y[0]) / inertia], (0.0, t_eval[-1]),
                  [THETA0, OMEGA0], method="DOP853", t_eval=t_eval, rtol=1e-12, atol=1e-12)
    assert r.success
    return r.y[0], r.y[1]


def energy(theta, omega, redundant: bool = True):
    """T + V (J) of the one-DOF model."""
    inertia, weight = _constants(redundant)
    return 0.5 * inertia * omega ** 2 + weight * np.sin(theta)


def singular_passages(theta) -> int:
    """How many times theta crosses a horizontal position (a multiple of pi)."""
    k = np.floor(np.asarray(theta) / np.pi)
    return int(np.sum(k[1:] != k[:-1]))
